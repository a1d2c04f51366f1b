"""rocklab: the rocking-block laboratory's data and models in Python.

The same C++ core as the ``rocklab`` command line (docs/python.md):

- ``block_params``: alpha, p and mu of a section (``rocklab params``);
- ``simulate``: Housner's model or the complex formulation under a table
  motion (``rocklab simulate``), numpy out;
- ``read_log``, ``read_raw``, ``info``: recorded LCM logs and raw CSV/LVM
  files into numpy structured arrays (``rocklab export``, ``rocklab info``);
- ``reconstruct``: theta and the checks from a raw file (``rocklab
  reconstruct``);
- ``fit``: alpha, p and mu from a record (``rocklab fit``);
- ``posterior``, ``posterior_problem``: their posterior by an ensemble
  sampler (``rocklab fit --posterior``), and its log density for other
  samplers;
- ``sweep``, ``fragility``: campaigns over records x blocks x scales and
  their lognormal fragility (``rocklab sweep``, ``rocklab sweep-plot``);
- the LCM message types of the lab (``rocklab.raw_frame_t`` etc., generated
  by ``lcm-gen -p``) where the package was built with them.

SI units throughout (m, s, rad, m/s^2). Every call releases the GIL while
it works; long ones take ``progress=callable(done, total)`` and stop with
KeyboardInterrupt on Ctrl-C. Bad arguments raise ValueError with the
command line's message (naming the option, e.g. ``--alpha``), as does a
file that opens but is not what it should be (no header, a rate that
disagrees, naming its line); files that cannot be read raise OSError.
"""

import functools as _functools
import html as _html
import json as _json
import operator as _operator
import os as _os
import sys as _sys
import warnings as _warnings

from . import _build_info


def _import_hint(error):
    """The ImportError of a failed ``import rocklab``: the interpreter and
    numpy the module was built for, the ones running, and the way out."""
    try:
        import numpy

        running_numpy = "numpy " + numpy.__version__
    except Exception:  # missing, or broken: either way not the build's
        running_numpy = "no importable numpy"
    running = "%d.%d.%d" % _sys.version_info[:3]
    b = _build_info
    return (
        f"import rocklab failed: {error}\n"
        f"The module rocklab was built for Python {b.PYTHON_VERSION} ({b.PYTHON_EXECUTABLE}) with numpy "
        f"{b.NUMPY_VERSION}; this is Python {running} ({_sys.executable}) with {running_numpy}.\n"
        f"Use the interpreter it was built for ({b.PYTHON_EXECUTABLE}): the system's /usr/bin/python3, or a venv "
        "made from it with `/usr/bin/python3 -m venv --system-site-packages DIR` (which sees Debian's numpy); "
        "or rebuild rocklab for this interpreter (docs/python.md, \"Install with pip\")."
    )


_built_minor = ".".join(_build_info.PYTHON_VERSION.split(".")[:2])
if _built_minor and "%d.%d" % _sys.version_info[:2] != _built_minor:
    raise ImportError(_import_hint(f"the native module is built for Python {_built_minor}"), name=__name__)
try:
    import numpy as _np

    from . import _rocklab
except (ImportError, RuntimeError) as _e:  # numpy missing, or of another ABI (RuntimeError at _import_array)
    raise ImportError(_import_hint(_e), name=__name__) from _e


def _numpy_abi_error(running, built):
    """Why numpy `running` cannot serve a module built against `built`, or
    None. numpy's rule: a module runs on the numpy major version it was
    built against, of that minor version or later (pybind11 reads numpy's
    API table only at the first array, so the import would not fail)."""
    import re

    r, b = (re.match(r"(\d+)\.(\d+)", v) for v in (running, built))
    if not r or not b:
        return None
    (rmaj, rmin), (bmaj, bmin) = ((int(m.group(1)), int(m.group(2))) for m in (r, b))
    if rmaj != bmaj or rmin < bmin:
        return f"numpy {running} cannot run a module built against numpy {built} (another ABI)"
    return None


_abi = _numpy_abi_error(getattr(_np, "__version__", ""), _build_info.NUMPY_VERSION)
if _abi:
    raise ImportError(_import_hint(_abi), name=__name__)

from ._lcm_types import *  # noqa: F401,F403  the LCM types (lcm-gen -p), rocklab.raw_frame_t etc.

__all__ = [
    "block_params",
    "simulate",
    "SimulationResult",
    "AssemblyResult",
    "ASSEMBLY_EVENT_DTYPE",
    "read_log",
    "read_raw",
    "LogTables",
    "info",
    "reconstruct",
    "Reconstruction",
    "fit",
    "FitResult",
    "posterior",
    "posterior_problem",
    "PosteriorProblem",
    "PosteriorSummary",
    "sweep",
    "fragility",
    "units",
    "SWEEP_DTYPE",
    "EVENT_DTYPE",
    "EVENT_FIELDS",
    "EVENTS_DTYPE",
    "events",
    "DEFAULT_L",
    "GRAVITY",
]

from . import _lcm_types  # noqa: E402

__all__ += sorted(n for n in vars(_lcm_types) if n.endswith("_t"))

def _path(p, what):
    """p (str, bytes or os.PathLike) as the library opens it; a NUL byte,
    which no file name holds and at which C would cut the name, refused."""
    s = _os.fspath(p)
    if ("\0" if isinstance(s, str) else b"\0") in s:
        raise ValueError(f"{what}: the path {s!r} holds a NUL byte, which no file name can")
    return s


_INF = float("inf")


def _short(v):
    """repr of v for a message, at most 60 characters."""
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _float(v, name):
    """v as a float; a wrong type or text raises naming the argument."""
    try:
        return float(v)
    except TypeError:
        raise TypeError(f"{name} must be a number, got {type(v).__name__} {_short(v)}") from None
    except ValueError:
        raise ValueError(f"{name} must be a number, got {_short(v)}") from None


def _int(v, name):
    """v as an int (a whole number); otherwise raises naming the argument."""
    try:
        i = _operator.index(v) if not isinstance(v, float) else int(v)
    except TypeError:
        try:
            i = int(v)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a whole number, got {type(v).__name__} {_short(v)}") from None
    if i != v:
        raise ValueError(f"{name} must be a whole number, got {_short(v)}")
    return i


def _floats(v, name):
    """v as a float64 array; a wrong type raises naming the argument."""
    try:
        return _np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of numbers, got {type(v).__name__} {_short(v)}") from None


def _named_type_errors(f):
    """The library's functions raise TypeError naming the argument (the
    helpers above); a type they do not check must still not show the
    binding's signature dump."""

    @_functools.wraps(f)
    def checked(*args, **kwargs):
        try:
            return f(*args, **kwargs)
        except TypeError as e:
            if "incompatible function arguments" not in str(e):
                raise
            raise TypeError(
                f"rocklab.{f.__name__}: an argument has a type it cannot take; help(rocklab.{f.__name__}) "
                "lists the arguments and their types"
            ) from None

    return checked


#: Default l of the complex formulation (normalised momentum of psi), 1.
__version__ = _rocklab.__version__  # the build's, as `rocklab --version` prints it
DEFAULT_L = _rocklab.DEFAULT_L
#: Gravity used throughout, m/s^2.
GRAVITY = _rocklab.GRAVITY

def _dtype(fields):
    """A structured dtype from (name, format, unit or None): a field with a
    unit has the title "name [unit]", which np.save, np.load and pickle
    keep (numpy cannot reload a dtype's metadata); ``units`` reads it."""
    return _np.dtype([((f"{n} [{u}]", n), f) if u else (n, f) for n, f, u in fields])


def units(a):
    """The units of a structured array's fields, {field: unit}, from their
    titles ("name [unit]") as every table rocklab returns has them, also
    after ``np.save``/``np.load`` or ``pickle``; a field without one is left
    out. ``a`` may be an array or its dtype."""
    dtype = getattr(a, "dtype", a)
    out = {}
    for name, spec in (dtype.fields or {}).items():
        title = spec[2] if len(spec) > 2 else None
        if isinstance(title, str) and title.startswith(name + " [") and title.endswith("]"):
            out[name] = title[len(name) + 2 : -1]
    return out


def _num(v, digits=4):
    """v for a summary: `digits` significant digits; None (withheld) as n/a."""
    if v is None:
        return "n/a"
    if isinstance(v, (float, _np.floating)):
        return f"{float(v):.{digits}g}"
    return str(v)


