"""One version, reported alike by the module, the library and the program."""
import os
import re

import qbond
from conftest import SOURCE_DIR


def test_module_library_and_program_report_the_project_version(run_cli):
    text = open(os.path.join(SOURCE_DIR, "CMakeLists.txt")).read()
    project = re.search(r"project\(qbond VERSION (\d+\.\d+\.\d+)", text).group(1)
    assert qbond.__version__ == project
    assert qbond.version() == project
    r = run_cli("--version")
    assert r.returncode == 0
    assert r.stdout.strip() == f"qbond {project}"
