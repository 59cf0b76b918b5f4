"""The type stub names every public member of the compiled classes, and nothing they lack."""
import ast
import os

import qbond


def stub_members():
    path = os.path.join(os.path.dirname(qbond.__file__), "_core.pyi")
    tree = ast.parse(open(path).read())
    out = {}
    for c in tree.body:
        if isinstance(c, ast.ClassDef):
            names = {f.name for f in c.body if isinstance(f, ast.FunctionDef)}
            names |= {f.target.id for f in c.body if isinstance(f, ast.AnnAssign)}
            out[c.name] = names - {"__init__"}
    return out


def test_stub_matches_the_module():
    stub = stub_members()
    for name in ("World", "Scene", "Simulation"):
        have = {n for n in dir(getattr(qbond, name)) if not n.startswith("_")}
        assert stub[name] == have, name
    for name in qbond.__all__:
        assert getattr(qbond, name) is not None
        if isinstance(getattr(qbond, name), type) or callable(getattr(qbond, name)):
            assert getattr(qbond, name).__doc__, f"{name} has no docstring"
