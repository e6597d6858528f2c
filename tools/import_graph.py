#!/usr/bin/env python3
"""The import graph of fepre: fails on an import cycle or an import from a higher layer.

Every module of the package is parsed (never imported) and every ``import`` and
``from ... import`` is collected, those inside functions too: a lazy import still ties the two
modules together. An edge goes to the module named; ``from pkg import name`` goes to the
submodule ``pkg.name`` if there is one and to the package's ``__init__`` otherwise. Importing a
module also runs the ``__init__`` of every package on its way that the importer is not already
inside (``from fepre.chunked.sampling import x`` in ``fepre.sampling`` runs
``fepre/chunked/__init__.py``), so those packages are edges as well, and a package's own
imports are the edges of its ``__init__``. Imports under ``if TYPE_CHECKING:`` never run: they
are left out of the cycles but still must look down the layers.

Checks:

- cycles: the strongly connected components of more than one module, each with its edges
  (file:line);
- layers: every module has a layer (``LAYERS``, the longest matching prefix wins) and imports
  only from its own layer or below.

Usage (from the repository's root)::

    python tools/import_graph.py            # the checks; exit status 1 on a cycle or violation
    python tools/import_graph.py --graph    # also every module's layer and imports
    python tools/import_graph.py --layers   # also the modules of each layer

Standard library only.
"""

from __future__ import annotations

import argparse
import ast
import sys
from dataclasses import dataclass, field
from pathlib import Path

# The layers, bottom first: a module imports from its own layer or the ones before it, never the
# ones after it (docs/design.md, Layout). Keys are module names or package prefixes.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("base", ("fepre.errors", "fepre.config", "fepre.child_runs", "fepre.kernel_threads", "fepre.arguments", "fepre.progress", "fepre.backends", "fepre.materials", "fepre._version", "fepre.vtk_messages", "fepre.callable_package",
              "fepre.constraint_keywords", "fepre.placement", "fepre.triangle_crossings")),
    ("model", ("fepre.sdf",)),
    ("grid", ("fepre.sampling", "fepre.surface")),
    ("chunked", ("fepre.chunked",)),  # grids beyond memory, cut from sampling's and surface's
    ("features", ("fepre.features",)),
    ("sizing", ("fepre.sizing",)),
    ("mesh", ("fepre._cell_kernels", "fepre.quality", "fepre.distmesh")),
    ("constraints", ("fepre.regions", "fepre.periodic")),  # the mesher's constraints: they import it, never the reverse
    ("export", ("fepre.export",)),
    (
        "application",
        (
            "fepre",  # the package's façade (fepre/__init__.py): re-exports everything below
            "fepre.__main__",
            "fepre.accessors",
            "fepre.mesh_metrics",
            "fepre.references",
            "fepre.compare",
            "fepre.comparison_table",
            "fepre.homogenization",
            "fepre.report",
            "fepre.plotting",
            "fepre.parts",
            "fepre.cad_parts",
            "fepre.modelfile",
            "fepre.cli",
            "fepre.demo",
            "fepre.bench",
            "fepre.corpus",
        ),
    ),
)


@dataclass(frozen=True)
class Edge:
    """One import: ``source`` imports ``target`` at ``path:line``."""

    source: str
    target: str
    path: str
    line: int
    lazy: bool  # inside a function
    type_only: bool  # under ``if TYPE_CHECKING:``
    via_package: bool = False  # a package ``__init__`` run on the way to the named module

    def where(self) -> str:
        notes = [n for n, on in (("in function", self.lazy), ("TYPE_CHECKING", self.type_only), ("package init", self.via_package)) if on]
        return f"{self.path}:{self.line}" + (f" ({', '.join(notes)})" if notes else "")


@dataclass
class Graph:
    """Modules (name -> file) and the imports between them."""

    root: Path
    modules: dict[str, Path]
    packages: set[str]
    edges: list[Edge] = field(default_factory=list)

    def successors(self, include_type_only: bool = False) -> dict[str, set[str]]:
        out: dict[str, set[str]] = {m: set() for m in self.modules}
        for e in self.edges:
            if include_type_only or not e.type_only:
                out[e.source].add(e.target)
        return out


# --- building the graph -------------------------------------------------------------------------