def _with_error(value, error, unit=""):
    """ "value +- error unit", the error to 2 significant digits."""
    text = _num(value) if error is None else f"{_num(value)} +- {_num(error, 2)}"
    return f"{text} {unit}" if unit else text


def _counts(names):
    """ "3 impact, 1 uplift": the count of each distinct name, most first."""
    tally = {}
    for n in names:
        tally[str(n)] = tally.get(str(n), 0) + 1
    return ", ".join(f"{c} {n}" for n, c in sorted(tally.items(), key=lambda kv: (-kv[1], kv[0]))) or "none"


def _fields_text(a, most=6):
    """An array's fields with their units, "time [s], theta [rad], ...", at most `most`."""
    fields = a.dtype.names or ()
    field_units = units(a)
    shown = [f"{n} [{field_units[n]}]" if n in field_units else n for n in fields[:most]]
    if len(fields) > most:
        shown.append(f"... (+{len(fields) - most} fields)")
    return ", ".join(shown)


class _Summarised:
    """A one-screen ``repr`` and a notebook's ``_repr_html_`` from
    ``_summary()``: (title, [(label, text)]), never the data itself (a
    log's tables are MB: their repr would fill a notebook cell)."""

    _SUMMARY_ROWS = 40

    def _rows(self):
        title, rows = self._summary()
        if len(rows) > self._SUMMARY_ROWS:
            more = len(rows) - self._SUMMARY_ROWS + 1
            rows = rows[: self._SUMMARY_ROWS - 1] + [("...", f"{more} more")]
        return title, rows

    def __repr__(self):
        title, rows = self._rows()
        width = max((len(label) for label, _ in rows), default=0)
        return "\n".join([title] + [f"  {label.ljust(width)}  {text}" for label, text in rows])

    def _repr_html_(self):
        title, rows = self._rows()
        e = _html.escape
        cells = "".join(
            f"<tr><th style='text-align:left'>{e(label)}</th><td style='text-align:left'>{e(text)}</td></tr>"
            for label, text in rows
        )
        return f"<div><strong>{e(title)}</strong><table>{cells}</table></div>"

    def _repr_pretty_(self, printer, cycle):
        # IPython's console: the same summary, not its dict pretty-printer.
        printer.text(repr(self))


def _event_kind_codes():
    """{name: code} of event_t's constants (UPLIFT 1, IMPACT 2, ...): the
    kind_name and kind_code of every events array."""
    event_type = getattr(_lcm_types, "event_t", None)
    return {
        k: v for k, v in vars(event_type).items() if k.isupper() and isinstance(v, int)
    } if event_type is not None else {}


#: The fields every events array has (read_log's RL_EVENT tables,
#: SimulationResult.events, Reconstruction.events), whatever else it holds:
#: ``time`` (s), ``kind_name`` (event_t's constant's name: "UPLIFT",
#: "IMPACT", ...), ``kind_code`` (its value, int64) and ``value``. The field
#: ``kind`` predates them and is kept as it was: read_log's and
#: reconstruct's the code, simulate's the lower-case name.
EVENT_FIELDS = ("time", "kind_name", "kind_code", "value")

#: dtype of SimulationResult.events.
EVENT_DTYPE = _dtype(
    [
        ("time", "f8", "s"),
        ("kind", "U8", None),
        ("value", "f8", "m/s^2 | rad/s | rad"),
        ("theta_dot_after", "f8", "rad/s"),
        ("kind_name", "U16", None),
        ("kind_code", "i8", None),
    ]
)


#: dtype of ``events(a)``: EVENT_FIELDS only, the same dtype (and so the
#: same shape) whatever the source. ``value`` has no unit title: its unit
#: is the kind's (docs/python.md).
EVENTS_DTYPE = _dtype(
    [
        ("time", "f8", "s"),
        ("kind_name", "U16", None),
        ("kind_code", "i8", None),
        ("value", "f8", None),
    ]
)


def events(a):
    """Any events as one structured array of EVENTS_DTYPE (``time`` s,
    ``kind_name``, ``kind_code``, ``value``), the same dtype from every
    source: read_log's RL_EVENT table or the whole ``LogTables`` (its
    events tables merged in time order; empty when it has none),
    ``SimulationResult.events``, ``AssemblyResult.events``,
    ``Reconstruction.events``, a ``FitResult`` (its impacts, ``value``
    NaN), or an object with such an ``events`` attribute. The sources keep their own arrays as they
    were (their field ``kind`` differs: the code in read_log, the name in
    simulate); this is the copy to concatenate, compare or save together."""
    if isinstance(a, LogTables):
        # Every events table of the log (RL_EVENT, and a channel's table of
        # another event type), merged in time order; none: empty.
        parts = [events(t) for n, t in a.items() if _is_event_type(a.info.get(n, {}).get("lcm_type", ""))]
        if not parts:
            return _np.empty(0, dtype=EVENTS_DTYPE)
        out = _np.concatenate(parts)
        return out[_np.argsort(out["time"], kind="stable")]
    if isinstance(a, FitResult):
        # The impacts the fit found (fit --json's impacts): IMPACT events at
        # their times; value NaN (the fit measures no theta_dot before them).
        impacts = a.get("impacts") or []
        out = _np.empty(len(impacts), dtype=EVENTS_DTYPE)
        out["time"] = [float(i["time"]) for i in impacts]
        out["kind_name"] = "IMPACT"
        out["kind_code"] = _event_kind_codes().get("IMPACT", 2)
        out["value"] = _np.nan
        return out
    src = getattr(a, "events", a)
    names = getattr(getattr(src, "dtype", None), "names", None) or ()
    missing = [f for f in EVENT_FIELDS if f not in names]
    if "kind" in names and missing:
        src = _with_kind_code(src)
        names = src.dtype.names
        missing = [f for f in EVENT_FIELDS if f not in names]
    if missing:
        raise ValueError(
            "events: not an events array (fields " + ", ".join(names or ("none",))
            + "; needs " + ", ".join(EVENT_FIELDS) + ")"
        )
    out = _np.empty(src.shape, dtype=EVENTS_DTYPE)
    for f in EVENT_FIELDS:
        out[f] = src[f]
    return out


def _is_event_type(lcm_type):
    """rocklab.event_t, rocklab.event2_t, ...: the types whose kind is event_t's constant."""
    import re

    return re.fullmatch(r"rocklab\.event[0-9]*_t", lcm_type) is not None


def _with_kind_code(a):
    """An events table with the field kind_code (int64, the field kind's
    event_t constant) appended, and kind_name where it lacks one (a copy;
    event tables are small)."""
    names = a.dtype.names or ()
    if "kind" not in names or "kind_code" in names:
        return a
    extra = [("kind_code", "<i8")]
    if "kind_name" not in names:
        extra.insert(0, ("kind_name", "<U16"))
    fields = []
    for n in names:
        spec = a.dtype.fields[n]
        fields.append(((spec[2], n) if len(spec) > 2 and spec[2] else n, spec[0]))
    out = _np.empty(a.shape, dtype=_np.dtype(fields + extra))
    for n in names:
        out[n] = a[n]
    out["kind_code"] = a["kind"]
    if "kind_name" not in names:
        by_code = {v: k for k, v in _event_kind_codes().items()}
        out["kind_name"] = [by_code.get(int(k), str(int(k))) for k in a["kind"]]
    return out


def block_params(width=None, height=None, chamfer=0.0, *, polygon=None):
    """alpha, p and mu of a block from its geometry (``rocklab params --json``).

    Either a rectangle ``width`` x ``height`` (2b x 2h, m) with an optional
    45 degree ``chamfer`` leg on both base corners (m), or ``polygon``: the
    path of a CSV of vertices (header ``x,z``, m) or an (N, 2) array of
    vertices (x, z), m, in order, standing on its base.

    Returns a dict with the keys of ``rocklab params --json``: ``alpha``
    (rad), ``p`` (rad/s), ``mu`` (1; ``mu_general``), ``mu_housner``,
    ``R`` (m), ``I_O_per_mass`` (m^2), ``area``, ``centroid``,
    ``symmetric``, and per side ``plus_side`` / ``minus_side`` (alpha, R,
    p, mu, I_O_per_mass, pivot) for asymmetric sections.

    Raises ValueError for a bad geometry, OSError for an unreadable file.
    """
    if polygon is not None:
        if width is not None or height is not None or chamfer != 0.0:
            raise ValueError("give either --polygon or --width/--height/--chamfer, not both")
        if isinstance(polygon, (str, _os.PathLike)):
            return _rocklab._polygon_file_params(_path(polygon, "polygon"))
        return _rocklab._polygon_array_params(_floats(polygon, "polygon"))
    if width is None and height is None:
        raise ValueError("--width and --height are required (or --polygon FILE.csv)")
    if width is None or height is None:
        raise ValueError("--width and --height are both required")
    return _rocklab._rectangle_params(_float(width, "width"), _float(height, "height"), _float(chamfer, "chamfer"))


