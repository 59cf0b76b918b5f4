"""The example notebook runs headless with nbconvert, on a kernel of this Python set up in a
temporary directory (nothing in the user's home is read or written)."""
import json
import os
import sys

import pytest

from conftest import SOURCE_DIR

nbformat = pytest.importorskip("nbformat", reason="needs Debian's python3-nbformat")
ExecutePreprocessor = pytest.importorskip(
    "nbconvert.preprocessors", reason="needs Debian's python3-nbconvert").ExecutePreprocessor
pytest.importorskip("ipykernel", reason="needs Debian's python3-ipykernel")


@pytest.fixture
def private_jupyter(tmp_path, monkeypatch):
    """A kernel spec for this interpreter in a temporary JUPYTER_PATH, and every Jupyter, IPython
    and Matplotlib directory in the temporary directory."""
    spec = tmp_path / "jupyter" / "kernels" / "qbond-test"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "qbond test", "language": "python"}))
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    for var, name in (("JUPYTER_DATA_DIR", "data"), ("JUPYTER_RUNTIME_DIR", "runtime"),
                      ("JUPYTER_CONFIG_DIR", "config"), ("IPYTHONDIR", "ipython"), ("MPLCONFIGDIR", "mpl")):
        (tmp_path / name).mkdir()
        monkeypatch.setenv(var, str(tmp_path / name))
    monkeypatch.setenv("JUPYTER_PLATFORM_DIRS", "1")
    return "qbond-test"


def test_rope_notebook_runs_and_plots(private_jupyter, tmp_path):
    nb = nbformat.read(os.path.join(SOURCE_DIR, "examples", "rope.ipynb"), as_version=4)
    ExecutePreprocessor(timeout=300, kernel_name=private_jupyter).preprocess(nb, {"metadata": {"path": str(tmp_path)}})
    code = [c for c in nb.cells if c.cell_type == "code"]
    text = "".join(o.get("text", "") for c in code for o in c.outputs if o.output_type == "stream")
    assert "qbond " in text and "lowest point z = -" in text
    images = [o for c in code for o in c.outputs if "image/png" in o.get("data", {})]
    assert len(images) == 1  # the plot was drawn
    assert not [o for c in code for o in c.outputs if o.output_type == "error"]
