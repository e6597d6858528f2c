"""The import graph of fepre (tools/import_graph.py): no cycles, layers that only look down."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def import_graph():
    spec = importlib.util.spec_from_file_location("import_graph", ROOT / "tools" / "import_graph.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)




def test_fepre_has_no_import_cycle(import_graph):
    graph = import_graph.build_graph(ROOT / "fepre")
    found = import_graph.cycles(graph)
    details = [
        f"{', '.join(c)}: " + "; ".join(f"{e.source} -> {e.target} {e.where()}" for e in import_graph.cycle_edges(graph, c))
        for c in found
    ]
    assert not found, "import cycles:\n" + "\n".join(details)


@pytest.mark.slow  # 3 s of the default run on 2 cores
def test_fepre_modules_import_only_from_their_layer_or_below(import_graph):
    graph = import_graph.build_graph(ROOT / "fepre")
    assert import_graph.unlayered(graph) == []
    violations = [f"{e.source} -> {e.target} {e.where()}" for e in import_graph.layer_violations(graph)]
    assert violations == []



def _write(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root / "pkg"


def test_a_cycle_through_a_lazy_import_and_a_package_init_is_found(import_graph, tmp_path):
    package = _write(
        tmp_path,
        {
            "pkg/__init__.py": "from . import low\n",
            "pkg/low.py": "def f():\n    from .high.b import g  # lazy: still an edge\n",
            "pkg/high/__init__.py": "from .a import *\n",
            "pkg/high/a.py": "import pkg.low\n",
            "pkg/high/b.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..low import f\n",
            "pkg/other.py": "import os\nfrom pkg.high import a, b\nfrom .low import f\n",
        },
    )
    graph = import_graph.build_graph(package)
    edges = {(e.source, e.target) for e in graph.edges}
    # the lazy import runs pkg/high/__init__.py first (package init), which imports a
    assert {("pkg.low", "pkg.high.b"), ("pkg.low", "pkg.high"), ("pkg.high", "pkg.high.a"), ("pkg.high.a", "pkg.low")} <= edges
    # from a package import a submodule: an edge to the submodule; os is not the package's
    assert {("pkg.other", "pkg.high.a"), ("pkg.other", "pkg.high.b"), ("pkg.other", "pkg.low")} <= edges
    assert import_graph.cycles(graph) == [["pkg.high", "pkg.high.a", "pkg.low"]]
    # a TYPE_CHECKING import never runs: no cycle, but it is kept for the layer check
    assert [e.type_only for e in graph.edges if (e.source, e.target) == ("pkg.high.b", "pkg.low")] == [True]
    lazy = [e for e in graph.edges if (e.source, e.target) == ("pkg.low", "pkg.high.b")]
    assert lazy[0].lazy and lazy[0].line == 2 and lazy[0].path == "pkg/low.py"

    layers = (("bottom", ("pkg.low",)), ("top", ("pkg", "pkg.high", "pkg.other")))
    assert import_graph.unlayered(graph, layers) == []
    upward = {(e.source, e.target) for e in import_graph.layer_violations(graph, layers)}
    assert upward == {("pkg.low", "pkg.high"), ("pkg.low", "pkg.high.b")}

    out = tmp_path / "report.txt"
    with out.open("w") as stream:
        problems = import_graph.report(graph, layers, show_graph=True, show_layers=True, out=stream)
    text = out.read_text()
    assert problems == 3  # one cycle, two upward imports
    assert "cycle 1 (3 modules): pkg.high, pkg.high.a, pkg.low" in text
    assert "pkg.high.a -> pkg.low  pkg/high/a.py:1" in text
    assert "layer 0 bottom (1 modules):" in text
    assert import_graph.main([str(package)]) == 1


def test_a_package_without_cycles_passes(import_graph, tmp_path, capsys):
    package = _write(
        tmp_path,
        {"pkg/__init__.py": "from .b import x\n", "pkg/a.py": "x = 1\n", "pkg/b.py": "from .a import x\n"},
    )
    graph = import_graph.build_graph(package)
    assert import_graph.cycles(graph) == []
    layers = (("all", ("pkg", "pkg.a", "pkg.b")),)
    assert import_graph.report(graph, layers) == 0
    assert import_graph.main([str(package)]) == 1  # fepre's own layer table names none of pkg's modules
    assert "no layer: pkg.a" in capsys.readouterr().out
