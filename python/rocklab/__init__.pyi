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
