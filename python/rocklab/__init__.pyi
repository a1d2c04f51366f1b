# Type stub of the package rocklab (python/rocklab/__init__.py) for editors
# and type checkers. SI units: m, s, rad, m/s^2.
import os
from typing import Callable, Dict, List, Literal, Mapping, NotRequired, Optional, Sequence, Tuple, TypedDict, Union, overload

import numpy as np
import numpy.typing as npt

# The LCM types (lcm-gen -p, generated into the package at build time; one
# line per lcm_types/*.lcm).
from .band_comparison_t import band_comparison_t as band_comparison_t
from .block_state2_t import block_state2_t as block_state2_t
from .block_state_t import block_state_t as block_state_t
from .comparison2_t import comparison2_t as comparison2_t
from .comparison3_t import comparison3_t as comparison3_t
from .comparison_t import comparison_t as comparison_t
from .daq_config2_t import daq_config2_t as daq_config2_t
from .daq_config_t import daq_config_t as daq_config_t
from .event2_t import event2_t as event2_t
from .event_t import event_t as event_t
from .health2_t import health2_t as health2_t
from .health_t import health_t as health_t
from .model_band_t import model_band_t as model_band_t
from .model_state2_t import model_state2_t as model_state2_t
from .model_state3_t import model_state3_t as model_state3_t
from .model_state4_t import model_state4_t as model_state4_t
from .model_state_t import model_state_t as model_state_t
from .raw_frame_t import raw_frame_t as raw_frame_t
from .table_state_t import table_state_t as table_state_t

PathLike = Union[str, "os.PathLike[str]"]
#: progress=callable(done, total): total None where unknown; its return value is ignored.
Progress = Optional[Callable[[float, Optional[float]], object]]
ArrayLike = npt.ArrayLike
FloatArray = npt.NDArray[np.float64]
#: A structured array (one field per column; units in the fields' titles).
Table = npt.NDArray[np.void]

__version__: str
DEFAULT_L: float
GRAVITY: float
EVENT_DTYPE: np.dtype[np.void]
EVENT_FIELDS: Tuple[str, ...]
EVENTS_DTYPE: np.dtype[np.void]
SWEEP_DTYPE: np.dtype[np.void]

# ---- block_params ---------------------------------------------------------

class BlockSide(TypedDict):
    """One side's parameters of a section (block_params' plus_side, minus_side)."""
    alpha: float  # rad
    R: float  # m
    p: float  # rad/s
    mu: float  # 1
    I_O_per_mass: float  # m^2
    pivot: Tuple[float, float]  # (x, z), m

class BlockParams(TypedDict):
    """block_params: the keys of `rocklab params --json`."""
    width: Optional[float]  # m; None for a polygon
    height: Optional[float]
    chamfer: Optional[float]
    alpha: float  # rad
    p: float  # rad/s
    mu: float  # 1, mu_general
    mu_housner: float
    mu_general: float
    R: float  # m
    I_O_per_mass: float  # m^2
    g: float  # m/s^2
    polygon: Optional[str]  # the CSV's path, or None
    vertices: Optional[List[Tuple[float, float]]]  # m; None for a rectangle
    area: float  # m^2
    I_G_per_mass: float  # m^2
    centroid: Tuple[float, float]  # m
    symmetric: bool
    plus_side: BlockSide
    minus_side: BlockSide

def block_params(
    width: Optional[float] = ...,
    height: Optional[float] = ...,
    chamfer: float = ...,
    *,
    polygon: Union[PathLike, ArrayLike, None] = ...,
) -> BlockParams: ...

# ---- simulate -------------------------------------------------------------

