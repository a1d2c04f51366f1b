"""The package rocklab as installed, and its LCM types.

Run by install_test.cmake with only the installed prefix's dist-packages on
PYTHONPATH, from a folder outside the build and source trees.

Oracle for the LCM types: the LCM log format (DESIGN.md, common/lcm_log.h:
big-endian sync word 0xEDA1DA01, event number, timestamp, channel and data
lengths) parsed here with struct, each payload decoded by the type lcm-gen
generated, against `rocklab export`'s CSV of the same log (%.17g).
"""

import csv
import os
import struct

import rocklab


def test_imported_from_the_installed_prefix():
    site = os.environ["ROCKLAB_INSTALLED_SITE"]
    assert os.path.realpath(rocklab.__file__).startswith(os.path.realpath(site))
    assert os.path.exists(os.path.join(os.path.dirname(rocklab.__file__), "__init__.pyi"))
    assert os.path.exists(os.path.join(os.path.dirname(rocklab.__file__), "py.typed"))
    r = rocklab.simulate("housner", 0.2, 3.8, 0.9, theta0=0.1, duration=1, rate=100)
    assert r.summary["impacts"] >= 1


def events(path):
    with open(path, "rb") as f:
        data = f.read()
    at = 0
    while at + 28 <= len(data):
        sync, number, stamp, channel_len, data_len = struct.unpack_from(">IqqII", data, at)
        assert sync == 0xEDA1DA01
        at += 28
        channel = data[at:at + channel_len].decode()
        at += channel_len
        yield channel, data[at:at + data_len]
        at += data_len


def test_lcm_types_decode_a_log_as_export_does(tmp_path):
    source = os.environ["ROCKLAB_SOURCE_DIR"]
    cli = os.environ["ROCKLAB_CLI"]
    log = tmp_path / "free.lcm"
    import subprocess

    subprocess.run([cli, "run", "--rig", os.path.join(source, "data/rigs/lab_rig.toml"), "--input",
                    os.path.join(source, "data/samples/free_rocking.csv"), "--max", "--log", str(log)],
                   check=True, capture_output=True)
    subprocess.run([cli, "export", str(log), "--out", str(tmp_path / "x.csv"), "--channels", "RL_THETA|RL_EVENT",
                    "--quiet"], check=True, capture_output=True)
    thetas = [rocklab.block_state_t.decode(d) for c, d in events(log) if c == "RL_THETA"]
    kinds = [rocklab.event2_t.decode(d) for c, d in events(log) if c == "RL_EVENT"]
    with open(tmp_path / "x_RL_THETA.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(thetas) == len(rows) > 100
    for msg, row in zip(thetas, rows):
        assert msg.utime == int(row["utime"]) and msg.seq == int(row["seq"])
        assert msg.theta == float(row["theta"]) and msg.theta_dot == float(row["theta_dot"])
    with open(tmp_path / "x_RL_EVENT.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [(m.kind, m.detail) for m in kinds] == [(int(r["kind"]), r["detail"]) for r in rows]
    # Encoding round-trips with the fingerprint LCM checks on decode.
    assert rocklab.block_state_t.decode(thetas[0].encode()).theta == thetas[0].theta


def test_stub_and_docstrings_cover_the_api():
    # Oracle: the package itself: every public name has a docstring (help())
    # and a declaration in __init__.pyi, functions with the same parameters.
    import ast
    import inspect

    stub_path = os.path.join(os.path.dirname(rocklab.__file__), "__init__.pyi")
    tree = ast.parse(open(stub_path).read())
    declared, params = set(), {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            declared.add(node.name)
            a = node.args
            params[node.name] = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
        elif isinstance(node, ast.ClassDef):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            declared.add(node.target.id)
        elif isinstance(node, ast.Assign):  # a functional TypedDict: PosteriorSummary = TypedDict(...)
            declared.update(t.id for t in node.targets if isinstance(t, ast.Name))
        elif isinstance(node, ast.ImportFrom) and node.level == 1:
            declared.update(alias.asname or alias.name for alias in node.names)
    assert set(rocklab.__all__) <= declared, set(rocklab.__all__) - declared
    for name in rocklab.__all__:
        obj = getattr(rocklab, name)
        if inspect.isfunction(obj):
            assert obj.__doc__ and len(obj.__doc__) > 80, name
            assert list(inspect.signature(obj).parameters) == params[name], name
        elif inspect.isclass(obj) and not name.endswith("_t"):
            assert obj.__doc__, name
