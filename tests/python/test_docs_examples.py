"""The programs docs/api.md shows are the tested ones, and the examples run."""
import os
import re
import subprocess
import sys

from conftest import SOURCE_DIR


def code_blocks(lang):
    text = open(os.path.join(SOURCE_DIR, "docs", "api.md")).read()
    return [b.strip() for b in re.findall(rf"```{lang}\n(.*?)```", text, re.S)]


def test_api_doc_shows_the_tested_programs():
    cpp = open(os.path.join(SOURCE_DIR, "tests", "install", "consumer", "main.cpp")).read().strip()
    py = open(os.path.join(SOURCE_DIR, "examples", "quickstart.py")).read().strip()
    assert cpp in code_blocks("cpp")
    assert py in code_blocks("python")


def run_example(name, *args):
    r = subprocess.run([sys.executable, os.path.join(SOURCE_DIR, "examples", name), *args],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_quickstart_runs():
    out = run_example("quickstart.py")
    assert "lowest quanta at z = -" in out


def test_cantilever_in_wind_runs_and_sways_downwind():
    out = run_example("cantilever_in_wind.py", "--duration", "0.2")
    sway = float(re.search(r"sway (-?[\d.]+) mm", out).group(1))
    sag = float(re.search(r"tip sag (-?[\d.]+) mm", out).group(1))
    assert sway > 0 and sag > 0
