"""rocklab.read_log, read_raw and info against `rocklab export` and `rocklab info`.

Oracle: the command line of the same build on the same files: `export
--out X.csv` prints every double with %.17g (round trip: the values must be
equal exactly) and integers in full; `info --json` is compared key by key.
The log is written by `rocklab run --max --log` from the bundled free
rocking sample, and damaged here by overwriting bytes in its middle.
"""

import csv
import json
import os
import re
import struct
import warnings

import numpy as np
import pytest

import rocklab


@pytest.fixture(scope="module")
def log_path(cli, source_dir, tmp_path_factory):
    path = tmp_path_factory.mktemp("log") / "free.lcm"
    cli.run("run", "--rig", os.path.join(source_dir, "data/rigs/lab_rig.toml"), "--input",
            os.path.join(source_dir, "data/samples/free_rocking.csv"), "--max", "--log", path)
    return path


@pytest.fixture(scope="module")
def damaged_log(log_path, tmp_path_factory):
    data = bytearray(log_path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 300] = b"\xff" * 300  # a region of garbage: a bad sync word, impossible lengths
    path = tmp_path_factory.mktemp("damaged") / "damaged.lcm"
    path.write_bytes(bytes(data))
    return path


def read_export_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def assert_table_equals_csv(array, path):
    header, rows = read_export_csv(path)
    names = list(array.dtype.names)
    if names[-1:] == ["kind_code"] and "kind" in header:
        # Events: read_log adds kind_code (the code of kind) after export's columns (issue 36).
        np.testing.assert_array_equal(array["kind_code"], array["kind"])
        names = names[:-1]
    assert names == header
    assert len(array) == len(rows)
    for j, name in enumerate(header):
        column = [r[j] for r in rows]
        kind = array.dtype[name].kind
        if kind == "f":
            expected = np.array([float(x) if x != "" else np.nan for x in column])
            np.testing.assert_array_equal(array[name], expected, err_msg=name)
        elif kind == "i":
            np.testing.assert_array_equal(array[name], np.array([int(x) for x in column]), err_msg=name)
        else:
            assert list(array[name]) == column, name


@pytest.mark.parametrize(
    "kwargs,args",
    [
        (dict(), []),
        (dict(channels="RL_(THETA|EVENT|MODEL_.*)"), ["--channels", "RL_(THETA|EVENT|MODEL_.*)"]),
        (dict(start=0.25, end=0.5), ["--start", 0.25, "--end", 0.5]),
    ],
)
def test_read_log_equals_export(cli, log_path, tmp_path, kwargs, args):
    out = tmp_path / "out.csv"
    cli.run("export", log_path, "--out", out, "--quiet", *args)
    files = {f.name[len("out_"):-len(".csv")]: f for f in tmp_path.iterdir() if f.name.startswith("out_")}
    tables = rocklab.read_log(log_path, **kwargs)
    assert set(tables) == set(files)
    assert len(tables) >= 3
    for name, path in files.items():
        assert_table_equals_csv(tables[name], path)
    assert tables.summary["damaged_regions"] == 0
    assert tables.summary["rows"] == sum(len(a) for a in tables.values())


def test_read_log_units_and_types(log_path):
    tables = rocklab.read_log(log_path, "RL_THETA|RL_TABLE")
    theta = tables["RL_THETA"]
    assert theta.dtype.fields["theta"][2] == "theta [rad]"
    assert rocklab.units(theta)["time"] == "s"
    assert rocklab.units(theta)["theta_dot"] == "rad/s"
    assert tables.info["RL_THETA"]["lcm_type"] == "rocklab.block_state_t"
    assert tables.info["RL_THETA"]["channel"] == "RL_THETA"
    assert tables.info["RL_THETA"]["units"]["theta"] == "rad"
    assert rocklab.units(tables["RL_TABLE"])["acceleration"] == "m/s^2"
    # The sample clock: time = utime / 1e6 at 1 kHz (to the last bit of a double).
    np.testing.assert_allclose(theta["time"], theta["utime"] / 1e6, rtol=4.5e-16, atol=0)
    assert np.all(np.diff(theta["seq"]) == 1)


