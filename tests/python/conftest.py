"""Shared fixtures of the Python module's tests: where the qbond program and the sources are.

ctest sets PYTHONPATH to the built package, QBOND_EXE to the program and QBOND_SOURCE_DIR."""
import json
import os
import subprocess

import pytest

SOURCE_DIR = os.environ.get("QBOND_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))


@pytest.fixture
def qbond_exe():
    exe = os.environ.get("QBOND_EXE")
    if not exe:
        pytest.fail("QBOND_EXE is not set (ctest sets it to the built qbond program)")
    return exe


@pytest.fixture
def run_cli(qbond_exe):
    """Runs the qbond program; returns the CompletedProcess."""
    def run(*args):
        return subprocess.run([qbond_exe, *args], capture_output=True, text=True)
    return run


def write_json(path, doc):
    with open(path, "w") as f:
        json.dump(doc, f)
    return str(path)
