"""rocklab.block_params and rocklab.simulate against the command line.

Oracle: `rocklab params --json` and `rocklab simulate --json --out --events`
of the same build on the same inputs. The library is the same, so values
that the CLI prints as JSON (round-trip precision) must be equal exactly;
the CSV prints theta and theta_dot with %.12g (a relative rounding of at
most 5e-12) and event times with %.9f (5e-10 s).
"""

import os

import numpy as np
import pytest

import rocklab

FIG8 = dict(alpha=0.168, p=3.767, mu=0.942)  # block 2 (docs/performance.md, figure 8)
FIG8_SINE = "sine:amp=0.006,freq=5,duration=20,start=0"


def read_csv(path):
    return np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")


def assert_printed(ours, printed, digits_rel):
    """ours equals a column printed with a relative rounding of digits_rel."""
    np.testing.assert_allclose(ours, printed, rtol=digits_rel, atol=1e-300)


@pytest.mark.parametrize(
    "kwargs,args",
    [
        (dict(width=0.2, height=0.8), ["--width", 0.2, "--height", 0.8]),
        (dict(width=0.246, height=0.5, chamfer=0.042), ["--width", 0.246, "--height", 0.5, "--chamfer", 0.042]),
    ],
)
def test_block_params_rectangle_equals_cli(cli, kwargs, args):
    ours = rocklab.block_params(**kwargs)
    theirs = cli.json("params", *args, "--json")
    theirs.pop("units")
    assert set(ours) == set(theirs)
    for key, value in theirs.items():
        mine = ours[key]
        if isinstance(mine, tuple):
            mine = list(mine)
        if isinstance(mine, dict):
            mine = {k: list(v) if isinstance(v, tuple) else v for k, v in mine.items()}
        assert mine == value, key


def test_block_params_polygon_file_and_array_equal_cli(cli, tmp_path):
    # An asymmetric L-shaped section: each side has its own alpha, p and mu.
    vertices = [(0.0, 0.0), (0.3, 0.0), (0.3, 0.2), (0.1, 0.2), (0.1, 0.9), (0.0, 0.9)]
    path = tmp_path / "l.csv"
    path.write_text("x,z\n" + "".join(f"{x},{z}\n" for x, z in vertices))
    theirs = cli.json("params", "--polygon", path, "--json")
    from_file = rocklab.block_params(polygon=path)
    from_array = rocklab.block_params(polygon=np.array(vertices))
    assert not theirs["symmetric"]
    for side in ("plus_side", "minus_side"):
        for key in ("alpha", "p", "mu", "R", "I_O_per_mass"):
            assert from_file[side][key] == theirs[side][key], (side, key)
            assert from_array[side][key] == theirs[side][key], (side, key)
    assert from_file["polygon"] == str(path) and from_array["polygon"] is None
    assert from_file["vertices"] == from_array["vertices"] == 6


def test_block_params_errors_are_the_clis(cli, tmp_path):
    with pytest.raises(ValueError) as e:
        rocklab.block_params(0.2, -1)
    assert str(e.value) == cli.error("params", "--width", 0.2, "--height", -1)
    with pytest.raises(ValueError) as e:
        rocklab.block_params(0.2, 0.8, 0.15)
    assert str(e.value) == cli.error("params", "--width", 0.2, "--height", 0.8, "--chamfer", 0.15)
    crossing = tmp_path / "bow.csv"
    crossing.write_text("x,z\n0,0\n1,1\n1,0\n0,1\n")
    with pytest.raises(ValueError) as e:
        rocklab.block_params(polygon=crossing)
    assert str(e.value) == cli.error("params", "--polygon", crossing)
    with pytest.raises(FileNotFoundError):
        rocklab.block_params(polygon=tmp_path / "missing.csv")


def simulate_cli(cli, tmp_path, name, args):
    out, events = tmp_path / f"{name}.csv", tmp_path / f"{name}.events.csv"
    summary = cli.json("simulate", *args, "--json", "--out", out, "--events", events)
    return summary, read_csv(out), read_csv(events)