class SimulationResult(_Summarised):
    """What ``simulate`` returns.

    Attributes:
        t: output times, s (k / rate, k = 0 .. floor(duration * rate)).
        theta: rocking angle at t, rad (> 0 about the +x corner).
        theta_dot: angular velocity at t, rad/s.
        events: structured array (EVENT_DTYPE): ``time`` (s), ``kind``
            ("uplift", "impact", "rest", "overturn"; also as ``kind_name``,
            "UPLIFT" .., and ``kind_code``, event_t's constant, as every
            events array has them: EVENT_FIELDS), ``value``: uplift:
            the table acceleration, m/s^2; impact: theta_dot just before,
            rad/s; rest: 0; overturn: theta, rad; and ``theta_dot_after``:
            impact: theta_dot just after, rad/s (0 where the block comes to
            rest; NaN for a complex-model crossing integrated through),
            NaN for the other kinds.
        summary: the dict of ``rocklab simulate --json`` (uplift_time,
            peak_abs_theta, peak_time, impacts, overturned, final_regime,
            solver statistics, cpu_time, ...).
    """

    __slots__ = ("t", "theta", "theta_dot", "events", "summary")

    def __init__(self, t, theta, theta_dot, events, summary):
        self.t = t
        self.theta = theta
        self.theta_dot = theta_dot
        self.events = events
        self.summary = summary

    def impacts(self):
        """The events of kind "impact" (a view of ``events``)."""
        return self.events[self.events["kind"] == "impact"]

    def _summary(self):
        s = self.summary
        title = (f"SimulationResult: {s.get('model')}, alpha {_num(s.get('alpha'))} rad, "
                 f"p {_num(s.get('p'))} rad/s, mu {_num(s.get('mu'))}")
        rows = [
            ("samples", f"{len(self.t)} at {_num(s.get('rate'))} Hz over {_num(s.get('duration'))} s"),
            ("events", _counts(self.events["kind"])),
            ("uplift", "none" if s.get("uplift_time") is None else f"{_num(s['uplift_time'])} s"),
            ("peak |theta|", f"{_num(s.get('peak_abs_theta'))} rad at {_num(s.get('peak_time'))} s"),
            ("impacts", str(s.get("impacts"))),
            ("overturned", f"yes, at {_num(s.get('overturn_time'))} s" if s.get("overturned") else "no"),
            ("final regime", str(s.get("final_regime"))),
            ("solver", f"{s.get('steps')} steps, {_num(s.get('cpu_time'), 3)} s CPU"),
        ]
        return title, rows


def simulate(
    model="housner",
    alpha=None,
    p=None,
    mu=None,
    *,
    excitation=None,
    accel=None,
    theta0=0.0,
    duration,
    rate,
    l=DEFAULT_L,
    complex_handoff=0.0,
    rtol=None,
    progress=None,
    assembly=None,
):
    """Simulates a rocking block, as ``rocklab simulate``, or an assembly
    of bodies, as ``rocklab simulate --assembly``.

    Args:
        model: "housner" or "complex" (the paper's eq. (10)).
        alpha: slenderness angle, rad, in (0, pi/2). A dict from
            block_params may be given instead, for alpha, p and mu.
        p: frequency parameter, rad/s, > 0.
        mu: coefficient of restitution, in (0, 1].
        excitation: a table motion spec ("sine:amp=0.006,freq=5,duration=20",
            "hanning:amp=M,freq=HZ,duration=S,start=S") or a list of them
            (summed), as ``--excitation``.
        accel: a table-acceleration record: the path of a ``time,accel``
            CSV (s, m/s^2) or a PEER .AT2 file (``--accel``), or a pair
            ``(t, a)`` of arrays (s, m/s^2; linear between samples, zero
            outside). Summed with ``excitation`` when both are given.
        theta0: initial rocking angle, rad (0: at rest).
        duration: simulated time, s, >= 0.
        rate: output rate, Hz, > 0.
        l: complex formulation momentum, > 0.
        complex_handoff: complex formulation, opt-in l -> 0 hand-off (see
            ``--complex-handoff``); 0: eq. (10) throughout.
        rtol: CVODE relative tolerance, in (0, 1e-3] (``--rtol``; default
            the model's, 1e-10).
        progress: None or callable(done_s, duration_s), called at most
            every 0.1 s (not with ``assembly``).
        assembly: instead of alpha, p, mu and theta0: the path of an
            assembly TOML file, or a dict with its keys ({"body": [{"name":
            .., "width_m": .., "height_m": .., "mass_kg": ..}, ..],
            "interface": [{"restitution": ..}, ..]} or {"frame": {..}}),
            as ``--assembly`` (docs/commands.md). ``accel`` is then a path.

    Returns:
        SimulationResult: t, theta, theta_dot (numpy arrays), events and
        summary (the statistics of ``simulate --json``); with
        ``assembly``, an AssemblyResult (per-body columns, modes, events
        naming interface and body).

    Raises:
        ValueError: a bad value, with the command line's message
            ("--alpha must be in (0, pi/2) rad, got 2").
        OSError: an ``accel`` file that cannot be read.
    """
    if assembly is not None:
        for name, value in (("alpha", alpha), ("p", p), ("mu", mu)):
            if value is not None:
                raise ValueError(f"{name} with assembly: the assembly gives its bodies")
        if theta0 != 0.0:
            raise ValueError("theta0 with assembly: an assembly starts at rest")
        excitations = [] if excitation is None else [excitation] if isinstance(excitation, str) else list(excitation)
        return _simulate_assembly(assembly, model, excitations, accel, duration, rate, l, complex_handoff, rtol)
    if isinstance(alpha, dict):
        block = alpha
        alpha = block["alpha"]
        p = block["p"] if p is None else p
        mu = block["mu"] if mu is None else mu
    for name, value in (("--alpha", alpha), ("--p", p), ("--mu", mu)):
        if value is None:
            raise ValueError(f"{name} is required")
    if excitation is None:
        excitations = []
    elif isinstance(excitation, str):
        excitations = [excitation]
    else:
        excitations = list(excitation)
    accel_path, accel_t, accel_a = "", None, None
    if isinstance(accel, (str, _os.PathLike)):
        accel_path = _path(accel, "accel")
    elif accel is not None:
        try:
            accel_t, accel_a = accel
        except (TypeError, ValueError):
            raise ValueError("accel must be a path or a pair (t, a) of 1-D arrays (s, m/s^2)") from None
        accel_t = _floats(accel_t, "accel_t")
        accel_a = _floats(accel_a, "accel_a")
    r = _rocklab._simulate(
        str(model), _float(alpha, "alpha"), _float(p, "p"), _float(mu, "mu"), excitations, accel_path,
        accel_t, accel_a, _float(theta0, "theta0"), _float(duration, "duration"), _float(rate, "rate"),
        _float(l, "l"), _float(complex_handoff, "complex_handoff"),
        None if rtol is None else _float(rtol, "rtol"), progress,
    )
    ev = r["events"]
    events = _np.empty(len(ev["time"]), dtype=EVENT_DTYPE)
    events["time"] = ev["time"]
    events["kind"] = ev["kind"]
    events["value"] = ev["value"]
    events["theta_dot_after"] = ev["theta_dot_after"]
    codes = _event_kind_codes()
    events["kind_name"] = _np.char.upper(events["kind"])
    events["kind_code"] = [codes.get(str(k), -1) for k in events["kind_name"]]
    return SimulationResult(r["t"], r["theta"], r["theta_dot"], events, r["summary"])


#: dtype of AssemblyResult.events (EVENT_FIELDS, value NaN, and where).
ASSEMBLY_EVENT_DTYPE = _dtype(
    [
        ("time", "f8", "s"),
        ("kind", "U8", None),
        ("interface", "i4", None),
        ("body", "U64", None),
        ("mode", "U16", None),
        ("value", "f8", None),
        ("kind_name", "U16", None),
        ("kind_code", "i8", None),
    ]
)


