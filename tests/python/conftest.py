"""Fixtures of the pytest suite of `import rocklab` (run from ctest).

ctest sets ROCKLAB_CLI (the `rocklab` executable of the same build) and
ROCKLAB_SOURCE_DIR, and PYTHONPATH to the built package; each test writes
under pytest's tmp_path, below the build tree's scratch folder
(--basetemp, one per ctest test).
"""

import json
import os
import subprocess

import pytest


def _env(name):
    value = os.environ.get(name)
    if not value:
        raise RuntimeError(f"{name} is not set: run these tests through ctest (tests/python/CMakeLists.txt)")
    return value


@pytest.fixture(scope="session")
def cli_path():
    return _env("ROCKLAB_CLI")


@pytest.fixture(scope="session")
def source_dir():
    return _env("ROCKLAB_SOURCE_DIR")


class Cli:
    """Runs the command line of the same build."""

    def __init__(self, path):
        self.path = path

    def run(self, *args, expect=0):
        r = subprocess.run([self.path, *map(str, args)], capture_output=True, text=True)
        assert r.returncode == expect, f"rocklab {' '.join(map(str, args))}: exit {r.returncode}\n{r.stderr}"
        return r

    def json(self, *args):
        return json.loads(self.run(*args).stdout)

    def error(self, *args):
        """The one-line message of a usage error (exit 2), without 'rocklab: '."""
        r = self.run(*args, expect=2)
        line = r.stderr.strip().splitlines()[-1]
        assert line.startswith("rocklab: "), r.stderr
        return line[len("rocklab: "):]


@pytest.fixture(scope="session")
def cli(cli_path):
    return Cli(cli_path)
