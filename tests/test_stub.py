"""The type stub `_core.pyi` describes the native module as it is."""

import ast
import inspect
from pathlib import Path

import wolfpack
from wolfpack import _core

STUB = Path(wolfpack.__file__).with_name("_core.pyi")


def _stub_functions() -> dict[str, list[str]]:
    tree = ast.parse(STUB.read_text())
    return {
        node.name: [a.arg for a in node.args.args]
        for node in tree.body
        if isinstance(node, ast.FunctionDef)
    }


def test_stub_lists_exactly_the_public_functions():
    native = {n for n in dir(_core) if not n.startswith("_") and callable(getattr(_core, n))}
    assert set(_stub_functions()) == native


def test_stub_parameters_match_the_native_signatures():
    for name, params in _stub_functions().items():
        sig = inspect.signature(getattr(_core, name))
        assert list(sig.parameters) == params, name


def test_package_is_marked_typed():
    assert Path(wolfpack.__file__).with_name("py.typed").exists()
