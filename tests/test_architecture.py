"""The house rules of ``src/omegahat``, checked on the source with the standard library's ``ast``.

* no module imports another module's private name (``from omegahat.x import _y``, or ``x._y`` on an imported
  omegahat module);
* no module is longer than ``MAX_LINES`` (500: issue 22's bound; a module that grows past it is split by job);
* every public pure-Python function and method is annotated: public is a name without a leading underscore, plus
  ``__init__`` and ``__call__``, in a module or a public class; every parameter but ``self``/``cls``, and the
  return (but for ``__init__``). Compiled functions (decorated with Numba's ``njit``/``jit``/``intrinsic``) are
  left out: Numba types them from their arguments, and ``mypy`` treats them as opaque (``pyproject.toml``);
* every module has a docstring;
* imports run one way: the import graph of the package's modules (every ``import`` statement, at module level or
  inside a function) has no circle, and no module imports one of a higher layer (:data:`LAYERS`: the library's
  layers from the compiled primitives up to the command line, then the laboratory, which the library never
  imports); ``import omegahat`` loads neither the laboratory nor Matplotlib, and the default ``omegahat estimate``
  neither ``scipy.signal`` nor ``scipy.stats``.

Each checker is a plain function of a module's source, so that the tests at the end can show that it catches what
it is meant to catch.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "omegahat"
MAX_LINES = 500
COMPILED_DECORATORS = {"njit", "jit", "intrinsic"}

#: The layers, lowest first: a module may import modules of its own layer or of lower ones, never of a higher one.
#: Names are module paths below ``omegahat`` (a package stands for every module in it).
LAYERS: tuple[tuple[str, ...], ...] = (
    ("omegahat", "kernels"),  # the package's __init__: the version, and lazy names it imports only when asked
    ("validation", "interface", "so3", "conversion", "rejections"),
    ("measurements",),
    ("observer",),
    ("simulation", "baselines"),
    ("identification",),
    ("io",),
    ("cli", "calibration", "calibration_result", "clock_offset"),
    ("lab",),
)


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


def module_name(path: str) -> str:
    """``"io/pipeline.py"`` -> ``"omegahat.io.pipeline"``; a package's ``__init__`` is the package."""
    parts = ["omegahat", *path.removesuffix(".py").split("/")]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(source: str, known: set[str]) -> set[str]:
    """The omegahat modules of ``known`` that ``source`` imports anywhere (module level or in a function):
    ``from a.b import c`` is ``a.b.c`` when that is a module, else ``a.b``; ``import a.b.c`` is the longest known
    prefix."""

    def longest(name: str) -> str | None:
        while name and name not in known:
            name = name.rpartition(".")[0]
        return name or None

    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "omegahat":
            module = node.module or ""
            for alias in node.names:
                target = f"{module}.{alias.name}" if f"{module}.{alias.name}" in known else longest(module)
                if target:
                    found.add(target)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "omegahat" and (target := longest(alias.name)):
                    found.add(target)
    return found


def layer_of(module: str) -> int:
    """The index in :data:`LAYERS` of the most specific entry that ``module`` falls under."""
    best, depth = -1, -1
    for i, names in enumerate(LAYERS):
        for name in names:
            full = "omegahat" if name == "omegahat" else f"omegahat.{name}"
            matches = module == full if name == "omegahat" else module == full or module.startswith(full + ".")
            if matches and full.count(".") > depth:
                best, depth = i, full.count(".")
    if best < 0:
        raise AssertionError(f"{module} is in no layer of LAYERS: add it where it belongs")
    return best


def import_graph() -> dict[str, set[str]]:
    """Module -> the omegahat modules it imports (itself and its own package's ``__init__`` left out)."""
    sources = {module_name(path): source for path, source in _modules()}
    known = set(sources)
    return {m: imported_modules(src, known) - {m} for m, src in sources.items()}


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """Every ``a -> b`` where b's layer is above a's."""
    return sorted(f"{a} -> {b}" for a, targets in graph.items() for b in targets if layer_of(b) > layer_of(a))


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(cycles)


