// Opens the rocklab monitor page in Debian's headless Chromium (through
// playwright-core, which downloads no browser) while a test replays into it,
// then reports what the page shows. Run by tests/monitor/browser_test.cpp:
//
//   node monitor_page.js URL OUT.json SCREENSHOT.png READY_FILE DONE_FILE PROFILE_DIR
//
// 1. opens URL in a fresh profile and waits for the live event stream;
// 2. writes READY_FILE (the test then starts the replay) and waits for
//    DONE_FILE (the replay has ended);
// 3. waits for the server's final snapshot (the compare node stopped, the
//    comparisons no longer changing), then until the table shows, for every
//    variant, its sample count (the page caught up with the last RL_COMPARE),
//    and for every assembly variant the mode samples of its last
//    RL_COMPAREBODIES;
// 4. writes OUT.json: the table cells (data-variant, data-field -> text), the
//    uPlot data lengths, an assembly's body charts and per-body cells
//    (data-assembly, data-body, data-field; data-modes, data-field), the
//    update count, console errors; saves a screenshot;
// 5. renders the page in static mode (files and the final snapshot inlined,
//    as `rocklab report` does) and adds what it shows, and the requests it
//    made, as "static".
'use strict';

const fs = require('fs');
const http = require('http');
const path = require('path');
const {chromium} = require('playwright-core');

const [url, outPath, screenshotPath, readyFile, doneFile, profileDir] = process.argv.slice(2);
const STEP_TIMEOUT_MS = 20000;  // a bound on each wait, not a measurement
const consoleErrors = [];       // the page's console errors and uncaught exceptions

function sleep(ms) {
  return new Promise((resolve) => setTimeout(resolve, ms));
}

async function waitForFile(file) {
  const deadline = Date.now() + 60000;
  while (!fs.existsSync(file)) {
    if (Date.now() > deadline) throw new Error('no ' + file + ' within 60 s');
    await sleep(50);
  }
}

async function getJson(address) {
  return JSON.parse(await getText(address));
}

// What the page shows, read in the page: table cells by data attributes,
// the uPlot data lengths, the update count and the mode.
function collectShown() {
  const cells = {};
  for (const td of document.querySelectorAll('td[data-variant][data-field]')) {
    const v = td.getAttribute('data-variant');
    (cells[v] = cells[v] || {})[td.getAttribute('data-field')] = td.textContent;
  }
  const health = {};
  for (const td of document.querySelectorAll('td[data-node][data-field]')) {
    const n = td.getAttribute('data-node');
    (health[n] = health[n] || {})[td.getAttribute('data-field')] = td.textContent;
  }
  const bodyCells = {};  // variant -> body index -> field -> text
  for (const td of document.querySelectorAll('td[data-assembly][data-body][data-field]')) {
    const v = td.getAttribute('data-assembly');
    const k = td.getAttribute('data-body');
    ((bodyCells[v] = bodyCells[v] || {})[k] = bodyCells[v][k] || {})[td.getAttribute('data-field')] = td.textContent;
  }
  const modeCells = {};  // variant -> field -> text
  for (const td of document.querySelectorAll('td[data-modes][data-field]')) {
    const v = td.getAttribute('data-modes');
    (modeCells[v] = modeCells[v] || {})[td.getAttribute('data-field')] = td.textContent;
  }
  return {cells, health, dataLengths: window.rocklabMonitor.dataLengths(),
    bodyRows: window.rocklabMonitor.bodyRows(), bodyCells, modeCells,
    bodiesHidden: document.getElementById('bodies-section').hidden,
    updates: window.rocklabMonitor.updates, mode: window.rocklabMonitor.mode};
}

// The server's final snapshot. The run has ended at DONE_FILE, but the
// monitor may still be reading its last messages from the socket (under
// load it was 550 samples of RL_COMPARE behind, and the page then caught
// up with numbers newer than the ones it was told to wait for): wait until
// the compare node's RL_HEALTH says "stopped" (it sends that after its
// final RL_COMPARE) and two reads 0.25 s apart agree on every variant's
// comparison.
async function settledSnapshot(base) {
  const deadline = Date.now() + STEP_TIMEOUT_MS;
  const key = (s) => JSON.stringify(s.variants.map((v) => [v.name, v.latest, v.bodies_latest || null]));
  let last = null;
  for (;;) {
    const snapshot = await getJson(base + 'api/snapshot');
    const stopped = snapshot.health.some((h) => h.node === 'compare' && h.state === 'stopped');
    if (stopped && last !== null && key(snapshot) === key(last)) return snapshot;
    if (Date.now() > deadline) throw new Error('the server\'s snapshot did not settle within ' + STEP_TIMEOUT_MS + ' ms');
    last = snapshot;
    await sleep(250);
  }
}

function window_updates([updates, mode]) {
  return updates + ' updates applied, ' + mode;
}

function getText(address) {
  return new Promise((resolve, reject) => {
    http.get(address, (res) => {
      let body = '';
      res.setEncoding('utf8');
      res.on('data', (chunk) => { body += chunk; });
      res.on('end', () => resolve(body));
    }).on('error', reject);
  });
}

