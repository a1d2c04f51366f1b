# Type stub of the package rocklab (python/rocklab/__init__.py) for editors
# and type checkers. SI units: m, s, rad, m/s^2.
import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

# The LCM types (lcm-gen -p, generated into the package at build time; one
# line per lcm_types/*.lcm).
from .band_comparison_t import band_comparison_t as band_comparison_t
from .block_state_t import block_state_t as block_state_t
from .comparison2_t import comparison2_t as comparison2_t
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
from .model_state_t import model_state_t as model_state_t
from .raw_frame_t import raw_frame_t as raw_frame_t
from .table_state_t import table_state_t as table_state_t

PathLike = Union[str, os.PathLike]
Progress = Optional[Callable[[float, Optional[float]], Any]]
ArrayLike = npt.ArrayLike

__version__: str
DEFAULT_L: float
GRAVITY: float
EVENT_DTYPE: np.dtype

def block_params(
    width: Optional[float] = ...,
    height: Optional[float] = ...,
    chamfer: float = ...,
    *,
    polygon: Union[PathLike, ArrayLike, None] = ...,
) -> Dict[str, Any]: ...

class SimulationResult:
    t: npt.NDArray[np.float64]
    theta: npt.NDArray[np.float64]
    theta_dot: npt.NDArray[np.float64]
    events: np.ndarray
    summary: Dict[str, Any]
    def impacts(self) -> np.ndarray: ...

def simulate(
    model: str = ...,
    alpha: Union[float, Dict[str, Any], None] = ...,
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
) -> SimulationResult: ...

class LogTables(Dict[str, np.ndarray]):
    summary: Dict[str, Any]
    info: Dict[str, Dict[str, Any]]

def units(a: Union[np.ndarray, np.dtype]) -> Dict[str, str]: ...

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
def info(path: PathLike, rig: Optional[PathLike] = ..., *, rate: float = ...) -> Dict[str, Any]: ...

class Reconstruction:
    states: np.ndarray
    events: np.ndarray
    summary: Dict[str, Any]

def reconstruct(raw: PathLike, rig: PathLike, *, progress: Progress = ...) -> Reconstruction: ...

class FitResult(Dict[str, Any]):
    def __getattr__(self, name: str) -> Any: ...

def fit(
    t: Union[PathLike, ArrayLike],
    theta: Optional[ArrayLike] = ...,
    width: Optional[float] = ...,
    height: Optional[float] = ...,
    *,
    chamfer: float = ...,
    method: str = ...,
    table: Union[PathLike, Tuple[ArrayLike, ArrayLike], None] = ...,
    quarter_time: str = ...,
    alpha_band: float = ...,
    min_impacts: int = ...,
    start: float = ...,
    end: Optional[float] = ...,
    progress: Progress = ...,
) -> FitResult: ...

class PosteriorProblem:
    names: List[str]
    lower: np.ndarray
    upper: np.ndarray
    def log_posterior(self, x: ArrayLike) -> float: ...
    def __call__(self, x: ArrayLike) -> float: ...
    def start(self) -> np.ndarray: ...
    def start_scale(self) -> np.ndarray: ...
    def to_reported(self, x: ArrayLike) -> np.ndarray: ...

def posterior_problem(
    t: Union[PathLike, ArrayLike],
    theta: Optional[ArrayLike] = ...,
    width: Optional[float] = ...,
    height: Optional[float] = ...,
    *,
    chamfer: float = ...,
    method: str = ...,
    table: Union[PathLike, Tuple[ArrayLike, ArrayLike], None] = ...,
    model: str = ...,
    rtol: float = ...,
    integrator: str = ...,
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
    method: str = ...,
    table: Union[PathLike, Tuple[ArrayLike, ArrayLike], None] = ...,
    model: str = ...,
    seed: int = ...,
    walkers: int = ...,
    steps: int = ...,
    burn_in: int = ...,
    threads: int = ...,
    rtol: float = ...,
    integrator: str = ...,
    priors: Optional[Dict[str, float]] = ...,
    alpha_band: float = ...,
    min_impacts: int = ...,
    progress: Progress = ...,
) -> Tuple[np.ndarray, Dict[str, Any]]: ...

SWEEP_DTYPE: np.dtype

def sweep(
    records: Union[PathLike, Sequence[PathLike]],
    *,
    model: str,
    scale: str = ...,
    pga_g: bool = ...,
    alpha: Union[float, Sequence[float]] = ...,
    p: Union[float, Sequence[float]] = ...,
    mu: Union[float, Sequence[float]] = ...,
    width: Union[float, Sequence[float]] = ...,
    height: Union[float, Sequence[float]] = ...,
    polygon: Union[PathLike, Sequence[PathLike]] = ...,
    duration: Optional[float] = ...,
    rate: float = ...,
    l: float = ...,
    rtol: Optional[float] = ...,
    threads: int = ...,
    progress: Progress = ...,
    csv_text: bool = ...,
) -> Any: ...
def fragility(
    x: Union[ArrayLike, np.ndarray],
    overturned: Optional[ArrayLike] = ...,
    trials: Optional[ArrayLike] = ...,
) -> Any: ...
