"""TPMS lattices: proven gradient bounds, sheet/network forms and infill."""

from __future__ import annotations

import numpy as np
import pytest

from fepre import sdf


def _raw_gradient_norm(name, x, y, z):
    """|grad g| / k of the raw implicit functions, differentiated by hand (independently)."""
    sx, cx, sy, cy, sz, cz = np.sin(x), np.cos(x), np.sin(y), np.cos(y), np.sin(z), np.cos(z)
    if name == "gyroid":
        g = (cx * cy - sz * sx, -sx * sy + cy * cz, -sy * sz + cz * cx)
    elif name == "schwarz_p":
        g = (-sx, -sy, -sz)
    elif name == "schwarz_d":
        g = (
            cx * sy * sz + cx * cy * cz - sx * sy * cz - sx * cy * sz,
            sx * cy * sz - sx * sy * cz + cx * cy * cz - cx * sy * sz,
            sx * sy * cz - sx * cy * sz - cx * sy * sz + cx * cy * cz,
        )
    else:
        g = (-sx * (3 + 4 * cy * cz), -sy * (3 + 4 * cx * cz), -sz * (3 + 4 * cx * cy))
    return np.sqrt(sum(c * c for c in g))


@pytest.mark.parametrize("name, sampled_max", [("gyroid", 1.0), ("schwarz_p", 1.0), ("schwarz_d", 1.0), ("neovius", 7 / np.sqrt(50))])
def test_gradient_bound_holds_on_a_dense_grid(name, sampled_max):
    lattice = getattr(sdf, name)(period=1.0, form="network")
    t = np.linspace(0, 2 * np.pi, 121)
    x, y, z = np.meshgrid(t, t, t, indexing="ij", sparse=True)
    ratio = _raw_gradient_norm(name, x, y, z).max() / lattice.gradient_bound
    # The bound holds and is tight to the sampled maximum.
    assert ratio <= 1.0 + 1e-12
    assert ratio == pytest.approx(sampled_max, abs=2e-3)
    # The node's own (finite difference) gradient agrees: 1-Lipschitz.
    points = np.random.default_rng(3).uniform(-2, 2, (20000, 3))
    assert np.linalg.norm(lattice.gradient(points), axis=1).max() <= 1 + 1e-6


@pytest.mark.parametrize("make", [sdf.gyroid, sdf.schwarz_p, sdf.schwarz_d, sdf.neovius])
@pytest.mark.parametrize("form", ["sheet", "network"])
def test_lattices_are_1_lipschitz_unbounded_and_inexact(make, form):
    lattice = make(period=0.7, thickness=0.08, form=form)
    assert lattice.bounds is None and not lattice.exact
    rng = np.random.default_rng(5)
    p = rng.uniform(-3, 3, (20000, 3))
    q = p + rng.normal(scale=0.1, size=p.shape)
    assert np.all(np.abs(lattice(p) - lattice(q)) <= np.linalg.norm(p - q, axis=1) * (1 + 1e-9) + 1e-12)


def test_sheet_and_network_forms():
    period, thickness = 2.0, 0.2
    k = 2 * np.pi / period
    p = np.random.default_rng(1).uniform(-2, 2, (5000, 3))
    x, y, z = (k * p).T
    g = (np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)) / (k * np.sqrt(3))
    np.testing.assert_allclose(sdf.gyroid(period, thickness)(p), np.abs(g) - thickness / 2, atol=1e-12)
    np.testing.assert_allclose(sdf.gyroid(period, thickness, form="network")(p), g - thickness / 2, atol=1e-12)
    shifted = sdf.gyroid(period, thickness, center=(0.3, 0, 0))
    np.testing.assert_allclose(shifted(p + [0.3, 0, 0]), sdf.gyroid(period, thickness)(p), atol=1e-12)
    # The sheet's true wall is at least ``thickness`` thick: walking along the gradient from the
    # mid-surface, the value needs at least thickness / 2 to reach zero.
    sheet = sdf.gyroid(period, thickness)
    on_surface = sdf.gyroid(period, 1e-9, form="network").project(p[:200], iterations=30)
    assert np.all(sheet(on_surface) <= -thickness / 2 + 1e-6)