class SimulationSummary(TypedDict):
    """SimulationResult.summary: the keys of `rocklab simulate --json` (without units)."""
    model: str
    alpha: float
    p: float
    mu: float
    l: Optional[float]
    theta0: float
    excitation: str
    duration: float
    rate: float
    samples: int
    uplift_time: Optional[float]
    peak_abs_theta: float
    peak_time: float
    impacts: int
    overturned: bool
    overturn_time: Optional[float]
    final_regime: str
    complex_handoff: Optional[float]
    eq10_fraction: float
    rocking_time: float
    steps: int
    rhs_evals: int
    error_test_fails: int
    restarts: int
    recoveries: int
    cpu_time: float

class SimulationResult:
    t: FloatArray
    theta: FloatArray
    theta_dot: FloatArray
    #: EVENT_DTYPE: time, kind (lower-case name), value, theta_dot_after, kind_name, kind_code.
    events: Table
    summary: SimulationSummary
    def __init__(self, t: FloatArray, theta: FloatArray, theta_dot: FloatArray, events: Table,
                 summary: SimulationSummary) -> None: ...
    def impacts(self) -> Table: ...
    def _repr_html_(self) -> str: ...

class AssemblyBodySummary(TypedDict):
    """AssemblySummary.bodies[i]: one body, bottom-up."""
    name: str
    peak_abs_theta: float
    peak_time: float

class AssemblySummary(TypedDict):
    """AssemblyResult.summary: the keys of `rocklab simulate --assembly --json`."""
    assembly: str
    kind: str  # "block", "frame" or "stack"
    model: str
    alpha: Optional[float]  # the single block run (block, frame); None for a stack
    p: Optional[float]
    mu: Optional[float]
    excitation: str
    duration: float
    rate: float
    samples: int
    bodies: List[AssemblyBodySummary]
    uplift_time: Optional[float]
    impacts: int
    overturned: bool
    overturned_body: Optional[str]
    overturn_time: Optional[float]
    modes: int
    mode_changes: int
    final_mode: Optional[str]
    events: int
    steps: int
    impacts_preload: int  # a stack's impacts resolved within the contacts' preloads
    impacts_held_pivots: int  # ... and with pivots held (docs/models.md)
    cpu_time: float
    units: Dict[str, str]

#: AssemblyResult.events: time, kind, interface, body, mode.
ASSEMBLY_EVENT_DTYPE: np.dtype[np.void]

class AssemblyResult:
    t: FloatArray
    names: List[str]
    #: shape (len(t), len(names)), rad
    theta: FloatArray
    theta_dot: FloatArray
    mode: npt.NDArray[np.str_]
    #: ASSEMBLY_EVENT_DTYPE
    events: Table
    summary: AssemblySummary
    def __init__(self, t: FloatArray, names: List[str], theta: FloatArray, theta_dot: FloatArray,
                 mode: npt.NDArray[np.str_], events: Table, summary: AssemblySummary) -> None: ...
    def _repr_html_(self) -> str: ...

#: an assembly file's keys as a dict: {"body": [{...}, ...], "interface": [...]} or {"frame": {...}}
AssemblyDict = Mapping[str, Union[Mapping[str, Union[float, str]], Sequence[Mapping[str, Union[float, str]]]]]

@overload
def simulate(
    model: Literal["housner", "complex"] = ...,
    alpha: None = ...,
    p: None = ...,
    mu: None = ...,
    *,
    excitation: Union[str, Sequence[str], None] = ...,
    accel: Optional[PathLike] = ...,
    theta0: float = ...,
    duration: float,
    rate: float,
    l: float = ...,
    complex_handoff: float = ...,
    rtol: Optional[float] = ...,
    progress: Progress = ...,
    assembly: Union[PathLike, AssemblyDict],
) -> AssemblyResult: ...
@overload
def simulate(
    model: Literal["housner", "complex"] = ...,
    alpha: Union[float, BlockParams, None] = ...,
    p: Optional[float] = ...,
    mu: Optional[float] = ...,
    *,
    excitation: Union[str, Sequence[str], None] = ...,
    accel: Union[PathLike, Tuple[ArrayLike, ArrayLike], None] = ...,
    theta0: float = ...,
    duration: float,
    rate: float,
    l: float = ...,
    complex_handoff: float = ...,
    rtol: Optional[float] = ...,
    progress: Progress = ...,
    assembly: None = ...,
) -> SimulationResult: ...