def test_tables_survive_np_save_and_pickle(log_path, tmp_path):
    # Issue 36: units once rode in the dtype's metadata, which np.save wrote
    # and np.load refused (ValueError). Titles survive both, and pickle.
    import pickle

    tables = rocklab.read_log(log_path, "RL_THETA|RL_TABLE|RL_EVENT")
    for name, a in tables.items():
        path = tmp_path / f"{name}.npy"
        np.save(path, a)
        back = np.load(path)
        assert back.dtype == a.dtype and back.tobytes() == a.tobytes(), name  # NaN rows included
        assert rocklab.units(back) == rocklab.units(a) and rocklab.units(a), name
    again = pickle.loads(pickle.dumps(tables))
    assert isinstance(again, rocklab.LogTables)
    assert again.summary == tables.summary and again.info == tables.info
    for name, a in tables.items():
        assert again[name].dtype == a.dtype and again[name].tobytes() == a.tobytes(), name
    np.savez(tmp_path / "all.npz", **tables)
    with np.load(tmp_path / "all.npz") as z:
        assert rocklab.units(z["RL_THETA"])["theta"] == "rad"


def test_info_equals_cli(cli, log_path, source_dir):
    assert rocklab.info(log_path) == cli.json("info", log_path, "--json")
    raw = os.path.join(source_dir, "data/samples/slip.lvm")
    rig = os.path.join(source_dir, "data/rigs/lab_rig.toml")
    assert rocklab.info(raw, rig) == cli.json("info", raw, "--json", "--rig", rig)


def test_damaged_log_is_read_and_counted_as_the_cli_does(cli, damaged_log, tmp_path):
    out = tmp_path / "out.csv"
    proc = cli.run("export", damaged_log, "--out", out, "--quiet", expect=1)
    assert "is damaged" in proc.stderr
    files = {f.name[len("out_"):-len(".csv")]: f for f in tmp_path.iterdir() if f.name.startswith("out_")}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tables = rocklab.read_log(damaged_log)
    info = cli.json("info", damaged_log, "--json")
    assert info["damaged_regions"] >= 1
    for key in ("damaged_regions", "damaged_bytes", "damaged_events"):
        assert tables.summary[key] == info[key], key
    assert len(tables.summary["problems"]) >= 1
    assert any(issubclass(w.category, RuntimeWarning) and "is damaged" in str(w.message) for w in caught)
    assert set(tables) == set(files)
    for name, path in files.items():
        assert_table_equals_csv(tables[name], path)


def test_read_raw_equals_export(cli, source_dir, tmp_path):
    rig = os.path.join(source_dir, "data/rigs/lab_rig.toml")
    for sample, args in (("slip.lvm", dict(rig=rig)), ("free_rocking.csv", dict(rate=1000, start=0.1, end=0.3))):
        raw = os.path.join(source_dir, "data/samples", sample)
        out = tmp_path / f"{sample}.csv"
        cli_args = ["--rig", rig] if "rig" in args else ["--rate", 1000, "--start", 0.1, "--end", 0.3]
        proc = cli.run("export", raw, "--out", out, "--quiet", *cli_args)
        tables = rocklab.read_raw(raw, **args)
        assert list(tables) == ["data"]
        assert_table_equals_csv(tables["data"], out)
        m = re.search(r"(\d+) rows written .* (\d+) outside the window, (\d+) bad rows skipped, (\d+) bad values",
                      proc.stderr)
        assert m, proc.stderr
        s = tables.summary
        assert (s["rows"], s["outside_window"], s["bad_rows"], s["bad_values"]) == tuple(map(int, m.groups()))
    units = rocklab.units(rocklab.read_raw(os.path.join(source_dir, "data/samples/slip.lvm"), rig)["data"])
    assert units["time"] == "s" and units["table_acc"] != ""


