"""Dual contouring: sharp corners and creases of CSG parts, topology and accuracy on smooth parts."""

from __future__ import annotations

import math

import numpy as np
import pytest
import pyvista as pv
from scipy.spatial import cKDTree

import fepre
from fepre import parts, sdf
from fepre.surface.grid_scan import scan_grid

# -- the parts' sharp features, exactly ---------------------------------------------------------


class Segment:
    def __init__(self, a, b):
        self.a, self.b = np.asarray(a, float), np.asarray(b, float)

    def sample(self, step):
        count = max(2, int(np.linalg.norm(self.b - self.a) / step) + 1)
        return self.a + np.linspace(0, 1, count)[:, None] * (self.b - self.a)

    def distance(self, points):
        d = self.b - self.a
        s = np.clip((points - self.a) @ d / (d @ d), 0, 1)
        return np.linalg.norm(points - (self.a + s[:, None] * d), axis=1)


class Circle:
    """A circle of ``radius`` around ``centre`` in a plane z = const."""

    def __init__(self, centre, radius):
        self.centre, self.radius = np.asarray(centre, float), float(radius)

    def sample(self, step):
        angle = np.linspace(0, 2 * np.pi, int(2 * np.pi * self.radius / step) + 2)
        return self.centre + self.radius * np.stack([np.cos(angle), np.sin(angle), 0 * angle], axis=1)

    def distance(self, points):
        r = np.hypot(points[:, 0] - self.centre[0], points[:, 1] - self.centre[1])
        return np.hypot(r - self.radius, points[:, 2] - self.centre[2])


class Polyline:
    """A curve given by points much denser than the grid (distance to the nearest point)."""

    def __init__(self, points):
        self.points = np.asarray(points, float)
        self.tree = cKDTree(self.points)

    def sample(self, step):
        return self.points

    def distance(self, points):
        return self.tree.query(points)[0]


def box_edges(low, high):
    low, high = np.asarray(low, float), np.asarray(high, float)
    corners = [np.where([i, j, k], high, low) for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    return [Segment(corners[a], corners[b]) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]


def rectangle(x, y, z):
    """The four edges of the rectangle [x0, x1] x [y0, y1] at height z."""
    (x0, x1), (y0, y1) = x, y
    c = [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)]
    return [Segment(c[i], c[(i + 1) % 4]) for i in range(4)]


def cube_with_hole_features():
    model, _ = parts.cube_with_hole()
    creases = box_edges((0, 0, 0), (5, 5, 5)) + [Circle((2.5, 2.5, z), 1.0) for z in (0.0, 5.0)]
    return model, parts.cube_with_hole_corners(), creases


def slotted_box_features():
    model, _ = parts.slotted_box()
    creases = box_edges((-2, -1, 0), (2, 1, 1))
    creases += rectangle((-1.2, 1.2), (-0.3, 0.3), 1.0) + rectangle((-1.2, 1.2), (-0.3, 0.3), 0.5)
    creases += [Segment((x, y, 0.5), (x, y, 1.0)) for x in (-1.2, 1.2) for y in (-0.3, 0.3)]
    return model, parts.slotted_box_corners(), creases


def _fillet_profile(count=20001):
    """Points (x, z) of the bracket's fillet: the zero set of the plates' smooth union, by bisection on rays."""
    base = sdf.box((4.0, 2.0, 0.6), center=(2.0, 1.0, 0.3))
    upright = sdf.box((0.6, 2.0, 3.0), center=(0.3, 1.0, 1.5))
    union = sdf.union(base, upright, k=0.3)
    angle = np.linspace(np.pi, 1.5 * np.pi, count)
    direction = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    low, high = np.zeros(count), np.full(count, 0.5)  # from (1.0, 1.0), outside, towards the corner
    for _ in range(60):
        middle = 0.5 * (low + high)
        xz = 1.0 + middle[:, None] * direction
        inside = union(np.stack([xz[:, 0], np.ones(count), xz[:, 1]], axis=1)) < 0
        high, low = np.where(inside, middle, high), np.where(inside, low, middle)
    xz = 1.0 + high[:, None] * direction
    return xz[(xz[:, 0] <= 0.9 + 1e-9) & (xz[:, 1] <= 0.9 + 1e-9)]


#: the bracket's L profile in (x, z): its sharp corners, in order, with the fillet between 2 and 3
BRACKET_PROFILE = [(0.0, 0.0), (4.0, 0.0), (4.0, 0.6), (0.9, 0.6), (0.6, 0.9), (0.6, 3.0), (0.0, 3.0)]


