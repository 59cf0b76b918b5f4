#!/usr/bin/env bash
# `pip install --no-build-isolation .` offline into a venv made with --system-site-packages (the
# README's way), then the module imported from it reports the project's version and steps.
#   pip_install_test.sh SOURCE_DIR WORK_DIR
set -euo pipefail
source=$1 work=$2
rm -rf "$work"
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
QBOND_PIP_BUILD_DIR=$work/build "$work/venv/bin/pip" install --no-build-isolation --no-index "$source" >"$work/pip.log" 2>&1 ||
  { tail -40 "$work/pip.log" >&2; exit 1; }
cd "$work"  # not the source tree: the installed package, not python/qbond, is imported
"$work/venv/bin/python" - "$source" <<'PY'
import re, sys
import qbond
project = re.search(r"project\(qbond VERSION (\d+\.\d+\.\d+)", open(sys.argv[1] + "/CMakeLists.txt").read()).group(1)
assert qbond.__version__ == project, (qbond.__version__, project)
assert "/venv/" in qbond.__file__, qbond.__file__
sim = qbond.Simulation(qbond.World(), 1e-3)
sim.step(2)
print("installed", qbond.__version__, "at", qbond.__file__)
PY