class AssemblyResult(_Summarised):
    """What ``simulate(assembly=...)`` returns: the bodies bottom-up.

    Attributes:
        t: output times, s (k / rate; a stack's stop at an overturning).
        names: the bodies' names, bottom-up (a frame: ["frame"]).
        theta: rocking angles, rad, shape (len(t), len(names)): column K-1
            is ``theta_K`` of ``simulate --assembly``'s CSV (> 0 rocking on
            the body's +x corner, as ``simulate``'s theta).
        theta_dot: angular velocities, rad/s, the same shape.
        mode: the contact state at t, one letter per interface bottom-up
            (C closed, L/R pivoting on the left/right corner).
        events: structured array (ASSEMBLY_EVENT_DTYPE): ``time`` (s),
            ``kind`` ("uplift", "impact", "rest", "overturn"),
            ``interface`` (0: on the table, K: under body K+1), ``body``
            (the name of the body above it), ``mode`` (after it), and
            EVENT_FIELDS's ``kind_name``, ``kind_code``, ``value`` (NaN).
        summary: the dict of ``rocklab simulate --assembly --json``.
    """

    __slots__ = ("t", "names", "theta", "theta_dot", "mode", "events", "summary")

    def __init__(self, t, names, theta, theta_dot, mode, events, summary):
        self.t = t
        self.names = names
        self.theta = theta
        self.theta_dot = theta_dot
        self.mode = mode
        self.events = events
        self.summary = summary

    def _summary(self):
        s = self.summary
        title = f"AssemblyResult: {s.get('kind')} of {len(self.names)} bodies, {s.get('model')}"
        rows = [
            ("samples", f"{len(self.t)} at {_num(s.get('rate'))} Hz over {_num(s.get('duration'))} s"),
            ("events", _counts(self.events["kind"])),
            ("uplift", "none" if s.get("uplift_time") is None else f"{_num(s['uplift_time'])} s"),
        ]
        for b in s.get("bodies", []):
            rows.append((str(b.get("name")), f"peak |theta| {_num(b.get('peak_abs_theta'))} rad at "
                                             f"{_num(b.get('peak_time'))} s"))
        rows += [
            ("impacts", str(s.get("impacts"))),
            ("modes", f"{s.get('modes')}, {s.get('mode_changes')} changes"),
            ("overturned", f"{s.get('overturned_body')} at {_num(s.get('overturn_time'))} s"
             if s.get("overturned") else "no"),
        ]
        return title, rows


def _toml_value(v, key):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, _np.integer)):
        return str(int(v))
    if isinstance(v, (float, _np.floating)):
        return repr(float(v))
    if isinstance(v, (str, _os.PathLike)):
        return _json.dumps(_os.fspath(v))
    raise ValueError(f"assembly: key '{key}' must be a number, a string or true/false, got {type(v).__name__}")


def _toml_key(k):
    """A dict key as a TOML key: bare where TOML allows it, else quoted."""
    k = str(k)
    return k if k and all(c.isascii() and (c.isalnum() or c in "_-") for c in k) else _json.dumps(k)


def _assembly_toml(d):
    """An assembly dict as the TOML text of its file ([[body]], [[interface]], [frame])."""
    plain, tables = [], []

    def entries(table, prefix):
        return [f"{_toml_key(k)} = {_toml_value(x, prefix + '.' + str(k))}" for k, x in table.items()]

    for key, v in d.items():
        if isinstance(v, dict):
            tables.append(f"[{_toml_key(key)}]")
            tables += entries(v, str(key))
        elif isinstance(v, (list, tuple)):
            for entry in v:
                if not isinstance(entry, dict):
                    raise ValueError(f"assembly: key '{key}' must be a list of dicts")
                tables.append(f"[[{_toml_key(key)}]]")
                tables += entries(entry, str(key))
        else:
            plain.append(f"{_toml_key(key)} = {_toml_value(v, str(key))}")
    return "\n".join(plain + tables) + "\n"


def _simulate_assembly(assembly, model, excitations, accel, duration, rate, l, complex_handoff, rtol):
    if isinstance(assembly, dict):
        path, text = "", _assembly_toml(assembly)
    elif isinstance(assembly, (str, _os.PathLike)):
        path, text = _path(assembly, "assembly"), ""
    else:
        raise ValueError("assembly must be the path of a TOML file or a dict of its keys")
    if accel is not None and not isinstance(accel, (str, _os.PathLike)):
        raise ValueError("accel with assembly: the path of a record (arrays are taken for a single block only)")
    r = _rocklab._simulate_assembly(
        path, text, str(model), excitations, "" if accel is None else _path(accel, "accel"),
        _float(duration, "duration"), _float(rate, "rate"), _float(l, "l"),
        _float(complex_handoff, "complex_handoff"), None if rtol is None else _float(rtol, "rtol"),
    )
    ev = r["events"]
    events = _np.empty(len(ev["time"]), dtype=ASSEMBLY_EVENT_DTYPE)
    for field in ("time", "kind", "interface", "body", "mode"):
        events[field] = ev[field]
    events["value"] = _np.nan
    codes = _event_kind_codes()
    events["kind_name"] = _np.char.upper(events["kind"])
    events["kind_code"] = [codes.get(str(k), -1) for k in events["kind_name"]]
    n = len(r["names"])
    shape = (len(r["t"]), n)
    theta = _np.column_stack(r["theta"]) if n else _np.empty(shape)
    theta_dot = _np.column_stack(r["theta_dot"]) if n else _np.empty(shape)
    return AssemblyResult(r["t"], list(r["names"]), theta, theta_dot, _np.array(r["mode"], dtype=str), events,
                          _json.loads(r["summary"]))