def test_bundled_raw_csvs_need_no_rate(cli, source_dir, tmp_path):
    # Issue 36: a CSV with a time column gives its own rate: no rate= (nor
    # --rate) anywhere, with or without the rig; oracle: the CLI's export and
    # info of the same files, and the 1 kHz the files were made at.
    rig = os.path.join(source_dir, "data/rigs/block1_rig.toml")
    for sample in ("fig7_block1.csv", "free_rocking.csv", "twist.csv", "free_block1.csv"):
        raw = os.path.join(source_dir, "data/samples", sample)
        for r in (None, rig):
            info = rocklab.info(raw, r)
            assert info == cli.json("info", raw, "--json", *(["--rig", r] if r else []))
            assert info["rate_hz"] == pytest.approx(1000.0, rel=1e-9)
        out = tmp_path / f"{sample}.csv"
        cli.run("export", raw, "--out", out, "--quiet")
        assert_table_equals_csv(rocklab.read_raw(raw)["data"], out)
        assert_table_equals_csv(rocklab.read_raw(raw, rig)["data"], out)
    fig7 = os.path.join(source_dir, "data/samples/fig7_block1.csv")
    # A readable file that disagrees is a ValueError in both (issue 36:
    # read_raw raised OSError, info ValueError), with the same message.
    with pytest.raises(ValueError) as e:
        rocklab.read_raw(fig7, rate=500)
    raw_message = str(e.value)
    assert "the time column gives a sample rate of 1000 Hz, but rate= is 500 Hz" in str(e.value)
    with pytest.raises(ValueError) as e:
        rocklab.info(fig7, rate=500)
    assert "the time column gives a sample rate of 1000 Hz, but rate= is 500 Hz" in str(e.value)
    assert str(e.value) == raw_message


def test_a_deeply_nested_channel_pattern_is_an_error_not_a_crash(cli, log_path, tmp_path):
    # Issue 34: 20 000 nested groups crashed the interpreter inside std::regex.
    deep = "(" * 20000 + "RL_THETA" + ")" * 20000
    with pytest.raises(ValueError) as e:
        rocklab.read_log(log_path, channels=deep)
    assert "longer than 1024 bytes" in str(e.value)
    assert str(e.value) == cli.error("export", log_path, "--out", tmp_path / "x.csv", "--channels", deep)


def test_errors_are_the_clis(cli, log_path, tmp_path, source_dir):
    with pytest.raises(ValueError) as e:
        rocklab.read_log(log_path, "(")
    assert str(e.value) == cli.error("export", log_path, "--out", tmp_path / "x.csv", "--channels", "(")
    with pytest.raises(ValueError) as e:
        rocklab.read_log(log_path, start=2, end=1)
    assert str(e.value) == cli.error("export", log_path, "--out", tmp_path / "x.csv", "--start", 2, "--end", 1)
    with pytest.raises(FileNotFoundError):
        rocklab.read_log(tmp_path / "missing.lcm")
    with pytest.raises(FileNotFoundError):
        rocklab.info(tmp_path / "missing.lcm")
    with pytest.raises(ValueError, match="not an LCM log"):
        rocklab.read_log(os.path.join(source_dir, "data/samples/free_rocking.csv"))
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(ValueError) as e:
        rocklab.read_raw(empty)
    assert str(e.value) == cli.error("export", empty, "--out", tmp_path / "y.csv")[len("INPUT: "):]


def test_read_log_progress(log_path):
    calls = []
    tables = rocklab.read_log(log_path, progress=lambda done, total: calls.append((done, total)))
    assert calls[-1] == (float(tables.summary["rows"]), None)