def assert_same_run(result, summary, rows, events):
    for key, value in summary.items():
        if key in ("units", "cpu_time"):
            continue
        assert result.summary[key] == value, key
    assert set(result.summary) == set(summary) - {"units"}
    assert result.t.shape == rows["time"].shape
    assert_printed(result.t, rows["time"], 5e-9)  # %.9g
    assert_printed(result.theta, rows["theta"], 5e-12)
    assert_printed(result.theta_dot, rows["theta_dot"], 5e-12)
    assert list(result.events["kind"]) == list(np.atleast_1d(events["kind"]))
    np.testing.assert_allclose(result.events["time"], np.atleast_1d(events["time"]), rtol=0, atol=5e-10)


@pytest.mark.parametrize("model", ["housner", "complex"])
def test_simulate_figure8_equals_cli(cli, tmp_path, model):
    args = ["--model", model, "--alpha", FIG8["alpha"], "--p", FIG8["p"], "--mu", FIG8["mu"],
            "--excitation", FIG8_SINE, "--duration", 20, "--rate", 200]
    summary, rows, events = simulate_cli(cli, tmp_path, model, args)
    result = rocklab.simulate(model, **FIG8, excitation=FIG8_SINE, duration=20, rate=200)
    assert summary["impacts"] > 10  # the case rocks
    assert_same_run(result, summary, rows, events)
    impacts = result.impacts()
    assert len(impacts) == summary["impacts"]
    assert np.all(np.isfinite(impacts["value"]))


def test_simulate_free_rocking_and_summed_excitations_equal_cli(cli, tmp_path):
    args = ["--alpha", 0.2, "--p", 3.8, "--mu", 0.9, "--theta0", 0.1, "--duration", 3, "--rate", 500,
            "--excitation", "hanning:amp=0.004,freq=3.3,duration=2,start=0.5",
            "--excitation", "sine:amp=0.001,freq=7,duration=1,start=1"]
    summary, rows, events = simulate_cli(cli, tmp_path, "free", args)
    result = rocklab.simulate(alpha=0.2, p=3.8, mu=0.9, theta0=0.1, duration=3, rate=500,
                              excitation=["hanning:amp=0.004,freq=3.3,duration=2,start=0.5",
                                          "sine:amp=0.001,freq=7,duration=1,start=1"])
    assert_same_run(result, summary, rows, events)


def test_simulate_accel_file_and_arrays_equal_cli(cli, tmp_path):
    # A table-acceleration record: a decaying 4 Hz burst at 200 Hz, strong
    # enough to uplift the block (g tan(0.168) = 1.66 m/s^2).
    t = np.arange(0, 4, 0.005)
    a = 4.0 * np.sin(2 * np.pi * 4 * t) * np.exp(-t / 1.5)
    record = tmp_path / "record.csv"
    with open(record, "w") as f:
        f.write("time,accel\n")
        for ti, ai in zip(t, a):
            f.write(f"{ti!r},{ai!r}\n")
    args = ["--alpha", FIG8["alpha"], "--p", FIG8["p"], "--mu", FIG8["mu"], "--accel", record,
            "--duration", 6, "--rate", 100]
    summary, rows, events = simulate_cli(cli, tmp_path, "accel", args)
    from_file = rocklab.simulate(**FIG8, accel=record, duration=6, rate=100)
    assert summary["uplift_time"] is not None
    assert_same_run(from_file, summary, rows, events)
    # The same samples as arrays: the same forcing, so the same trajectory.
    from_arrays = rocklab.simulate(**FIG8, accel=(t, a), duration=6, rate=100)
    np.testing.assert_array_equal(from_arrays.theta, from_file.theta)
    np.testing.assert_array_equal(from_arrays.events["time"], from_file.events["time"])
    assert from_arrays.summary["excitation"] == "accel:array(800 samples)"