class LogTables(_Summarised, dict):
    """What ``read_log`` and ``read_raw`` return: {table name: structured array}.

    A log's tables are named by their channel (a channel that changed type
    has a second table ``CHANNEL_<type>``); a raw file's table is ``data``.
    Each array has one field per message field (``time`` first, s, the
    sample clock; arrays as ``values_0`` .. ``values_{n-1}``); a field's
    unit is its title, "name [unit]" (``rocklab.units(a)`` gives
    {field: unit}), which ``np.save``/``np.load`` and ``pickle`` keep.

    Attribute ``info``: per table, its ``channel``, ``lcm_type`` (or a raw
    file's ``source``) and ``units``.

    Attribute ``summary``: the counts of ``rocklab export`` (rows,
    outside_window, filtered, unknown_type, undecodable, damaged_regions,
    damaged_bytes, damaged_events, bad_rows, bad_values, read_error) and
    ``problems``, the lines it prints about the damage.

    The comparator's results by (variant, body): ``compared()`` lists the
    keys the log holds, ``comparison(variant, body)`` gives one (an
    assembly's body by its index, 0 on the table; docs/python.md).
    """

    def __init__(self, tables, summary, info=None):
        super().__init__(tables)
        self.summary = summary
        self.info = info if info is not None else {n: {"units": units(a)} for n, a in tables.items()}

    def _comparison_tables(self, lcm_types):
        # (table name, array) of the tables of those types, in table order.
        return [(n, a) for n, a in self.items() if self.info.get(n, {}).get("lcm_type") in lcm_types]

    def compared(self):
        """The comparisons the log holds, as (variant, body) keys for ``comparison``.

        A variant compared as a single block (RL_COMPARE_<name>) gives
        (variant, None); an assembly variant (RL_COMPAREBODIES_<name>) also
        (variant, 0) .. (variant, n-1), its bodies by index, bottom-up (its
        RL_COMPARE_<name> is body 0 against RL_THETA). Variants in the order
        they first appear, by the messages' ``name``.
        """
        keys = {}
        for _, a in self._comparison_tables(_SINGLE_COMPARISON_TYPES):
            for v in _unique(a["name"]):
                keys.setdefault(v, set()).add(None)
        for _, a in self._comparison_tables((_BODIES_COMPARISON_TYPE,)):
            n = _body_count(a)
            for v in _unique(a["name"]):
                keys.setdefault(v, set()).update(range(n))
        return [(v, b) for v, bodies in keys.items() for b in sorted(bodies, key=lambda b: -1 if b is None else b)]

    def comparison(self, variant, body=None):
        """The comparator's messages for one variant, or one body of an assembly variant.

        Args:
            variant: the variant's name (the messages' ``name``, the channel's suffix).
            body: None: the variant's RL_COMPARE_<name> (comparison2_t, or
                comparison_t in an older log) rows as ``read_log`` gives them
                (for an assembly variant, its body 0 against RL_THETA). An
                int k: body k of an assembly variant (0 on the table,
                upwards; simulate's and reconstruct's CSV column theta_{k+1}),
                from RL_COMPAREBODIES_<name> (comparison3_t).

        Returns:
            A structured array, one row per message. For a body: ``time``
            (s), ``utime``, ``seq``, ``name``, then comparison2_t's fields
            for that body under comparison2_t's names (``error``,
            ``rms_window``, ``window_s``, ``rms_total``, ``nrms``,
            ``peak_error``, ``impact_timing_error``, ``correlation``,
            ``valid``, ``samples``), so code written for a single block
            reads it unchanged; then the variant's ``mode_model``,
            ``mode_measured``, ``mode_rest_rad``, ``mode_agreement`` and
            ``mode_samples`` (the same on every body). Units as titles.

        Raises:
            KeyError: no comparison of that variant in the log (or no
                per-body one, for a body).
            IndexError: a body the variant does not have.
            TypeError: a body that is not an int (or None).
        """
        variant = str(variant)
        if body is None:
            found = [(n, a[a["name"] == variant]) for n, a in self._comparison_tables(_SINGLE_COMPARISON_TYPES)]
            found = [(n, rows) for n, rows in found if len(rows)]
            if not found:
                raise KeyError(f"no RL_COMPARE_<name> of variant {variant!r} in the log (compared: {self.compared()})")
            if len(found) > 1:
                raise ValueError(f"variant {variant!r} is compared in tables of two types ({[n for n, _ in found]}): "
                                 "read them by table name")
            return found[0][1]
        if isinstance(body, bool) or not isinstance(body, (int, _np.integer)):
            raise TypeError(f"body must be an int (the body's index, 0 on the table) or None, got {_short(body)}")
        body = int(body)
        found = [(n, a[a["name"] == variant]) for n, a in self._comparison_tables((_BODIES_COMPARISON_TYPE,))]
        found = [(n, rows) for n, rows in found if len(rows)]
        if not found:
            raise KeyError(f"no RL_COMPAREBODIES_<name> of variant {variant!r} in the log: "
                           f"not an assembly variant (compared: {self.compared()})")
        if len(found) > 1:
            raise ValueError(f"variant {variant!r} is compared per body in two tables ({[n for n, _ in found]}): "
                             "read them by table name")
        a = found[0][1]
        n = _body_count(a)
        if not 0 <= body < n:
            raise IndexError(f"variant {variant!r} has bodies 0..{n - 1} (by index, 0 on the table), not {body}")
        return _body_comparison(a, body)

    def __reduce__(self):
        # dict subclasses pickle their items, not their attributes.
        return (LogTables, (dict(self), self.summary, self.info))

    def _summary(self):
        # One line per table (rows, time span, fields with units), not the
        # arrays: a log's repr must fit a notebook cell.
        s = self.summary
        title = f"LogTables: {len(self)} tables, {s.get('rows', 0)} rows"
        lost = [f"{s[k]} {k.replace('_', ' ')}" for k in ("damaged_regions", "bad_rows", "undecodable") if s.get(k)]
        if lost:
            title += " (" + ", ".join(lost) + ")"
        rows = []
        for name, a in self.items():
            span = ""
            if "time" in (a.dtype.names or ()) and len(a):
                span = f", {_num(a['time'][0])} .. {_num(a['time'][-1])} s"
            rows.append((name, f"{len(a)} rows{span}: {_fields_text(a)}"))
        return title, rows


_SINGLE_COMPARISON_TYPES = ("rocklab.comparison2_t", "rocklab.comparison_t")
_BODIES_COMPARISON_TYPE = "rocklab.comparison3_t"
# comparison3_t's per-body fields, in comparison2_t's order among its scalar ones.
_BODY_COMPARISON_FIELDS = ("error", "rms_window", "window_s", "rms_total", "nrms", "peak_error",
                           "impact_timing_error", "correlation", "valid", "samples")
_MODE_FIELDS = ("mode_model", "mode_measured", "mode_rest_rad", "mode_agreement", "mode_samples")


def _unique(values):
    # The distinct values in the order they first appear.
    return list(dict.fromkeys(values.tolist()))


def _body_count(a):
    # A comparison3_t table's bodies: its columns error_0 .. error_{n-1}
    # (n from the channel's first message, as export makes them).
    n = 0
    while f"error_{n}" in a.dtype.names:
        n += 1
    return n


def _body_comparison(a, k):
    # Body k's columns of a comparison3_t table under comparison2_t's names,
    # with the variant's modes; each field keeps its unit (title).
    sources = [("time", "time"), ("utime", "utime"), ("seq", "seq"), ("name", "name")]
    sources += [(f, f if f in ("window_s", "samples") else f"{f}_{k}") for f in _BODY_COMPARISON_FIELDS]
    sources += [(f, f) for f in _MODE_FIELDS]
    unit_of = units(a.dtype)
    names, formats, titles = [], [], []
    for mine, theirs in sources:
        names.append(mine)
        formats.append(a.dtype[theirs])
        unit = unit_of.get(theirs)
        titles.append(f"{mine} [{unit}]" if unit else None)
    out = _np.empty(len(a), dtype=_np.dtype({"names": names, "formats": formats, "titles": titles}))
    for mine, theirs in sources:
        out[mine] = a[theirs]
    return out


def _warn_damage(path, summary, what):
    # The damage line of every log-reading command (pipeline::ReportDamage).
    if summary["damaged_regions"] > 0:
        regions = summary["damaged_regions"]
        _warnings.warn(
            f"{what}: {path} is damaged: {regions} region{'s' if regions != 1 else ''} skipped "
            f"({summary['damaged_bytes']} bytes, {summary['damaged_events']} events lost); "
            "the rest was read",
            RuntimeWarning,
            stacklevel=3,
        )
    if summary["read_error"]:
        _warnings.warn(f"{what}: {summary['read_error']}", RuntimeWarning, stacklevel=3)


def read_log(path, channels=".*", *, start=0.0, end=None, progress=None):
    """Reads a recorded LCM log (rocklab's or lcm-logger's) into numpy.

    The tables of ``rocklab export``: one structured array per selected
    channel, one row per message that decodes, one field per message field.

    Args:
        path: the log.
        channels: regular expression (ECMAScript) matched against the whole
            channel name, as ``--channels``.
        start, end: window, s from the record's first sample (the
            sample-clock utime of its first rocklab message); end None: to
            the end.
        progress: None or callable(rows_read, None), at most every 0.1 s.

    Returns:
        LogTables: {channel: structured array}, with ``.summary``.

    A damaged log is read as the command line reads it: damaged regions are
    skipped, counted in ``.summary`` and reported once as a RuntimeWarning.

    Raises:
        ValueError: a bad regex or window, or a file that is not an LCM log.
        OSError: a file that cannot be opened.
    """
    path = _path(path, "path")
    tables, summary, table_info = _rocklab._read_log(
        path, str(channels), _float(start, "start"), _INF if end is None else _float(end, "end"), progress
    )
    _warn_damage(path, summary, "rocklab.read_log")
    # RL_EVENT tables gain kind_code beside export's kind and kind_name (EVENT_FIELDS).
    tables = {n: _with_kind_code(a) if _is_event_type(table_info.get(n, {}).get("lcm_type", "")) else a
              for n, a in tables.items()}
    return LogTables(tables, summary, table_info)