def test_read_raw_at2(cli, tmp_path):
    # Oracle: the PEER format by hand: NPTS values in g, sample k at k DT,
    # converted with g = 9.81 (docs/errata.md item 1's g); and `simulate --accel`
    # of the same file equal to simulate with these arrays.
    at2 = tmp_path / "rec.AT2"
    values_g = [0.01, -0.02, 0.3, 0.0, -0.005, 0.06, 0.07, -0.4, 0.25, 0.0]
    at2.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nSynthetic\nACCELERATION TIME SERIES IN UNITS OF G\n"
                   f"NPTS= {len(values_g)}, DT= .0100 SEC\n"
                   + "\n".join(" ".join(f"{v:.4E}" for v in values_g[i:i + 5]) for i in range(0, 10, 5)) + "\n")
    data = rocklab.read_raw(at2)["data"]
    np.testing.assert_allclose(data["time"], np.arange(10) * 0.01, rtol=1e-15, atol=1e-17)
    np.testing.assert_allclose(data["accel"], np.array(values_g) * 9.81, rtol=1e-15, atol=0)
    assert rocklab.units(data)["accel"] == "m/s^2"
    a = rocklab.simulate(alpha=0.05, p=5, mu=0.9, accel=at2, duration=0.2, rate=100)
    b = rocklab.simulate(alpha=0.05, p=5, mu=0.9, accel=(data["time"], data["accel"]), duration=0.2, rate=100)
    np.testing.assert_array_equal(a.theta, b.theta)
    assert a.summary["uplift_time"] is not None
    bad = tmp_path / "bad.AT2"
    bad.write_text(at2.read_text().replace("NPTS= 10", "NPTS= 12"))
    with pytest.raises(ValueError) as e:
        rocklab.read_raw(bad)
    assert str(e.value) == cli.error("simulate", "--alpha", 0.05, "--p", 5, "--mu", 0.9, "--accel", bad,
                                     "--duration", 1, "--rate", 10, "--out", tmp_path / "x.csv")[len("--accel: "):]


def test_version_is_the_clis(cli):
    # rocklab.__version__: the first line of `rocklab --version`, "rocklab X.Y.Z".
    first = cli.run("--version").stdout.splitlines()[0]
    assert first == "rocklab " + rocklab.__version__
    assert re.fullmatch(r"\d+\.\d+\.\d+", rocklab.__version__)


def test_log_tables_repr_is_a_one_screen_summary(log_path):
    # Issue 36: a LogTables repr was the arrays (66 KB in a notebook cell).
    tables = rocklab.read_log(log_path)
    text, html = repr(tables), tables._repr_html_()
    lines = text.splitlines()
    assert len(text) < 4000 and len(lines) <= 1 + len(tables), text
    assert lines[0] == f"LogTables: {len(tables)} tables, {tables.summary['rows']} rows"
    for name, a in tables.items():
        line = next(x for x in lines[1:] if x.split()[0] == name)
        assert f" {len(a)} rows" in line, line
        assert any(f"{n} [{u}]" in line for n, u in rocklab.units(a).items()), line
    assert "theta [rad]" in next(x for x in lines if x.split()[0] == "RL_THETA")
    assert html.startswith("<div>") and html.count("<tr>") == len(tables) and len(html) < 8000
    # IPython's console printer uses the same text.
    printed = []
    tables._repr_pretty_(type("P", (), {"text": lambda self, t: printed.append(t)})(), False)
    assert printed == [text]


def event_kind_codes():
    return {k: v for k, v in vars(rocklab.event_t).items() if k.isupper() and isinstance(v, int)}


