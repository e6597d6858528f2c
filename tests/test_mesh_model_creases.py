"""Creases of closed triangle-mesh models read from their triangles' edges equal the grid search's."""

import numpy as np
import pytest
import pyvista as pv

import fepre
from fepre import sdf
from fepre.sdf.meshmodel.model import MeshModel


@pytest.fixture(scope="module")
def cad_part(tmp_path_factory):
    """A 6 x 6 x 3 block with a through bore (r 1) and a boss (r 1.5, 1.5 high) beside it on
    top, tessellated by gmsh's OpenCASCADE kernel: corners, straight and circular creases, and
    a concave circle where the boss meets the top."""
    import gmsh

    path = tmp_path_factory.mktemp("cad") / "block.stl"
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        block = occ.addBox(0, 0, 0, 6, 6, 3)
        boss = occ.addCylinder(4, 4, 3, 0, 0, 1.5, 1.5)
        body, _ = occ.fuse([(3, block)], [(3, boss)])
        bore = occ.addCylinder(1.8, 1.8, -1, 0, 0, 6, 1.0)
        occ.cut(body, [(3, bore)])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def _dense(found, step):
    """Points along every curve's polyline no more than ``step`` apart."""
    points = []
    for curve in found.curves:
        p = np.vstack([curve.points, curve.points[:1]]) if curve.closed else curve.points
        for a, b in zip(p[:-1], p[1:]):
            t = np.linspace(0.0, 1.0, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)[:, None]
            points.append(a + t * (b - a))
    return np.vstack(points)


def _grid_search(model, h, monkeypatch):
    with monkeypatch.context() as patch:
        patch.setattr(MeshModel, "creases_from_triangles", False)
        return fepre.features(model, h, warn=False)


def _assert_same(found, grid, h):
    from scipy.spatial import cKDTree

    assert len(found.corners) == len(grid.corners)
    if len(grid.corners):
        assert cKDTree(found.corners).query(grid.corners)[0].max() < 1e-9 * h
    assert len(found.curves) == len(grid.curves)
    assert sum(c.closed for c in found.curves) == sum(c.closed for c in grid.curves)
    lengths = np.sort([c.length for c in found.curves])
    assert lengths == pytest.approx(np.sort([c.length for c in grid.curves]), rel=0.01)
    ours, theirs = _dense(found, h / 20), _dense(grid, h / 20)
    hausdorff = max(cKDTree(ours).query(theirs)[0].max(), cKDTree(theirs).query(ours)[0].max())
    assert hausdorff < 0.1 * h  # the same lines, nodes placed along them a little differently


def test_cad_part_creases_from_triangles_equal_the_grid_search(cad_part, monkeypatch):
    model = sdf.mesh(cad_part)
    assert model.creases_from_triangles
    found = fepre.features(model, h=0.5)
    _assert_same(found, _grid_search(model, 0.5, monkeypatch), 0.5)
    assert len(found.corners) >= 8 and sum(c.closed for c in found.curves) >= 3  # bore x2, boss x2
    box = np.array([[x, y, z] for x in (0, 6) for y in (0, 6) for z in (0, 3)], float)
    assert np.min(np.linalg.norm(found.corners[None] - box[:, None], axis=2), axis=1).max() < 1e-9


def test_far_from_the_origin_the_same_creases(cad_part):
    """fepre.features moves a far part to a local frame (an Affine of the model): the
    triangles are read through it, and the creases are those at the origin, moved."""
    offset = np.array([1e4, -2e4, 1e4])
    surface = pv.read(cad_part)
    model = sdf.mesh(surface)
    moved = surface.copy()
    moved.points = np.asarray(surface.points, np.float64) + offset  # the STL's are float32
    moved = sdf.mesh(moved)
    assert moved.creases_from_triangles
    here, there = fepre.features(model, 0.5), fepre.features(moved, 0.5)
    assert len(here.corners) == len(there.corners) and len(here.curves) == len(there.curves)
    assert np.abs(np.sort(there.corners - offset, axis=0) - np.sort(here.corners, axis=0)).max() < 1e-9
    assert np.abs(_dense(there, 0.05).mean(axis=0) - offset - _dense(here, 0.05).mean(axis=0)).max() < 1e-6


@pytest.mark.parametrize("resolution", [(6, 6), (8, 5)])
def test_faceted_sphere_creases_from_triangles_equal_the_grid_search(resolution, monkeypatch):
    ball = sdf.mesh(pv.Sphere(radius=1.0, theta_resolution=resolution[0], phi_resolution=resolution[1]))
    assert ball.patch_count > 10 and ball.creases_from_triangles
    found = fepre.features(ball, 0.15)
    assert len(found.corners) == 24
    _assert_same(found, _grid_search(ball, 0.15, monkeypatch), 0.15)


def test_spanned_openings_use_the_grid_search():
    """An open hemisphere's span meets the sheet without shared edges: its rim, a crease of
    90 degrees, is found on the grid."""
    bowl = pv.Sphere(theta_resolution=48, phi_resolution=48).clip(normal="-z", origin=(0, 0, 0))
    cap = sdf.mesh(bowl, inside="winding")
    assert not cap.creases_from_triangles
    found = fepre.features(cap, 0.1)
    assert len(found.curves) == 1 and found.curves[0].closed
    assert found.curves[0].length == pytest.approx(np.pi, rel=0.02)


def test_a_folded_triangle_is_no_crease(monkeypatch):
    """The top face's centre moved past the line between two edge midpoints turns their
    triangle over in the face's plane (normal -z): a patch meeting its neighbours at 180
    degrees, and the corner triangle beyond it a patch of its own. As on the grid, they are one
    surface with the face: the cube's edges along them carry no corner in their middle (read
    from the triangles without that, 10 corners and 14 curves)."""
    cube = pv.Cube().triangulate().subdivide(1, "linear").clean()
    vertices = np.asarray(cube.points, float)
    faces = cube.faces.reshape(-1, 4)[:, 1:]
    vertices[np.all(np.isclose(vertices, [0.0, 0.0, 0.5]), axis=1)] = [0.3, 0.3, 0.5]
    model = sdf.mesh(pv.PolyData(vertices, np.column_stack([np.full(len(faces), 3), faces]).ravel()))
    assert model.patch_count == 8 and (model._distance.normals[:, 2] < -0.99).sum() == 9  # bottom 8 + the fold
    found = fepre.features(model, 0.2)
    assert len(found.corners) == 8 and len(found.curves) == 12 and not found.skipped
    _assert_same(found, _grid_search(model, 0.2, monkeypatch), 0.2)
