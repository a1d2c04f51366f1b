"""rocklab.reconstruct, fit, sweep and fragility against the command line.

Oracle: `rocklab reconstruct`, `fit --json`, `sweep --out` and `sweep-plot`'s
fragility.csv of the same build on the same files (the CSVs print %.9f /
%.12g, JSON and the sweep's rows round-trip, the fragility table 9
significant digits); the fragility of counts against a maximum-likelihood
fit written here with scipy (the lognormal model's log-likelihood
maximised by Nelder-Mead); fits of records synthesised here with known
parameters and seeded noise.
"""

import csv
import os

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.stats import norm

import rocklab

ALPHA, P, MU = 0.2, 3.8, 0.9


def write_csv(path, header, columns):
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        for row in zip(*columns):
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def test_reconstruct_equals_cli(cli, source_dir, tmp_path):
    rig = os.path.join(source_dir, "data/rigs/lab_rig.toml")
    for sample in ("slip.lvm", "twist.csv"):
        raw = os.path.join(source_dir, "data/samples", sample)
        out = tmp_path / f"{sample}.theta.csv"
        proc = cli.run("reconstruct", "--rig", rig, "--input", raw, "--out", out)
        r = rocklab.reconstruct(raw, rig)
        with open(out, newline="") as f:
            rows = list(csv.reader(f))
        header, rows = rows[0], rows[1:]
        assert len(r.states) == len(rows) == r.summary["reconstructed"]
        for j, name in enumerate(header):
            printed = np.array([float(x[j]) for x in rows])
            if name == "time":
                np.testing.assert_allclose(r.states[name], printed, rtol=0, atol=5e-10)  # %.9f
            elif name == "flags":
                np.testing.assert_array_equal(r.states[name], printed)
            else:
                np.testing.assert_allclose(r.states[name], printed, rtol=5e-12, atol=1e-300)  # %.12g
        assert rocklab.units(r.states)["sliding"] == "m"
        from test_typing import typed_dict_keys

        assert set(r.summary) == typed_dict_keys("ReconstructionSummary")  # the stub's keys
        text = repr(r)  # a summary, not the states (issue 36)
        assert len(text) < 2000 and text.startswith(f"Reconstruction: {len(r.states)} samples"), text
        assert "sliding [m]" in text or "... (+" in text
        # The counts line of the command.
        for key in ("bad_rows", "bad_values", "gaps", "invalid_led_samples", "flagged"):
            words = {"bad_rows": "bad rows", "bad_values": "bad values", "gaps": "gaps",
                     "invalid_led_samples": "invalid LED samples", "flagged": "flagged"}[key]
            assert f"{r.summary[key]} {words}" in proc.stderr, (key, proc.stderr)
    # The fault of each sample is seen: slip.lvm slides from 0.5 s.
    slip = rocklab.reconstruct(os.path.join(source_dir, "data/samples/slip.lvm"), rig)
    sliding = slip.events[slip.events["detail"] == "sliding above tolerance"]
    assert len(sliding) >= 1 and sliding["time"][0] == pytest.approx(0.5, abs=0.01)


def _same_text(value, printed, fmt):
    """A value against the CLI's field, to the last printed digit: fmt's
    text of it (the CLI prints by to_chars, which is printf's), NaN as
    "nan" or "-nan" (Python prints either sign as "nan")."""
    if printed in ("nan", "-nan"):
        return bool(np.isnan(value))
    return fmt % value == printed