def test_events_have_the_same_fields_everywhere(log_path, source_dir):
    # Issue 36: read_log's events had kind (int) and kind_name, simulate's
    # kind (str). Now every events array has EVENT_FIELDS; kind stays as it was.
    codes = event_kind_codes()
    assert codes["UPLIFT"] == 1 and codes["IMPACT"] == 2  # event_t.lcm
    logged = rocklab.read_log(log_path, "RL_EVENT")["RL_EVENT"]
    simulated = rocklab.simulate("housner", 0.235, 3.884, 0.937, theta0=0.1, duration=3, rate=100).events
    rig = os.path.join(source_dir, "data/rigs/lab_rig.toml")
    checked = rocklab.reconstruct(os.path.join(source_dir, "data/samples/slip.lvm"), rig).events
    for name, events in (("read_log", logged), ("simulate", simulated), ("reconstruct", checked)):
        assert len(events) > 0, name
        assert set(rocklab.EVENT_FIELDS) <= set(events.dtype.names), name
        assert events["kind_code"].dtype == np.int64 and events["kind_name"].dtype.kind == "U", name
        assert [codes[n] for n in events["kind_name"]] == list(events["kind_code"]), name
        assert rocklab.units(events)["time"] == "s", name
    np.testing.assert_array_equal(logged["kind"], logged["kind_code"])
    np.testing.assert_array_equal(checked["kind"], checked["kind_code"])
    assert list(simulated["kind"]) == [n.lower() for n in simulated["kind_name"]]
    assert "impact" in set(simulated["kind"])
    # The events table still pickles and saves with its titles.
    import pickle

    assert pickle.loads(pickle.dumps(logged)).dtype == logged.dtype
    # rocklab.events: one dtype from every source (EVENTS_DTYPE), so they
    # concatenate; the values are the source's own, row for row.
    same = [rocklab.events(e) for e in (logged, simulated, checked)]
    assert rocklab.events(rocklab.simulate("housner", 0.235, 3.884, 0.937, theta0=0.1, duration=3,
                                           rate=100)).dtype == rocklab.EVENTS_DTYPE
    for source, out in zip((logged, simulated, checked), same):
        assert out.dtype == rocklab.EVENTS_DTYPE and out.dtype.names == rocklab.EVENT_FIELDS
        for f in rocklab.EVENT_FIELDS:
            assert list(out[f]) == list(source[f]), f
    assert len(np.concatenate(same)) == sum(len(e) for e in same)
    # A whole log: its events tables merged in time order (this log's only
    # one is RL_EVENT); a log or raw file without events: none, same dtype.
    whole = rocklab.events(rocklab.read_log(log_path))
    assert whole.dtype == rocklab.EVENTS_DTYPE
    np.testing.assert_array_equal(whole, same[0][np.argsort(same[0]["time"], kind="stable")])
    no_events = rocklab.events(rocklab.read_log(log_path, "RL_THETA"))
    assert no_events.dtype == rocklab.EVENTS_DTYPE and len(no_events) == 0
    # An old table without kind_code (an np.save from before issue 36) gets it from kind.
    old = np.zeros(2, dtype=[("time", "f8"), ("kind", "i8"), ("value", "f8")])
    old["kind"] = [codes["UPLIFT"], codes["IMPACT"]]
    assert list(rocklab.events(old)["kind_name"]) == ["UPLIFT", "IMPACT"]
    with pytest.raises(ValueError, match="not an events array"):
        rocklab.events(np.zeros(2, dtype=[("time", "f8")]))


def write_lcm_log(path, events):
    """(utime, channel, payload) framed in LCM's log format, in the given order."""
    with open(path, "wb") as f:
        for n, (utime, channel, data) in enumerate(events):
            f.write(struct.pack(">IqqII", 0xEDA1DA01, n, utime, len(channel), len(data)))
            f.write(channel.encode())
            f.write(data)


