"""The Python API reference (docs/python-api.md) is what the docstrings say, and the stubs name every
public function and Camera member."""

import ast
import importlib.util

import obscura
from conftest import ROOT

SCRIPTS = ROOT / "crates" / "obscura-python" / "scripts"


def test_api_reference_is_up_to_date():
    spec = importlib.util.spec_from_file_location("api_docs", SCRIPTS / "api_docs.py")
    api_docs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(api_docs)
    committed = (ROOT / "docs" / "python-api.md").read_text()
    assert api_docs.render() == committed, (
        "docs/python-api.md is out of date: run python3 crates/obscura-python/scripts/api_docs.py"
    )


def test_stubs_cover_the_module():
    stub = ast.parse((ROOT / "crates/obscura-python/python/obscura/_obscura.pyi").read_text())
    functions = {n.name for n in stub.body if isinstance(n, ast.FunctionDef)}
    camera = next(n for n in stub.body if isinstance(n, ast.ClassDef) and n.name == "Camera")
    members = {n.name for n in camera.body if isinstance(n, ast.FunctionDef)}
    public = {n for n in obscura.__all__ if not n.startswith("_") and n != "Camera"}
    assert public <= functions, public - functions
    native = {n for n in vars(obscura.Camera) if not n.startswith("_")}
    assert native <= members, native - members
    for name in native:
        assert getattr(obscura.Camera, name).__doc__, f"Camera.{name} has no docstring"
