"""The mesher as a pipeline: stages over a MeshingJob, constraints behind one protocol, and the
import direction (fepre.regions and fepre.periodic import fepre.distmesh, never the reverse)."""

from __future__ import annotations

import ast
import pathlib

import numpy as np

import fepre
from fepre import sdf
from fepre.arguments import domain_bounds
from fepre.distmesh.constraints import FeatureNodes, MeshConstraint
from fepre.distmesh.job import MeshingJob
from fepre.distmesh.options import DistMeshOptions
from fepre.distmesh.pipeline import run_pipeline

PACKAGE = pathlib.Path(fepre.__file__).parent


def job_of(model, h: float, constraints: list[MeshConstraint]) -> MeshingJob:
    """The job fepre.distmesh(model, h) runs (a float h, no size, default options), with ``constraints``."""
    lower, upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(model, None))
    return MeshingJob(model=model, given_model=model, h=h, size=None, options=DistMeshOptions(), lower=lower,
                      upper=upper, constraints=constraints)


def test_a_constraint_with_only_the_protocol_s_defaults_changes_nothing():
    model = sdf.box((2, 1, 1)) - sdf.cylinder(0.25, 2.0)
    expected = fepre.distmesh(model, 0.3)
    mesh = run_pipeline(job_of(model, 0.3, [FeatureNodes(), MeshConstraint()]))
    assert np.asarray(mesh.points).tobytes() == np.asarray(expected.points).tobytes()
    assert np.array_equal(mesh.cells_dict[10], expected.cells_dict[10])
    assert np.array_equal(mesh["feature"], expected["feature"])
    assert expected.field_data["distmesh_feature_nodes"][0] > 0  # the features were constrained


class CentreNode(MeshConstraint):
    """A new constraint, added without touching the stages: a node at the origin, marked."""

    def fixed_nodes(self, job, fixed):
        return np.zeros((1, 3))

    def pinned_nodes(self, job):  # an interior node: the quality stage would move it
        return np.abs(job.points).max(axis=1) == 0

    def check(self, job):
        job.history["centre_nodes"] = np.array([int((np.abs(job.points).max(axis=1) == 0).sum())])

    def annotate(self, job, grid):
        grid.point_data["centre"] = (np.abs(job.points).max(axis=1) == 0).astype(np.uint8)


def test_a_new_constraint_lays_its_node_checks_and_annotates():
    mesh = run_pipeline(job_of(sdf.sphere(1.0), 0.3, [CentreNode()]))
    at_origin = np.flatnonzero(np.abs(np.asarray(mesh.points)).max(axis=1) == 0)
    assert len(at_origin) == 1 and mesh["centre"][at_origin[0]] == 1 and mesh["centre"].sum() == 1
    assert mesh.field_data["distmesh_centre_nodes"][0] == 1


def imports_of(path: pathlib.Path) -> set[str]:
    """The fepre modules ``path`` imports, those inside functions included (relative ones resolved)."""
    module = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = module.rsplit(".", 1)[0] if path.name != "__init__.py" else module.removesuffix(".__init__")
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[: len(package.split(".")) - node.level + 1] if node.level else []
            name = ".".join(base + ([node.module] if node.module else []))
            found.update([name] + [f"{name}.{alias.name}" for alias in node.names])
    return {name for name in found if name.startswith("fepre")}


def test_fepre_distmesh_imports_neither_regions_nor_periodic():
    for path in sorted((PACKAGE / "distmesh").glob("*.py")):
        above = {name for name in imports_of(path) if name.startswith(("fepre.regions", "fepre.periodic"))}
        assert not above, f"{path.name} imports {sorted(above)}"


def test_no_module_of_distmesh_regions_or_periodic_imports_one_that_imports_it_back():
    paths = [path for sub in ("distmesh", "regions", "periodic") for path in sorted((PACKAGE / sub).glob("*.py"))]
    name_of = {path: ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(".__init__") for path in paths}
    modules = set(name_of.values())

    def module(name: str) -> str | None:  # fepre.regions.conform.final_region_mesh -> fepre.regions.conform
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    edges = {name_of[path]: {module(name) for name in imports_of(path)} - {None, name_of[path]} for path in paths}
    state: dict[str, int] = {}  # 1 on the current path, 2 done

    def cycle_from(name: str, path: list[str]) -> list[str] | None:
        state[name] = 1
        for target in sorted(edges[name]):
            if state.get(target) == 1:
                return path[path.index(target):] + [target]
            if target not in state and (found := cycle_from(target, path + [target])):
                return found
        state[name] = 2
        return None

    for name in sorted(edges):
        if name not in state:
            cycle = cycle_from(name, [name])
            assert cycle is None, " -> ".join(cycle)