def test_read_log_reads_the_single_block_and_the_per_body_types(tmp_path):
    # Oracle: the messages made here. A log whose RL_THETA and RL_MODEL_stack
    # change from the single-block types to the per-body ones (issue 37):
    # both are read, the per-body fields as one column per body.
    old = rocklab.block_state_t()
    old.utime, old.seq, old.theta, old.leds_used = 1000, 0, 0.01, 4
    old.flags = rocklab.block_state_t.FLAG_JUMP
    new = rocklab.block_state2_t()
    new.utime, new.seq, new.nbodies = 2000, 1, 2
    for k, name in enumerate(["theta", "theta_dot", "theta_mirror", "theta_camera", "sliding", "jump", "twist",
                              "out_of_plane"]):
        setattr(new, name, [0.1 * k + 0.02, -0.1 * k - 0.03])
    new.leds_used = [4, 3]
    new.flags = [0, rocklab.block_state2_t.FLAG_SLIDING | rocklab.block_state2_t.FLAG_TWIST]
    m3 = rocklab.model_state3_t()
    m3.utime, m3.seq, m3.name, m3.model, m3.theta, m3.equations = 1000, 0, "stack", "housner", 0.05, 0
    m4 = rocklab.model_state4_t()
    m4.utime, m4.seq, m4.name, m4.model, m4.nbodies = 2000, 1, "stack", "housner", 2
    for name in ("theta", "theta_dot", "chi", "psi", "alpha", "p", "mu"):
        setattr(m4, name, [1.5, 2.5])
    m4.regime = [rocklab.model_state4_t.REGIME_REST, rocklab.model_state4_t.REGIME_ROCKING]
    m4.energy, m4.impact_count, m4.mode = 0.25, 3, "upper-alone"
    log = tmp_path / "bodies.lcm"
    write_lcm_log(log, [(1000, "RL_THETA", old.encode()), (1000, "RL_MODEL_stack", m3.encode()),
                        (2000, "RL_THETA", new.encode()), (2000, "RL_MODEL_stack", m4.encode())])
    tables = rocklab.read_log(log)
    assert set(tables) == {"RL_THETA", "RL_THETA_block_state2_t", "RL_MODEL_stack", "RL_MODEL_stack_model_state4_t"}
    assert tables["RL_THETA"]["theta"][0] == 0.01 and tables["RL_THETA"]["flags"][0] == 2
    bodies = tables["RL_THETA_block_state2_t"]
    assert tables.info["RL_THETA_block_state2_t"]["lcm_type"] == "rocklab.block_state2_t"
    assert list(bodies.dtype.names[:6]) == ["time", "utime", "seq", "nbodies", "theta_0", "theta_1"]
    assert bodies["nbodies"][0] == 2
    assert bodies["theta_0"][0] == 0.02 and bodies["theta_1"][0] == -0.03
    assert bodies["jump_0"][0] == 0.1 * 5 + 0.02 and bodies["jump_1"][0] == -0.1 * 5 - 0.03
    assert bodies["flags_1"][0] == 1 | 4 and bodies["leds_used_0"][0] == 4
    assert rocklab.units(bodies)["theta_dot_1"] == "rad/s"
    model = tables["RL_MODEL_stack_model_state4_t"]
    assert list(model["regime_0"]) == [0] and list(model["regime_1"]) == [1]
    assert model["p_1"][0] == 2.5 and model["energy"][0] == 0.25 and model["mode"][0] == "upper-alone"
    assert tables["RL_MODEL_stack"]["theta"][0] == 0.05
    info = rocklab.info(log)
    types = {c["name"]: c["type"] for c in info["channels"]}
    assert "block_state2_t" in types["RL_THETA"] and "block_state_t" in types["RL_THETA"]
    assert "model_state4_t" in types["RL_MODEL_stack"]


def test_read_log_reads_an_assemblys_comparison(tmp_path):
    # Oracle: the message made here. RL_COMPAREBODIES_<name> (comparison3_t,
    # docs/compare.md): the per-body figures one column per body, the modes
    # as text, the agreement and its units; `info` names the type.
    c = rocklab.comparison3_t()
    c.utime, c.seq, c.name, c.nbodies, c.window_s, c.samples = 5000, 4, "statue", 2, 2.0, 600
    for name in ("error", "rms_window", "rms_total", "nrms", "peak_error", "impact_timing_error", "correlation"):
        setattr(c, name, [1e-3, 2e-3])
    c.valid = [True, False]
    c.mode_model, c.mode_measured = "RC", "RR"
    c.mode_rest_rad, c.mode_agreement, c.mode_samples = 2e-3, 0.6, 600
    log = tmp_path / "compare_bodies.lcm"
    write_lcm_log(log, [(5000, "RL_COMPAREBODIES_statue", c.encode())])
    table = rocklab.read_log(log)["RL_COMPAREBODIES_statue"]
    assert list(table.dtype.names[:7]) == ["time", "utime", "seq", "name", "nbodies", "error_0", "error_1"]
    assert table["rms_total_1"][0] == 2e-3 and table["valid_0"][0] == 1 and table["valid_1"][0] == 0
    assert table["mode_model"][0] == "RC" and table["mode_measured"][0] == "RR"
    assert table["mode_agreement"][0] == 0.6 and table["mode_samples"][0] == 600
    units = rocklab.units(table)
    assert units["rms_total_0"] == "rad" and units["mode_agreement"] == "1" and units["mode_rest_rad"] == "rad"
    info = rocklab.info(log)
    types = {c["name"]: c["type"] for c in info["channels"]}
    assert "comparison3_t" in types["RL_COMPAREBODIES_statue"]


