"""The type stub `_core.pyi` describes the native module as it is."""

import ast
import inspect
from pathlib import Path

import wolfpack
from wolfpack import _core

STUB = Path(wolfpack.__file__).with_name("_core.pyi")


def _stub_functions() -> dict[str, list[str]]:
    tree = ast.parse(STUB.read_text())
    return {node.name: [a.arg for a in node.args.args] for node in tree.body if isinstance(node, ast.FunctionDef)}


def _stub_classes() -> dict[str, dict[str, list[str]]]:
    tree = ast.parse(STUB.read_text())
    out = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            out[node.name] = {f.name: [a.arg for a in f.args.args] for f in node.body if isinstance(f, ast.FunctionDef)}
            out[node.name]["__attributes__"] = sorted(a.target.id for a in node.body if isinstance(a, ast.AnnAssign))
    return out


def test_stub_lists_exactly_the_public_functions_and_classes():
    public = [n for n in dir(_core) if not n.startswith("_")]
    native_functions = {n for n in public if callable(getattr(_core, n)) and not isinstance(getattr(_core, n), type)}
    native_classes = {n for n in public if isinstance(getattr(_core, n), type)}
    assert set(_stub_functions()) == native_functions
    assert set(_stub_classes()) == native_classes


def test_stub_classes_match_the_native_methods_and_attributes():
    for name, members in _stub_classes().items():
        cls = getattr(_core, name)
        native_methods = {m for m in dir(cls) if not m.startswith("_") and callable(getattr(cls, m))}
        native_attrs = sorted(m for m in dir(cls) if not m.startswith("_") and not callable(getattr(cls, m)))
        stub_methods = {m for m in members if not m.startswith("_")}
        assert stub_methods == native_methods, name
        assert members["__attributes__"] == native_attrs, name
        for method in stub_methods:
            sig = inspect.signature(getattr(cls, method))
            assert list(sig.parameters) == members[method], f"{name}.{method}"
        init = inspect.signature(cls)
        assert ["self", *init.parameters] == members["__init__"], f"{name}.__init__"


def test_stub_parameters_match_the_native_signatures():
    for name, params in _stub_functions().items():
        sig = inspect.signature(getattr(_core, name))
        assert list(sig.parameters) == params, name


def test_package_is_marked_typed():
    assert Path(wolfpack.__file__).with_name("py.typed").exists()
