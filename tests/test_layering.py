"""The package's imports point down a fixed stack of layers.

Every module of ``sparseedm/`` is parsed with :mod:`ast` (nothing is imported)
and each of its imports of another sparseedm module, at module level or inside
a function, is checked:

- it never points to a higher layer of :data:`LAYERS`;
- the import graph has no cycle;
- no private name (``_x``) is imported from another module;
- the optional dependencies (torch, matplotlib, dask) are imported only inside
  functions, so the core imports without them.

It also keeps functions short: none over :data:`MAX_FUNCTION_LINES` lines but
the few listed in :data:`LONG_FUNCTIONS`.

Importing ``a.b.c`` from outside package ``a.b`` also runs ``a/b/__init__.py``:
that implied import is checked too. A new module belongs to the layer of the
longest :data:`LAYERS` prefix that names it; a module no prefix names fails
with a message saying where to add it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "sparseedm"

#: bottom to top; a module may import its own layer (without a cycle) or lower ones.
#: Entries are dotted prefixes: "sparseedm.mocap" covers the mocap package.
LAYERS = [
    # 0 foundations: nothing of the package below them
    ("sparseedm._version", "sparseedm.exceptions"),
    # 1 plumbing: files in and out, argument checks, shipped files, the skeleton
    ("sparseedm._atomic", "sparseedm._safeio", "sparseedm._validation", "sparseedm._shipped",
     "sparseedm._progress", "sparseedm._extras", "sparseedm._deprecated", "sparseedm.skeleton"),
    # 2 geometry, protocol and metrics, drawing (pure functions)
    ("sparseedm.edm", "sparseedm.normalize", "sparseedm.metrics", "sparseedm.placement",
     "sparseedm.cameras", "sparseedm.plotting", "sparseedm.lifting.metrics",
     "sparseedm.lifting.mds", "sparseedm.lifting.plotting", "sparseedm.lifting.defaults",
     "sparseedm.lifting.trc", "sparseedm.lifting.uncertainty3d", "sparseedm.real_protocol"),
    # 3 file formats and the lasso solvers
    ("sparseedm.dictionary", "sparseedm.keypoints", "sparseedm.formats", "sparseedm.mocap",
     "sparseedm.dataset",
     "sparseedm.solvers", "sparseedm.fconv.network", "sparseedm.fconv.model"),
    # 4 coding: parallel plumbing, dictionary learning, the baselines
    ("sparseedm._parallel", "sparseedm._coding", "sparseedm.learning", "sparseedm.baselines",
     "sparseedm.gaussian_fill"),
    # 5 what every recovery path shares: statuses, result, screening, placement, combine
    ("sparseedm._recovery_base", "sparseedm.uncertainty"),
    # 6 the sparse recovery kernel
    ("sparseedm._recovery_kernel",),
    # 7 methods on top of the kernel: adaptation, FConv, the lifters, the outlier check
    ("sparseedm.adaptation", "sparseedm.file_atoms", "sparseedm.exemplars", "sparseedm.donors",
     "sparseedm.cold_bank",
     "sparseedm.outliers", "sparseedm.fconv", "sparseedm.lifting.base",
     "sparseedm.lifting.dictionary", "sparseedm.lifting.mlp", "sparseedm.lifting.fconv",
     "sparseedm.lifting.adaptation"),
    # 8 ensembles of adapted dictionaries; recovery over tracks and frames
    ("sparseedm.ensemble", "sparseedm.temporal"),
    # 9 the dispatchers: recover(), lift() (and the video lifting it runs)
    ("sparseedm.recovery", "sparseedm.lifting.lift", "sparseedm.lifting.video"),
    # 10 workflows: evaluation, file-to-file recovery and lifting; the video
    # evaluation and the gap fillers temporal recovery is compared with (one of
    # them runs recover()); the lifting package, which exports lift_file
    ("sparseedm.evaluation", "sparseedm.evaluation_real", "sparseedm.batch", "sparseedm.lifting.io",
     "sparseedm.lifting.evaluation", "sparseedm.lifting", "sparseedm.temporal.fillers",
     "sparseedm.temporal.evaluation", "sparseedm.temporal.sequences",
     "sparseedm.temporal.protocols"),
    # 11 the command line and the package root
    ("sparseedm.cli", "sparseedm.__main__", "sparseedm"),
]

#: imported only inside functions (extras)
OPTIONAL = ("torch", "matplotlib", "dask", "distributed")

#: (importer, imported): known exceptions, each with its reason
ALLOWED = {
    # sparseedm.mocap.MAX_FILE_BYTES is a documented setting users change on the
    # package; the reader looks it up there at call time
    ("sparseedm.mocap._text", "sparseedm.mocap"),
    # the temporal package (layer 8, imported by recover()) exports the video
    # evaluation (layer 10) too: its __getattr__ imports those modules on first
    # use of one of their names, never when sparseedm.temporal.recover is imported
    *(("sparseedm.temporal", f"sparseedm.temporal.{m}")
      for m in ("fillers", "protocols", "sequences", "evaluation")),
}


def _module_name(path):
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules():
    return {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


MODULES = _modules()


def layer_of(module):
    """The layer of the longest prefix naming `module`; the root names only itself."""
    best = None
    for level, prefixes in enumerate(LAYERS):
        for p in prefixes:
            if module == p or (p != "sparseedm" and module.startswith(p + ".")):
                if best is None or len(p) > len(best[1]):
                    best = (level, p)
    return None if best is None else best[0]


def _imports(module, path, source=None):
    """(target module, imported names, line, inside a function) of each import;
    `source` stands for the file's text when given."""
    tree = ast.parse(path.read_text() if source is None else source, str(path))
    in_function = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            in_function.update(id(n) for n in ast.walk(node) if n is not node)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        local = id(node) in in_function
        if isinstance(node, ast.Import):
            for alias in node.names:
                out.append((alias.name, [], node.lineno, local))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            names = [a.name for a in node.names]
            subs = [n for n in names if f"{target}.{n}" in MODULES]
            if subs:  # ``from . import rigs``: an import of the submodule
                out.extend((f"{target}.{n}", [], node.lineno, local) for n in subs)
                names = [n for n in names if n not in subs]
                if not names:
                    continue
            out.append((target, names, node.lineno, local))
    return out


