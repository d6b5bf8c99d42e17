"""What the tests of the Python module share: where the tools and the small corridor are (CTest sets
SMSEG_BIN_DIR, SMSEG_SMALL_CORRIDOR and SMSEG_SOURCE_DIR, and PYTHONPATH to build/python)."""
import json
import os
import subprocess
from pathlib import Path

import pytest


def _env_path(name):
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"{name} is not set: run these tests through CTest (tests/CMakeLists.txt)")
    return Path(value)


@pytest.fixture(scope="session")
def bin_dir():
    return _env_path("SMSEG_BIN_DIR")


@pytest.fixture(scope="session")
def source_dir():
    return _env_path("SMSEG_SOURCE_DIR")


@pytest.fixture(scope="session")
def corridor():
    """(sequence folder, work folder) of the small corridor (tests/package/make_small_corridor.sh)."""
    root = _env_path("SMSEG_SMALL_CORRIDOR")
    return root / "data" / "corridor", root / "work" / "corridor"


@pytest.fixture(scope="session")
def run_tool(bin_dir):
    """run_tool("train-forest", args...) -> CompletedProcess (text, not checked)."""
    def run(tool, *args):
        return subprocess.run([str(bin_dir / tool), *map(str, args)], capture_output=True, text=True)
    return run


def without_timings(forest_json):
    """A forest file's content without its wall-clock fields (all else must match byte for byte)."""
    forest = json.loads(forest_json)
    forest["stats"].pop("seconds")
    for tree in forest["stats"]["trees"]:
        tree.pop("seconds")
    return forest