def test_reconstruct_of_two_bodies_equals_cli(cli, source_dir, tmp_path):
    # A rig of two [[body]] tables (the statue on its pedestal): the states
    # carry the bottom body's columns, as RL_THETA does, then the CLI's
    # per-body columns theta_1 .. flags_2. Oracle: `rocklab reconstruct`'s
    # CSV of the same raw file, every field to its last printed digit
    # (%.9f time, %.12g reals, integers). The raw file: synth of the
    # statue under a short 8 Hz shake (0.6 s, both bodies rock).
    rig = os.path.join(source_dir, "data/rigs/statue_rig.toml")
    raw, out = tmp_path / "statue.csv", tmp_path / "statue.theta.csv"
    cli.run("synth", "--rig", rig, "--assembly", os.path.join(source_dir, "data/assemblies/statue_on_pedestal.toml"),
            "--excitation", "sine:amp=0.007,freq=8,duration=0.4,start=0.1", "--duration", 0.6, "--rate", 1000,
            "--out", raw, "--truth", tmp_path / "statue.truth.csv")
    cli.run("reconstruct", "--rig", rig, "--input", raw, "--out", out)
    r = rocklab.reconstruct(raw, rig)
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    header, rows = rows[0], rows[1:]
    assert header[1:4] == ["theta_1", "theta_dot_1", "theta_mirror_1"] and header[-1] == "flags_2"
    assert len(r.states) == len(rows) > 500
    for j, name in enumerate(header):
        assert name in r.states.dtype.names, name
        fmt = "%.9f" if name == "time" else "%d" if r.states.dtype[name].kind == "i" else "%.12g"
        bad = [(x[0], x[j], v) for x, v in zip(rows, r.states[name]) if not _same_text(v, x[j], fmt)]
        assert not bad, (name, bad[:3])
    units = rocklab.units(r.states)
    assert units["theta_2"] == "rad" and units["sliding_1"] == "m" and "flags_2" not in units
    # The bottom body is RL_THETA's block; the statue rocks on its own.
    for field in ("theta", "theta_camera", "sliding", "flags", "leds_used"):
        np.testing.assert_array_equal(r.states[field], r.states[field + "_1"])
    assert np.nanmax(np.abs(r.states["theta_2"] - r.states["theta_1"])) > 0.01


def test_reconstruct_errors(cli, source_dir, tmp_path):
    rig = os.path.join(source_dir, "data/rigs/lab_rig.toml")
    with pytest.raises(FileNotFoundError):
        rocklab.reconstruct(tmp_path / "missing.csv", rig)
    with pytest.raises(FileNotFoundError):
        rocklab.reconstruct(os.path.join(source_dir, "data/samples/slip.lvm"), tmp_path / "missing.toml")
    bad = tmp_path / "bad.csv"
    bad.write_text("time,x\n0,1\n")
    with pytest.raises(ValueError) as e:
        rocklab.reconstruct(bad, rig)
    assert str(e.value) == cli.error("reconstruct", "--rig", rig, "--input", bad, "--out", tmp_path / "o.csv")


@pytest.fixture(scope="module")
def free_record(tmp_path_factory):
    """Free rocking from a 0.5 s hold at 0.1 rad, 1 kHz, noise 1e-4 rad (seed 1)."""
    r = rocklab.simulate("housner", ALPHA, P, MU, theta0=0.1, duration=4, rate=1000)
    hold = np.arange(0, 0.5, 0.001)
    t = np.concatenate([hold, r.t + 0.5])
    theta = np.concatenate([np.full(hold.size, 0.1), r.theta])
    theta = theta + np.random.default_rng(1).normal(0, 1e-4, theta.size)
    path = tmp_path_factory.mktemp("fit") / "free.csv"
    write_csv(path, ["time", "theta"], [t, theta])
    return path, t, theta