def read_raw(path, rig=None, *, rate=0.0, start=0.0, end=None, progress=None):
    """Reads a raw DAQ file (CSV, LabVIEW .lvm) or a PEER .AT2 record into numpy.

    CSV and LVM: the table ``data`` of ``rocklab export``: ``time`` (s)
    then the channels by name, NaN where a value is missing; bad rows
    skipped and counted as the DAQ's sources do.

    .AT2 (by extension): the ground-motion record as ``simulate --accel``
    and ``sweep --records`` read it: ``data`` with ``time`` (s, k DT) and
    ``accel`` (m/s^2, the file's g times 9.81); a malformed file raises
    ValueError naming its line. ``rig``, ``rate`` and the window do not
    apply.

    Args:
        path: the .csv or .lvm file.
        rig: a rig file (TOML) naming the channels' units, or None; its
            sample_rate_hz is checked against the file's time column.
        rate: sample rate, Hz: needed for a file without a time column or
            time base; else 0 (the file's) or checked against the file's
            (a disagreement over 0.1 % is a ValueError naming both).
        start, end: window, s from the first row's time; end None: to the end.
        progress: None or callable(rows_read, None).

    Returns:
        LogTables: {"data": structured array}, with ``.summary`` (bad_rows,
        bad_values, read_error, ...).
    """
    path = _path(path, "path")
    if path.lower().endswith(".at2"):
        t, a, _ = _rocklab._read_acceleration(path)
        data = _np.empty(len(t), dtype=_dtype([("time", "f8", "s"), ("accel", "f8", "m/s^2")]))
        data["time"], data["accel"] = t, a
        summary = dict(rows=len(t), outside_window=0, bad_rows=0, bad_values=0, read_error="", problems=[],
                       format="at2")
        return LogTables({"data": data}, summary, {"data": {"source": path, "units": units(data)}})
    tables, summary, table_info = _rocklab._read_raw(
        path, "" if rig is None else _path(rig, "rig"), _float(rate, "rate"), _float(start, "start"),
        _INF if end is None else _float(end, "end"), progress,
    )
    _warn_damage(path, summary, "rocklab.read_raw")
    return LogTables(tables, summary, table_info)


def info(path, rig=None, *, rate=0.0):
    """What a recorded LCM log or a raw CSV/LVM file holds: ``rocklab info --json``.

    Args:
        path: an LCM log, or a raw .csv / .lvm file.
        rig: raw files: a rig file (TOML) naming the channels' units (its
            sample_rate_hz is checked against the file's time column).
        rate: raw files: sample rate, Hz, as ``read_raw``'s.

    Returns:
        dict: the JSON of ``rocklab info --json`` (docs/export.md), e.g.
        for a log ``channels`` (name, type, count, rate, sequence gaps),
        ``damaged_regions``, the rig's RL_DAQ_CONFIG.
    """
    import json

    return json.loads(
        _rocklab._info_json(_path(path, "path"), "" if rig is None else _path(rig, "rig"), _float(rate, "rate"))
    )


class Reconstruction(_Summarised):
    """What ``reconstruct`` returns.

    Attributes:
        states: structured array, one row per reconstructed sample: ``time``
            (s), ``theta``, ``theta_dot``, ``theta_mirror``, ``theta_camera``,
            ``sliding`` (m), ``twist`` (rad), ``out_of_plane`` (m), ``jump``
            (m), ``tilt`` (rad), ``table_displacement`` (m),
            ``table_acceleration`` (m/s^2), ``flags`` (bitmask of the checks,
            docs/acquisition.md), ``leds_used``; units in the fields'
            titles (``rocklab.units(states)``).
        events: structured array of the checks' events: ``time`` (s),
            ``kind`` (event_t's constant), ``value``, ``detail``, then
            ``kind_name`` and ``kind_code`` (EVENT_FIELDS).
        summary: counts as ``rocklab reconstruct`` prints them (rows,
            bad_rows, bad_values, gaps, missing, duplicates, out_of_order,
            invalid_led_samples, flagged, damage, read_error, problems).
    """

    __slots__ = ("states", "events", "summary")

    def __init__(self, states, events, summary):
        self.states = states
        self.events = events
        self.summary = summary

    def _summary(self):
        s, st = self.summary, self.states
        span = f", {_num(st['time'][0])} .. {_num(st['time'][-1])} s" if len(st) else ""
        rows = [
            ("states", f"{len(st)} samples{span}: {_fields_text(st)}"),
            ("flagged", f"{s.get('flagged', 0)} samples"),
            ("events", _counts(self.events["kind_name"])),
        ]
        lost = [f"{s[k]} {k.replace('_', ' ')}" for k in ("bad_rows", "bad_values", "gaps", "missing", "duplicates",
                                                          "out_of_order", "invalid_led_samples") if s.get(k)]
        rows.append(("input", ", ".join(lost) if lost else "no bad rows, gaps or missing samples"))
        return f"Reconstruction: {len(st)} samples, {s.get('flagged', 0)} flagged", rows


def reconstruct(raw, rig, *, progress=None):
    """Reconstructs theta and the checks from a raw file, as ``rocklab reconstruct``.

    Args:
        raw: the raw file: .csv, .lvm or an LCM log (RL_RAW).
        rig: the rig configuration (TOML): channels, calibration, geometry.
        progress: None or callable(sample_time_s, None).

    Returns:
        Reconstruction: ``states`` (theta, theta_dot, the mirror and camera
        thetas, sliding, twist, flags, ...), ``events``, ``summary``. A rig
        of several ``[[body]]`` tables: those columns are the bottom body's
        (as RL_THETA), then ``theta_K`` ... ``flags_K`` per body K = 1..N
        bottom-up, the columns of ``rocklab reconstruct``'s CSV.
    """
    raw, rig = _path(raw, "raw"), _path(rig, "rig")
    columns, events, summary = _rocklab._reconstruct(raw, rig, progress)
    names = list(columns)
    dtype = _dtype([(n, columns[n][0].dtype, columns[n][1]) for n in names])
    states = _np.empty(len(columns["time"][0]), dtype=dtype)
    for n in names:
        states[n] = columns[n][0]
    ev = _with_kind_code(_np.array(
        [tuple(e) for e in events],
        dtype=_dtype([("time", "f8", "s"), ("kind", "i1", None), ("value", "f8", None), ("detail", "U64", None)]),
    ))
    _warn_damage(raw, summary, "rocklab.reconstruct")
    return Reconstruction(states, ev, summary)


class FitResult(_Summarised, dict):
    """What ``fit`` returns: the dict of ``rocklab fit --json``.

    Keys: alpha (rad), p (rad/s), mu; their standard errors alpha_stderr,
    p_stderr, mu_stderr (None when withheld); alpha_p_correlation;
    rms_residual (s for impacts, rad for trajectory), noise (rad),
    residual_to_noise, chi2, chi2_per_dof, p_value, band_ratio, band_p_value,
    band_hz (the trajectory method's band test), significance, noise_dof,
    converged (the chi-square test at that significance; trajectory: it and
    the band test at half of it each), starts,
    starts_refined; impacts (per impact: n, time, peak, mu_n,
    tau, residual); theory and alpha_band (from the geometry); warnings.
    The same values are attributes: ``r.alpha``, ``r.warnings``.
    """

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    def _summary(self):
        g = self.get
        state = "converged" if g("converged") else "NOT converged"
        title = f"FitResult: {g('method')} method, {state}"
        rows = [
            ("alpha", _with_error(g("alpha"), g("alpha_stderr"), "rad")),
            ("p", _with_error(g("p"), g("p_stderr"), "rad/s")),
            ("mu", _with_error(g("mu"), g("mu_stderr"))),
        ]
        theory = g("theory")
        if isinstance(theory, dict):
            rows.append(("theory", ", ".join(f"{k} {_num(theory.get(k))}" for k in ("alpha", "p", "mu") if k in theory)))
        residual_unit = "s" if g("method") == "impacts" else "rad"
        rows += [
            ("impacts", str(len(g("impacts") or []))),
            ("rms residual", f"{_num(g('rms_residual'))} {residual_unit}"
                             f" ({_num(g('residual_to_noise'), 3)} x noise)"),
            ("chi2/dof", f"{_num(g('chi2_per_dof'), 3)}, p-value {_num(g('p_value'), 3)}"),
        ]
        for w in (g("warnings") or [])[:3]:
            rows.append(("warning", str(w)))
        if len(g("warnings") or []) > 3:
            rows.append(("warning", f"... {len(g('warnings')) - 3} more"))
        return title, rows


