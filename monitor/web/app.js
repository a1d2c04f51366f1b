// rocklab monitor page: theta measured and modelled, the error and its
// windowed RMS (uPlot charts), flags as shaded bands and events as markers
// (uPlot hooks), the latest comparison numbers, node health, counters, and
// each ensemble's posterior predictive band (median, 68 % and 95 %) shaded
// around the model curves with its coverage numbers; for an assembly, a
// theta chart per body (measured, RL_BODIES, and each assembly variant's)
// with each body's comparison figures and each variant's mode agreement
// (RL_COMPAREBODIES_<name>).
//
// Two modes:
//  - live (`rocklab monitor`): an EventSource on api/events receives a full
//    LiveState snapshot first, then incremental updates (new points, events
//    and flag changes, at 10 Hz while anything changes); the page keeps only
//    the window (window_s of sample clock) in its arrays, so it does not grow
//    over hours.
//  - static (`rocklab report`): when `window.ROCKLAB_SNAPSHOT` is defined
//    before this script runs (a LiveState Snapshot() object inlined in the
//    page), the page renders it once and opens no connection.
// The JSON schema is documented in monitor/live_state.h.
//
// For tests and scripts, `window.rocklabMonitor` exposes the uPlot instances
// (`plots.theta`, `plots.error`), `updates` (messages applied), `mode`,
// `dataLengths()` (points per chart series), `bandNames()` (the bands
// drawn on the theta chart) and `bodyRows()` (an assembly's per-body charts:
// each one's body index and series labels).
//
// Bodies are numbered by their index, 0 for the body on the table, upwards,
// as RL_BODIES' arrays, compare's summary and `rocklab report`; the CSV
// columns of simulate and reconstruct number them from 1 (theta_1 is body
// 0): docs/compare.md, "Numbering the bodies".
(function () {
  'use strict';

  const FLAG_FILL = {
    sliding: 'rgba(230, 120, 0, 0.18)',
    jump: 'rgba(200, 0, 0, 0.18)',
    twist: 'rgba(140, 0, 200, 0.18)',
    stale: 'rgba(110, 110, 110, 0.25)',
  };
  const MARKER = {  // events drawn as markers on the time axis
    uplift: {color: '#1565c0', letter: 'U'},
    rest: {color: '#2e7d32', letter: 'R'},
    overturn: {color: '#c62828', letter: 'O'},
  };
  const PALETTE = ['#d62728', '#1f77b4', '#2ca02c', '#ff7f0e', '#9467bd', '#8c564b', '#e377c2',
    '#17becf', '#bcbd22', '#7f7f7f'];
  const MAX_EVENT_ROWS = 60;     // rows in the events table
  const MAX_EVENTS = 2000;       // events kept by the page (the server keeps at most 1000)
  // The comparison table: whole-test figures of each variant, from its
  // newest RL_COMPARE (`latest`: totals since the start) or from every
  // sample (`whole`, live_json.cpp); [source, field, is an angle].
  const COMPARISON_COLUMNS = [['latest', 'rms_total', true], ['latest', 'nrms', false],
    ['latest', 'correlation', false], ['whole', 'impact_timing_rms', false],
    ['whole', 'impact_timings', false], ['whole', 'peak_theta', true],
    ['whole', 'peak_theta_measured', true]];
  const SIGNIFICANT_DIGITS = 4;  // every number in the tables
  // Angles are shown in the unit of the switch (#angle-unit): rad, as the
  // CLI, its files and the JSON, or deg. The snapshot's series are in deg.
  const DEG_PER_RAD = 180 / Math.PI;
  let angleUnit = 'rad';
  function fromRad(x) { return typeof x === 'number' && angleUnit === 'deg' ? x * DEG_PER_RAD : x; }
  function fromDeg(x) { return typeof x === 'number' && angleUnit === 'rad' ? x / DEG_PER_RAD : x; }
  // An event's value: its unit on the page and the value shown (from the SI
  // value; lcm_types/event_t.lcm gives the SI unit of each kind; null: an angle).
  const EVENT_UNIT = {
    uplift: 'm/s^2', impact: null, rest: '', overturn: null, sliding: 'm', twist: null,
    gap: 'samples', stale: 's', jump: 'm', out_of_plane: 'm', disagree: null, recovered: '',
    bad_sample: 'samples',
  };
  function eventValue(e) {
    const unit = EVENT_UNIT[e.kind];
    if (unit === null) return [fromRad(e.value), e.kind === 'impact' ? angleUnit + '/s' : angleUnit];
    return [e.value, unit === undefined ? '' : unit];
  }
  // The CSV downloads keep their columns' units (deg, as their names say).
  function eventValueDeg(e) {
    const unit = EVENT_UNIT[e.kind];
    if (unit === null && typeof e.value === 'number') {
      return [e.value * DEG_PER_RAD, e.kind === 'impact' ? 'deg/s' : 'deg'];
    }
    return [e.value, unit === null || unit === undefined ? '' : unit];
  }
  const BAND_FIELDS = ['coverage95_window', 'coverage95_total', 'coverage68_window',
    'coverage68_total', 'median_error', 'width95', 'impact_timing_z', 'impact_time_sd',
    'impact_timing_z_rms', 'matched_crossings', 'unmatched_crossings'];
  const BAND_ANGLE_FIELDS = new Set(['median_error', 'width95']);
  const BAND_RGB = ['90, 90, 200', '200, 110, 40', '40, 150, 120', '160, 60, 160'];
  // What the page holds: the same shape as a snapshot, in arrays it trims.
  const held = {
    record: null,
    windowS: null,         // null: the whole record (static mode)
    tLatest: null,
    t0Utime: null,         // sample clock of t = 0, us
    measured: {t: [], theta: []},
    table: {t: [], accel: []},  // RL_TABLE u_g'', m/s^2
    variants: new Map(),   // name -> {meta, color, theta: {t, theta}, cmp: {t, err, rms}, latest, whole,
                           //          bodies: [{t, theta}] per body, bodiesLatest: RL_COMPAREBODIES or null}
    bodies: [],            // an assembly: RL_BODIES theta per body, [{t, theta}], bottom-up
    bodiesDropped: 0,      // bodies beyond the server's limit, counted by it
    bands: new Map(),      // name -> {meta, rgb, band: {t, median, lo68, hi68, lo95, hi95}, latest}
    flags: new Map(),      // interval id -> {flag, source, start, end}
    events: [],
    health: [],
    config: null,
    counters: null,
  };
  const plots = {theta: null, error: null, bodies: []};  // bodies: one chart per body, bottom-up
  let plottedVariants = '';  // the variant list the plots were built for
  let plottedBodies = '';    // the bodies and assembly variants the body charts were built for
  let updates = 0;
  let mode = 'starting';
  let renderPending = false;

  // %.4g as C's printf writes it (SIGNIFICANT_DIGITS; `precision` for others).
  function fmtG(x, precision) {
    const p = precision || SIGNIFICANT_DIGITS;
    if (x === null || x === undefined) return '—';
    if (typeof x === 'boolean') return x ? 'yes' : 'no';
    if (typeof x !== 'number') return String(x);
    if (!Number.isFinite(x)) return Number.isNaN(x) ? 'nan' : (x > 0 ? 'inf' : '-inf');
    if (x === 0) return '0';
    const strip = (s) => (s.indexOf('.') >= 0 ? s.replace(/0+$/, '').replace(/\.$/, '') : s);
    const exponential = x.toExponential(p - 1);
    const e = parseInt(exponential.slice(exponential.indexOf('e') + 1), 10);
    if (e < -4 || e >= p) {
      const mantissa = strip(exponential.slice(0, exponential.indexOf('e')));
      return mantissa + 'e' + (e < 0 ? '-' : '+') + String(Math.abs(e)).padStart(2, '0');
    }
    return strip(x.toFixed(p - 1 - e));
  }

  // -- applying snapshots and updates ----------------------------------------

  function append(to, from, keys) {
    for (const [mine, theirs] of keys) {
      const src = from[theirs] || [];
      for (let i = 0; i < src.length; i++) to[mine].push(src[i]);
    }
  }

  function variantFor(name) {
    let v = held.variants.get(name);
    if (!v) {
      v = {meta: {name: name}, color: PALETTE[held.variants.size % PALETTE.length],
        theta: {t: [], theta: []}, cmp: {t: [], err: [], rms: []}, latest: null,
        bodies: [], bodiesLatest: null};
      held.variants.set(name, v);
    }
    return v;
  }

  function bandFor(name) {
    let b = held.bands.get(name);
    if (!b) {
      b = {meta: {name: name}, rgb: BAND_RGB[held.bands.size % BAND_RGB.length],
        band: {t: [], median: [], lo68: [], hi68: [], lo95: [], hi95: []}, latest: null};
      held.bands.set(name, b);
    }
    return b;
  }

  // The series of body k in `list` (an array of {t, theta}), made when new.
  function bodySeries(list, k) {
    while (list.length <= k) list.push({t: [], theta: []});
    return list[k];
  }

  function reset() {
    held.measured = {t: [], theta: []};
    held.bodies = [];
    held.bodiesDropped = 0;
    held.table = {t: [], accel: []};
    held.variants = new Map();
    held.bands = new Map();
    held.flags = new Map();
    held.events = [];
  }

  function apply(msg) {
    if (msg.full || msg.record !== held.record) reset();
    held.record = msg.record;
    held.windowS = msg.window_s;
    held.tLatest = msg.t_latest;
    held.t0Utime = msg.t0_utime;
    append(held.measured, msg.measured, [['t', 't'], ['theta', 'theta_deg']]);
    if (msg.table) append(held.table, msg.table, [['t', 't'], ['accel', 'accel_mps2']]);
    for (const mv of msg.variants) {
      const v = variantFor(mv.name);
      v.meta = mv;
      v.latest = mv.latest;
      v.whole = mv.whole;
      append(v.theta, mv.theta, [['t', 't'], ['theta', 'theta_deg']]);
      append(v.cmp, mv.comparison, [['t', 't'], ['err', 'error_deg'], ['rms', 'rms_window_deg']]);
      // An assembly variant only (a single block's has no "bodies").
      (mv.bodies || []).forEach((s, k) => append(bodySeries(v.bodies, k), s, [['t', 't'], ['theta', 'theta_deg']]));
      v.bodiesLatest = mv.bodies_latest || null;
    }
    if (msg.bodies) {
      (msg.bodies.measured || []).forEach((s, k) =>
        append(bodySeries(held.bodies, k), s, [['t', 't'], ['theta', 'theta_deg']]));
      held.bodiesDropped = msg.bodies.dropped || 0;
    }
    for (const mb of msg.bands || []) {
      const b = bandFor(mb.name);
      b.meta = mb;
      b.latest = mb.latest;
      append(b.band, mb.band, [['t', 't'], ['median', 'median_deg'], ['lo68', 'lo68_deg'],
        ['hi68', 'hi68_deg'], ['lo95', 'lo95_deg'], ['hi95', 'hi95_deg']]);
    }
    for (const f of msg.flags) held.flags.set(f.id, f);
    for (const e of msg.events) held.events.push(e);
    held.health = msg.health;
    held.config = msg.config;
    held.counters = msg.counters;
    trim();
    updates++;
  }

  // First index whose t is >= cutoff (t increasing).
  function firstFrom(t, cutoff) {
    let lo = 0, hi = t.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (t[mid] < cutoff) lo = mid + 1; else hi = mid;
    }
    return lo;
  }

  function trimSeries(s, cutoff) {
    const n = firstFrom(s.t, cutoff);
    if (n > 0) for (const key of Object.keys(s)) s[key].splice(0, n);
  }

  // Keeps what lies in the window, as the server does.
  // A static record (window null) keeps every event it was given.
  function trim() {
    if (held.windowS === null || held.tLatest === null) return;
    if (held.events.length > MAX_EVENTS) held.events.splice(0, held.events.length - MAX_EVENTS);
    const cutoff = held.tLatest - held.windowS;
    trimSeries(held.measured, cutoff);
    trimSeries(held.table, cutoff);
    for (const v of held.variants.values()) {
      trimSeries(v.theta, cutoff);
      trimSeries(v.cmp, cutoff);
      for (const s of v.bodies) trimSeries(s, cutoff);
    }
    for (const s of held.bodies) trimSeries(s, cutoff);
    for (const b of held.bands.values()) trimSeries(b.band, cutoff);
    for (const [id, f] of held.flags) {
      if (f.end !== null && f.end < cutoff) held.flags.delete(id);
    }
    const firstEvent = held.events.findIndex((e) => e.t >= cutoff);
    held.events.splice(0, firstEvent < 0 ? held.events.length : firstEvent);
  }

  // -- charts -------------------------------------------------------------------

  // Flags as shaded bands behind the series, events as markers: one uPlot
  // plugin, drawn with the plot's own scales.
  function flagsAndEvents() {
    return {
      hooks: {
        drawClear: [(u) => {
          const ctx = u.ctx;
          const {top, height} = u.bbox;
          ctx.save();
          for (const f of held.flags.values()) {
            const end = f.end === null ? held.tLatest : f.end;
            if (end === null) continue;
            const x0 = u.valToPos(f.start, 'x', true);
            const x1 = u.valToPos(end, 'x', true);
            ctx.fillStyle = FLAG_FILL[f.flag] || FLAG_FILL.stale;
            ctx.fillRect(x0, top, Math.max(x1 - x0, 1), height);
          }
          ctx.restore();
        }],
        draw: [(u) => {
          const ctx = u.ctx;
          const {left, top, width, height} = u.bbox;
          const px = window.devicePixelRatio || 1;
          ctx.save();
          ctx.font = Math.round(10 * px) + 'px sans-serif';
          ctx.textAlign = 'center';
          // One row per variant's impacts (triangles), then one for uplift,
          // rest and overturn (letters): a marker closer than MARKER_GAP_PX to
          // the last drawn one of its row is left out and counted.
          const rows = markerRows();
          const stats = [];
          rows.forEach((row, i) => {
            const y = top + (2 + i * MARKER_ROW_PX) * px;
            let last = -Infinity;
            const drawn = [];
            let hidden = 0, outside = 0;
            for (const e of row.events) {
              const x = u.valToPos(e.t, 'x', true);
              if (!(x >= left && x <= left + width)) { outside++; continue; }
              if (x - last < MARKER_GAP_PX * px) { hidden++; continue; }
              last = x;
              drawn.push(x / px);
              if (e.kind === 'impact') {
                ctx.fillStyle = row.color;
                ctx.beginPath();
                ctx.moveTo(x, y);
                ctx.lineTo(x - 4 * px, y + 7 * px);
                ctx.lineTo(x + 4 * px, y + 7 * px);
                ctx.fill();
              } else {
                const m = MARKER[e.kind];
                ctx.strokeStyle = m.color;
                ctx.fillStyle = m.color;
                ctx.setLineDash([4 * px, 3 * px]);
                ctx.lineWidth = px;
                ctx.beginPath();
                ctx.moveTo(x, y + 10 * px);
                ctx.lineTo(x, top + height);
                ctx.stroke();
                ctx.setLineDash([]);
                ctx.fillText(m.letter, x, y + 8 * px);
              }
            }
            if (hidden > 0) {  // on a white box over the row's end
              const label = '+' + hidden + ' more';
              const w = ctx.measureText(label).width + 4 * px;
              ctx.fillStyle = 'rgba(255, 255, 255, 0.9)';
              ctx.fillRect(left + width - w, y - px, w, 10 * px);
              ctx.fillStyle = row.color;
              ctx.textAlign = 'right';
              ctx.fillText(label, left + width - 2 * px, y + 8 * px);
              ctx.textAlign = 'center';
            }
            stats.push({row: row.name, drawn: drawn, hidden: hidden, outside: outside});
          });
          markerStats.set(u, stats);
          if (u === plots.theta) renderMarkerNote(stats);
          ctx.restore();
        }],
      },
    };
  }

  const MARKER_ROW_PX = 11;  // height of a marker row, CSS px
  const MARKER_GAP_PX = 9;   // markers of a row at least this far apart (a triangle is 8 px wide)
  // plot -> per row {row, drawn: [x, CSS px], hidden: too close, outside: out of the plot's time range}
  const markerStats = new Map();

  // The events drawn as markers, in rows: each variant's impacts, then the
  // uplifts, rests and overturns of every source (in time order).
  function markerRows() {
    const rows = [];
    const byVariant = new Map();
    const others = {name: 'uplift/rest/overturn', color: '#444', events: []};
    for (const e of held.events) {
      if (e.kind === 'impact') {
        let row = byVariant.get(e.source);
        if (!row) {
          const v = held.variants.get(e.source);
          row = {name: 'impact ' + e.source, color: v ? v.color : '#555', events: []};
          byVariant.set(e.source, row);
        }
        row.events.push(e);
      } else if (MARKER[e.kind]) {
        others.events.push(e);
      }
    }
    for (const name of held.variants.keys()) if (byVariant.has(name)) rows.push(byVariant.get(name));
    for (const [name, row] of byVariant) if (!held.variants.has(name)) rows.push(row);
    if (others.events.length) rows.push(others);
    for (const row of rows) row.events.sort((a, b) => a.t - b.t);
    return rows;
  }

  const CHART_HEIGHT_PX = 300;
  const BODY_CHART_HEIGHT_PX = 220;  // a body's chart: several stack up

  function chartWidth(el) {
    return Math.max(300, el.clientWidth || 900);
  }

  // `height`: CSS px (300 unless given); `plugins`: the flags and events
  // unless given (the body charts draw neither: both are the bottom body's).
  function makePlot(el, yLabel, series, bands, height, plugins) {
    el.textContent = '';
    const options = {
      width: chartWidth(el),
      height: height || CHART_HEIGHT_PX,
      scales: {x: {time: false}},
      axes: [{label: 'time (s)'}, {label: yLabel}],
      series: [{label: 't (s)', value: (u, v) => (v === null ? '—' : v.toFixed(3))}].concat(series),
      cursor: {drag: {x: true, y: false}},
      legend: {live: true},
      plugins: plugins || [flagsAndEvents()],
      bands: bands || [],
    };
    return new uPlot(options, [[]].concat(series.map(() => [])), el);
  }

  function buildPlots() {
    const names = Array.from(held.variants.keys()).concat(Array.from(held.bands.keys(), (n) => 'band:' + n));
    const key = names.join('\n') + '\n' + angleUnit;
    if (plots.theta && key === plottedVariants) return;
    plottedVariants = key;
    if (plots.theta) plots.theta.destroy();
    if (plots.error) plots.error.destroy();
    const thetaSeries = [{label: 'measured', stroke: '#111', width: 1.6, spanGaps: true}];
    const errorSeries = [];
    for (const [name, v] of held.variants) {
      thetaSeries.push({label: name, stroke: v.color, width: 1.2, spanGaps: true});
      errorSeries.push({label: name + ' error', stroke: v.color, width: 1.2, spanGaps: true});
      errorSeries.push({label: name + ' rms', stroke: v.color, width: 1.6, dash: [6, 4], spanGaps: true});
    }
    // Each band: its median (dashed) and four quantile curves, the 95 % and
    // 68 % ranges filled between them (uPlot bands: [upper, lower] series).
    const fills = [];
    for (const [name, b] of held.bands) {
      const first = thetaSeries.length + 1;  // uPlot's index of the median (0 is x)
      const edge = 'rgba(' + b.rgb + ', 0.35)';
      thetaSeries.push({label: name + ' median', stroke: 'rgb(' + b.rgb + ')', width: 1.4, dash: [8, 4], spanGaps: true});
      thetaSeries.push({label: name + ' 2.5 %', stroke: edge, width: 0.5, spanGaps: true});
      thetaSeries.push({label: name + ' 16 %', stroke: edge, width: 0.5, spanGaps: true});
      thetaSeries.push({label: name + ' 84 %', stroke: edge, width: 0.5, spanGaps: true});
      thetaSeries.push({label: name + ' 97.5 %', stroke: edge, width: 0.5, spanGaps: true});
      fills.push({series: [first + 4, first + 1], fill: 'rgba(' + b.rgb + ', 0.14)'});  // 97.5 %, 2.5 %
      fills.push({series: [first + 3, first + 2], fill: 'rgba(' + b.rgb + ', 0.22)'});  // 84 %, 16 %
    }
    plots.theta = makePlot(document.getElementById('theta-chart'), 'θ (' + angleUnit + ')', thetaSeries, fills);
    plots.error = makePlot(document.getElementById('error-chart'), 'error (' + angleUnit + ')', errorSeries);
  }

  // theta_model - theta_measured (deg) at each model point held: the
  // measured value at the same sample-clock time (both series keep the
  // first sample of each slot of the same clock), else interpolated
  // linearly between its neighbours; null outside the measured span.
  function modelRateError(model) {
    const mt = held.measured.t, mtheta = held.measured.theta;
    const out = new Array(model.t.length);
    for (let i = 0; i < model.t.length; i++) {
      const t = model.t[i];
      const j = firstFrom(mt, t);
      let measured = null;
      if (j < mt.length && mt[j] === t) {
        measured = mtheta[j];
      } else if (j > 0 && j < mt.length && mtheta[j - 1] !== null && mtheta[j] !== null) {
        const w = (t - mt[j - 1]) / (mt[j] - mt[j - 1]);
        measured = mtheta[j - 1] + w * (mtheta[j] - mtheta[j - 1]);
      }
      const theta = model.theta[i];
      out[i] = measured === null || theta === null ? null : theta - measured;
    }
    return out;
  }

  function shown(degreesArray) { return degreesArray.map(fromDeg); }

  function renderCharts() {
    buildPlots();
    const thetaTables = [[held.measured.t, shown(held.measured.theta)]];
    const errorTables = [];
    for (const v of held.variants.values()) {
      thetaTables.push([v.theta.t, shown(v.theta.theta)]);
      errorTables.push([v.theta.t, shown(modelRateError(v.theta))]);
      errorTables.push([v.cmp.t, shown(v.cmp.rms)]);
    }
    for (const b of held.bands.values()) {
      const s = b.band;
      thetaTables.push([s.t, shown(s.median), shown(s.lo95), shown(s.lo68), shown(s.hi68), shown(s.hi95)]);
    }
    // uPlot.join aligns the series on one x array (they share the sample
    // clock's decimation grid, so it mostly merges equal times).
    plots.theta.setData(uPlot.join(thetaTables));
    plots.error.setData(errorTables.length ? uPlot.join(errorTables) : [[]]);
  }

  // -- an assembly: a chart per body ----------------------------------------------

  const NO_SERIES = {t: [], theta: []};

  // The variants that carry bodies (model_state4_t of two or more), in order.
  function assemblyVariants() {
    return Array.from(held.variants).filter(([, v]) => v.bodies.length > 0 || v.bodiesLatest !== null);
  }

  // Bodies to draw: the most that any source has (RL_BODIES, a variant's
  // theta or its RL_COMPAREBODIES); 0 for a single block.
  function bodyCount() {
    let n = held.bodies.length;
    for (const [, v] of assemblyVariants()) {
      n = Math.max(n, v.bodies.length, v.bodiesLatest ? v.bodiesLatest.nbodies : 0);
    }
    return n;
  }

  function bodyName(k, n) {
    return 'body ' + k + (k === 0 ? ' (on the table)' : (k === n - 1 ? ' (top)' : ''));
  }

  // One chart per body: the measured angle (RL_BODIES) and each assembly
  // variant's, in the variant's colour. Rebuilt when the bodies, the
  // assembly variants or the unit change.
  function buildBodyPlots(n, variants) {
    const key = n + '\n' + variants.map(([name]) => name).join('\n') + '\n' + angleUnit;
    if (key === plottedBodies) return;
    plottedBodies = key;
    for (const p of plots.bodies) p.destroy();
    plots.bodies = [];
    const container = document.getElementById('bodies-charts');
    container.textContent = '';
    for (let k = 0; k < n; k++) {
      const row = document.createElement('div');
      row.className = 'body-row';
      row.setAttribute('data-body', String(k));
      const title = document.createElement('h3');
      title.textContent = 'θ (' + angleUnit + ') of ' + bodyName(k, n);
      const el = document.createElement('div');
      el.className = 'chart body-chart';
      row.appendChild(title);
      row.appendChild(el);
      container.appendChild(row);
      const series = [{label: 'measured', stroke: '#111', width: 1.6, spanGaps: true}];
      for (const [name, v] of variants) series.push({label: name, stroke: v.color, width: 1.2, spanGaps: true});
      plots.bodies.push(makePlot(el, 'θ, body ' + k + ' (' + angleUnit + ')', series, [], BODY_CHART_HEIGHT_PX, []));
    }
  }

  function renderBodies() {
    const n = bodyCount();
    const section = document.getElementById('bodies-section');
    if (section) section.hidden = n === 0;
    const variants = assemblyVariants();
    if (n === 0) {
      if (plots.bodies.length) buildBodyPlots(0, []);
    } else {
      buildBodyPlots(n, variants);
      plots.bodies.forEach((p, k) => {
        const m = held.bodies[k] || NO_SERIES;
        const tables = [[m.t, shown(m.theta)]];
        for (const [, v] of variants) {
          const s = v.bodies[k] || NO_SERIES;
          tables.push([s.t, shown(s.theta)]);
        }
        p.setData(uPlot.join(tables));
      });
    }
    const dropped = document.getElementById('bodies-dropped');
    if (dropped) {
      dropped.textContent = held.bodiesDropped > 0
        ? 'bodies beyond those drawn, left out by the monitor: ' + held.bodiesDropped : '';
    }
    renderBodyTables(n, variants);
  }

  // -- tables ---------------------------------------------------------------------

  function cell(row, text, attrs, cls) {
    const td = document.createElement('td');
    td.textContent = text;
    if (cls) td.className = cls;
    for (const [k, v] of Object.entries(attrs || {})) td.setAttribute(k, v);
    row.appendChild(td);
    return td;
  }

  // A table row for `name` (attribute `attr` on it and its cells) opening
  // with a cell of a colour swatch and the name.
  function nameRow(attr, name, colour) {
    const row = document.createElement('tr');
    row.setAttribute(attr, name);
    const first = cell(row, '', {[attr]: name, 'data-field': 'name'});
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = colour;
    first.appendChild(swatch);
    first.appendChild(document.createTextNode(name));
    return row;
  }

  function renderComparison() {
    const body = document.querySelector('#comparison tbody');
    body.textContent = '';
    for (const [name, v] of held.variants) {
      const row = nameRow('data-variant', name, v.color);
      const m = v.meta;
      const at = (f) => ({'data-variant': name, 'data-field': f});
      cell(row, m.model || '—', at('model'), 'text');
      cell(row, fmtG(fromRad(m.alpha)), at('alpha'));
      cell(row, fmtG(m.p), at('p'));
      cell(row, fmtG(m.mu), at('mu'));
      const l = v.latest || {};
      // Samples compared; marked when the newest comparison was invalid (DAQ flags).
      cell(row, l.samples === undefined ? '—' : String(l.samples) + (l.valid === false ? ' (invalid now)' : ''),
        at('samples'), l.valid === false ? 'invalid' : '');
      const sources = {latest: l, whole: v.whole || {}};
      for (const [source, f, angle] of COMPARISON_COLUMNS) {
        const x = sources[source][f];
        cell(row, f === 'impact_timings' ? (x === undefined ? '—' : String(x)) : fmtG(angle ? fromRad(x) : x), at(f));
      }
      body.appendChild(row);
    }
  }

  function renderBands() {
    const section = document.getElementById('bands-section');
    if (section) section.hidden = held.bands.size === 0;
    const body = document.querySelector('#bands tbody');
    if (!body) return;
    body.textContent = '';
    for (const [name, b] of held.bands) {
      const row = nameRow('data-band', name, 'rgba(' + b.rgb + ', 0.5)');
      const m = b.meta;
      cell(row, m.model || '—', {'data-band': name, 'data-field': 'model'}, 'text');
      cell(row, m.members === null || m.members === undefined ? '—' : m.members + '/' + m.draws,
        {'data-band': name, 'data-field': 'members'});
      const l = b.latest || {};
      for (const f of BAND_FIELDS) {
        cell(row, fmtG(BAND_ANGLE_FIELDS.has(f) ? fromRad(l[f]) : l[f]), {'data-band': name, 'data-field': f});
      }
      body.appendChild(row);
    }
  }

  // An assembly's figures (each variant's newest RL_COMPAREBODIES_<name>):
  // a row per (variant, body), cells data-assembly / data-body / data-field
  // (not data-variant: those cells are the single-block table's), and a row
  // per variant with its modes and their agreement (data-modes).
  // [field, is an angle]: totals since the start, then the newest values.
  const BODY_COLUMNS = [['rms_total', true], ['nrms', false], ['correlation', false],
    ['peak_error', true], ['impact_timing_error', false]];
  const MODE_COLUMNS = [['mode_model', false], ['mode_measured', false], ['mode_agreement', false],
    ['mode_samples', false], ['mode_rest_rad', true]];

  function renderBodyTables(n, variants) {
    const body = document.querySelector('#bodies tbody');
    const modes = document.querySelector('#modes tbody');
    if (!body || !modes) return;
    body.textContent = '';
    modes.textContent = '';
    for (const [name, v] of variants) {
      const l = v.bodiesLatest || {};
      for (let k = 0; k < n; k++) {
        const row = nameRow('data-assembly', name, v.color);
        row.setAttribute('data-body', String(k));
        row.firstChild.setAttribute('data-body', String(k));
        const at = (f) => ({'data-assembly': name, 'data-body': String(k), 'data-field': f});
        cell(row, bodyName(k, n), at('body'), 'text');
        const valid = Array.isArray(l.valid) ? l.valid[k] : undefined;
        cell(row, l.samples === undefined ? '—' : String(l.samples) + (valid === false ? ' (invalid now)' : ''),
          at('samples'), valid === false ? 'invalid' : '');
        for (const [f, angle] of BODY_COLUMNS) {
          const x = Array.isArray(l[f]) ? l[f][k] : undefined;
          cell(row, fmtG(angle ? fromRad(x) : x), at(f));
        }
        body.appendChild(row);
      }
      const row = nameRow('data-modes', name, v.color);
      for (const [f, angle] of MODE_COLUMNS) {
        const x = l[f];
        const text = f === 'mode_samples' ? (x === undefined ? '—' : String(x))
          : (f.startsWith('mode_m') ? (x === undefined || x === '' ? '—' : x) : fmtG(angle ? fromRad(x) : x));
        cell(row, text, {'data-modes': name, 'data-field': f}, f.startsWith('mode_m') ? 'text' : '');
      }
      modes.appendChild(row);
    }
  }

  // Live: each node's latest RL_HEALTH. A finished test (static): its
  // final counts, and the rates over the time it ran (count over the
  // sample clock from the record's start to the node's last message).
  const HEALTH_LIVE = [['state', 'state'], ['rate_in_hz', 'in (Hz)'], ['rate_out_hz', 'out (Hz)'],
    ['count_in', 'count in'], ['count_out', 'count out'], ['dropped', 'dropped'],
    ['gaps', 'missing in (gaps)'], ['bad_samples', 'bad samples'], ['lag_s', 'lag (s)']];
  const HEALTH_FINAL = [['state', 'final state'], ['count_in', 'messages in'],
    ['count_out', 'messages out'], ['mean_rate_in_hz', 'rate in while it ran (Hz)'],
    ['mean_rate_out_hz', 'rate out while it ran (Hz)'], ['ran_s', 'ran (s)'], ['dropped', 'dropped'],
    ['gaps', 'missing in (gaps)'], ['bad_samples', 'bad samples']];

  function renderHealth() {
    const finished = mode === 'static';
    const columns = finished ? HEALTH_FINAL : HEALTH_LIVE;
    const title = document.getElementById('health-title');
    if (title) title.textContent = finished ? 'Node health at the end of the test (last RL_HEALTH of each node)'
      : 'Node health (latest RL_HEALTH)';
    const head = document.querySelector('#health thead tr');
    head.textContent = '';
    for (const label of ['node'].concat(columns.map(([, l]) => l))) {
      const th = document.createElement('th');
      th.textContent = label;
      head.appendChild(th);
    }
    const body = document.querySelector('#health tbody');
    body.textContent = '';
    const t0 = held.t0Utime;
    for (const h of held.health) {
      const row = document.createElement('tr');
      row.setAttribute('data-node', h.node);
      cell(row, h.node, {'data-node': h.node, 'data-field': 'node'});
      const ran = typeof t0 === 'number' && typeof h.utime === 'number' ? (h.utime - t0) / 1e6 : null;
      const value = {
        ran_s: ran,
        mean_rate_in_hz: ran > 0 ? h.count_in / ran : null,
        mean_rate_out_hz: ran > 0 ? h.count_out / ran : null,
      };
      for (const [f] of columns) {
        const x = f in value ? value[f] : h[f];
        cell(row, f === 'state' ? h.state : (Number.isInteger(x) ? String(x) : fmtG(x)),
          {'data-node': h.node, 'data-field': f}, f === 'state' ? 'text' : '');
      }
      body.appendChild(row);
    }
  }

  function renderEvents() {
    const body = document.querySelector('#events tbody');
    body.textContent = '';
    const n = held.events.length;
    for (let i = n - 1; i >= Math.max(0, n - MAX_EVENT_ROWS); i--) {
      const e = held.events[i];
      const row = document.createElement('tr');
      cell(row, e.t.toFixed(3));
      cell(row, e.source, {}, 'text');
      cell(row, e.kind, {}, 'text');
      const [value, unit] = eventValue(e);
      cell(row, fmtG(value));
      cell(row, unit, {}, 'text');
      cell(row, e.detail, {}, 'text');
      body.appendChild(row);
    }
  }

  function renderCounters() {
    const body = document.querySelector('#counters tbody');
    body.textContent = '';
    const c = held.counters;
    if (!c) return;
    for (const [channel, count] of Object.entries(c.messages)) {
      const row = document.createElement('tr');
      cell(row, channel, {'data-channel': channel, 'data-field': 'channel'});
      cell(row, String(count), {'data-channel': channel, 'data-field': 'messages'});
      cell(row, String(c.decode_errors[channel] || 0), {'data-channel': channel, 'data-field': 'decode_errors'});
      // Messages missing by their publishers' seq ('-': an older type without one).
      const missing = c.seq_missing && channel in c.seq_missing ? String(c.seq_missing[channel]) : '-';
      cell(row, missing, {'data-channel': channel, 'data-field': 'seq_missing'});
      body.appendChild(row);
    }
    const dropped = Object.entries(c.dropped).filter(([, n]) => n > 0);
    document.getElementById('dropped').textContent = dropped.length
      ? 'dropped by the monitor: ' + dropped.map(([k, n]) => k + ' ' + n).join(', ') : '';
  }

  function renderHeader() {
    const c = held.config;
    const parts = [];
    if (c) {
      parts.push('rig ' + c.rig_name, 'calibration ' + c.calibration_id);
      if (c.sample_rate_hz !== null) parts.push(fmtG(c.sample_rate_hz) + ' Hz');
      if (c.alpha !== null) {
        parts.push('alpha ' + fmtG(fromRad(c.alpha)) + ' ' + angleUnit + ', p ' + fmtG(c.p) + ' rad/s, mu ' + fmtG(c.mu));
      }
    }
    document.getElementById('rig').textContent = c ? parts.join(' · ') : 'no RL_DAQ_CONFIG yet';
    document.getElementById('clock').textContent =
      (held.tLatest === null ? 't —' : 't ' + held.tLatest.toFixed(2) + ' s') +
      (held.windowS === null ? ' · whole record' : ' · window ' + held.windowS + ' s');
  }

  function render() {
    renderPending = false;
    for (const el of document.querySelectorAll('.angle-unit')) el.textContent = angleUnit;
    renderCharts();
    renderBodies();
    renderComparison();
    renderBands();
    renderHealth();
    renderEvents();
    renderCounters();
    renderHeader();
  }

  // Under the error chart: the marker rows that left markers out, with counts.
  function renderMarkerNote(stats) {
    const note = document.getElementById('marker-note');
    if (!note) return;
    const thinned = stats.filter((r) => r.hidden > 0)
      .map((r) => r.row + ': ' + r.drawn.length + ' drawn, ' + r.hidden + ' too close left out');
    note.textContent = thinned.length ? 'markers thinned (' + thinned.join('; ') + ')' : '';
  }

  const unitSwitch = document.getElementById('angle-unit');
  if (unitSwitch) {
    unitSwitch.value = angleUnit;
    unitSwitch.addEventListener('change', () => {
      angleUnit = unitSwitch.value === 'deg' ? 'deg' : 'rad';
      render();
    });
  }

  function scheduleRender() {
    if (renderPending) return;
    renderPending = true;
    // At most one render per frame; a hidden tab renders when shown again.
    requestAnimationFrame(render);
  }

  function setStatus(state, text) {
    mode = state;
    const el = document.getElementById('status');
    el.setAttribute('data-status', state);
    el.textContent = text;
  }

  window.addEventListener('resize', () => {
    for (const p of [plots.theta, plots.error]) {
      if (p) p.setSize({width: chartWidth(p.root.parentNode), height: CHART_HEIGHT_PX});
    }
    for (const p of plots.bodies) p.setSize({width: chartWidth(p.root.parentNode), height: BODY_CHART_HEIGHT_PX});
  });

  // -- the page's data as CSV, built in the page (a Blob, no request) ---------

  function csvField(x) {
    if (x === null || x === undefined) return '';
    if (typeof x === 'number') return Number.isFinite(x) ? String(x) : '';
    const text = String(x);
    return /[",\r\n]/.test(text) ? '"' + text.replace(/"/g, '""') + '"' : text;
  }

  // Every series the page holds on one time axis (the union of their
  // sample-clock times, s): a cell is empty where a series has no point.
  function seriesCsv() {
    const columns = [['theta_measured_deg', held.measured.t, held.measured.theta],
      ['table_accel_mps2', held.table.t, held.table.accel]];
    for (const [name, v] of held.variants) {
      columns.push(['theta_' + name + '_deg', v.theta.t, v.theta.theta]);
      columns.push(['error_' + name + '_deg', v.cmp.t, v.cmp.err]);
      columns.push(['rms_window_' + name + '_deg', v.cmp.t, v.cmp.rms]);
    }
    // An assembly: each body's measured and assembly variants' angles.
    held.bodies.forEach((s, k) => columns.push(['theta_measured_body_' + k + '_deg', s.t, s.theta]));
    for (const [name, v] of held.variants) {
      v.bodies.forEach((s, k) => columns.push(['theta_' + name + '_body_' + k + '_deg', s.t, s.theta]));
    }
    for (const [name, b] of held.bands) {
      for (const q of ['median', 'lo95', 'lo68', 'hi68', 'hi95']) {
        columns.push(['band_' + name + '_' + q + '_deg', b.band.t, b.band[q]]);
      }
    }
    const times = new Set();
    for (const [, t] of columns) for (const x of t) times.add(x);
    const axis = Array.from(times).sort((a, b) => a - b);
    const index = new Map(axis.map((t, i) => [t, i]));
    const rows = axis.map((t) => [t].concat(columns.map(() => null)));
    columns.forEach(([, t, values], c) => {
      for (let i = 0; i < t.length; i++) rows[index.get(t[i])][c + 1] = values[i];
    });
    const lines = [['t_s'].concat(columns.map(([name]) => name)).map(csvField).join(',')];
    for (const row of rows) lines.push(row.map(csvField).join(','));
    return lines.join('\n') + '\n';
  }

  function eventsCsv() {
    const lines = ['t_s,source,kind,value,unit,detail'];
    for (const e of held.events) {
      const [value, unit] = eventValueDeg(e);
      lines.push([e.t, e.source, e.kind, value, unit, e.detail].map(csvField).join(','));
    }
    return lines.join('\n') + '\n';
  }

  function download(name, text) {
    const url = URL.createObjectURL(new Blob([text], {type: 'text/csv'}));
    const a = document.createElement('a');
    a.href = url;
    a.download = name;
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 0);
  }

  function baseName() {
    const title = document.title.replace(/^rocklab (report|monitor): ?/, '');
    return (title || 'rocklab').replace(/\.lcm$/, '').replace(/[^A-Za-z0-9._-]+/g, '_');
  }

  for (const [id, make, suffix] of [['download-series', seriesCsv, '_series.csv'],
    ['download-events', eventsCsv, '_events.csv']]) {
    const button = document.getElementById(id);
    if (button) button.addEventListener('click', () => download(baseName() + suffix, make()));
  }

  window.rocklabMonitor = {
    plots: plots,
    get updates() { return updates; },
    get mode() { return mode; },
    dataLengths: () => ({
      theta: plots.theta ? plots.theta.data.map((a) => a.length) : [],
      error: plots.error ? plots.error.data.map((a) => a.length) : [],
    }),
    // An assembly's body charts, bottom-up: the body index, the heading, the
    // series' labels (measured, then each assembly variant) and the points
    // of each series that are not null (x first). [] for a single block.
    bodyRows: () => plots.bodies.map((p, k) => ({
      body: k,
      title: p.root.parentNode.parentNode.querySelector('h3').textContent,
      series: p.series.slice(1).map((s) => s.label),
      points: p.data.map((a) => a.filter((x) => x !== null && x !== undefined).length),
    })),
    bandNames: () => Array.from(held.bands.keys()),
    // Per chart and marker row: the markers' x (CSS px) drawn and the number left out.
    markers: () => ({theta: markerStats.get(plots.theta) || [], error: markerStats.get(plots.error) || []}),
    get angleUnit() { return angleUnit; },
    setAngleUnit: (u) => { if (unitSwitch) { unitSwitch.value = u; unitSwitch.dispatchEvent(new Event('change')); } },
    fmtG: fmtG,
    seriesCsv: seriesCsv,
    eventsCsv: eventsCsv,
  };

  if (window.ROCKLAB_SNAPSHOT !== undefined) {
    setStatus('static', 'recorded test');
    const heading = document.querySelector('h1');
    if (heading) heading.textContent = 'rocklab report';
    apply(window.ROCKLAB_SNAPSHOT);
    render();
    return;
  }
  const source = new EventSource('api/events');
  source.onopen = () => setStatus('live', 'live');
  source.onerror = () => setStatus('reconnecting', 'reconnecting…');
  source.onmessage = (event) => {
    apply(JSON.parse(event.data));
    scheduleRender();
  };
})();