def l_bracket_features():
    model = parts.l_bracket()[0]
    sharp = [p for i, p in enumerate(BRACKET_PROFILE) if i not in (3, 4)]
    corners = np.array([(x, y, z) for y in (0.0, 2.0) for x, z in sharp])
    creases = [Segment((x, 0, z), (x, 2, z)) for x, z in sharp]
    fillet = _fillet_profile()
    for y in (0.0, 2.0):
        for i in range(len(BRACKET_PROFILE)):
            if i != 3:  # the fillet replaces the straight piece from (0.9, 0.6) to (0.6, 0.9)
                (x0, z0), (x1, z1) = BRACKET_PROFILE[i], BRACKET_PROFILE[(i + 1) % len(BRACKET_PROFILE)]
                creases.append(Segment((x0, y, z0), (x1, y, z1)))
        creases.append(Polyline(np.stack([fillet[:, 0], np.full(len(fillet), y), fillet[:, 1]], axis=1)))
    creases += [Circle((2.8, 1.0, z), 0.4) for z in (0.0, 0.6)]
    return model, corners, creases


FEATURES = {"cube_with_hole": cube_with_hole_features, "slotted_box": slotted_box_features, "l_bracket": l_bracket_features}


def crease_errors(surface, grid, creases):
    """Per point along the creases, the distance from the crease to the vertex of the active cell holding it.

    A point inside a cell asks that cell's vertex to lie on a crease. A point on a cell face or
    edge (faces on grid planes) touches several cells: the crease is kept when one of their
    vertices lies on it (at a concave crease on grid planes the cells beside the one on the
    crease hold plain face vertices). Vertex c of a dual surface belongs to active cell c.
    """
    dims = np.asarray(grid.dimensions)
    origin, step = np.asarray(grid.origin), np.asarray(grid.spacing)
    values = np.asarray(grid["sdf"]).reshape(tuple(reversed(grid.dimensions)))
    cells = scan_grid(values, 0.0).cells
    assert surface.n_points == cells.size
    points = np.asarray(surface.points)
    vertex_distance = np.min([curve.distance(points) for curve in creases], axis=0)
    along = np.concatenate([curve.sample(0.05 * step.min()) for curve in creases])
    u = (along - origin) / step
    best = np.full(len(along), np.inf)
    for shift in np.array(np.meshgrid(*[[-1e-7, 1e-7]] * 3)).T.reshape(-1, 3):
        ijk = np.floor(u + shift).astype(np.int64)
        ids = ijk[:, 0] + dims[0] * (ijk[:, 1] + dims[1] * ijk[:, 2])
        where = np.minimum(np.searchsorted(cells, ids), cells.size - 1)
        active = cells[where] == ids
        best[active] = np.minimum(best[active], vertex_distance[where[active]])
    return best


def corner_errors(surface, corners):
    return cKDTree(np.asarray(surface.points)).query(corners)[0]


def sharp_surface(name, spacing):
    model, corners, creases = FEATURES[name]()
    grid = fepre.sample(model, spacing=spacing)
    surface = fepre.isosurface(grid, method="dual_contouring", model=model)
    return model, corners, creases, grid, surface


