# Type stub of the package rocklab (python/rocklab/__init__.py) for editors
# and type checkers. SI units: m, s, rad, m/s^2.
import os
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike]
Progress = Optional[Callable[[float, Optional[float]], Any]]
ArrayLike = npt.ArrayLike

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
    progress: Progress = ...,
) -> FitResult: ...

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
    threads: int = ...,
    progress: Progress = ...,
    csv_text: bool = ...,
) -> Any: ...
def fragility(
    x: Union[ArrayLike, np.ndarray],
    overturned: Optional[ArrayLike] = ...,
    trials: Optional[ArrayLike] = ...,
) -> Any: ...