def comparison3(utime, seq, name, rms, agreement):
    """A comparison3_t of len(rms) bodies whose figures are body k's rms[k] scaled (error rms, nrms 10 rms, ...)."""
    c = rocklab.comparison3_t()
    c.utime, c.seq, c.name, c.nbodies, c.window_s, c.samples = utime, seq, name, len(rms), 2.0, 100 + seq
    c.error = [-r for r in rms]
    c.rms_window = [0.5 * r for r in rms]
    c.rms_total = list(rms)
    c.nrms = [10 * r for r in rms]
    c.peak_error = [2 * r for r in rms]
    c.impact_timing_error = [3 * r for r in rms]
    c.correlation = [1 - r for r in rms]
    c.valid = [k != 1 for k in range(len(rms))]
    c.mode_model, c.mode_measured = "RC", "RR"
    c.mode_rest_rad, c.mode_agreement, c.mode_samples = 2e-3, agreement, 90 + seq
    return c


def test_comparisons_by_variant_and_body(tmp_path):
    # Oracle: the messages made here. A single block "block" (comparison2_t
    # on RL_COMPARE_block) and a three-body assembly "drums" (its body 0 on
    # RL_COMPARE_drums, every body on RL_COMPAREBODIES_drums, two messages):
    # (variant, None) is the RL_COMPARE table's rows as read_log gives them;
    # (variant, k) body k's column of every per-body field under
    # comparison2_t's names, the modes beside, the units kept.
    single = rocklab.comparison2_t()
    single.utime, single.seq, single.name, single.rms_total, single.nrms, single.valid = 1000, 0, "block", 1e-3, 0.1, True
    bottom = rocklab.comparison2_t()
    bottom.utime, bottom.seq, bottom.name, bottom.rms_total, bottom.valid = 1000, 0, "drums", 4e-3, True
    first = comparison3(1000, 0, "drums", [4e-3, 5e-3, 6e-3], 0.5)
    second = comparison3(2000, 1, "drums", [7e-3, 8e-3, 9e-3], 0.75)
    log = tmp_path / "compared.lcm"
    write_lcm_log(log, [(1000, "RL_COMPARE_block", single.encode()), (1000, "RL_COMPARE_drums", bottom.encode()),
                        (1000, "RL_COMPAREBODIES_drums", first.encode()),
                        (2000, "RL_COMPAREBODIES_drums", second.encode())])
    tables = rocklab.read_log(log)
    assert tables.compared() == [("block", None), ("drums", None), ("drums", 0), ("drums", 1), ("drums", 2)]

    # A single block's comparison: the table read_log gives, unchanged.
    np.testing.assert_array_equal(tables.comparison("block"), tables["RL_COMPARE_block"])
    assert tables.comparison("block").dtype == tables["RL_COMPARE_block"].dtype
    assert tables.comparison("drums")["rms_total"].tolist() == [4e-3]

    comparison2_names = [n for n in tables["RL_COMPARE_block"].dtype.names]
    for k in range(3):
        body = tables.comparison("drums", k)
        assert list(body.dtype.names) == comparison2_names + ["mode_model", "mode_measured", "mode_rest_rad",
                                                               "mode_agreement", "mode_samples"]
        assert body["time"].tolist() == [1e-3, 2e-3] and body["seq"].tolist() == [0, 1]
        rms = np.array([[4e-3, 5e-3, 6e-3], [7e-3, 8e-3, 9e-3]])[:, k]
        assert body["rms_total"].tolist() == rms.tolist()
        assert body["error"].tolist() == (-rms).tolist()
        assert body["rms_window"].tolist() == (0.5 * rms).tolist()
        assert body["nrms"].tolist() == (10 * rms).tolist()
        assert body["peak_error"].tolist() == (2 * rms).tolist()
        assert body["impact_timing_error"].tolist() == (3 * rms).tolist()
        assert body["correlation"].tolist() == (1 - rms).tolist()
        assert body["valid"].tolist() == [int(k != 1)] * 2
        assert body["window_s"].tolist() == [2.0, 2.0] and body["samples"].tolist() == [100, 101]
        assert body["mode_agreement"].tolist() == [0.5, 0.75] and body["mode_samples"].tolist() == [90, 91]
        assert body["mode_model"].tolist() == ["RC", "RC"] and body["mode_measured"].tolist() == ["RR", "RR"]
        assert rocklab.units(body) == {**rocklab.units(tables["RL_COMPARE_block"]), "mode_rest_rad": "rad",
                                       "mode_agreement": "1"}

    with pytest.raises(IndexError, match=r"bodies 0\.\.2"):
        tables.comparison("drums", 3)
    with pytest.raises(IndexError, match=r"bodies 0\.\.2"):
        tables.comparison("drums", -1)
    with pytest.raises(KeyError, match="not an assembly variant"):
        tables.comparison("block", 0)
    with pytest.raises(KeyError, match="'nothing'"):
        tables.comparison("nothing")
    with pytest.raises(TypeError, match="body must be an int"):
        tables.comparison("drums", "1")