def test_simulate_errors_are_the_clis(cli, tmp_path):
    base = ["--duration", 1, "--rate", 10]
    cases = [
        (dict(alpha=2, p=1, mu=0.5), ["--alpha", 2, "--p", 1, "--mu", 0.5]),
        (dict(alpha=0.2, p=1, mu=1.5), ["--alpha", 0.2, "--p", 1, "--mu", 1.5]),
        (dict(alpha=0.2, p=1, mu=0.5, excitation="sine:amp=0.01,freq=-1,duration=1"),
         ["--alpha", 0.2, "--p", 1, "--mu", 0.5, "--excitation", "sine:amp=0.01,freq=-1,duration=1"]),
        (dict(model="other", alpha=0.2, p=1, mu=0.5), ["--model", "other", "--alpha", 0.2, "--p", 1, "--mu", 0.5]),
    ]
    for kwargs, args in cases:
        with pytest.raises(ValueError) as e:
            rocklab.simulate(**kwargs, duration=1, rate=10)
        assert str(e.value) == cli.error("simulate", *args, *base, "--out", tmp_path / "x.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("time,accel\n0,1\n0,2\n")
    with pytest.raises(ValueError) as e:
        rocklab.simulate(alpha=0.2, p=1, mu=0.5, accel=bad, duration=1, rate=10)
    assert str(e.value) == cli.error("simulate", "--alpha", 0.2, "--p", 1, "--mu", 0.5, "--accel", bad, *base,
                                     "--out", tmp_path / "x.csv")
    missing = tmp_path / "missing.csv"
    with pytest.raises(FileNotFoundError) as e:
        rocklab.simulate(alpha=0.2, p=1, mu=0.5, accel=missing, duration=1, rate=10)
    assert e.value.filename == str(missing)
    assert e.value.strerror == cli.error("simulate", "--alpha", 0.2, "--p", 1, "--mu", 0.5, "--accel", missing,
                                         *base, "--out", tmp_path / "x.csv")
    with pytest.raises(ValueError, match=r"^accel: .*time_s\[2\]"):
        rocklab.simulate(alpha=0.2, p=1, mu=0.5, accel=([0, 1, 1], [0, 0, 0]), duration=1, rate=10)


def test_simulate_progress_and_interrupt():
    calls = []

    def progress(done, total):
        calls.append((done, total))

    rocklab.simulate(**FIG8, excitation=FIG8_SINE, duration=20, rate=200, progress=progress)
    # At most every 0.1 s, then the end once: the last call is (duration, duration).
    assert calls and calls[-1] == (20.0, 20.0)
    assert all(0 <= d <= t for d, t in calls)

    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop()

    # The first call comes 0.1 s in: a run long enough to reach it.
    with pytest.raises(Stop):
        rocklab.simulate(**FIG8, excitation="sine:amp=0.006,freq=5,duration=2000", duration=2000, rate=200,
                         progress=stop)


def test_simulate_rtol_equals_cli(cli, tmp_path):
    args = ["--alpha", FIG8["alpha"], "--p", FIG8["p"], "--mu", FIG8["mu"], "--excitation", FIG8_SINE,
            "--duration", 5, "--rate", 200, "--rtol", 1e-6]
    summary, rows, events = simulate_cli(cli, tmp_path, "rtol", args)
    loose = rocklab.simulate(**FIG8, excitation=FIG8_SINE, duration=5, rate=200, rtol=1e-6)
    assert_same_run(loose, summary, rows, events)
    tight = rocklab.simulate(**FIG8, excitation=FIG8_SINE, duration=5, rate=200)
    assert loose.summary["steps"] < tight.summary["steps"]
    with pytest.raises(ValueError) as e:
        rocklab.simulate(**FIG8, duration=1, rate=10, rtol=-1)
    assert str(e.value) == cli.error("simulate", "--alpha", 0.2, "--p", 1, "--mu", 0.5, "--duration", 1,
                                     "--rate", 10, "--rtol", -1, "--out", tmp_path / "x.csv")


def test_simulate_releases_the_gil():
    # A simulation in one thread while this thread counts: with the GIL
    # released the count runs all along the call; held, this thread could
    # only run before and after it (a switch interval, 5 ms, each side).
    import threading
    import time

    t0 = time.perf_counter()
    n = 0
    while time.perf_counter() - t0 < 0.2:
        n += 1
    free_rate = n / 0.2  # counts/s of this loop alone
    worker = threading.Thread(
        target=rocklab.simulate,
        args=("complex",),
        # about 1.5 s of CPU (24 Nov 2026)
        kwargs=dict(**FIG8, excitation="sine:amp=0.006,freq=5,duration=500", duration=500, rate=200),
    )
    t0 = time.perf_counter()
    worker.start()
    n = 0
    while worker.is_alive():
        n += 1
    seconds = time.perf_counter() - t0
    assert seconds > 0.5, "the call must outlast many switch intervals"
    # Held, n <= free_rate * 0.01; released, n ~ free_rate * seconds (less
    # on a loaded machine): ask for 5 % of it, above 5x the held bound.
    assert n > max(0.05 * free_rate * seconds, 0.05 * free_rate), (n, free_rate, seconds)


def test_simulation_result_repr_is_a_one_screen_summary():
    r = rocklab.simulate("housner", **FIG8, excitation=FIG8_SINE, duration=20, rate=200)
    text = repr(r)
    assert len(text.splitlines()) <= 12 and len(text) < 1000, text
    assert text.startswith(f"SimulationResult: housner, alpha {FIG8['alpha']:.4g} rad")
    kinds = dict(zip(*np.unique(r.events["kind"], return_counts=True)))
    assert f"{kinds['impact']} impact" in text and f"{len(r.t)} at 200 Hz" in text, text
    assert f"{r.summary['peak_abs_theta']:.4g} rad at {r.summary['peak_time']:.4g} s" in text
    assert r._repr_html_().count("<tr>") == len(text.splitlines()) - 1


def _import_rocklab_with(tmp_path, env_path, setup=""):
    """stderr of `import rocklab` in a fresh interpreter with env_path first on PYTHONPATH."""
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(env_path), os.environ["PYTHONPATH"]]))
    r = subprocess.run([sys.executable, "-c", setup + "import rocklab"], env=env, capture_output=True, text=True,
                       cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    return r.stderr


def test_import_error_names_the_build_and_the_interpreter(tmp_path):
    # Issue 36: with a pyenv or venv python3 first on PATH the import failed
    # (numpy missing) with no hint. Hidden here by a numpy that cannot import.
    import platform
    import sys

    from rocklab import _build_info as built

    assert built.PYTHON_VERSION == platform.python_version() and built.NUMPY_VERSION == np.__version__
    hide = tmp_path / "hide"
    (hide / "numpy").mkdir(parents=True)
    (hide / "numpy" / "__init__.py").write_text("raise ImportError('numpy hidden by the test')\n")
    err = _import_rocklab_with(tmp_path, hide)
    last = err[err.rindex("ImportError: import rocklab failed"):]
    assert "numpy hidden by the test" in last
    assert (f"built for Python {built.PYTHON_VERSION} ({built.PYTHON_EXECUTABLE}) with numpy "
            f"{built.NUMPY_VERSION}; this is Python {platform.python_version()} ({sys.executable}) "
            "with no importable numpy") in last
    assert "-m venv --system-site-packages" in last
    # A numpy of another ABI (older than the build's): refused at the import,
    # not at the first array.
    (hide / "numpy" / "__init__.py").write_text("__version__ = '1.19.5'\n")
    err = _import_rocklab_with(tmp_path, hide)
    last = err[err.rindex("ImportError: import rocklab failed"):]
    assert f"numpy 1.19.5 cannot run a module built against numpy {built.NUMPY_VERSION}" in last
    assert f"({sys.executable}) with numpy 1.19.5" in last
    # A module built for another interpreter: the package as installed, its
    # _build_info saying Python 3.9; refused before the native module loads.
    other = tmp_path / "other" / "rocklab"
    other.mkdir(parents=True)
    package = os.path.dirname(rocklab.__file__)
    for name in os.listdir(package):
        if name != "_build_info.py" and not name.startswith("__pycache__"):
            os.symlink(os.path.join(package, name), other / name)
    (other / "_build_info.py").write_text(
        'PYTHON_VERSION = "3.9.2"\nPYTHON_EXECUTABLE = "/usr/bin/python3.9"\nNUMPY_VERSION = "1.19.5"\n')
    err = _import_rocklab_with(tmp_path, other.parent)
    last = err[err.rindex("ImportError: import rocklab failed"):]
    assert "the native module is built for Python 3.9" in last
    assert (f"built for Python 3.9.2 (/usr/bin/python3.9) with numpy 1.19.5; this is Python "
            f"{platform.python_version()} ({sys.executable}) with numpy {np.__version__}") in last


STACK_SINE = "sine:amp=0.02,freq=2,duration=10,start=0"


def test_assembly_equals_cli(cli, source_dir, tmp_path):
    """simulate(assembly=...) against `simulate --assembly`: the CSV prints
    the shortest text of each double, so the angles are equal exactly; the
    summary too (but its CPU time). A dict of the file's keys is the file."""
    toml = os.path.join(source_dir, "data", "assemblies", "statue_on_pedestal.toml")
    ours = rocklab.simulate(assembly=toml, excitation=STACK_SINE, duration=2, rate=100)
    out = tmp_path / "stack.csv"
    theirs = cli.json("simulate", "--assembly", toml, "--excitation", STACK_SINE, "--duration", 2, "--rate", 100,
                      "--out", out, "--json")
    csv = read_csv(out)
    assert ours.names == ["pedestal", "statue"]
    assert ours.theta.shape == (len(csv), 2)
    for k in (1, 2):
        np.testing.assert_array_equal(ours.theta[:, k - 1], csv[f"theta_{k}"])
        np.testing.assert_array_equal(ours.theta_dot[:, k - 1], csv[f"theta_dot_{k}"])
    assert list(ours.mode) == list(csv["mode"])
    assert ours.summary["impacts"] > 0 and ours.events["body"][0] == "statue"
    # rocklab.events: the assembly's events in the one dtype, row for row.
    same_shape = rocklab.events(ours)
    assert same_shape.dtype == rocklab.EVENTS_DTYPE and len(same_shape) == len(ours.events)
    assert list(same_shape["kind_name"]) == list(ours.events["kind_name"])
    np.testing.assert_array_equal(same_shape["time"], ours.events["time"])
    for key in ("cpu_time", "units"):
        ours.summary.pop(key)
        theirs.pop(key)
    assert ours.summary == theirs
    as_dict = {"body": [
        {"name": "pedestal", "width_m": 0.5, "height_m": 0.4, "depth_m": 0.5, "density_kg_m3": 2400.0},
        {"name": "statue", "width_m": 0.2, "height_m": 0.8, "depth_m": 0.2, "density_kg_m3": 2700},
    ]}
    same = rocklab.simulate(assembly=as_dict, excitation=STACK_SINE, duration=2, rate=100)
    np.testing.assert_array_equal(same.theta, ours.theta)
    assert "statue" in repr(same)


def test_assembly_errors_name_the_key():
    body = {"name": "a", "width_m": -0.2, "height_m": 1.0, "mass_kg": 3.0}
    with pytest.raises(ValueError, match="key 'body.width_m' must be in"):
        rocklab.simulate(assembly={"body": [body]}, duration=1, rate=10)
    with pytest.raises(ValueError, match="only housner takes a stack"):
        rocklab.simulate("complex", assembly={"body": [dict(body, width_m=0.2), dict(body, name="b", width_m=0.2)]},
                         duration=1, rate=10)
    with pytest.raises(ValueError, match="alpha with assembly"):
        rocklab.simulate(alpha=0.2, assembly={"body": [body]}, duration=1, rate=10)