def fit(
    t,
    theta=None,
    width=None,
    height=None,
    *,
    chamfer=0.0,
    method="impacts",
    table=None,
    quarter_time="exact",
    alpha_band=0.01,
    min_impacts=4,
    start=0.0,
    end=None,
    progress=None,
):
    """Fits alpha, p and mu to a recorded test, as ``rocklab fit``.

    Args:
        t: sample times, s (with ``theta``); or the path of a record: a CSV
            with a ``time,theta`` header or a rocklab LCM log (RL_THETA,
            RL_TABLE), as ``--input``.
        theta: rocking angle at t, rad (NaN: a lost sample).
        width, height, chamfer: block geometry (2b, 2h, chamfer leg; m): the
            theoretical row, the admissible alpha band, the trajectory
            method's start.
        method: "impacts" (the paper's, free rocking) or "trajectory" (the
            whole record, free or forced).
        table: the table acceleration of a forced record: a pair (t, a) of
            arrays (s, m/s^2), or the path of a ``time,accel`` CSV; read
            between its samples as the not-a-knot cubic spline (point
            samples; ``rocklab fit``'s default ``--table spline``).
        quarter_time: impacts method: "exact" (corrected eq. 12) or
            "slender" (eq. 13).
        alpha_band: admissible error on b, m.
        min_impacts: fewest impacts accepted (>= 3).
        start, end: fit only the samples in this window, s from the
            record's first sample (``--start``/``--end``); end None: to the end.
        progress: trajectory method: None or callable(model_runs,
            max_runs), after each iteration. An exception it raises comes
            out of fit once the fit has ended.

    Returns:
        FitResult (a dict, keys of ``rocklab fit --json``).

    Raises:
        ValueError: bad options, or a record that cannot give an answer
            (the CLI's message: never rocks, too few impacts, ...).
        OSError: a file that cannot be read.
    """
    path, ts, th, table_t, table_a, accel = _record_args(t, theta, table)
    r = _rocklab._fit(
        path, ts, th, table_t, table_a, accel,
        None if width is None else _float(width, "width"), None if height is None else _float(height, "height"),
        _float(chamfer, "chamfer"), str(method), str(quarter_time), _float(alpha_band, "alpha_band"),
        _int(min_impacts, "min_impacts"), _float(start, "start"), _INF if end is None else _float(end, "end"),
        progress,
    )
    return FitResult(r)


def _record_args(t, theta, table):
    """(path, t, theta, table_t, table_a, accel) of fit's record arguments."""
    path, ts, th, table_t, table_a, accel = "", None, None, None, None, ""
    if isinstance(t, (str, _os.PathLike)):
        if theta is not None:
            raise ValueError("give either a record path or the arrays t and theta")
        path = _path(t, "t")
    else:
        if theta is None:
            raise ValueError("theta is required with the array t")
        ts = _floats(t, "t")
        th = _floats(theta, "theta")
    if isinstance(table, (str, _os.PathLike)):
        accel = _path(table, "table")
    elif table is not None:
        table_t, table_a = (_np.asarray(x, dtype=float) for x in table)
    return path, ts, th, table_t, table_a, accel


class PosteriorSummary(_Summarised, dict):
    """The summary ``posterior`` returns: the dict of ``rocklab fit --json``'s
    ``posterior`` object (per parameter median, ci68, ci95, sd, mean;
    correlation; rhat, ess, tau; acceptance, walkers, steps, seed,
    converged, problems, units, ...), with a one-screen repr."""

    def __reduce__(self):
        return (PosteriorSummary, (dict(self),))

    def _summary(self):
        g = self.get
        state = "converged" if g("converged") else "NOT converged"
        title = (f"PosteriorSummary: {g('method')} method, {g('model')} model, {state} "
                 f"({g('walkers')} walkers x {g('steps')} steps, acceptance {_num(g('acceptance'), 3)})")
        draw_units = g("units") or {}
        rows = []
        for name in g("parameters") or []:
            p = g(name) or {}
            ci = p.get("ci68") or [None, None]
            unit = draw_units.get(name, "")
            unit = "" if unit == "1" else " " + unit
            rows.append((name, f"{_num(p.get('median'))}{unit}, 68 % [{_num(ci[0])}, {_num(ci[1])}], "
                               f"sd {_num(p.get('sd'), 2)}, rhat {_num((g('rhat') or {}).get(name), 3)}"))
        for problem in (g("problems") or [])[:3]:
            rows.append(("problem", str(problem)))
        return title, rows


class PosteriorProblem(_Summarised):
    """The log posterior of one record (``posterior_problem``), for any sampler.

    Attributes:
        names: the sampled coordinates in order: alpha, p, mu[, l], sigma,
            t_offset (rad, rad/s, 1[, log10 l], rad, s).
        lower, upper: the prior's support per coordinate.
    Methods:
        log_posterior(x): log prior + log likelihood at x (-inf outside the
            support); thread-safe, releases the GIL.
        start(), start_scale(): the point rocklab's walkers start about, and
            the scale of their initial ball.
        to_reported(x): x with l = 10**x[3] (complex model).
    """

    __slots__ = ("_p",)

    def __init__(self, p):
        self._p = p

    names = property(lambda self: list(self._p.names))
    lower = property(lambda self: _np.array(self._p.lower))
    upper = property(lambda self: _np.array(self._p.upper))

    def log_posterior(self, x):
        return self._p.log_posterior(_np.asarray(x, dtype=float))

    def __call__(self, x):
        return self.log_posterior(x)

    def start(self):
        return _np.array(self._p.start())

    def start_scale(self):
        return _np.array(self._p.start_scale())

    def to_reported(self, x):
        return _np.array(self._p.to_reported(_np.asarray(x, dtype=float)))

    def _summary(self):
        return (f"PosteriorProblem: {len(self.names)} coordinates",
                [(n, f"[{_num(lo)}, {_num(hi)}]") for n, lo, hi in zip(self.names, self.lower, self.upper)])


def _problem(t, theta, width, height, chamfer, method, table, model, seed, walkers, steps, burn_in, threads,
             rtol, integrator, priors, alpha_band, min_impacts):
    path, ts, th, table_t, table_a, accel = _record_args(t, theta, table)
    if width is None or height is None:
        raise ValueError("--posterior needs the block geometry: width and height")
    return _rocklab._posterior_problem(
        path, ts, th, table_t, table_a, accel, _float(width, "width"), _float(height, "height"),
        _float(chamfer, "chamfer"), str(method), "exact", _float(alpha_band, "alpha_band"),
        _int(min_impacts, "min_impacts"), str(model), _int(seed, "seed"), _int(walkers, "walkers"),
        _int(steps, "steps"), _int(burn_in, "burn_in"), _int(threads, "threads"), _float(rtol, "rtol"),
        str(integrator), dict(priors or {}),
    )


def posterior_problem(
    t, theta=None, width=None, height=None, *, chamfer=0.0, method="impacts", table=None, model="housner",
    rtol=1e-6, integrator="adams", priors=None, alpha_band=0.01, min_impacts=4,
):
    """The log posterior of a record, as ``rocklab fit --posterior`` samples it.

    Arguments as ``posterior``. Returns a PosteriorProblem, whose
    ``log_posterior(x)`` another sampler (emcee) can use.
    """
    return PosteriorProblem(_problem(t, theta, width, height, chamfer, method, table, model, 1, 32, 2000, -1, 0,
                                     rtol, integrator, priors, alpha_band, min_impacts))


def posterior(
    t, theta=None, width=None, height=None, *, chamfer=0.0, method="impacts", table=None, model="housner",
    seed=1, walkers=32, steps=5000, burn_in=-1, threads=0, rtol=1e-6, integrator="adams", priors=None,
    alpha_band=0.01, min_impacts=4, progress=None,
):
    """Samples the posterior of alpha, p, mu (, l), sigma and t_offset, as ``rocklab fit --posterior``.

    Args:
        t, theta, width, height, chamfer, method, table: as ``fit``; the
            geometry is required (the priors come from it).
        model: trajectory method: "housner" or "complex" (samples l too).
        seed, walkers, steps, burn_in (-1: half the steps), threads (0: all
            cores): the ensemble sampler's.
        rtol, integrator: trajectory method: the model run's relative
            tolerance and integrator ("adams" or "rk").
        priors: dict of the rig file's [posterior] keys (alpha_band_m,
            p_range, mu_min, mu_max, log10_l_min, log10_l_max, t_offset_s,
            sigma_mu_max: given, a restitution per impact, impacts method).
        progress: None or callable(step, steps).

    Returns:
        (draws, summary): draws, a numpy structured array with one field per
        parameter (alpha, p, mu[, l], sigma, t_offset) and log_posterior;
        summary, a PosteriorSummary: the dict of ``rocklab fit --json``'s ``posterior`` object
        (per parameter median, ci68, ci95, sd; correlation; rhat, ess, tau;
        acceptance, walkers, steps, seed, converged, problems).
        A run that fails the convergence rule warns (RuntimeWarning) and
        says so in summary["converged"] and summary["problems"].
    """
    import json as _json

    p = _problem(t, theta, width, height, chamfer, method, table, model, seed, walkers, steps, burn_in, threads,
                 rtol, integrator, priors, alpha_band, min_impacts)
    names, columns, log_posterior, summary_json = _rocklab._sample_posterior(p, progress)
    summary = PosteriorSummary(_json.loads(summary_json))
    draw_units = summary["units"]
    dtype = _dtype([(n, "f8", draw_units.get(n, "1")) for n in names] + [("log_posterior", "f8", None)])
    draws = _np.empty(len(log_posterior), dtype=dtype)
    for n, c in zip(names, columns):
        draws[n] = c
    draws["log_posterior"] = log_posterior
    if not summary["converged"]:
        _warnings.warn(
            "rocklab.posterior: not converged: " + "; ".join(summary["problems"]), RuntimeWarning, stacklevel=2
        )
    return draws, summary