def test_an_assembly_runs_comparisons_by_variant_and_body(cli, source_dir, tmp_path):
    # Oracle: `rocklab run`'s --summary JSON of the same run (compare's
    # figures per body and its mode agreement, written from the metrics its
    # final RL_COMPAREBODIES carries): the statue on its pedestal shaken
    # (synth's record, docs/compare.md), compared as the assembly variant
    # "stack" and as a single block "block" (the pedestal's alpha and p,
    # rocklab params: 0.5 m by 0.4 m).
    rig = os.path.join(source_dir, "data/rigs/statue_rig.toml")
    assembly = os.path.join(source_dir, "data/assemblies/statue_on_pedestal.toml")
    raw, log, summary_path = tmp_path / "raw.csv", tmp_path / "run.lcm", tmp_path / "summary.json"
    cli.run("synth", "--rig", rig, "--assembly", assembly, "--excitation",
            "sine:amp=0.007,freq=8,duration=1,start=0.2", "--duration", "2.5", "--rate", "1000", "--seed", "3",
            "--out", raw, "--truth", tmp_path / "truth.csv")
    cli.run("run", "--rig", rig, "--input", raw, "--max", "--log", log, "--summary", summary_path,
            "--variant", f"stack:housner:{assembly}", "--variant", "block:housner:alpha=0.896,p=4.79,mu=0.9")
    summary = {v["name"]: v for v in json.loads(summary_path.read_text())["variants"]}
    tables = rocklab.read_log(log)
    assert set(tables.compared()) == {("stack", None), ("stack", 0), ("stack", 1), ("block", None)}
    for name in ("stack", "block"):
        last = tables.comparison(name)[-1]
        assert last["samples"] == summary[name]["samples"]
        assert last["rms_total"] == summary[name]["rms"] and last["nrms"] == summary[name]["nrms"]
    stack = summary["stack"]
    assert [b["body"] for b in stack["bodies"]] == [0, 1] and [b["number"] for b in stack["bodies"]] == [1, 2]
    for b in stack["bodies"]:
        last = tables.comparison("stack", b["body"])[-1]
        assert last["samples"] == b["samples"]
        for mine, theirs in (("rms_total", "rms"), ("nrms", "nrms"), ("correlation", "correlation")):
            assert last[mine] == b[theirs], (b["body"], mine)
        assert last["mode_agreement"] == stack["mode_agreement"] and last["mode_samples"] == stack["mode_samples"]
    # The bodies differ, so a body read from another's column would show.
    assert stack["bodies"][0]["rms"] != stack["bodies"][1]["rms"]