# ---- logs and raw files ---------------------------------------------------

class ReadTable(TypedDict):
    """ReadSummary.tables[i]: one table read."""
    channel: str
    type: str  # the LCM type's name, or "raw"
    rows: int
    reshaped: int  # rows whose arrays changed length, padded or cut to the table's

class ReadSummary(TypedDict):
    """LogTables.summary: the counts `rocklab export` prints (raw files and
    .AT2 records have the keys that apply to them)."""
    tables: NotRequired[List[ReadTable]]
    rows: int
    outside_window: int
    filtered: NotRequired[int]
    unknown_type: NotRequired[int]
    undecodable: NotRequired[int]
    damaged_regions: NotRequired[int]
    damaged_bytes: NotRequired[int]
    damaged_events: NotRequired[int]
    bad_rows: int
    bad_values: int
    read_error: str
    problems: List[str]
    format: NotRequired[str]

class TableInfo(TypedDict):
    """LogTables.info[name]: where a table comes from, and its units."""
    channel: NotRequired[str]
    lcm_type: NotRequired[str]
    source: NotRequired[str]
    units: Dict[str, str]

class LogTables(Dict[str, Table]):
    summary: ReadSummary
    info: Dict[str, TableInfo]
    def __init__(self, tables: Dict[str, Table], summary: ReadSummary,
                 info: Optional[Dict[str, TableInfo]] = ...) -> None: ...
    #: (variant, None) for RL_COMPARE_<name>, (variant, k) for body k (index, 0 on the table).
    def compared(self) -> List[Tuple[str, Optional[int]]]: ...
    def comparison(self, variant: str, body: Optional[int] = ...) -> Table: ...
    def _repr_html_(self) -> str: ...

def units(a: Union[npt.NDArray[np.generic], np.dtype[np.generic]]) -> Dict[str, str]: ...
def events(
    a: Union[npt.NDArray[np.void], LogTables, SimulationResult, AssemblyResult, Reconstruction, FitResult]
) -> npt.NDArray[np.void]: ...

def read_log(
    path: PathLike,
    channels: str = ...,
    *,
    start: float = ...,
    end: Optional[float] = ...,
    progress: Progress = ...,
) -> LogTables: ...
def read_raw(
    path: PathLike,
    rig: Optional[PathLike] = ...,
    *,
    rate: float = ...,
    start: float = ...,
    end: Optional[float] = ...,
    progress: Progress = ...,
) -> LogTables: ...

class RigConfig(TypedDict):
    """LogInfo.config: the rig's RL_DAQ_CONFIG as the log holds it."""
    rig: str
    calibration: str
    sample_rate_hz: Optional[float]
    channels: List[str]
    units: List[str]
    sensors: List[str]
    alpha: Optional[float]  # rad
    p: Optional[float]  # rad/s
    mu: Optional[float]
    messages: int
    changes: int

class LogChannel(TypedDict):
    """LogInfo.channels[i]: one channel (and type) of a log."""
    name: str
    type: str
    fingerprint: str  # "0x..."
    count: int
    bytes: int
    first_time: Optional[float]  # s, sample clock
    last_time: Optional[float]
    rate_hz: Optional[float]
    seq_gaps: Optional[int]  # None: the type has no sequence number
    seq_missing: Optional[int]
    seq_back: Optional[int]
    seq_late: Optional[int]
    seq_duplicates: Optional[int]
    seq_restarts: Optional[int]
    seq_wild: Optional[int]
    undecodable: int

class LogInfo(TypedDict):
    """info(log): `rocklab info --json` of an LCM log."""
    kind: Literal["lcm_log"]
    path: str
    file_bytes: int
    events: int
    duration: float  # s, sample clock
    first_time: Optional[float]
    last_time: Optional[float]
    log_duration: float  # s, the writer's stamps
    damaged_regions: int
    damaged_bytes: int
    damaged_events: int
    config: Optional[RigConfig]
    channels: List[LogChannel]