@pytest.mark.parametrize("method", ["impacts", "trajectory"])
def test_fit_equals_cli_and_finds_the_parameters(cli, free_record, method):
    path, t, theta = free_record
    width, height = 2 * 0.5 * np.tan(ALPHA), 2 * 0.5  # b / h = tan(alpha)
    theirs = cli.json("fit", "--input", path, "--method", method, "--width", width, "--height", height,
                      "--json", "--quiet")
    from_file = rocklab.fit(path, width=width, height=height, method=method)
    from_arrays = rocklab.fit(t, theta, width, height, method=method)
    for key, value in theirs.items():
        if key in ("units", "runtime", "input", "provenance"):  # provenance: the CLI's alone
            continue
        assert from_file[key] == value, key
        assert from_arrays[key] == value, key
    assert from_file.input == str(path) and from_arrays.input == "<arrays>"
    # The synthesised parameters, within 5 standard errors of the fit.
    for name, truth in (("alpha", ALPHA), ("p", P), ("mu", MU)):
        assert abs(from_file[name] - truth) < 5 * from_file[f"{name}_stderr"] + 1e-12, name
    assert from_file.theory is not None
    # Its repr: the values with their standard errors, one screen (issue 36).
    text = repr(from_file)
    assert len(text.splitlines()) <= 14 and len(text) < 1500, text
    assert text.startswith(f"FitResult: {method} method, " + ("converged" if from_file.converged else "NOT"))
    assert f"{from_file.alpha:.4g} +- {from_file.alpha_stderr:.2g} rad" in text
    assert f"{from_file.p:.4g} +- {from_file.p_stderr:.2g} rad/s" in text
    assert any(line.split() == ["impacts", str(len(from_file.impacts))] for line in text.splitlines()), text
    assert from_file._repr_html_().count("<tr>") == len(text.splitlines()) - 1
    # rocklab.events: the impacts it found as IMPACT events (value NaN).
    found = rocklab.events(from_file)
    assert found.dtype == rocklab.EVENTS_DTYPE and len(found) == len(from_file.impacts)
    assert list(found["time"]) == [i["time"] for i in from_file.impacts]
    assert len(found) > 0 or method == "trajectory"  # the trajectory method lists none
    assert (found["kind_name"] == "IMPACT").all() and (found["kind_code"] == rocklab.event_t.IMPACT).all()
    assert np.isnan(found["value"]).all()


def test_fit_window_equals_cli_and_the_sliced_record(cli, free_record):
    # fit(start=, end=) as `fit --start --end`; oracle: the fit of the same
    # samples cut out here (t[0] = 0: the window is in the record's times).
    path, t, theta = free_record
    width, height = 2 * 0.5 * np.tan(ALPHA), 2 * 0.5
    theirs = cli.json("fit", "--input", path, "--width", width, "--height", height, "--start", 0.3, "--end", 3.5,
                      "--json", "--quiet")
    windowed = rocklab.fit(path, width=width, height=height, start=0.3, end=3.5)
    keep = (t >= 0.3) & (t <= 3.5)
    sliced = rocklab.fit(t[keep], theta[keep], width, height)
    whole = rocklab.fit(path, width=width, height=height)
    for key in ("alpha", "p", "mu", "alpha_stderr", "residuals", "impacts"):
        assert windowed[key] == theirs[key], key
        assert windowed[key] == sliced[key], key
    assert windowed["residuals"] < whole["residuals"]  # the impacts after 3.5 s are left out
    with pytest.raises(ValueError) as e:
        rocklab.fit(path, start=2, end=1)
    assert str(e.value) == cli.error("fit", "--input", path, "--start", 2, "--end", 1)