# spacings with faces on grid planes (0.1, 0.25) and off them (0.0937, 0.23)
@pytest.mark.parametrize("spacing", [0.25, 0.1, 0.0937])
@pytest.mark.parametrize("name", list(FEATURES))
def test_corners_and_creases_are_sharp(name, spacing):
    model, corners, creases, grid, surface = sharp_surface(name, spacing)
    assert corner_errors(surface, corners).max() < 0.01 * spacing
    distance = crease_errors(surface, grid, creases)
    assert np.isfinite(distance).all()  # every crease point lies in an active cell
    assert distance.max() < 0.01 * spacing
    check = fepre.check_surface(surface)
    assert check.watertight and check.manifold and check.oriented
    assert check.degenerate_triangles == 0
    # no triangle turned inside out (its normal against the model's gradient)
    p = np.asarray(surface.points)[surface.regular_faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", normal, model.gradient(p.mean(axis=1))).min() > -0.1


def test_sharp_parts_have_the_exact_volume_and_area():
    for model, volume, area, spacing in (
        (parts.slotted_box()[0], parts.SLOTTED_BOX_VOLUME, 31.0, 0.0937),
        (parts.cube_with_hole()[0], parts.CUBE_WITH_HOLE_VOLUME, 150 + 8 * math.pi, 0.1),
    ):
        check = fepre.check_surface(fepre.isosurface(model, spacing=spacing, method="dual_contouring"))
        if volume == parts.SLOTTED_BOX_VOLUME:  # planar faces only: exact
            assert check.volume == pytest.approx(volume, rel=1e-9) and check.area == pytest.approx(area, rel=1e-9)
        else:  # the hole's wall is a polygon: second order, no chamfer on the 24 edges
            assert check.volume == pytest.approx(volume, rel=1e-3) and check.area == pytest.approx(area, rel=1e-3)


def test_cube_with_hole_keeps_its_edges_where_flying_edges_chamfers_them():
    model, _ = parts.cube_with_hole()
    grid = fepre.sample(model, spacing=0.1)
    dc = fepre.check_surface(fepre.isosurface(grid, method="dual_contouring", model=model), model)
    fe = fepre.check_surface(fepre.isosurface(grid, method="flying_edges"), model)
    exact = 150 + 8 * math.pi
    assert abs(dc.area / exact - 1) < 0.1 * abs(fe.area / exact - 1)
    # faces on grid planes: coincident vertices welded, no zero-area triangle left by either
    assert fe.degenerate_triangles == 0 and dc.degenerate_triangles == 0


# -- smooth parts and topology ----------------------------------------------------------------

SMOOTH = {
    "sphere": (sdf.sphere(1.0), 4 * math.pi, 4 / 3 * math.pi, 2),
    "torus": (sdf.torus(1.0, 0.4), 4 * math.pi**2 * 0.4, 2 * math.pi**2 * 0.4**2, 0),
}


@pytest.mark.parametrize("name", list(SMOOTH))
@pytest.mark.parametrize("source", ["model", "grid"])
def test_smooth_parts_closed_with_analytic_area_and_volume(name, source):
    model, area, volume, euler = SMOOTH[name]
    if source == "model":
        surface = fepre.isosurface(model, spacing=0.05, method="dual_contouring")
    else:  # an ImageData alone: normals from the grid's gradient
        surface = fepre.isosurface(fepre.sample(model, spacing=0.05), method="dual_contouring")
    check = fepre.check_surface(surface, model)
    assert check.watertight and check.manifold and check.oriented and check.components == 1
    assert check.euler_characteristic == euler
    assert check.area == pytest.approx(area, rel=0.01)
    assert check.volume == pytest.approx(volume, rel=0.01)
    assert check.degenerate_triangles == 0
    assert check.max_sdf_error < (0.02 if source == "model" else 0.05)


def test_cube_with_hole_and_gyroid_block_are_closed_manifold_oriented():
    model, _ = parts.cube_with_hole()
    check = fepre.check_surface(fepre.isosurface(model, spacing=0.1, method="dual_contouring"))
    assert check.watertight and check.manifold and check.oriented and check.genus == 1
    gyroid = parts.gyroid_block()
    grid = fepre.sample(gyroid, spacing=0.04)
    fe = fepre.check_surface(fepre.isosurface(grid, method="flying_edges"))
    for surface in (
        fepre.isosurface(grid, method="dual_contouring", model=gyroid),
        fepre.isosurface(grid, method="dual_contouring"),
    ):
        check = fepre.check_surface(surface)
        assert check.watertight and check.manifold and check.oriented
        assert check.components == fe.components and check.euler_characteristic == fe.euler_characteristic
        assert check.volume == pytest.approx(fe.volume, rel=0.01)


def test_grid_source_without_a_model_still_works_and_a_model_sharpens_it():
    model, _ = parts.cube_with_hole()
    spacing = 0.0937  # faces off the grid planes (on them, the grid's own gradient is exact)
    grid = fepre.sample(model, spacing=spacing)
    grid.point_data["distance"] = grid.point_data.pop("sdf")
    plain = fepre.isosurface(grid, method="dual_contouring", scalars="distance")
    sharp = fepre.isosurface(grid, method="dual_contouring", scalars="distance", model=model)
    assert plain.n_points == sharp.n_points and plain.n_cells == sharp.n_cells  # same connectivity
    corners = parts.cube_with_hole_corners()
    assert corner_errors(sharp, corners).max() < 1e-9
    # the grid's gradient blurs the normals next to an edge: corners stay within a cell, rounded
    assert 0.01 * spacing < corner_errors(plain, corners).max() < spacing
    for surface in (plain, sharp):
        check = fepre.check_surface(surface)
        assert check.watertight and check.manifold and check.oriented and check.genus == 1


def test_normals_and_a_level_other_than_zero():
    ball = sdf.sphere(1.0)
    surface = fepre.isosurface(ball, spacing=0.1, method="dual_contouring", level=0.25, normals=True)
    np.testing.assert_allclose(np.linalg.norm(surface.points, axis=1), 1.25, atol=0.02 * 0.1)
    np.testing.assert_allclose(surface.point_data["Normals"], ball.gradient(surface.points), atol=1e-9)


def test_same_surface_on_one_and_two_threads():
    model, _ = parts.slotted_box()
    grid = fepre.sample(model, spacing=0.05)
    one = fepre.isosurface(grid, method="dual_contouring", model=model, workers=1)
    two = fepre.isosurface(grid, method="dual_contouring", model=model, workers=2)
    np.testing.assert_array_equal(one.points, two.points)
    np.testing.assert_array_equal(one.regular_faces, two.regular_faces)


# -- bad input --------------------------------------------------------------------------------


def small_grid():
    grid = pv.ImageData(dimensions=(6, 6, 6), spacing=(0.5,) * 3, origin=(-1.25,) * 3)
    grid.point_data["sdf"] = np.linalg.norm(grid.points, axis=1) - 1.0
    return grid


def test_bad_input():
    with pytest.warns(UserWarning, match="surface is empty"):
        assert fepre.isosurface(small_grid(), method="dual_contouring", level=10.0).n_points == 0
    with pytest.warns(UserWarning, match="surface is empty"):
        assert fepre.isosurface(small_grid(), method="dual_contouring", level=10.0, model=sdf.sphere(1.0)).n_points == 0
    broken = small_grid()
    broken.point_data["sdf"][17] = np.nan
    with pytest.raises(ValueError, match="contain NaN .*point 17"):
        fepre.isosurface(broken, method="dual_contouring")
    with pytest.raises(ValueError, match="model applies only when source is an ImageData"):
        fepre.isosurface(sdf.sphere(1.0), method="dual_contouring", spacing=0.2, model=sdf.sphere(1.0))
    with pytest.raises(TypeError, match="model must be a fepre.sdf.SDF or None; got ndarray"):
        fepre.isosurface(small_grid(), method="dual_contouring", model=np.zeros(3))
    with pytest.raises(ValueError, match="method must be one of"):
        fepre.isosurface(small_grid(), method="dual-contouring")


def test_surface_open_at_a_grid_cut_is_still_oriented():
    cut = ((-1.5, -1.5, 0.0), (1.5, 1.5, 1.5))
    surface = fepre.isosurface(sdf.sphere(1.0), shape=20, bounds=cut, method="dual_contouring")
    check = fepre.check_surface(surface)
    assert surface.n_cells > 0 and not check.watertight and check.oriented


# -- wiring -----------------------------------------------------------------------------------


def test_cli_and_accessor_take_dual_contouring(tmp_path, capsys):
    from fepre.cli import main

    (tmp_path / "block.py").write_text("from fepre import sdf\nmodel = sdf.box((1.0, 2.0, 0.5))\n")
    out = tmp_path / "block.stl"
    assert main(["surface", str(tmp_path / "block.py"), "-o", str(out), "--method", "dual_contouring", "--spacing", "0.1"]) == 0
    assert "watertight" in capsys.readouterr().out
    block = pv.read(out)
    assert block.volume == pytest.approx(1.0, rel=1e-9)  # every edge and corner kept
    grid = fepre.sample(sdf.box((1.0, 2.0, 0.5)), spacing=0.0937)
    surface = grid.fepre.isosurface(method="dual_contouring", model=sdf.box((1.0, 2.0, 0.5)))
    assert fepre.check_surface(surface).volume == pytest.approx(1.0, rel=1e-9)
    assert surface.field_data["surface_method"][0] == "dual_contouring"


def test_rotated_box_keeps_its_corners():
    # creases and corners at an angle to the grid: corners found outside their cell are handed
    # to the cell holding them. The few cells along oblique creases that hold two pieces of
    # surface pinched it (one vertex per cell); each piece has its own vertex now, so the
    # surface is closed and manifold, at a chamfer of those cells' creases (area -0.2%).
    from scipy.spatial.transform import Rotation

    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    model = sdf.box((2.0, 1.5, 1.0)).rotate(40.0, axis=tuple(axis))
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-0.75, 0.75) for z in (-0.5, 0.5)])
    corners = corners @ Rotation.from_rotvec(np.radians(40.0) * axis).as_matrix().T
    assert np.abs(model(corners)).max() < 1e-12
    surface = fepre.isosurface(model, spacing=0.1, method="dual_contouring")
    assert corner_errors(surface, corners).max() < 0.01 * 0.1
    check = fepre.check_surface(surface, model)
    assert check.volume == pytest.approx(3.0, rel=2e-3) and check.area == pytest.approx(13.0, rel=3e-3)
    assert check.mean_sdf_error < 0.005
    assert (check.watertight, check.manifold, check.components, check.genus) == (True, True, 1, 0)
