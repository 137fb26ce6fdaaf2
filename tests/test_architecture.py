"""The house rules of ``src/omegahat``, checked on the source with the standard library's ``ast``.

* no module imports another module's private name (``from omegahat.x import _y``, or ``x._y`` on an imported
  omegahat module);
* no module is longer than ``MAX_LINES`` (the guideline is about 500 lines; the limit leaves room to finish a
  change before splitting a module);
* every public pure-Python function and method is annotated: public is a name without a leading underscore, plus
  ``__init__`` and ``__call__``, in a module or a public class; every parameter but ``self``/``cls``, and the
  return (but for ``__init__``). Compiled functions (decorated with Numba's ``njit``/``jit``/``intrinsic``) are
  left out: Numba types them from their arguments, and ``mypy`` treats them as opaque (``pyproject.toml``);
* every module has a docstring.

Each checker is a plain function of a module's source, so that the tests at the end can show that it catches what
it is meant to catch.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "omegahat"
MAX_LINES = 560
COMPILED_DECORATORS = {"njit", "jit", "intrinsic"}


def _modules() -> list[tuple[str, str]]:
    """``(path relative to the package, source)`` of every module."""
    paths = sorted(PACKAGE.rglob("*.py"))
    assert len(paths) > 30, f"found only {len(paths)} modules under {PACKAGE}"
    return [(p.relative_to(PACKAGE).as_posix(), p.read_text(encoding="utf-8")) for p in paths]


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _is_omegahat_module(dotted: str) -> bool:
    parts = dotted.split(".")
    if parts[0] != "omegahat":
        return False
    p = PACKAGE.joinpath(*parts[1:])
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def _dotted(node: ast.AST) -> str | None:
    """``"a.b.c"`` for the expression ``a.b.c``, None for anything else."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        head = _dotted(node.value)
        return None if head is None else f"{head}.{node.attr}"
    return None


def private_imports(source: str) -> list[str]:
    """Private names this module takes from other omegahat modules, as ``"line: what"``."""
    tree = ast.parse(source)
    found, modules = [], {}  # modules: local name -> the omegahat module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.level > 0 or (node.module or "").split(".")[0] == "omegahat"):
            for alias in node.names:
                if _is_private(alias.name):
                    found.append(f"{node.lineno}: from {'.' * node.level}{node.module or ''} import {alias.name}")
                elif node.module and _is_omegahat_module(f"{node.module}.{alias.name}"):
                    modules[alias.asname or alias.name] = f"{node.module}.{alias.name}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "omegahat":
                    modules[alias.asname or "omegahat"] = alias.name if alias.asname else "omegahat"
    for node in ast.walk(tree):  # m._y where m is an imported omegahat module (or a dotted path to one)
        if isinstance(node, ast.Attribute) and _is_private(node.attr):
            value = _dotted(node.value)
            root = None if value is None else value.split(".")[0]
            if root in modules and _is_omegahat_module(modules[root] + value[len(root) :]):
                found.append(f"{node.lineno}: {value}.{node.attr}")
    return found


def _is_compiled(func: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    for decorator in func.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in COMPILED_DECORATORS:
            return True
    return False


def unannotated(source: str) -> list[str]:
    """Public functions and methods with a parameter or the return unannotated, as ``"line name: what"``."""
    found: list[str] = []

    def visit(node: ast.AST, owner: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef) and not child.name.startswith("_"):
                visit(child, f"{owner}{child.name}.")
            elif isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                if (child.name.startswith("_") and child.name not in ("__init__", "__call__")) or _is_compiled(child):
                    continue
                a = child.args
                params = [*a.posonlyargs, *a.args, *a.kwonlyargs, *filter(None, (a.vararg, a.kwarg))]
                if owner:  # a method: self or cls needs no annotation
                    params = [p for p in params if p.arg not in ("self", "cls")]
                missing = [p.arg for p in params if p.annotation is None]
                if child.returns is None and child.name != "__init__":
                    missing.append("return")
                if missing:
                    found.append(f"{child.lineno} {owner}{child.name}: {', '.join(missing)}")

    visit(ast.parse(source), "")
    return found


def test_no_module_imports_a_private_name_of_another():
    bad = [f"{path}:{hit}" for path, source in _modules() for hit in private_imports(source)]
    assert not bad, "private names imported across modules (make them public or move the code):\n" + "\n".join(bad)


def test_no_module_is_too_long():
    bad = [f"{path}: {n} lines" for path, source in _modules() if (n := len(source.splitlines())) > MAX_LINES]
    assert not bad, f"modules longer than {MAX_LINES} lines (split them by job):\n" + "\n".join(bad)


def test_every_public_function_is_annotated():
    bad = [f"{path}:{hit}" for path, source in _modules() for hit in unannotated(source)]
    assert not bad, "public functions without type hints:\n" + "\n".join(bad)


def test_every_module_has_a_docstring():
    bad = [path for path, source in _modules() if not ast.get_docstring(ast.parse(source))]
    assert not bad, "modules without a docstring:\n" + "\n".join(bad)


# ------------------------------------------------------------------------------------- the checkers themselves


@pytest.mark.parametrize(
    "source, expected",
    [
        ("from omegahat.so3 import _rows\n", ["1: from omegahat.so3 import _rows"]),
        ("from .engine import _call\n", ["1: from .engine import _call"]),
        ("from omegahat import measurements as ms\nms._conversion(1)\n", ["2: ms._conversion"]),
        ("import omegahat.so3\nomegahat.so3._rows\n", ["2: omegahat.so3._rows"]),
        ("import omegahat.kernels.checks as c\nc._rows_from_matrix\n", ["2: c._rows_from_matrix"]),
        ("from omegahat import __version__\nfrom omegahat.so3 import hat\nfrom numpy import _core\n", []),
        ("import numpy as np\nnp._core\n", []),
    ],
)
def test_private_imports_are_found(source, expected):
    assert private_imports(source) == expected


def test_unannotated_functions_are_found():
    source = """
import numba

def public(x, y: int): ...
def returns_nothing_said(x: int): ...
def fine(x: int, *args: int, k: float = 1.0, **kw: str) -> None: ...
def _private(x): ...
@numba.njit(cache=True)
def compiled(x): ...
class Thing:
    def __init__(self, a): ...
    def method(self, b: int) -> int: ...
    @classmethod
    def make(cls, c) -> "Thing": ...
    def __call__(self, *args) -> None: ...
    def __repr__(self): ...
class _Hidden:
    def method(self, b): ...
"""
    assert unannotated(source) == [
        "4 public: x, return",
        "5 returns_nothing_said: return",
        "11 Thing.__init__: a",
        "14 Thing.make: c",
        "15 Thing.__call__: args",
    ]