def test_no_import_runs_up_a_layer():
    bad = upward_imports(import_graph())
    assert not bad, "imports from a lower layer to a higher one (see LAYERS):\n" + "\n".join(bad)


def test_no_import_circle():
    cycles = import_cycles(import_graph())
    assert not cycles, "modules that import each other (directly or round a circle):\n" + "\n".join(map(str, cycles))


def test_the_estimate_loop_is_in_no_circle():
    """The one loop of ``omegahat estimate`` (io/pipeline.py) imports its pickers and settings; none imports it back
    (the one-direction path once repeated the loop and the two imported each other)."""
    graph = import_graph()
    looped = [c for c in import_cycles(graph) if "omegahat.io.pipeline" in c]
    assert not looped, looped
    users = sorted(
        m
        for m, targets in graph.items()
        if "omegahat.io.pipeline" in targets and layer_of(m) < layer_of("omegahat.lab")
    )
    assert users == ["omegahat.cli.estimate", "omegahat.io.frames"], users  # the library's two shells over the loop


def test_import_omegahat_loads_neither_the_laboratory_nor_matplotlib():
    code = (
        "import sys, omegahat; from omegahat import SarrasEstimator, read_log; "
        "print(sorted(m for m in sys.modules if m.startswith(('omegahat.lab', 'matplotlib'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]"


def test_the_default_estimate_loads_neither_scipy_signal_nor_scipy_stats(tmp_path):
    """Their import costs every command about half a second (SciPy parses their docstrings as it loads them): the
    default path, from the parser through the identification to the written file, does without them."""
    t = np.arange(0.0, 20.0, 0.01)
    q = Rotation.from_rotvec(np.outer(np.sin(t), [0.3, -0.2, 0.9])).as_quat(scalar_first=True)
    np.savetxt(tmp_path / "log.csv", np.column_stack([t, q]), delimiter=",", header="t,qw,qx,qy,qz", comments="")
    code = (
        "import sys; from omegahat.cli import main; "
        f"status = main(['estimate', {str(tmp_path / 'log.csv')!r}, '-o', {str(tmp_path / 'out.csv')!r}, "
        "'--no-progress']); "
        "print(status, sorted(m for m in sys.modules if m.split('.')[:2] in (['scipy', 'signal'], ['scipy', 'stats'])))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out.splitlines()[-1] == "0 []"
    assert (tmp_path / "out.csv").stat().st_size > 0


def test_the_lazy_public_names_are_the_librarys():
    import omegahat

    lab = sorted(name for name, module in omegahat._PUBLIC.items() if layer_of(module) == layer_of("omegahat.lab"))
    assert not lab, f"omegahat's public names must not come from the laboratory: {lab}"


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


def test_layers_and_circles_are_found():
    graph = {
        "omegahat.kernels.rotation": {"omegahat.io.pipeline"},  # up: kernels import io
        "omegahat.io.pipeline": {"omegahat.io.output", "omegahat.kernels.rotation"},
        "omegahat.io.output": {"omegahat.io.pipeline"},  # a circle of two
        "omegahat.lab.cli.paper": {"omegahat.simulation.engine"},  # down: fine
    }
    assert upward_imports(graph) == ["omegahat.kernels.rotation -> omegahat.io.pipeline"]
    assert import_cycles(graph) == [["omegahat.io.output", "omegahat.io.pipeline", "omegahat.kernels.rotation"]]
    assert layer_of("omegahat.lab.evaluation.broad") > layer_of("omegahat.cli") > layer_of("omegahat.io.csvlog")
    with pytest.raises(AssertionError, match="in no layer"):
        layer_of("omegahat.nowhere")


def test_imports_inside_functions_count():
    source = "def f():\n    from omegahat.io import pipeline\n    import omegahat.so3\n"
    known = {"omegahat.io", "omegahat.io.pipeline", "omegahat.so3", "omegahat"}
    assert imported_modules(source, known) == {"omegahat.io.pipeline", "omegahat.so3"}
