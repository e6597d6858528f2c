"""The quality stage meets all three targets (worst dihedral, largest dihedral, radius ratio)
with default options on parts users model, checked by fepre.quality (not the stage's kernel)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import quality, sdf
from fepre.distmesh.smoothing import _independent_moves
from fepre.distmesh.topology import check_topology

MIN_DIHEDRAL, MAX_DIHEDRAL, MIN_RADIUS_RATIO = 25.0, 150.0, 0.25


def stepped_shaft():
    """A revolved stepped shaft: radius 10 for z in [0, 40], radius 6 up to z = 80."""
    return sdf.revolve(sdf.polygon([(0, 0), (10, 0), (10, 40), (6, 40), (6, 80), (0, 80)]))


def assert_targets(mesh: pv.UnstructuredGrid, model, h: float) -> None:
    points = np.asarray(mesh.points, dtype=np.float64)
    tets = mesh.cells_dict[pv.CellType.TETRA].astype(np.int64)
    q = quality.tet_quality(points, tets)
    assert q["volume"].min() > 0
    assert q["min_dihedral_angle"].min() >= MIN_DIHEDRAL
    assert q["max_dihedral_angle"].max() <= MAX_DIHEDRAL
    assert q["radius_ratio"].min() >= MIN_RADIUS_RATIO
    report = check_topology(tets, len(points))
    assert report.ok, report
    assert np.abs(model(points[np.unique(report.boundary_faces)])).max() <= 1e-3 * h


@pytest.mark.slow
def test_stepped_shaft_meets_every_target():
    """Before: worst dihedral 24.4 deg, largest 156.6 deg, radius ratio 0.123 (the stage
    aimed at the smallest angle only); then 23.6 deg with a ConvergenceWarning (a bad cell's
    boundary vertices kept the move and its interior vertex, which could fix it, waited)."""
    shaft, h = stepped_shaft(), 2.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(shaft, h)
    assert_targets(mesh, shaft, h)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        raw = fepre.distmesh(shaft, h, slivers=False)
    assert raw["max_dihedral_angle"].max() > 170  # the problem is real
    assert mesh.volume == pytest.approx(raw.volume, rel=2e-3)
    assert mesh.volume == pytest.approx(np.pi * (100 * 40 + 36 * 40), rel=0.01)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 6])
def test_the_revolved_stepped_shaft_meets_every_target_at_other_seeds(seed):
    """Seed 1 ended at 24.8 deg and radius ratio 0.248 with a ConvergenceWarning (issue 12);
    seeds 0-13 now all meet the targets, 1 and 6 being the closest (26.2 and 28.6 deg)."""
    shaft = stepped_shaft()
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(shaft, 2.0, seed=seed)
    assert_targets(mesh, shaft, 2.0)
    assert mesh.volume == pytest.approx(np.pi * (100 * 40 + 36 * 40), rel=0.01)


def test_moving_vertices_share_no_cell_and_the_best_vertex_of_a_bad_cell_moves_first():
    # vertex stars over cells: v0 {0, 1}, v1 {1, 2}, v2 {2, 3}, v3 {3}, v4 {4}
    cells = np.array([0, 1, 1, 2, 2, 3, 3, 4])
    segment = np.array([0, 0, 1, 1, 2, 2, 3, 4])
    seg_starts = np.array([0, 2, 4, 6, 7])
    improving = np.ones(5, dtype=bool)
    current = np.array([10.0, 10.0, 10.0, 10.0, 30.0])
    # equal current (one bad cell): v1 reaches the best star, so it moves and blocks v0 and v2;
    # v3 (sharing cell 3 with v2 only) moves in a second pass; v4 is independent
    best = np.array([12.0, 20.0, 11.0, 11.0, 31.0])
    selected = _independent_moves(5, cells, segment, seg_starts, improving, current, best)
    assert selected.tolist() == [False, True, False, True, True]


@pytest.mark.parametrize("name, value", [("max_dihedral", 70.0), ("max_dihedral", 180.0), ("min_radius_ratio", 0.0),
                                         ("min_radius_ratio", 1.0), ("min_radius_ratio", float("nan"))])
def test_impossible_targets_are_refused(name, value):
    ball = sdf.sphere(1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        raw = fepre.distmesh(ball, 0.4, slivers=False)
    with pytest.raises(ValueError, match=name):
        fepre.improve(raw, ball, **{name: value})


@pytest.mark.slow
def test_improve_puts_another_meshers_sharp_edge_nodes_on_the_model():
    """gmsh's nodes on the cube-with-hole's edges sit on its own surface, 0.0045 h off the
    model; improve pinned them there, against its promise of 1e-3 h."""
    pytest.importorskip("gmsh")
    from fepre.parts import cube_with_hole
    from fepre.references import gmsh_mesh, reference_surface

    model, _ = cube_with_hole()
    h = 0.5
    mesh = gmsh_mesh(reference_surface(model, h / 4), h)
    mesh = mesh[0] if isinstance(mesh, tuple) else mesh
    points = np.asarray(mesh.points)
    boundary = np.unique(check_topology(mesh.cells_dict[pv.CellType.TETRA], len(points)).boundary_faces)
    assert np.abs(model(points[boundary])).max() > 2e-3 * h  # the problem is real
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        better = fepre.improve(mesh, model)
    assert better.field_data["improve_snapped"][0] > 0
    assert_targets(better, model, h)
    corners = np.array([[x, y, z] for x in (0, 5) for y in (0, 5) for z in (0, 5)], dtype=float)
    gap = np.linalg.norm(np.asarray(better.points)[:, None] - corners[None], axis=2).min(axis=0)
    assert gap.max() <= 1e-9


def boundary_face_fit(mesh, model) -> tuple[float, float]:
    """Largest depth of a boundary face's centroid under or over the zero set, and the smallest
    cosine between a boundary face's normal and the model's normal there."""
    points = np.asarray(mesh.points)
    faces = check_topology(mesh.cells_dict[pv.CellType.TETRA], len(points)).boundary_faces
    corners = points[faces]
    values, gradient = model.value_and_gradient(corners.mean(axis=1))
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    cosine = np.einsum("ij,ij->i", normals, gradient) / np.linalg.norm(normals, axis=1) / np.linalg.norm(gradient, axis=1)
    return float(np.abs(values).max()), float(cosine.min())


@pytest.mark.slow
def test_boundary_faces_stay_on_the_surface_of_a_thin_gyroid_infill():
    """Sheets 1.2 h thick, shell 1.5 h: without the surface guard, smoothing slid boundary
    vertices along the sheet until a boundary face turned almost over (normal 119 deg from the
    model's, cosine -0.48; the loop's worst is +0.03); with it no boundary face ends up deeper
    or more tilted than the loop left it (or than 0.1 h and 45 deg), and the targets hold."""
    part = sdf.infill(sdf.box((2.0, 2.0, 1.0)), sdf.gyroid(period=1.0, thickness=0.12), wall=0.15)
    h = 0.1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        raw = fepre.distmesh(part, h, slivers=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ConvergenceWarning)
        mesh = fepre.improve(raw, part)
    assert_targets(mesh, part, h)
    raw_depth, raw_cosine = boundary_face_fit(raw, part)
    depth, cosine = boundary_face_fit(mesh, part)
    # (the stage first projects the boundary nodes onto the zero set: the faces shift a little)
    assert cosine >= min(raw_cosine, np.cos(np.radians(45.0))) - 1e-3
    assert depth <= max(raw_depth, 0.1 * h) + 1e-3 * h


def test_stage_pins_release_feature_nodes_left_inside_and_keep_the_users():
    from fepre.distmesh.improve_mesh import stage_pins

    ball, h = sdf.sphere(1.0), 0.3
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        raw = fepre.distmesh(ball, h, slivers=False)
    points = np.asarray(raw.points, dtype=np.float64)
    tets = raw.cells_dict[pv.CellType.TETRA].astype(np.int64)
    boundary = raw["boundary"].astype(bool)
    inside = np.flatnonzero(~boundary)
    fixed = np.zeros(len(points), dtype=bool)
    fixed[inside[:3]] = True  # as feature nodes the final mesh left inside
    fixed[np.flatnonzero(boundary)[:2]] = True
    pinned = stage_pins(points, tets, fixed, points[inside[2:3]], ball, h)  # the user's point
    assert pinned[np.flatnonzero(boundary)[:2]].all()
    assert not pinned[inside[:2]].any()
    assert pinned[inside[2]]
    assert not pinned[inside[3:]].any()


def test_plate_one_edge_length_thick_gets_points_on_both_faces_and_meets_the_targets():
    """The surface sampling kept one point per 1.1 h cube: both faces of a plate h thick fall
    in the same cubes, so the bottom face had no point inside its rim (77 on the top), its
    cells spanned 5-10 h and the stage stopped at 10.0 deg with a ConvergenceWarning."""
    plate, h = sdf.box((10.0, 10.0, 1.0)), 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(plate, h)
    assert_targets(mesh, plate, h)
    points = np.asarray(mesh.points)
    inside_rim = (np.abs(points[:, :2]) < 5.0 - 0.25 * h).all(axis=1)
    for z in (-0.5, 0.5):
        assert (inside_rim & (np.abs(points[:, 2] - z) < 1e-9)).sum() >= 40
    assert mesh.volume == pytest.approx(100.0, rel=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_stepped_shaft_of_two_cylinders_meets_every_target_for_every_seed(seed):
    """Before: seeds 0 and 2 ended at 1.7 and 2.2 deg with a ConvergenceWarning. The surface
    nodes of a cylinder settle in columns along its generators; gmsh's triangulation dropped the
    flat cells of the co-circular rim nodes, the cracks sent the final triangulation to Qhull,
    whose full Delaunay triangulation held 2,182 cells longer than 3 h (up to 38, the lower
    cylinder's height) inside the part, stacked too deep for the quality stage.

    Since the flat faces start from the lattice's own layer, seed 1 stopped at 22.0 deg with a
    ConvergenceWarning: the stage's cells between the cylinder's columns, next to the rim at
    z = 40, locked up. Since the quality stage splits long edges and removes boundary edges
    over open rings (issue 32), every seed meets the targets."""
    shaft = sdf.cylinder(10, 40, center=(0, 0, 20)) | sdf.cylinder(6, 40, center=(0, 0, 60))
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(shaft, 2.0, seed=seed)
    assert_targets(mesh, shaft, 2.0)
    cells = np.asarray(mesh.points)[mesh.cells_dict[pv.CellType.TETRA]]
    edges = cells[:, [0, 0, 0, 1, 1, 2]] - cells[:, [1, 2, 3, 2, 3, 3]]
    assert np.linalg.norm(edges, axis=2).max() < 3 * 2.0
    assert mesh.volume == pytest.approx(np.pi * (100 * 40 + 36 * 40), rel=0.01)