class RawChannel(TypedDict):
    """RawInfo.channels[i]: a raw file's channel and its units."""
    name: str
    unit: Optional[str]  # the values' unit: the file's, else the rig's
    file_unit: Optional[str]
    rig_unit: Optional[str]

class RawInfo(TypedDict):
    """info(raw file): `rocklab info --json` of a CSV or LVM file."""
    kind: Literal["csv", "lvm"]
    path: str
    file_bytes: int
    rows: int
    bad_rows: int
    bad_values: int
    empty_values: int
    comments: int
    warnings: int
    segments: int
    rate_hz: Optional[float]
    measured_rate_hz: Optional[float]
    first_time: Optional[float]
    last_time: Optional[float]
    duration: Optional[float]
    seq_gaps: int
    seq_missing: int
    read_error: Optional[str]
    channels: List[RawChannel]

#: What info returns: a log's or a raw file's (tell them apart by ``kind``).
FileInfo = Union[LogInfo, RawInfo]

def info(path: PathLike, rig: Optional[PathLike] = ..., *, rate: float = ...) -> FileInfo: ...

# ---- reconstruct ----------------------------------------------------------

class ReconstructionSummary(TypedDict):
    """Reconstruction.summary: the counts `rocklab reconstruct` prints."""
    rows: int
    bad_rows: int
    bad_values: int
    gaps: int
    missing: int
    duplicates: int
    out_of_order: int
    invalid_led_samples: int
    reconstructed: int
    flagged: int
    damaged_regions: int
    damaged_bytes: int
    damaged_events: int
    read_error: str
    problems: List[str]

class Reconstruction:
    states: Table
    #: time, kind (event_t's constant), value, detail, kind_name, kind_code.
    events: Table
    summary: ReconstructionSummary
    def __init__(self, states: Table, events: Table, summary: ReconstructionSummary) -> None: ...
    def _repr_html_(self) -> str: ...

def reconstruct(raw: PathLike, rig: PathLike, *, progress: Progress = ...) -> Reconstruction: ...

# ---- fit ------------------------------------------------------------------

class FitImpact(TypedDict):
    """FitResult.impacts[i]: one impact of the record (None: not measured)."""
    n: int
    time: Optional[float]  # s
    peak: Optional[float]  # rad
    mu_n: Optional[float]
    tau: Optional[float]  # s
    residual: Optional[float]  # s
    residual_noise: Optional[float]  # s

class FitTheory(TypedDict):
    """FitResult.theory: the parameters of the stated geometry."""
    alpha: float
    p: float
    mu: float

class FitSecondMinimum(TypedDict):
    alpha: float  # rad
    p: float  # rad/s
    mu: float
    delta_chi2: float  # its chi-square above the answer's

class FitAlphaBand(TypedDict):
    """FitResult.alpha_band: the admissible alpha from the geometry."""
    lo: float  # rad
    hi: float
    band_m: float  # m