def test_infill_keeps_a_wall_and_fills_the_inside_with_the_lattice():
    part = sdf.box((4.0, 4.0, 4.0))
    lattice = sdf.gyroid(period=1.0, thickness=0.1)
    wall = 0.3
    light = sdf.infill(part, lattice, wall)
    assert light.bounds == part.bounds
    rng = np.random.default_rng(2)
    p = rng.uniform(-2.5, 2.5, (50000, 3))
    v, inside, lat = light(p), part(p), lattice(p)
    # Outside the part: outside the infill.
    assert np.all(v[inside > 0] > 0)
    # In the wall: solid.
    assert np.all(v[(inside < 0) & (inside > -wall)] < 0)
    # Deeper in: solid exactly where the lattice is.
    deep = inside < -wall - 1e-9
    assert np.array_equal(v[deep] < 0, lat[deep] < 0)
    assert 0.05 < np.mean(v[deep] < 0) < 0.5


def test_bad_lattice_input():
    with pytest.raises(ValueError, match="period must be > 0"):
        sdf.gyroid(period=0)
    with pytest.raises(ValueError, match="thickness"):
        sdf.schwarz_p(thickness=-1)
    with pytest.raises(ValueError, match="form must be one of 'sheet', 'network'"):
        sdf.neovius(form="solid")
    with pytest.raises(ValueError, match="period must be finite"):
        sdf.schwarz_d(period=float("inf"))
    with pytest.raises(TypeError, match="infill operand 1"):
        sdf.infill(sdf.sphere(1), "gyroid", 0.1)
    with pytest.raises(ValueError, match="wall must be > 0"):
        sdf.infill(sdf.sphere(1), sdf.gyroid(), 0)


@pytest.mark.parametrize(
    "name, mean, thickest, thinnest",
    [("gyroid", 1.13, 1.22, 1.0), ("schwarz_p", 1.32, 1.73, 1.0), ("schwarz_d", 1.16, 1.22, 1.0),
     ("neovius", 2.75, 7.1, 1.36)],
)
def test_sheet_walls_are_at_least_thickness_and_as_documented(name, mean, thickest, thinnest):
    # A user asked for 1.2 and measured 1.27: the documented figures are the wall measured along
    # the surface normal (bisection on the sheet's value) over one cell, area-weighted.
    import pyvista as pv

    period, thickness = 1.0, 0.01
    sheet = getattr(sdf, name)(period=period, thickness=thickness)
    network = getattr(sdf, name)(period=period, thickness=1e-9, form="network")  # g / G
    n = 60
    grid = pv.ImageData(dimensions=(n + 1,) * 3, spacing=(period / n,) * 3)
    grid.point_data["g"] = network(np.asarray(grid.points))
    surface = grid.contour([0.0], scalars="g").compute_cell_sizes()
    start = np.asarray(surface.cell_centers().points)
    start = network.project(start)
    normal = network.gradient(start)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    sides = []
    for sign in (1.0, -1.0):
        lo, hi = np.zeros(len(start)), np.full(len(start), 10 * thickness)
        for _ in range(50):
            middle = 0.5 * (lo + hi)
            inside = sheet(start + sign * middle[:, None] * normal) < 0
            lo, hi = np.where(inside, middle, lo), np.where(inside, hi, middle)
        sides.append(lo)
    wall = (sides[0] + sides[1]) / thickness
    area = np.asarray(surface["Area"])
    assert wall.min() >= thinnest * 0.995
    assert (wall * area).sum() / area.sum() == pytest.approx(mean, abs=0.03)
    assert np.percentile(wall, 99.9) <= thickest * 1.02