#: dtype of sweep's results: the columns of ``rocklab sweep``'s CSV.
SWEEP_DTYPE = _dtype(
    [
        ("record", "U256", None),
        ("scale", "f8", "1"),
        ("pga_g", "f8", "g"),
        ("alpha", "f8", "rad"),
        ("p", "f8", "rad/s"),
        ("mu", "f8", "1"),
        ("model", "U8", None),
        ("peak_theta_over_alpha", "f8", "1"),
        ("overturned", "?", None),
        ("overturn_time", "f8", "s"),
        ("impacts", "i8", None),
        ("uplift_time", "f8", "s"),
        ("peak_time", "f8", "s"),
        ("block", "U256", None),
        ("alpha_minus", "f8", "rad"),
        ("p_minus", "f8", "rad/s"),
        ("mu_minus", "f8", "1"),
    ]
)


def _sweep_dtype(header):
    """SWEEP_DTYPE, and for an assembly's sweep the columns after it
    (docs/sweep.md, "Assemblies"): first_overturned_body ("" for none) and
    peak_abs_theta_K (rad) per body K bottom-up."""
    names = list(SWEEP_DTYPE.names)
    assert header[: len(names)] == names, header
    extra = header[len(names):]
    if not extra:
        return SWEEP_DTYPE
    assert extra == ["first_overturned_body"] + [f"peak_abs_theta_{k}" for k in range(1, len(extra))], header
    fields = [(n, SWEEP_DTYPE[n].str, units(SWEEP_DTYPE).get(n)) for n in names]
    fields.append(("first_overturned_body", "U256", None))
    fields += [(n, "f8", "rad") for n in extra[1:]]
    return _dtype(fields)


def _sweep_rows(text):
    import csv
    import io

    # The sweep's definition (`# key: value` lines) comes before the header.
    reader = csv.reader(line for line in io.StringIO(text) if not line.startswith("#"))
    header = next(reader)
    dtype = _sweep_dtype(header)
    rows = []
    for r in reader:
        values = []
        for name, field in zip(dtype.names, r):
            kind = dtype[name].kind
            if kind == "f":
                values.append(float(field) if field != "" else _np.nan)
            elif kind == "i":
                values.append(int(field))
            elif kind == "b":
                values.append(field == "1")
            else:
                values.append(field)
        rows.append(tuple(values))
    return _np.array(rows, dtype=dtype)


def sweep(
    records,
    *,
    model,
    scale="1:1:1",
    pga_g=False,
    alpha=(),
    p=(),
    mu=(),
    width=(),
    height=(),
    polygon=(),
    assembly=None,
    duration=None,
    rate=1000.0,
    l=DEFAULT_L,
    rtol=None,
    threads=0,
    progress=None,
    csv_text=False,
):
    """Runs a rocking campaign, as ``rocklab sweep``: every (record, block, scale).

    Args:
        records: paths of ground-motion records (``time,accel`` CSV or PEER
            .AT2), as ``--records``.
        model: "housner" or "complex".
        scale: "A:B:N", N values from A to B: factors on each record, or the
            target PGA in g with ``pga_g=True``.
        alpha, p, mu: blocks by their parameters (rad, rad/s, 1; mu empty:
            Housner's 1 - 1.5 sin^2 alpha), as ``--alpha --p --mu``.
        width, height: blocks as rectangles (2b, 2h; m); polygon: section
            files (x,z CSV).
        assembly: instead of the blocks, the path of an assembly TOML file
            (``--assembly``; a file, not a dict: the results' definition
            names the file and hashes its bytes). A one-body assembly or a
            frame runs as its single block, a stack by the stack model
            (housner only); the rows then add ``first_overturned_body``
            ("" for none) and ``peak_abs_theta_K`` (rad) per body K
            bottom-up (docs/sweep.md, "Assemblies").
        duration: simulated time per case, s (None: record end + 10 s).
        rate: rate at which peak theta is sampled, Hz.
        l: complex formulation momentum.
        rtol: CVODE relative tolerance, in (0, 1e-3] (None: the model's 1e-10).
        threads: worker threads (0: all cores).
        progress: None or callable(cases_done, cases).
        csv_text: also return the CSV text (``rocklab sweep --out``'s bytes).

    Returns:
        A structured array (SWEEP_DTYPE, with an assembly's columns after
        it: the columns of sweep's CSV, in its case order: record
        outermost, then block, then scale); with ``csv_text``, (array,
        text).
    """

    def floats(v):
        return [float(x) for x in _np.atleast_1d(v)] if v is not None else []

    if assembly is not None and not isinstance(assembly, (str, bytes, _os.PathLike)):
        raise TypeError(f"assembly must be the path of a TOML file, got {type(assembly).__name__}")

    text = _rocklab._sweep(
        [_path(r, "records") for r in ([records] if isinstance(records, (str, _os.PathLike)) else records)],
        str(scale), bool(pga_g), floats(alpha), floats(p), floats(mu), floats(width), floats(height),
        [_path(x, "polygon") for x in ([polygon] if isinstance(polygon, (str, _os.PathLike)) else polygon)],
        "" if assembly is None else _os.fsdecode(_path(assembly, "assembly")), str(model), None if duration is None else _float(duration, "duration"), _float(rate, "rate"), _float(l, "l"),
        None if rtol is None else _float(rtol, "rtol"), _int(threads, "threads"), progress,
    )
    rows = _sweep_rows(text)
    return (rows, text) if csv_text else rows


def fragility(x, overturned=None, trials=None):
    """Lognormal fragility, P(x) = Phi(ln(x / median) / beta), by maximum likelihood.

    Two forms:

    - ``fragility(x, overturned, trials=None)``: intensities x (e.g. PGA in
      g, > 0) and the count overturned at each (or booleans), out of
      ``trials`` (default 1 each): one fit (sweep::FitLognormalFragility).
    - ``fragility(results)``: a result array of ``sweep``: one fit per block
      (model, alpha, p, mu) against pga_g, as ``rocklab sweep-plot``.

    Returns:
        dict (or a list of them, one per block): ``status`` ("fitted",
        "none", "all", "separated"), ``median`` and ``beta`` (fitted),
        ``log_likelihood``, ``safe_below`` / ``overturned_above``
        (separated: the bracket of the median), ``iterations``; per block
        also model, alpha, p, mu, rows, overturned.
    """
    if overturned is None and isinstance(x, _np.ndarray) and x.dtype.names and "pga_g" in x.dtype.names:
        r = x
        text = [repr(float(v)) for v in r["alpha"]], [repr(float(v)) for v in r["p"]], [repr(float(v)) for v in r["mu"]]
        return _rocklab._sweep_fragilities(
            [str(m) for m in r["model"]], *text, _np.asarray(r["pga_g"], float),
            _np.asarray(r["peak_theta_over_alpha"], float), [bool(o) for o in r["overturned"]],
        )
    if overturned is None:
        raise ValueError("fragility(x, overturned[, trials]) or fragility(sweep_results)")
    x = _floats(x, "x")
    k = _floats(overturned, "overturned")
    n = _np.ones_like(x) if trials is None else _floats(trials, "trials")
    return _rocklab._fragility(x, k, n)


for _name in ("block_params", "simulate", "read_log", "read_raw", "info", "reconstruct", "fit", "posterior",
              "posterior_problem", "sweep", "fragility"):
    globals()[_name] = _named_type_errors(globals()[_name])
del _name