def _edges():
    """(importer, imported, line, names, in function), with the implied package imports."""
    edges = []
    for module, path in MODULES.items():
        for target, names, line, local in _imports(module, path):
            if target.split(".")[0] != "sparseedm":
                continue
            edges.append((module, target, line, names, local))
            parts = target.split(".")
            for k in range(2, len(parts)):  # a.b/__init__ runs before a.b.c
                pkg = ".".join(parts[:k])
                if pkg in MODULES and not (module == pkg or module.startswith(pkg + ".")):
                    edges.append((module, pkg, line, [], local))
    return edges


EDGES = _edges()


def test_every_module_has_a_layer():
    missing = [m for m in MODULES if layer_of(m) is None]
    assert not missing, (f"modules in no layer: {missing}; add them to LAYERS in "
                         "tests/test_layering.py (and DEVELOPERS.md's module map)")


def test_imports_point_down():
    up = [f"{a} (layer {layer_of(a)}) imports {b} (layer {layer_of(b)}) at line {line}"
          for a, b, line, _, _ in EDGES
          if (a, b) not in ALLOWED and None not in (layer_of(a), layer_of(b))
          and layer_of(b) > layer_of(a)]
    assert not up, "imports pointing up a layer:\n" + "\n".join(up)


def test_no_import_cycles():
    graph = {}
    for a, b, _, _, _ in EDGES:
        if a != b and (a, b) not in ALLOWED:
            graph.setdefault(a, set()).add(b)
    cycles, state = [], {}

    def visit(node, stack):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                cycles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_no_private_names_across_modules():
    private = [f"{a} imports {n} from {b} (line {line})"
               for a, b, line, names, _ in EDGES if b != a
               for n in names if n.startswith("_") and not n.startswith("__")]
    assert not private, "private names imported from another module:\n" + "\n".join(private)


def test_optional_dependencies_only_inside_functions():
    top = [f"{m} imports {t} at module level (line {line})"
           for m, path in MODULES.items()
           for t, _, line, local in _imports(m, path)
           if t.split(".")[0] in OPTIONAL and not local]
    assert not top, "\n".join(top)


@pytest.mark.parametrize("source, private, up", [
    ("from ..recovery import _screen\n", ["_screen"], ["sparseedm.recovery"]),
    ("def f():\n    from .._recovery_base import screen as _screen\n"
     "    from ..batch import recover_file\n", [], ["sparseedm.batch"]),
])
def test_the_checks_see_a_planted_violation(source, private, up):
    """A private import, and an upward one inside a function, planted in a layer-7
    module (read as text, never written into the package) are both caught."""
    module = "sparseedm.lifting.base"
    found = _imports(module, PACKAGE / "lifting" / "base.py", source)
    assert [n for _, names, _, _ in found for n in names if n.startswith("_")] == private
    assert [t for t, _, _, _ in found if layer_of(t) > layer_of(module)] == up


#: the longest a function's body may be (lines after its docstring)
MAX_FUNCTION_LINES = 80

#: "path:function" allowed past it, each with its reason
LONG_FUNCTIONS = {
    # numba kernels kept bit-identical to the speed-regression fixtures
    "solvers/fast.py:_lars_core": "numba LARS kernel",
    "solvers/fast.py:_lars_masked_numpy": "LARS kernel's numpy twin, kept line for line",
}


def _long_functions(source, name="<planted>"):
    """(function name, body lines) of each function whose body, after its
    docstring, is longer than MAX_FUNCTION_LINES."""
    out = []
    for node in ast.walk(ast.parse(source, name)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            first = body[0]
            doc = (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
                   and isinstance(first.value.value, str) and len(body) > 1)
            start = body[1].lineno if doc else first.lineno
            lines = node.end_lineno - start + 1
            if lines > MAX_FUNCTION_LINES:
                out.append((node.name, lines))
    return out


def test_functions_are_short():
    long = [f"{key} has {lines} lines"
            for path in sorted(PACKAGE.rglob("*.py"))
            for name, lines in _long_functions(path.read_text(), str(path))
            for key in [f"{path.relative_to(PACKAGE).as_posix()}:{name}"]
            if key not in LONG_FUNCTIONS]
    assert not long, (f"functions over {MAX_FUNCTION_LINES} lines (split them into short "
                      "functions with one job):\n" + "\n".join(long))


def test_the_length_check_sees_a_planted_long_function():
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES + 1))
    source = f'def short():\n    """Doc."""\n    return 1\n\n\ndef long():\n    """Doc."""\n{body}'
    assert _long_functions(source) == [("long", MAX_FUNCTION_LINES + 1)]