def discover(package_dir: Path) -> tuple[dict[str, Path], set[str]]:
    """Every module under ``package_dir`` by dotted name, and which of them are packages."""
    package_dir = package_dir.resolve()
    base = package_dir.parent
    modules: dict[str, Path] = {}
    packages: set[str] = set()
    for path in sorted(package_dir.rglob("*.py")):
        parts = list(path.relative_to(base).with_suffix("").parts)
        if any(not p.isidentifier() for p in parts[:-1]):
            continue
        if parts[-1] == "__init__":
            parts.pop()
            packages.add(".".join(parts))
        modules[".".join(parts)] = path
    return modules, packages


def _ancestors(name: str) -> list[str]:
    parts = name.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _import_nodes(tree: ast.Module):
    """(node, inside a function, under TYPE_CHECKING) for every import statement of a module."""

    def visit(node: ast.AST, lazy: bool, type_only: bool):
        for child in ast.iter_child_nodes(node):
            child_lazy = lazy or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child, lazy, type_only
            elif isinstance(child, ast.Call) and _literal_import_module(child) is not None:
                yield child, lazy, type_only
            if isinstance(child, ast.If) and _is_type_checking(child.test):
                for stmt in child.body:
                    yield from visit(ast.Module(body=[stmt], type_ignores=[]), child_lazy, True)
                for stmt in child.orelse:
                    yield from visit(ast.Module(body=[stmt], type_ignores=[]), child_lazy, type_only)
            else:
                yield from visit(child, child_lazy, type_only)

    yield from visit(tree, False, False)


def _literal_import_module(call: ast.Call) -> str | None:
    """The module of ``importlib.import_module("name")`` with a literal absolute name."""
    func = call.func
    name = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else None
    if name != "import_module" or not call.args:
        return None
    arg = call.args[0]
    if isinstance(arg, ast.Constant) and isinstance(arg.value, str) and not arg.value.startswith("."):
        return arg.value
    return None


