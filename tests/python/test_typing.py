"""The type stub python/rocklab/__init__.pyi against the package and a
type checker.

Oracles: the result classes the stub declares exist (test_installed.py
checks every name of rocklab.__all__ is in the stub); the keys the
functions return on small inputs (the stub's TypedDicts list exactly the
keys block_params, simulate's summary, fit and fragility give); and
`mypy --strict` (Debian's python3-mypy) on typing_example.py, which uses
every function as a user would (no error), and on lines that misuse a
result (each one an error the stub must catch).
"""

import ast
import os
import subprocess
import sys

import numpy as np
import pytest

import rocklab

STUB = os.path.join(os.path.dirname(rocklab.__file__), "__init__.pyi")
HERE = os.path.dirname(os.path.abspath(__file__))


def stub_tree():
    with open(STUB) as f:
        return ast.parse(f.read())


def typed_dict_keys(name):
    """The keys of the stub's TypedDict `name` (class or functional form)."""
    for node in stub_tree().body:
        if isinstance(node, ast.ClassDef) and node.name == name:
            keys = {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
            for base in node.bases:
                if isinstance(base, ast.Name) and base.id != "TypedDict":
                    keys |= typed_dict_keys(base.id)
            return keys
        if isinstance(node, ast.Assign) and node.targets[0].id == name:
            return {k.value for k in node.value.args[1].keys}
    raise KeyError(name)


def test_stub_has_no_any_and_the_result_classes_exist():
    # Every name of rocklab.__all__ is in the stub: test_installed.py.
    with open(STUB) as f:
        assert "Any" not in f.read().replace("ArrayLike", "")  # every shape known is typed
    for cls in ("SimulationResult", "AssemblyResult", "LogTables", "Reconstruction", "FitResult", "PosteriorProblem",
                "PosteriorSummary"):
        assert hasattr(rocklab, cls), cls


def test_stub_keys_are_the_results_keys(tmp_path):
    block = rocklab.block_params(0.247, 1.0)
    assert set(block) == typed_dict_keys("BlockParams")
    assert set(block["plus_side"]) == typed_dict_keys("BlockSide")
    run = rocklab.simulate("housner", block, theta0=0.1, duration=4, rate=500)
    assert set(run.summary) == typed_dict_keys("SimulationSummary")
    stack = rocklab.simulate(assembly={"body": [{"name": "a", "width_m": 0.4, "height_m": 0.5, "mass_kg": 1.0},
                                                {"name": "b", "width_m": 0.2, "height_m": 0.8, "mass_kg": 1.0}]},
                             duration=0.1, rate=100)
    assert set(stack.summary) == typed_dict_keys("AssemblySummary")
    assert set(stack.summary["bodies"][0]) == typed_dict_keys("AssemblyBodySummary")
    f = rocklab.fit(run.t, run.theta, 0.247, 1.0)
    assert set(f) == typed_dict_keys("FitResult")
    assert set(f.impacts[0]) == typed_dict_keys("FitImpact")
    assert set(f.theory) == typed_dict_keys("FitTheory") and set(f.alpha_band) == typed_dict_keys("FitAlphaBand")
    assert set(rocklab.fragility([0.1, 0.2, 0.4], [0, 1, 1])) == typed_dict_keys("Fragility")
    log = tmp_path / "t.csv"
    log.write_text("time,a\n0,1\n0.001,2\n0.002,3\n")
    assert set(rocklab.info(log)) == typed_dict_keys("RawInfo")
    assert set(rocklab.info(log)["channels"][0]) == typed_dict_keys("RawChannel")
    summary = rocklab.read_raw(log).summary
    assert set(summary) == typed_dict_keys("ReadSummary") - {"format"}
    assert set(summary["tables"][0]) == typed_dict_keys("ReadTable")


MISUSES = [
    ("f = rocklab.fit([0.0], [0.0], 0.2, 1.0)\nx: int = f.alpha", "Incompatible types in assignment"),
    ("f = rocklab.fit([0.0], [0.0], 0.2, 1.0)\nf.alpah", 'has no attribute "alpah"'),
    ("r = rocklab.simulate(alpha=0.2, p=3.0, mu=0.9, duration=1.0, rate=1.0)\nr.summary['impact']",
     'TypedDict "SimulationSummary" has no key "impact"'),
    ("rocklab.block_params(0.2, 1.0)['alpha'].upper()", 'has no attribute "upper"'),
    ("s: str = rocklab.info('x')['channels'][0]['count']", "Incompatible types in assignment"),
    # simulate is overloaded (a block, or assembly=): mypy names no argument.
    ("rocklab.simulate('hausner', 0.2, 3.0, 0.9, duration=1.0, rate=1.0)", 'No overload variant of "simulate"'),
    ("ar = rocklab.simulate(assembly='a.toml', duration=1.0, rate=1.0)\nar.summary['final_regime']",
     'TypedDict "AssemblySummary" has no key "final_regime"'),
]


def mypy(tmp_path, script):
    """mypy --strict on script, or the end of the run with exit code 77
    (ctest: skipped; the tests before this one have run) where Debian's
    python3-mypy is missing, a failure under CI=true (tools/setup.sh
    installs it with the test tools)."""
    if subprocess.run([sys.executable, "-m", "mypy", "--version"], capture_output=True).returncode != 0:
        if os.environ.get("CI") == "true":
            pytest.fail("CI=true: mypy (python3-mypy) must be installed")
        pytest.exit("SKIPPED: mypy (python3-mypy) is not installed", returncode=77)
    path = tmp_path / "script.py"
    path.write_text(script)
    env = dict(os.environ, MYPYPATH=os.path.dirname(os.path.dirname(rocklab.__file__)))
    cmd = [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "--cache-dir", os.devnull,
           "--follow-imports", "silent", str(path)]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp_path)


def test_mypy_strict_accepts_the_api_and_catches_misuse(tmp_path):
    with open(os.path.join(HERE, "typing_example.py")) as f:
        example = f.read()
    bad = "\n".join(["import rocklab"] + [code for code, _ in MISUSES]) + "\n"
    r = mypy(tmp_path, example + "\n# ---- misuses\n" + bad)
    errors = [line for line in r.stdout.splitlines() if ": error:" in line]
    marker = len(example.splitlines()) + 2  # the line "# ---- misuses"
    good_errors = [e for e in errors if int(e.split(":")[1]) < marker]
    assert not good_errors, "\n".join(good_errors)
    # Each misuse is an error with the expected message on its last line.
    line = marker + 2  # after "import rocklab"
    for code, message in MISUSES:
        last = line + code.count("\n")
        hits = [e for e in errors if int(e.split(":")[1]) == last]
        assert any(message in e for e in hits), (code, hits, r.stdout)
        line = last + 1