def test_fit_table_and_errors(cli, free_record, tmp_path):
    path, t, theta = free_record
    with pytest.raises(ValueError) as e:
        rocklab.fit(path, min_impacts=2)
    assert str(e.value) == cli.error("fit", "--input", path, "--min-impacts", 2)
    with pytest.raises(ValueError) as e:
        rocklab.fit(path, method="other")
    assert str(e.value) == cli.error("fit", "--input", path, "--method", "other")
    flat = tmp_path / "flat.csv"
    write_csv(flat, ["time", "theta"], [t, np.zeros_like(t)])
    with pytest.raises(ValueError) as e:
        rocklab.fit(flat)
    assert str(e.value) == cli.error("fit", "--input", flat)
    with pytest.raises(FileNotFoundError):
        rocklab.fit(tmp_path / "missing.csv")
    # A table record beside the arrays: the same as --accel with a CSV.
    table = tmp_path / "table.csv"
    write_csv(table, ["time", "accel"], [t, np.zeros_like(t)])
    a = rocklab.fit(t, theta, table=table)
    b = rocklab.fit(t, theta, table=(t, np.zeros_like(t)))
    c = cli.json("fit", "--input", path, "--accel", table, "--json", "--quiet")
    assert a.alpha == b.alpha == c["alpha"] and a.mu == b.mu == c["mu"]


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Two ground motions (decaying bursts at 2 and 4 Hz, 200 Hz samples)."""
    folder = tmp_path_factory.mktemp("records")
    paths = []
    for freq in (2.0, 4.0):
        t = np.arange(0, 4, 0.005)
        a = 4.0 * np.sin(2 * np.pi * freq * t) * np.exp(-t / 1.5)
        path = folder / f"burst_{freq:g}hz.csv"
        write_csv(path, ["time", "accel"], [t, a])
        paths.append(path)
    return paths


def test_sweep_equals_cli_and_fragility_equals_sweep_plot(cli, records, tmp_path):
    out = tmp_path / "sweep.csv"
    cli.run("sweep", "--records", *records, "--model", "housner", "--scale", "0.2:0.8:7", "--pga-g",
            "--alpha", 0.168, 0.2, "--p", 3.767, "--duration", 8, "--rtol", 1e-8, "--out", out, "--threads", 2)
    calls = []
    rows, text = rocklab.sweep(records, model="housner", scale="0.2:0.8:7", pga_g=True, alpha=[0.168, 0.2],
                               p=3.767, duration=8, rtol=1e-8, threads=2, csv_text=True,
                               progress=lambda done, total: calls.append((done, total)))
    # The rows of `rocklab sweep`, byte for byte; the CLI's file adds its
    # provenance lines (docs/provenance.md), the module's text has none.
    cli_text = "".join(line for line in out.read_text().splitlines(keepends=True)
                       if not line.startswith(("# rocklab provenance", "# provenance.")))
    assert "# provenance.command: " in out.read_text()
    assert text == cli_text
    assert len(rows) == 2 * 2 * 7 and rows.dtype == rocklab.SWEEP_DTYPE
    assert calls[-1] == (28.0, 28.0)
    assert 0 < rows["overturned"].sum() < len(rows)
    plot = tmp_path / "plot"
    cli.run("sweep-plot", out, "--out-dir", plot)
    with open(plot / "fragility.csv", newline="") as f:
        table = list(csv.DictReader(f))
    fits = rocklab.fragility(rows)
    assert len(fits) == len(table) == 2
    for ours, theirs in zip(fits, table):
        assert (ours["model"], ours["alpha"], ours["p"], ours["mu"]) == (
            theirs["model"], theirs["alpha"], theirs["p"], theirs["mu"])
        assert ours["status"] == theirs["status"]
        assert (ours["rows"], ours["overturned"]) == (int(theirs["rows"]), int(theirs["overturned"]))
        for key, column in (("median", "median_pga_g"), ("beta", "beta"), ("safe_below", "safe_below_g"),
                            ("overturned_above", "overturned_above_g")):
            if theirs[column] == "":
                assert ours[key] is None
            else:
                assert ours[key] == pytest.approx(float(theirs[column]), rel=5e-9)  # printed to 9 digits


def test_sweep_of_an_assembly_equals_cli(cli, records, source_dir, tmp_path):
    # sweep(assembly=) as `sweep --assembly`: the statue on its pedestal
    # (a stack of two, the stack model) under the two bursts at 0.3 and
    # 0.9 g. Oracle: the CLI's file of the same build, byte for byte but
    # its provenance lines, and every parsed field its printed text.
    statue = os.path.join(source_dir, "data/assemblies/statue_on_pedestal.toml")
    out = tmp_path / "stack.csv"
    args = ("--scale", "0.3:0.9:2", "--pga-g", "--duration", 5)
    cli.run("sweep", "--records", *records, "--model", "housner", "--assembly", statue, *args, "--out", out)
    rows, text = rocklab.sweep(records, model="housner", assembly=statue, scale="0.3:0.9:2", pga_g=True, duration=5,
                               threads=2, csv_text=True)
    cli_text = "".join(line for line in out.read_text().splitlines(keepends=True)
                       if not line.startswith(("# rocklab provenance", "# provenance.")))
    assert text == cli_text
    assert "# assembly: statue_on_pedestal.toml " in text
    assert rows.dtype.names[: len(rocklab.SWEEP_DTYPE.names)] == rocklab.SWEEP_DTYPE.names
    assert rows.dtype.names[-3:] == ("first_overturned_body", "peak_abs_theta_1", "peak_abs_theta_2")
    assert rocklab.units(rows)["peak_abs_theta_2"] == "rad" and rocklab.units(rows)["pga_g"] == "g"
    lines = [line for line in cli_text.splitlines() if not line.startswith("#")]
    assert lines[0].split(",") == list(rows.dtype.names) and len(rows) == len(lines) - 1 == 4
    for row, line in zip(rows, lines[1:]):
        for name, field in zip(rows.dtype.names, line.split(",")):
            v = row[name]
            if rows.dtype[name].kind == "f":
                assert (np.isnan(v) and field == "") or repr(float(v)) == repr(float(field)), (name, field)
            elif rows.dtype[name].kind == "b":
                assert v == (field == "1"), (name, field)
            else:
                assert str(v) == field, (name, field)
    assert set(rows["block"]) == {"statue_on_pedestal.toml"}
    # The grid spans both outcomes: the statue falls first at 0.9 g of the 2 Hz burst.
    assert set(rows["first_overturned_body"]) == {"", "statue"}
    assert np.all(rows["peak_abs_theta_2"] > 0)
    # Errors are the CLI's: a stack takes housner only; a missing file.
    with pytest.raises(ValueError) as e:
        rocklab.sweep(records, model="complex", assembly=statue)
    assert str(e.value) == cli.error("sweep", "--records", *records, "--model", "complex", "--assembly", statue,
                                     "--out", tmp_path / "x.csv")
    with pytest.raises(FileNotFoundError):
        rocklab.sweep(records, model="housner", assembly=tmp_path / "missing.toml")


def test_sweep_errors_are_the_clis(cli, records, tmp_path):
    with pytest.raises(ValueError) as e:
        rocklab.sweep(records, model="other", alpha=0.2, p=3)
    assert str(e.value) == cli.error("sweep", "--records", *records, "--model", "other", "--alpha", 0.2, "--p", 3,
                                     "--out", tmp_path / "x.csv")
    with pytest.raises(ValueError) as e:
        rocklab.sweep(records, model="housner", alpha=0.2, p=3, scale="1:2")
    assert str(e.value) == cli.error("sweep", "--records", *records, "--model", "housner", "--alpha", 0.2, "--p", 3,
                                     "--scale", "1:2", "--out", tmp_path / "x.csv")


def test_fragility_matches_a_scipy_maximum_likelihood():
    # Overlapping outcomes (a finite maximum): counts at five intensities.
    x = np.array([0.1, 0.2, 0.3, 0.4, 0.6])
    trials = np.array([10, 10, 10, 10, 10])
    overturned = np.array([0, 2, 5, 7, 10])

    def nll(v):
        median, beta = np.exp(v[0]), np.exp(v[1])
        prob = np.clip(norm.cdf(np.log(x / median) / beta), 1e-300, 1 - 1e-16)
        return -np.sum(overturned * np.log(prob) + (trials - overturned) * np.log1p(-prob))

    best = minimize(nll, [np.log(0.3), np.log(0.5)], method="Nelder-Mead",
                    options=dict(xatol=1e-10, fatol=1e-12, maxiter=5000))
    ours = rocklab.fragility(x, overturned, trials)
    assert ours["status"] == "fitted"
    # Nelder-Mead to 1e-10 in log(median), log(beta): 1e-6 relative is ample.
    assert ours["median"] == pytest.approx(np.exp(best.x[0]), rel=1e-6)
    assert ours["beta"] == pytest.approx(np.exp(best.x[1]), rel=1e-6)
    assert ours["log_likelihood"] == pytest.approx(-best.fun, rel=1e-9)
    # Separated outcomes have no finite maximum: the bracket instead.
    sep = rocklab.fragility([0.1, 0.2, 0.3, 0.4], [False, False, True, True])
    assert sep["status"] == "separated" and (sep["safe_below"], sep["overturned_above"]) == (0.2, 0.3)
    with pytest.raises(ValueError):
        rocklab.fragility([0.1, -1], [0, 1])