class FitResult(Dict[str, object]):
    """fit: the dict of `rocklab fit --json`, its keys also attributes
    (typed here; index the dict for the JSON-like view)."""
    input: str  # the record's path, or "<arrays>"
    method: Literal["impacts", "trajectory"]
    quarter_time: Optional[str]
    alpha: float  # rad
    p: float  # rad/s
    mu: float
    mu_spread: Optional[float]
    alpha_stderr: Optional[float]  # None: withheld
    p_stderr: Optional[float]
    mu_stderr: Optional[float]
    alpha_p_correlation: Optional[float]
    rms_residual: float  # s (impacts) or rad (trajectory)
    residuals: List[float]
    iterations: int
    evaluations: int
    runtime: float  # s
    forced: bool
    noise: float  # rad
    dof: int
    converged: bool
    residual_to_noise: Optional[float]
    chi2: Optional[float]
    chi2_per_dof: Optional[float]
    p_value: Optional[float]
    band_ratio: Optional[float]  # trajectory: low-band / high-band residual power per degree of freedom
    band_p_value: Optional[float]
    band_hz: Optional[float]  # Hz, the low band's top
    significance: float
    noise_dof: Optional[float]
    noise_stated: bool
    starts: int
    starts_refined: int
    noise_residual: Optional[float]
    stderr_withheld: bool
    missing_samples: int
    gaps: int
    longest_gap: float  # s
    missing_table_samples: int
    table_interpolation_error: Optional[float]  # rad
    table_reading: Optional[str]  # forced trajectory fit: "spline" or "chord"
    second_minimum: Optional[FitSecondMinimum]
    release_time: Optional[float]  # s
    impacts: List[FitImpact]
    warnings: List[str]
    theory: Optional[FitTheory]
    alpha_band: Optional[FitAlphaBand]
    def _repr_html_(self) -> str: ...

def fit(
    t: Union[PathLike, ArrayLike],
    theta: Optional[ArrayLike] = ...,
    width: Optional[float] = ...,
    height: Optional[float] = ...,
    *,
    chamfer: float = ...,
    method: Literal["impacts", "trajectory"] = ...,
    table: Union[PathLike, Tuple[ArrayLike, ArrayLike], None] = ...,
    quarter_time: Literal["exact", "slender"] = ...,
    alpha_band: float = ...,
    min_impacts: int = ...,
    start: float = ...,
    end: Optional[float] = ...,
    progress: Progress = ...,
) -> FitResult: ...

# ---- posterior ------------------------------------------------------------

class PosteriorProblem:
    names: List[str]
    lower: FloatArray
    upper: FloatArray
    def log_posterior(self, x: ArrayLike) -> float: ...
    def __call__(self, x: ArrayLike) -> float: ...
    def start(self) -> FloatArray: ...
    def start_scale(self) -> FloatArray: ...
    def to_reported(self, x: ArrayLike) -> FloatArray: ...
    def _repr_html_(self) -> str: ...

class ParameterSummary(TypedDict):
    """PosteriorSummary[name]: one parameter's marginal."""
    median: float
    ci68: List[float]  # [lo, hi]
    ci95: List[float]
    sd: float
    mean: float

class Correlation(TypedDict):
    order: List[str]
    matrix: List[List[Optional[float]]]

# The name of a TypedDict at type-checking time; at run time posterior's
# summary is rocklab.PosteriorSummary, a dict with a one-screen repr.
PosteriorSummary = TypedDict(
    "PosteriorSummary",
    {
        "alpha": ParameterSummary,  # rad
        "p": ParameterSummary,  # rad/s
        "mu": ParameterSummary,
        "l": NotRequired[ParameterSummary],  # model "complex"
        "sigma": ParameterSummary,  # rad
        "t_offset": ParameterSummary,  # s
        "sigma_mu": NotRequired[ParameterSummary],  # per-impact restitution
        "mu_bar": NotRequired[ParameterSummary],
        "parameters": List[str],
        "correlation": Correlation,
        "rhat": Dict[str, Optional[float]],
        "ess": Dict[str, Optional[float]],
        "tau": Dict[str, Optional[float]],
        "acceptance": float,
        "walkers": int,
        "steps": int,
        "burn_in": int,
        "draws": int,
        "seed": int,
        "threads": int,
        "method": str,
        "model": str,
        "converged": bool,
        "problems": List[str],
        "start": str,
        "warnings": List[str],
        "runtime": float,  # s
        "units": Dict[str, str],
    },
)