def _resolve_from(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute module named by ``from <node.module> import ...`` inside ``module``."""
    if node.level == 0:
        return node.module or ""
    parts = module.split(".")
    if not is_package:
        parts = parts[:-1]
    if node.level > 1:
        parts = parts[: len(parts) - (node.level - 1)]
    base = ".".join(parts)
    return f"{base}.{node.module}" if node.module else base


def _known(name: str, modules: dict[str, Path]) -> str | None:
    """``name`` or its longest prefix that is a module of the package (None: outside it)."""
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


def _targets(module: str, graph: Graph, node: ast.AST) -> list[tuple[str, bool]]:
    """(module imported, only as a package run on the way) for one import statement."""
    named: list[str] = []
    if isinstance(node, ast.Import):
        named = [n.name for n in node.names]
    elif isinstance(node, ast.Call):
        named = [_literal_import_module(node) or ""]
    else:
        base = _resolve_from(module, module in graph.packages, node)
        for alias in node.names:
            sub = f"{base}.{alias.name}"
            if alias.name != "*" and sub in graph.modules:
                named.append(sub)
                if base != module and base not in _ancestors(module):
                    named.append(base)  # ``from pkg import sub`` runs pkg/__init__ first
            else:
                named.append(base)
    out: list[tuple[str, bool]] = []
    inside = set(_ancestors(module))
    for name in named:
        target = _known(name, graph.modules)
        if target is None:
            continue
        out.append((target, False))
        for pkg in _ancestors(target):
            if pkg not in inside and pkg in graph.modules:
                out.append((pkg, True))
    seen: dict[str, bool] = {}
    for target, via in out:
        if target != module:
            seen[target] = seen.get(target, True) and via
    return list(seen.items())


def build_graph(package_dir: str | Path) -> Graph:
    """Parse every module under ``package_dir`` and collect its imports of the package."""
    package_dir = Path(package_dir)
    modules, packages = discover(package_dir)
    graph = Graph(package_dir.resolve().parent, modules, packages)
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        rel = path.relative_to(graph.root).as_posix()
        for node, lazy, type_only in _import_nodes(tree):
            for target, via in _targets(module, graph, node):
                graph.edges.append(Edge(module, target, rel, node.lineno, lazy, type_only, via))
    return graph


# --- checks -------------------------------------------------------------------------------------


def strongly_connected(successors: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components (iterative), each sorted, in sorted order."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    counter = 0
    for start in sorted(successors):
        if start in index:
            continue
        work = [(start, iter(sorted(successors[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(successors[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    components.append(sorted(component))
    return sorted(components)


def cycles(graph: Graph) -> list[list[str]]:
    """The strongly connected components of more than one module (imports that run only)."""
    return [c for c in strongly_connected(graph.successors()) if len(c) > 1]


def cycle_edges(graph: Graph, component: list[str]) -> list[Edge]:
    members = set(component)
    return sorted(
        (e for e in graph.edges if e.source in members and e.target in members and not e.type_only),
        key=lambda e: (e.source, e.target, e.path, e.line),
    )


def layer_of(module: str, layers=LAYERS) -> tuple[int, str] | None:
    """(index, name) of the layer whose longest key is ``module`` or a package prefix of it (a
    key without a dot, the top package, names its ``__init__`` only)."""
    best: tuple[int, int, str] | None = None
    for i, (name, keys) in enumerate(layers):
        for key in keys:
            if module == key or ("." in key and module.startswith(key + ".")):
                if best is None or len(key) > best[0]:
                    best = (len(key), i, name)
    return None if best is None else (best[1], best[2])


def layer_violations(graph: Graph, layers=LAYERS) -> list[Edge]:
    """Imports of a module from a layer above its own."""
    out = []
    for e in graph.edges:
        src, dst = layer_of(e.source, layers), layer_of(e.target, layers)
        if src is not None and dst is not None and dst[0] > src[0]:
            out.append(e)
    return sorted(out, key=lambda e: (e.source, e.target, e.line))


def unlayered(graph: Graph, layers=LAYERS) -> list[str]:
    return sorted(m for m in graph.modules if layer_of(m, layers) is None)


# --- report -------------------------------------------------------------------------------------


def _label(module: str, layers) -> str:
    layer = layer_of(module, layers)
    return f"{module} [{layer[1]}]" if layer else f"{module} [no layer]"


def report(graph: Graph, layers=LAYERS, show_graph: bool = False, show_layers: bool = False, out=None) -> int:
    """Print the checks (and the graph or layers if asked) to ``out`` (default stdout); the
    number of problems found."""
    out = sys.stdout if out is None else out
    lazy = sum(e.lazy for e in graph.edges)
    print(f"{len(graph.modules)} modules, {len(graph.edges)} imports ({lazy} inside functions)", file=out)
    if show_layers:
        for i, (name, _keys) in enumerate(layers):
            members = [m for m in sorted(graph.modules) if (layer_of(m, layers) or (None,))[0] == i]
            print(f"layer {i} {name} ({len(members)} modules):", file=out)
            for m in members:
                print(f"    {m}", file=out)
    if show_graph:
        by_source: dict[str, list[Edge]] = {m: [] for m in graph.modules}
        for e in graph.edges:
            by_source[e.source].append(e)
        for m in sorted(graph.modules):
            print(_label(m, layers), file=out)
            for e in sorted(by_source[m], key=lambda e: (e.target, e.line)):
                print(f"    -> {_label(e.target, layers)}  {e.where()}", file=out)
    problems = 0
    found = cycles(graph)
    for k, component in enumerate(found, 1):
        print(f"cycle {k} ({len(component)} modules): {', '.join(component)}", file=out)
        for e in cycle_edges(graph, component):
            print(f"    {e.source} -> {e.target}  {e.where()}", file=out)
    problems += len(found)
    missing = unlayered(graph, layers)
    for m in missing:
        print(f"no layer: {m} (add it to LAYERS in tools/import_graph.py)", file=out)
    problems += len(missing)
    violations = layer_violations(graph, layers)
    for e in violations:
        print(f"upward import: {_label(e.source, layers)} -> {_label(e.target, layers)}  {e.where()}", file=out)
    problems += len(violations)
    print(
        f"{len(found)} cycles, {len(violations)} upward imports, {len(missing)} modules without a layer",
        file=out,
    )
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    default = Path(__file__).resolve().parent.parent / "fepre"
    parser.add_argument("package", nargs="?", default=str(default), help="package directory (default: fepre)")
    parser.add_argument("--graph", action="store_true", help="print every module's layer and imports")
    parser.add_argument("--layers", action="store_true", help="print the modules of each layer")
    args = parser.parse_args(argv)
    graph = build_graph(args.package)
    return 1 if report(graph, show_graph=args.graph, show_layers=args.layers) else 0


if __name__ == "__main__":
    sys.exit(main())