// The page with its files and a snapshot inlined (no network at all).
async function staticHtml(base, snapshot) {
  const file = (name) => getText(base + name);
  const [html, app, style, uplot, uplotCss] = await Promise.all(
    [file('index.html'), file('app.js'), file('style.css'), file('uPlot.iife.min.js'), file('uPlot.min.css')]);
  const data = JSON.stringify(snapshot).replace(/</g, '\\u003c');
  // Function replacements: the inlined code may hold "$&"-like sequences.
  return html
    .replace('<link rel="stylesheet" href="uPlot.min.css">', () => '<style>' + uplotCss + '</style>')
    .replace('<link rel="stylesheet" href="style.css">', () => '<style>' + style + '</style>')
    .replace('<script src="uPlot.iife.min.js"></script>', () => '<script>' + uplot + '</script>')
    .replace('<script src="app.js"></script>',
      () => '<script>window.ROCKLAB_SNAPSHOT = ' + data + ';</script><script>' + app + '</script>');
}

async function main() {
  const context = await chromium.launchPersistentContext(profileDir, {
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
    viewport: {width: 1280, height: 1000},
  });
  try {
    const page = context.pages()[0] || await context.newPage();
    page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
    page.on('pageerror', (e) => consoleErrors.push(String(e)));
    await page.goto(url, {timeout: STEP_TIMEOUT_MS});
    await page.waitForFunction(() => window.rocklabMonitor && window.rocklabMonitor.mode === 'live',
      null, {timeout: STEP_TIMEOUT_MS});
    fs.writeFileSync(readyFile, 'ready\n');

    await waitForFile(doneFile);
    const snapshot = await settledSnapshot(url);
    const expected = {};
    const expectedModes = {};
    for (const v of snapshot.variants) {
      if (v.latest) expected[v.name] = String(v.latest.samples);
      if (v.bodies_latest) expectedModes[v.name] = String(v.bodies_latest.mode_samples);
    }
    const caughtUp = page.waitForFunction(([want, wantModes]) => {
      for (const [name, samples] of Object.entries(want)) {
        const td = document.querySelector(`td[data-variant="${name}"][data-field="samples"]`);
        if (!td || td.textContent !== samples) return false;
      }
      for (const [name, samples] of Object.entries(wantModes)) {
        const td = document.querySelector(`td[data-modes="${name}"][data-field="mode_samples"]`);
        if (!td || td.textContent !== samples) return false;
      }
      return window.rocklabMonitor.dataLengths().theta.length > 1;
    }, [expected, expectedModes], {timeout: STEP_TIMEOUT_MS});
    try {
      await caughtUp;
    } catch (e) {
      // Say what differed: the samples the page shows, those of the
      // snapshot taken at DONE_FILE and of one taken now.
      const shownSamples = await page.evaluate(() => Array.from(
        document.querySelectorAll('td[data-field="samples"],td[data-field="mode_samples"]'),
        (td) => [td.getAttribute('data-variant') || td.getAttribute('data-assembly') || td.getAttribute('data-modes'),
          td.textContent]));
      const now = await getJson(url + 'api/snapshot');
      throw new Error(e.message + '\nwaited for ' + JSON.stringify([expected, expectedModes]) +
        '\nthe page shows ' + JSON.stringify(shownSamples) + ' (' + window_updates(await page.evaluate(
          () => [window.rocklabMonitor.updates, window.rocklabMonitor.mode])) + ')\nthe server now has ' +
        JSON.stringify(now.variants.map((v) => [v.name, v.latest && v.latest.samples])));
    }

    const shown = await page.evaluate(collectShown);
    fs.mkdirSync(path.dirname(screenshotPath), {recursive: true});
    await page.screenshot({path: screenshotPath, fullPage: true});
    shown.serverVariants = Object.keys(expected);

    // Static mode, as `rocklab report` uses the page: the same files inlined
    // with the final snapshot as window.ROCKLAB_SNAPSHOT; it must render that
    // and request nothing.
    const staticPage = await context.newPage();
    const requests = [];
    staticPage.on('request', (r) => { if (!r.url().startsWith('data:')) requests.push(r.url()); });
    staticPage.on('pageerror', (e) => consoleErrors.push('static page: ' + String(e)));
    await staticPage.setContent(await staticHtml(url, snapshot));
    await staticPage.waitForFunction(() => window.rocklabMonitor && window.rocklabMonitor.mode === 'static',
      null, {timeout: STEP_TIMEOUT_MS});
    shown.static = await staticPage.evaluate(collectShown);
    shown.static.requests = requests;
    shown.consoleErrors = consoleErrors;
    fs.writeFileSync(outPath, JSON.stringify(shown, null, 2) + '\n');
  } finally {
    await context.close();
  }
}

main().catch((e) => {
  console.error('monitor_page.js: ' + (e && e.stack ? e.stack : e));
  if (consoleErrors.length) console.error('page console errors:\n' + consoleErrors.join('\n'));
  process.exit(1);
});