def posterior_problem(
    t: Union[PathLike, ArrayLike],
    theta: Optional[ArrayLike] = ...,
    width: Optional[float] = ...,
    height: Optional[float] = ...,
    *,
    chamfer: float = ...,
    method: Literal["impacts", "trajectory"] = ...,
    table: Union[PathLike, Tuple[ArrayLike, ArrayLike], None] = ...,
    model: Literal["housner", "complex"] = ...,
    rtol: float = ...,
    integrator: Literal["adams", "rk"] = ...,
    priors: Optional[Dict[str, float]] = ...,
    alpha_band: float = ...,
    min_impacts: int = ...,
) -> PosteriorProblem: ...

def posterior(
    t: Union[PathLike, ArrayLike],
    theta: Optional[ArrayLike] = ...,
    width: Optional[float] = ...,
    height: Optional[float] = ...,
    *,
    chamfer: float = ...,
    method: Literal["impacts", "trajectory"] = ...,
    table: Union[PathLike, Tuple[ArrayLike, ArrayLike], None] = ...,
    model: Literal["housner", "complex"] = ...,
    seed: int = ...,
    walkers: int = ...,
    steps: int = ...,
    burn_in: int = ...,
    threads: int = ...,
    rtol: float = ...,
    integrator: Literal["adams", "rk"] = ...,
    priors: Optional[Dict[str, float]] = ...,
    alpha_band: float = ...,
    min_impacts: int = ...,
    progress: Progress = ...,
) -> Tuple[Table, PosteriorSummary]: ...

# ---- sweep and fragility --------------------------------------------------

@overload
def sweep(
    records: Union[PathLike, Sequence[PathLike]],
    *,
    model: Literal["housner", "complex"],
    scale: str = ...,
    pga_g: bool = ...,
    alpha: Union[float, Sequence[float]] = ...,
    p: Union[float, Sequence[float]] = ...,
    mu: Union[float, Sequence[float]] = ...,
    width: Union[float, Sequence[float]] = ...,
    height: Union[float, Sequence[float]] = ...,
    polygon: Union[PathLike, Sequence[PathLike]] = ...,
    assembly: Optional[PathLike] = ...,
    duration: Optional[float] = ...,
    rate: float = ...,
    l: float = ...,
    rtol: Optional[float] = ...,
    threads: int = ...,
    progress: Progress = ...,
    csv_text: Literal[False] = ...,
) -> Table: ...
@overload
def sweep(
    records: Union[PathLike, Sequence[PathLike]],
    *,
    model: Literal["housner", "complex"],
    scale: str = ...,
    pga_g: bool = ...,
    alpha: Union[float, Sequence[float]] = ...,
    p: Union[float, Sequence[float]] = ...,
    mu: Union[float, Sequence[float]] = ...,
    width: Union[float, Sequence[float]] = ...,
    height: Union[float, Sequence[float]] = ...,
    polygon: Union[PathLike, Sequence[PathLike]] = ...,
    assembly: Optional[PathLike] = ...,
    duration: Optional[float] = ...,
    rate: float = ...,
    l: float = ...,
    rtol: Optional[float] = ...,
    threads: int = ...,
    progress: Progress = ...,
    csv_text: Literal[True],
) -> Tuple[Table, str]: ...

class Fragility(TypedDict):
    """A lognormal fragility fit (sweep::FitLognormalFragility)."""
    status: Literal["fitted", "none", "all", "separated"]
    median: Optional[float]  # fitted: the intensity's unit (g for pga_g)
    beta: Optional[float]  # fitted: 1
    log_likelihood: Optional[float]
    safe_below: Optional[float]  # separated: the bracket of the median
    overturned_above: Optional[float]
    iterations: int

class BlockFragility(Fragility):
    """fragility(sweep_rows): one block's fit, as sweep-plot's fragility.csv."""
    model: str
    alpha: float
    p: float
    mu: float
    rows: int
    overturned: int

@overload
def fragility(x: Table) -> List[BlockFragility]: ...
@overload
def fragility(x: ArrayLike, overturned: ArrayLike, trials: Optional[ArrayLike] = ...) -> Fragility: ...
