"""A script using rocklab's API as a user writes it, for `mypy --strict`
(test_typing.py): the stub (python/rocklab/__init__.pyi) must type every
result to its fields, so each line below type-checks without a cast and
each `reveal`-free annotation states the type the stub must give. Not run,
only checked."""

from typing import List, Optional, Tuple

import numpy as np
import numpy.typing as npt

import rocklab

block: rocklab.BlockParams = rocklab.block_params(0.247, 1.0)
alpha: float = block["alpha"]
pivot: Tuple[float, float] = block["plus_side"]["pivot"]

run: rocklab.SimulationResult = rocklab.simulate("housner", block, duration=5.0, rate=100.0, theta0=0.1)
theta: npt.NDArray[np.float64] = run.theta
impacts: int = run.summary["impacts"]
uplift: Optional[float] = run.summary["uplift_time"]
events: npt.NDArray[np.void] = run.impacts()
html: str = run._repr_html_()

stack: rocklab.AssemblyResult = rocklab.simulate(
    assembly={"body": [{"name": "pedestal", "width_m": 0.5, "height_m": 0.4, "mass_kg": 240.0},
                       {"name": "statue", "width_m": 0.2, "height_m": 0.8, "mass_kg": 86.4}]},
    excitation="sine:amp=0.02,freq=2,duration=2", duration=2.0, rate=100.0)
statue: npt.NDArray[np.float64] = stack.theta[:, 1]
body_names: List[str] = stack.names
overturned_body: Optional[str] = stack.summary["overturned_body"]
peak: float = stack.summary["bodies"][1]["peak_abs_theta"]
frame: rocklab.AssemblyResult = rocklab.simulate("complex", assembly="portal_frame.toml", duration=1.0, rate=100.0)

log: rocklab.LogTables = rocklab.read_log("test.lcm", channels="RL_THETA")
th: npt.NDArray[np.void] = log["RL_THETA"]
rows: int = log.summary["rows"]
problems: List[str] = log.summary["problems"]
unit: str = rocklab.units(th)["theta"]
lcm_type: str = log.info["RL_THETA"].get("lcm_type", "")
keys: List[Tuple[str, Optional[int]]] = log.compared()
upper_body: npt.NDArray[np.void] = log.comparison("stack", 1)

about: rocklab.FileInfo = rocklab.info("test.lcm")

test: rocklab.Reconstruction = rocklab.reconstruct("raw.csv", "rig.toml")
flagged: int = test.summary["flagged"]

f: rocklab.FitResult = rocklab.fit(run.t, run.theta, width=0.247, height=1.0, start=0.0, end=None)
value: float = f.alpha
error: Optional[float] = f.alpha_stderr
converged: bool = f.converged
warnings: List[str] = f.warnings
first_peak: Optional[float] = f.impacts[0]["peak"]

draws, summary = rocklab.posterior(run.t, run.theta, 0.247, 1.0, steps=100)
median: float = summary["alpha"]["median"]
ci68: List[float] = summary["alpha"]["ci68"]
rhat: Optional[float] = summary["rhat"]["alpha"]
names: List[str] = rocklab.posterior_problem(run.t, run.theta, 0.247, 1.0).names

table: npt.NDArray[np.void] = rocklab.sweep(["a.csv"], model="housner", alpha=0.2, p=3.0)
table2, text = rocklab.sweep(["a.csv"], model="housner", alpha=0.2, p=3.0, csv_text=True)
stack_rows: npt.NDArray[np.void] = rocklab.sweep("a.csv", model="housner", assembly="statue.toml")
length: int = len(text)
fits: List[rocklab.BlockFragility] = rocklab.fragility(table)
median_g: Optional[float] = fits[0]["median"]
one: rocklab.Fragility = rocklab.fragility([0.1, 0.2], [0, 1])
status: str = one["status"]
version: str = rocklab.__version__
