"""The package's import rules that import-linter's contracts (pyproject.toml, run by .ci/run)
cannot state: an import inside a function of the package's own modules is there only to defer
a heavy optional dependency, and the command line starts without one."""

import ast
import subprocess
import sys
from pathlib import Path

import wolfpack

PACKAGE = Path(wolfpack.__file__).parent
#: What a deferred import may be deferring: each takes seconds to import, and the core install
#: has none of them but matplotlib.
HEAVY = ("torch", "matplotlib", "stable_baselines3", "imageio")


def deferred_imports() -> dict[str, list[str]]:
    """{module imported inside a function: [file:line, ...]} over the package's sources (the
    package's own __init__, whose lazy attributes are its public API, aside)."""
    found: dict[str, list[str]] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        if path == PACKAGE / "__init__.py":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(fn):
                if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("wolfpack"):
                    names = [f"wolfpack.{a.name}" for a in node.names] if node.module == "wolfpack" else [node.module]
                elif isinstance(node, ast.Import):
                    names = [a.name for a in node.names if a.name.startswith("wolfpack")]
                else:
                    continue
                for name in names:
                    found.setdefault(name, []).append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
    return found


def brings(modules: list[str]) -> dict[str, list[str]]:
    """{module: the heavy dependencies that importing it alone brings}, each module imported in a
    fresh interpreter (all at once)."""
    code = "import importlib, sys; importlib.import_module(sys.argv[1]); print(' '.join(h for h in {!r} if h in sys.modules))".format(HEAVY)
    runs = {m: subprocess.Popen([sys.executable, "-c", code, m], stdout=subprocess.PIPE, text=True) for m in modules}
    out = {m: run.communicate()[0].split() for m, run in runs.items()}
    assert all(run.returncode == 0 for run in runs.values()), {m: run.returncode for m, run in runs.items()}
    return out


def test_a_deferred_import_of_the_package_defers_a_heavy_dependency():
    found = deferred_imports()
    assert found, "the scan found no deferred import at all: it no longer sees them"
    heavy = brings(sorted(found))
    light = {module: where for module, where in found.items() if not heavy[module]}
    assert not light, f"imported inside a function though importing them brings none of {', '.join(HEAVY)}: import them at the top of the module: {light}"


def test_the_command_line_starts_without_a_heavy_dependency():
    assert brings(["wolfpack.cli"]) == {"wolfpack.cli": []}


def test_no_source_edits_the_import_path():
    """The scripts of training/ and benchmarks/ and the tests import the installed package (a
    script's own folder is on the path when it runs): none edits the import path."""
    root = PACKAGE.parents[1]
    spelled = "sys." + "path"  # not spelled out here, so that this file does not find itself
    found = [
        f"{path.relative_to(root)}:{n}"
        for folder in ("envs", "training", "benchmarks", "tests", "rust")
        for path in sorted((root / folder).rglob("*.py"))
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if spelled in line
    ]
    assert not found, found
