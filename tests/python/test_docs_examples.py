"""The programs docs/api.md shows are the tested ones, and the examples run."""
import os
import re
import subprocess
import sys

import pytest

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


def test_drop_and_break_breaks_the_bar_in_pieces():
    out = run_example("drop_and_break.py", "--duration", "0.25")
    m = re.search(r"first bond broke at ([\d.]+) ms, (\d+) of (\d+) bonds broken, (\d+) pieces", out)
    assert m, out
    assert int(m.group(2)) > 0 and int(m.group(4)) >= 2
    # It falls 3 cm onto the post: no bond breaks in free fall, before √(2 · 0.03 m / g) = 78.2 ms.
    assert float(m.group(1)) > 78.2


def test_fit_stiffness_recovers_the_stiffness_that_made_the_sag():
    pytest.importorskip("scipy", reason="needs Debian's python3-scipy")
    out = run_example("fit_stiffness.py")
    k = float(re.search(r"fitted stiffness ([\d.]+) N/m", out).group(1))
    # The measurement was made at 1500 N/m by the same model: only brentq's tolerance separates them.
    assert abs(k / 1500 - 1) < 1e-3, out


def test_pulled_cloth_writes_its_animation(tmp_path):
    from PIL import Image
    gif = tmp_path / "cloth.gif"
    out = run_example("pulled_cloth.py", "--out", str(gif), "--frames", "12")
    assert "13 frames" in out
    with Image.open(gif) as im:
        assert im.n_frames == 13
    low = float(re.search(r"lowest point is z = (-?[\d.]+) mm", out).group(1))
    # A sheet 0.30 m tall hangs from z = 0, its bottom corners pulled 2 cm further down: they are
    # its lowest points, where their keyframes hold them.
    assert abs(low + 320) < 0.1


def test_force_field_trap_gives_its_period():
    out = run_example("force_field.py")
    err = float(re.search(r"relative error ([-+.\de]+)", out).group(1))
    # Symplectic Euler's period error for the trap is (ωh)²/24 ≈ 2e-6 at ωh = 0.0063.
    assert abs(err) < 1e-4, out
