"""fepre.export: formats read back by meshio, boundary/region tagging, the .inp text, tet10
midside nodes, atomic writes and bad input."""

from __future__ import annotations

import dataclasses
import importlib.util
import os
import re
import subprocess
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest
import pyvista as pv
from hypothesis import given, settings
from hypothesis import strategies as st

import fepre
from fepre import sdf
from fepre.export import BoundaryWarning, FORMATS, tag_boundaries, tag_regions
from fepre.export.atomic import STAGING_PREFIX
from fepre.export.data import FACE_EDGE_NODES
from fepre.export.quadratic import (
    MIN_CORNER_JACOBIAN_RATIO,
    MIN_JACOBIAN_RATIO,
    jacobian_ratios,
    quadratic_tetrahedra,
)

from test_export_meshes import kuhn_ball, kuhn_box

# The block [-1, 1] x [-0.5, 0.5] x [-0.5, 0.5]; its six faces are named by planes (fepre SDFs).
SIDES = {
    "left": sdf.plane((-1, 0, 0), (-1, 0, 0)),
    "right": sdf.plane((1, 0, 0), (1, 0, 0)),
    "front": sdf.plane((0, -1, 0), (0, -0.5, 0)),
    "back": sdf.plane((0, 1, 0), (0, 0.5, 0)),
    "bottom": sdf.plane((0, 0, -1), (0, 0, -0.5)),
}
FACE_AREAS = {"left": 1.0, "right": 1.0, "front": 2.0, "back": 2.0, "bottom": 2.0, "boundary": 2.0}
REGIONS = {"core": sdf.plane((1, 0, 0), (0, 0, 0))}  # cells with centroid x < 0


@pytest.fixture(scope="module")
def block() -> pv.UnstructuredGrid:
    return kuhn_box((-1, -0.5, -0.5), (1, 0.5, 0.5), (6, 3, 3))


def triangle_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    p = points[triangles[:, :3]]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


# ----------------------------------------------------------------------------- tagging
def test_named_faces_cover_each_side_exactly(block):
    faces = tag_boundaries(block, SIDES)
    names = faces.field_data["boundary_names"].tolist()
    assert names == ["left", "right", "front", "back", "bottom", "boundary"]
    points, triangles = np.asarray(faces.points), faces.regular_faces
    areas = triangle_areas(points, triangles)
    ids = faces["boundary_id"]
    for index, name in enumerate(names):
        assert areas[ids == index].sum() == pytest.approx(FACE_AREAS[name], rel=1e-12), name
    # Triangles are oriented outward: normals of "left" point along -x, of the rest (top) along +z.
    p = points[triangles]
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    assert np.allclose(normals[ids == 0], [-1, 0, 0])
    assert np.allclose(normals[ids == 5], [0, 0, 1])
    # element/element_face name the tetrahedron face the triangle is.
    cells = block.cells_dict[pv.CellType.TETRA]
    abaqus_faces = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]])  # S1..S4 (manual)
    from_elements = np.sort(cells[faces["element"]][np.arange(ids.size)[:, None],
                                                    abaqus_faces[faces["element_face"] - 1]], axis=1)
    assert np.array_equal(from_elements, np.sort(triangles, axis=1))


@settings(max_examples=15, deadline=None)
@given(
    size=st.tuples(*[st.floats(0.2, 5.0)] * 3),
    divisions=st.tuples(*[st.integers(1, 4)] * 3),
    angle=st.floats(-3.1, 3.1),
)
def test_tagging_property_sides_of_any_rotated_block(size, divisions, angle):
    # A block of any proportions and subdivision, rotated about z: each named side gets exactly
    # its area, the faces left over are exactly the unnamed top, and every face is tagged once.
    mesh = kuhn_box((0, 0, 0), size, divisions)
    c, s_ = np.cos(angle), np.sin(angle)
    rotation = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]])
    mesh.points = np.asarray(mesh.points) @ rotation.T
    ex, ey = rotation[:, 0], rotation[:, 1]
    sides = {
        "xmin": sdf.plane(-ex, (0, 0, 0)),
        "xmax": sdf.plane(ex, size[0] * ex),
        "ymin": sdf.plane(-ey, (0, 0, 0)),
        "ymax": sdf.plane(ey, size[1] * ey),
        "zmin": sdf.plane((0, 0, -1), (0, 0, 0)),
    }
    faces = tag_boundaries(mesh, sides)
    areas = triangle_areas(np.asarray(faces.points), faces.regular_faces)
    sums = np.bincount(faces["boundary_id"], weights=areas, minlength=6)
    a, b, h = size
    assert np.allclose(sums, [b * h, b * h, a * h, a * h, a * b, a * b], rtol=1e-9)
    assert faces.n_cells == 4 * (divisions[0] * divisions[1] + divisions[1] * divisions[2]
                                 + divisions[0] * divisions[2])


def test_faces_next_to_a_sharp_edge_stay_on_their_side():
    # One layer of coarse elements: top faces have centroids within a quarter of h of the y
    # sides (fepre < 0.9 kept them off only by the normal check); a face joins a side only with
    # all its nodes on it, so even with the normal check off (90 degrees) they stay on the top.
    mesh = kuhn_box((0, 0, 0), (1, 1, 1), (1, 2, 1))
    sides = {"ymin": lambda c: c[:, 1], "ymax": lambda c: c[:, 1] - 1.0}
    faces = tag_boundaries(mesh, sides)
    areas = triangle_areas(np.asarray(faces.points), faces.regular_faces)
    assert np.allclose(np.bincount(faces["boundary_id"], weights=areas), [1.0, 1.0, 4.0])
    loose = tag_boundaries(mesh, sides, boundary_angle=90)
    assert np.allclose(np.bincount(loose["boundary_id"], weights=areas), [1.0, 1.0, 4.0])
    with pytest.raises(ValueError, match="boundary_angle must be in"):
        tag_boundaries(mesh, sides, boundary_angle=120)


def test_callables_and_tolerance(block):
    faces = tag_boundaries(block, {"bottom": lambda c: c[:, 2] + 0.5})
    assert np.count_nonzero(faces["boundary_id"] == 0) == 2 * 6 * 3
    # A plane 0.05 below the bottom (0.13 x the faces' mean edge length of 0.38): the nodes are
    # not on it to the default 1e-3 h, so the set is empty and the warning says how far they are
    # and which tolerance would take them; 0.2 takes them, 0.1 does not.
    shifted = {"bottom": lambda c: c[:, 2] + 0.55}
    with pytest.warns(BoundaryWarning, match=r"'bottom': 0 faces .* none: their nodes lie a median 0.132 h "
                                             r"from it .* pass boundary_tolerance=0.198"):
        faces = tag_boundaries(block, shifted)
    assert np.all(faces["boundary_id"] == 1)
    assert np.count_nonzero(tag_boundaries(block, shifted, boundary_tolerance=0.2)["boundary_id"] == 0) == 36
    with pytest.warns(BoundaryWarning, match="'bottom'"):
        faces = tag_boundaries(block, shifted, boundary_tolerance=0.1)
    assert np.all(faces["boundary_id"] == 1)
    for bad in (0.0, -1e-3, 0.5, float("nan")):
        with pytest.raises(ValueError, match=r"boundary_tolerance must be .*\(0, 0.25\]|boundary_tolerance"):
            tag_boundaries(block, shifted, boundary_tolerance=bad)


def test_overlapping_and_empty_boundaries_warn_with_names(block):
    twice = {"floor": SIDES["bottom"], "base": SIDES["bottom"], "nowhere": sdf.sphere(0.1)}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        faces = tag_boundaries(block, twice)
    messages = [str(w.message) for w in caught if issubclass(w.category, BoundaryWarning)]
    assert any("'base' and 'floor' overlap on 36 faces" in m for m in messages), messages
    assert any("'base', 'nowhere' match no boundary face" in m for m in messages), messages
    assert np.count_nonzero(faces["boundary_id"] == 0) == 36  # ties go to the first name


def test_regions_select_cells_by_centroid(block):
    tagged = tag_regions(block, REGIONS)
    centroids = np.asarray(block.points)[block.cells_dict[pv.CellType.TETRA]].mean(axis=1)
    assert tagged.field_data["region_names"].tolist() == ["core", "volume"]
    assert np.array_equal(tagged["region_id"], np.where(centroids[:, 0] < 0, 0, 1))


# ----------------------------------------------------------------------------- round trips
def expected_sets(mesh):
    faces = tag_boundaries(mesh, SIDES)
    regions = tag_regions(mesh, REGIONS)
    face_counts = np.bincount(faces["boundary_id"], minlength=6)
    region_counts = np.bincount(regions["region_id"], minlength=2)
    return faces, face_counts, region_counts


def counts_by_id(ids, n):
    return np.bincount(np.asarray(ids, dtype=np.int64), minlength=n + 1)[1:]


FORMAT_CASES = [(name, order) for name, f in FORMATS.items() for order in f.orders if name != "exodus"]
EXTENSION = {name: f.extensions[0] for name, f in FORMATS.items()}


@pytest.mark.parametrize("name,order", FORMAT_CASES)
def test_round_trip_through_meshio(tmp_path, block, name, order):
    skip_without_backend(name)
    path = tmp_path / f"part{EXTENSION[name]}"
    out = fepre.export(block, path, order=order, boundaries=SIDES, regions=REGIONS, model=sdf.box((2, 1, 1)))
    faces, face_counts, region_counts = expected_sets(block)
    n_points = block.n_points if order == 1 else out.n_points
    if order == 2:  # one midside node per edge: V - E + F - T = 1 for a ball
        n_edges = n_points - block.n_points
        assert block.n_points - n_edges + (4 * block.n_cells + faces.n_cells) // 2 - block.n_cells == 1
    volume_type, surface_type = ("tetra10", "triangle6") if order == 2 else ("tetra", "triangle")
    back = meshio.read(path)
    assert back.points.shape == (n_points, 3)
    assert np.allclose(back.points, out.points, rtol=0, atol=1e-9)
    blocks = {b.type: i for i, b in enumerate(back.cells)}
    assert len(back.cells[blocks[volume_type]].data) == block.n_cells
    names = ["core", "volume"], ["left", "right", "front", "back", "bottom", "boundary"]
    if name == "abaqus":
        assert set(back.point_sets) == set(names[1])
        assert set(back.cell_sets) == {"EALL", *names[0]}
        for index, region in enumerate(names[0]):
            assert sum(len(s) for s in back.cell_sets[region]) == region_counts[index]
        # A side's node set is every node on that side (sides are closed faces of the block).
        planes = {**SIDES, "boundary": sdf.plane((0, 0, 1), (0, 0, 0.5))}
        for side in names[1]:
            on_side = np.flatnonzero(np.abs(planes[side](np.asarray(out.points))) < 1e-12)
            assert np.array_equal(np.sort(back.point_sets[side]), on_side), side
        assert surface_type not in blocks
        return
    if name == "xdmf":
        facets = meshio.read(tmp_path / "part_facets.xdmf")
        assert {k: v.tolist() for k, v in back.field_data.items()} == {"core": [1, 3], "volume": [2, 3]}
        assert list(facets.field_data) == names[1]
        assert np.array_equal(facets.points, back.points)
        assert facets.cells[0].type == surface_type and len(facets.cells[0].data) == faces.n_cells
        assert np.array_equal(counts_by_id(back.cell_data["region_id"][0], 2), region_counts)
        assert np.array_equal(counts_by_id(facets.cell_data["boundary_id"][0], 6), face_counts)
        return
    if name == "vtu":  # the tagged grid: tetrahedra only, boundary faces as field data
        assert list(blocks) == [volume_type]
        # each set's faces and area travel too (the block's sides, exactly)
        assert back.field_data["boundary_areas"] == pytest.approx([FACE_AREAS[n] for n in names[1]], rel=1e-12)
        assert back.field_data["boundary_face_counts"].tolist() == face_counts.tolist()
        sets_only = ("boundary_faces", "boundary_areas", "boundary_face_counts")
        assert {k: v.tolist() for k, v in back.field_data.items() if k not in sets_only} == {
            **{n: [i, 3] for i, n in enumerate(names[0])},
            **{n: [i, 2] for i, n in enumerate(names[1])},
        }
        assert np.array_equal(counts_by_id(back.cell_data["region_id"][0] + 1, 2), region_counts)
        assert np.array_equal(counts_by_id(back.field_data["boundary_faces"][:, 2] + 1, 6), face_counts)
        return
    assert len(back.cells[blocks[surface_type]].data) == faces.n_cells
    if name == "gmsh22":
        assert {k: v.tolist() for k, v in back.field_data.items()} == {
            **{n: [i + 1, 3] for i, n in enumerate(names[0])},
            **{n: [i + 1, 2] for i, n in enumerate(names[1])},
        }
    key = {"gmsh22": "gmsh:physical", "nastran": "nastran:ref", "medit": "medit:ref",
           "med": "cell_tags"}[name]
    if name == "med":
        tags = {int(k): v for k, v in back.cell_tags.items()}
        assert tags == {-1: ["core"], -2: ["volume"], **{-(3 + i): [n] for i, n in enumerate(names[1])}}
        volume_ids = -back.cell_data[key][blocks[volume_type]]
        surface_ids = -back.cell_data[key][blocks[surface_type]] - 2
        # MED numbers tetrahedra with the opposite orientation to VTK's.
        corners = back.cells[blocks[volume_type]].data[:, :4]
        p = back.points[corners]
        det = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
        assert np.all(det < 0)
    else:
        volume_ids = back.cell_data[key][blocks[volume_type]]
        surface_ids = back.cell_data[key][blocks[surface_type]]
    assert np.array_equal(counts_by_id(volume_ids, 2), region_counts)
    assert np.array_equal(counts_by_id(surface_ids, 6), face_counts)


def backend_missing(name: str) -> bool:
    backend = FORMATS[name].backend
    return backend is not None and importlib.util.find_spec(backend[0]) is None


def skip_without_backend(name: str) -> None:
    if backend_missing(name):
        pytest.skip(f"format {name!r} needs the optional package {FORMATS[name].backend[1]!r}")


@pytest.mark.parametrize("name", [n for n, f in FORMATS.items() if f.backend is not None])
def test_optional_backends(tmp_path, block, name):
    path = tmp_path / f"part{EXTENSION[name]}"
    package = FORMATS[name].backend[1]
    if backend_missing(name):  # a clear error naming the package, and nothing written
        with pytest.raises(ImportError, match=f"needs the Python package '{package}'.*pip install {package}"):
            fepre.export(block, path, boundaries=SIDES)
        assert list(tmp_path.iterdir()) == []
    else:  # the backend is installed: a real round trip
        fepre.export(block, path, boundaries=SIDES)
        back = meshio.read(path)
        assert len(back.points) == block.n_points
        assert sum(len(b.data) for b in back.cells if b.type == "tetra") == block.n_cells


# ----------------------------------------------------------------------------- the .inp text
def test_inp_text(tmp_path, block):
    model = sdf.box((2, 1, 1))
    fepre.export(block, tmp_path / "part.inp", order=2, boundaries=SIDES, regions=REGIONS, model=model)
    text = (tmp_path / "part.inp").read_text()
    lines = text.splitlines()
    assert lines[0] == "*HEADING" and lines[1].startswith("fepre ") and model.describe() in lines[1]
    node_start = lines.index("*NODE, NSET=NALL") + 1
    element_header = next(i for i, line in enumerate(lines) if line.startswith("*ELEMENT"))
    assert lines[element_header] == "*ELEMENT, TYPE=C3D10, ELSET=EALL"
    fields = [f.strip() for line in lines[node_start:element_header] for f in line.split(",")]
    assert len(fields) == 4 * (element_header - node_start)
    assert max(len(f) for f in fields) <= 20  # CalculiX reads at most 20 characters per field
    assert len(re.findall(r"^\*SURFACE, NAME=(\w+), TYPE=ELEMENT$", text, flags=re.M)) == 6
    # every *SURFACE line names an element face S1..S4 whose nodes lie on that side
    points = np.array([[float(v) for v in line.split(",")[1:]] for line in lines[node_start:element_header]])
    elements = np.array([[int(v) for v in line.split(",")] for line in lines[element_header + 1 :
                         element_header + 1 + block.n_cells]])
    match = re.search(r"^\*SURFACE, NAME=left, TYPE=ELEMENT\n((?:\d+, S\d\n)+)", text, flags=re.M)
    entries = np.array([[int(e), int(s[1])] for e, s in (row.split(", ") for row in match.group(1).split("\n") if row)])
    abaqus_faces = np.array([[1, 2, 3], [1, 4, 2], [2, 4, 3], [3, 4, 1]])  # C3D4/C3D10 faces, manual
    corner_ids = elements[entries[:, 0] - 1][np.arange(len(entries))[:, None], abaqus_faces[entries[:, 1] - 1]]
    assert np.allclose(points[corner_ids - 1][:, :, 0], -1.0)


def test_returned_mesh_carries_tags(tmp_path, block):
    out = fepre.export(block, tmp_path / "part.vtu", boundaries=SIDES, regions=REGIONS)
    assert out.field_data["boundary_names"].tolist()[:5] == list(SIDES)
    assert np.array_equal(out["region_id"], tag_regions(block, REGIONS)["region_id"])
    ids = out["boundary_id"]
    points = np.asarray(out.points)
    assert np.all(ids[np.isclose(points[:, 0], -1)] == 0)  # "left" is the first name
    interior = np.all(np.abs(points) < [0.99, 0.49, 0.49], axis=1)
    assert np.all(ids[interior] == -1) and np.all(ids[~interior] >= 0)


# ----------------------------------------------------------------------------- tet10
def tet10_volume(grid) -> float:
    """Volume of a quadratic tetrahedral mesh by the 4-point Gauss rule on each element."""
    from fepre.export.quadratic import _DN

    nodes = np.asarray(grid.points)[grid.cells_dict[pv.CellType.QUADRATIC_TETRA]]
    det = np.linalg.det(np.einsum("mak,qal->mqkl", nodes, _DN[:4]))
    return float(det.sum() / 24.0)


def test_curved_midside_nodes_lie_on_the_sphere(tmp_path):
    ball = sdf.sphere(1.0)
    mesh = kuhn_ball(4)
    curved = fepre.export(mesh, tmp_path / "ball.msh", order=2, model=ball)
    straight = fepre.export(mesh, tmp_path / "flat.msh", order=2)
    cells = curved.cells_dict[pv.CellType.QUADRATIC_TETRA]
    points = np.asarray(curved.points)
    r = np.linalg.norm(points, axis=1)
    on_sphere = np.isclose(r[: mesh.n_points], 1.0, atol=1e-12)
    edge_pairs = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])
    ends = cells[:, edge_pairs]  # (M, 6, 2)
    mids = cells[:, 4:]
    boundary_edge = on_sphere[ends].all(axis=2)
    # Boundary edges of this mesh have both ends on the sphere; their midside nodes now are too.
    faces = tag_boundaries(mesh)
    assert np.all(on_sphere[faces.regular_faces])
    local = FACE_EDGE_NODES[faces["element_face"] - 1]
    surface_mids = np.unique(cells[faces["element"]][np.arange(faces.n_cells)[:, None], local])
    curved_count = int(curved.field_data["curved_midside_nodes"][0])
    straightened = int(curved.field_data["straightened_midside_nodes"][0])
    assert curved_count + straightened == surface_mids.size == 288
    assert straightened <= 0.1 * surface_mids.size
    assert np.count_nonzero(np.abs(r[surface_mids] - 1.0) < 1e-12) == curved_count
    interior = np.setdiff1d(np.unique(mids), surface_mids)
    midpoint = points[ends].mean(axis=2)
    inside_mid = np.isin(mids, interior)
    assert np.allclose(points[mids[inside_mid]], midpoint[inside_mid], atol=1e-15)
    assert boundary_edge.sum() >= surface_mids.size
    gauss, corner = jacobian_ratios(points, cells)
    assert gauss.min() >= MIN_JACOBIAN_RATIO and corner.min() >= MIN_CORNER_JACOBIAN_RATIO
    # The curved mesh's volume (Gauss quadrature of det J) is much closer to the ball's.
    exact = 4 / 3 * np.pi
    assert abs(tet10_volume(curved) - exact) < 0.1 * abs(tet10_volume(straight) - exact)


def test_bad_projection_falls_back_to_straight_midpoints():
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0.2]])
    cells = np.array([[0, 1, 2, 3]])
    boundary = fepre.export.boundaries.boundary_faces(cells)[2]

    class Inward:
        """A model whose projection pulls every midside node 40% of its edge towards the middle."""

        def project(self, points):
            return points + 0.4 * (corners.mean(axis=0) - points) * 3

    result = quadratic_tetrahedra(corners.astype(float), cells, boundary, Inward())
    assert result.straightened > 0
    gauss, corner = jacobian_ratios(result.points, result.cells)
    assert gauss.min() >= MIN_JACOBIAN_RATIO and corner.min() >= MIN_CORNER_JACOBIAN_RATIO
    mids = result.points[result.cells[0, 4:]]
    ends = corners[np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])].mean(axis=1)
    moved = ~np.all(np.isclose(mids, ends), axis=1)
    assert moved.sum() == result.curved


# ----------------------------------------------------------------------------- bad input
def test_unknown_format_lists_accepted(tmp_path, block):
    with pytest.raises(ValueError, match=r"extension '\.foo'.*abaqus \(\.inp\)"):
        fepre.export(block, tmp_path / "part.foo")
    with pytest.raises(ValueError, match="format 'stl' is not known.*gmsh22"):
        fepre.export(block, tmp_path / "part.inp", format="stl")
    with pytest.raises(ValueError, match="medit.*supports order"):
        fepre.export(block, tmp_path / "part.mesh", order=2)
    with pytest.raises(ValueError, match="order must be one of 1, 2"):
        fepre.export(block, tmp_path / "part.inp", order=3)
    assert list(tmp_path.iterdir()) == []


def test_non_tetrahedral_and_inverted_cells_are_refused(tmp_path, block):
    hexes = pv.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid()
    with pytest.raises(ValueError, match="8 of 8 cells are VOXEL"):
        fepre.export(hexes, tmp_path / "part.inp")
    with pytest.raises(TypeError, match="UnstructuredGrid"):
        fepre.export(pv.Sphere(), tmp_path / "part.inp")
    cells = block.cells_dict[pv.CellType.TETRA].copy()
    cells[7] = cells[7][[1, 0, 2, 3]]  # inverted
    cells[11, 3] = cells[11, 0]  # degenerate: zero volume
    inverted = pv.UnstructuredGrid({pv.CellType.TETRA: cells}, block.points)
    p = np.asarray(block.points)[cells]
    volumes = np.linalg.det(p[:, 1:] - p[:, :1]) / 6
    worst = int(np.argmin(volumes))
    assert worst == 7 and volumes[11] == 0
    with pytest.raises(ValueError, match=rf"2 inverted .* cell {worst} with volume {volumes[worst]:.6g}"):
        fepre.export(inverted, tmp_path / "part.inp")
    assert list(tmp_path.iterdir()) == []


def test_bad_boundaries_and_names(tmp_path, block):
    with pytest.raises(TypeError, match="boundaries must be a dict"):
        fepre.export(block, tmp_path / "a.inp", boundaries=[SIDES["left"]])
    with pytest.raises(ValueError, match="set name 'two words'"):
        fepre.export(block, tmp_path / "a.inp", boundaries={"two words": SIDES["left"]})
    with pytest.raises(ValueError, match="'Left' and 'left' differ only in case"):
        fepre.export(block, tmp_path / "a.inp", boundaries={"Left": SIDES["left"], "left": SIDES["left"]})
    with pytest.raises(ValueError, match=r"boundaries\['x'\] must return one value per point"):
        fepre.export(block, tmp_path / "a.inp", boundaries={"x": lambda c: c})
    with pytest.raises(ValueError, match="also a region name"):
        fepre.export(block, tmp_path / "a.inp", boundaries={"core": SIDES["left"]}, regions=REGIONS)
    assert list(tmp_path.iterdir()) == []


def test_missing_directory_and_overwrite(tmp_path, block):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        fepre.export(block, tmp_path / "missing" / "part.inp")
    target = tmp_path / "part.inp"
    target.write_text("keep me")
    with pytest.raises(FileExistsError, match="overwrite=False"):
        fepre.export(block, target, overwrite=False)
    assert target.read_text() == "keep me"
    fepre.export(block, target)
    assert target.read_text().startswith("*HEADING")
    (tmp_path / "part_facets.xdmf").write_text("keep me")  # one of XDMF's four files exists
    with pytest.raises(FileExistsError, match="part_facets.xdmf"):
        fepre.export(block, tmp_path / "part.xdmf", overwrite=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["part.inp", "part_facets.xdmf"]


def test_failure_while_writing_leaves_nothing(tmp_path, block, monkeypatch):
    def broken(directory, filename, data):
        (directory / filename).write_text("half")
        raise OSError("disk full")


    monkeypatch.setitem(FORMATS, "abaqus", dataclasses.replace(FORMATS["abaqus"], writer=broken))
    with pytest.raises(OSError, match="disk full"):
        fepre.export(block, tmp_path / "part.inp")
    assert list(tmp_path.iterdir()) == []


def test_no_write_permission(tmp_path, block):
    directory = tmp_path / "locked"
    directory.mkdir()
    directory.chmod(0o555)
    immutable = False
    if os.geteuid() == 0:  # root ignores file modes; an immutable directory refuses even root
        immutable = subprocess.run(["chattr", "+i", str(directory)], capture_output=True).returncode == 0
        if not immutable:  # a filesystem without attributes: sysfs refuses new files to root
            directory = Path("/sys")
    try:
        with pytest.raises(PermissionError, match="no permission to write in directory"):
            fepre.export(block, directory / "part.inp")
        assert not any(p.name.startswith(STAGING_PREFIX) for p in directory.iterdir())
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(directory)], check=True)
        directory.chmod(0o755) if directory != Path("/sys") else None


def test_package_is_callable_and_accessor_exports(tmp_path, block):
    # fepre.export is both the package (fepre.export.tag_boundaries) and the function.
    assert fepre.export.tag_boundaries is tag_boundaries
    out = fepre.export(block, tmp_path / "a.inp", boundaries={"bottom": SIDES["bottom"]})
    accessor = block.fepre.export(tmp_path / "b.inp", boundaries={"bottom": SIDES["bottom"]})
    assert (tmp_path / "a.inp").read_text() == (tmp_path / "b.inp").read_text()
    assert np.array_equal(out["boundary_id"], accessor["boundary_id"])


@pytest.fixture(scope="module")
def bracket_mesh():
    part = sdf.box((2, 1, 1)) - sdf.cylinder(radius=0.25, height=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        return fepre.distmesh(part, h=0.25)


def names_read_back(name: str, path: Path) -> set[str]:
    """The set names a format carries, as meshio reads them back."""
    back = meshio.read(path)
    if name == "abaqus":
        return set(back.point_sets) | set(back.cell_sets) - {"EALL"}
    if name == "xdmf":
        return set(back.field_data) | set(meshio.read(path.with_name(path.stem + "_facets.xdmf")).field_data)
    if name == "med":
        return {n for names in back.cell_tags.values() for n in names}
    if name in ("nastran", "medit"):  # integer ids only
        key = f"{name}:ref"
        return {f"id{i}" for block in back.cell_data[key] for i in np.unique(block)}
    if name == "vtu":  # a set named like a point or cell array is written as <name>_set
        arrays = set(back.point_data) | set(back.cell_data)
        return {n[:-4] if n.endswith("_set") and n[:-4] in arrays else n for n in back.field_data} - {"boundary_faces", "boundary_areas", "boundary_face_counts"}
    return set(back.field_data) - {"boundary_faces"}


@pytest.mark.parametrize("name", [n for n in FORMATS if n != "exodus"])
def test_round_trip_distmesh_bracket(tmp_path, bracket_mesh, name):
    skip_without_backend(name)
    boundaries = {"hole": sdf.cylinder(radius=0.25, height=2), "fixed": sdf.plane((-1, 0, 0), (-1, 0, 0))}
    path = tmp_path / f"bracket{EXTENSION[name]}"
    fepre.export(bracket_mesh, path, boundaries=boundaries)
    back = meshio.read(path)
    faces = tag_boundaries(bracket_mesh, boundaries)
    assert len(back.points) == bracket_mesh.n_points
    counts = {block.type: len(block.data) for block in back.cells}
    assert counts["tetra"] == bracket_mesh.n_cells
    assert counts.get("triangle", faces.n_cells) == faces.n_cells
    if name == "vtu":
        assert len(back.field_data["boundary_faces"]) == faces.n_cells
    expected = {"volume", "hole", "fixed", "boundary"}
    if name in ("nastran", "medit"):
        expected = {"id1", "id2", "id3"}  # volume 1 on tetrahedra; hole, fixed, boundary 1..3
    assert names_read_back(name, path) == expected


def test_midside_nodes_of_feature_curve_edges_lie_on_both_surfaces(tmp_path):
    # A washer's rims are circles where a flat face meets a cylinder. Projected onto the model
    # alone, a rim edge's midside node stayed on the chord (the flat face is nearer than the
    # cylinder), a sagitta of about 0.08 inside the radius 25 at h = 4; now every rim midside node is on the circle.
    part = sdf.cylinder(radius=25.0, height=10.0) - sdf.cylinder(radius=10.0, height=30.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(part, h=4.0)
    grid = fepre.export(mesh, tmp_path / "washer.vtu", order=2, model=part)
    points = np.asarray(grid.points)
    cells = grid.cells_dict[pv.CellType.QUADRATIC_TETRA]
    radius = np.hypot(points[:, 0], points[:, 1])
    ends = cells[:, [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]]]
    mids = cells[:, 4:]
    for rim, z in [(25.0, 5.0), (25.0, -5.0), (10.0, 5.0), (10.0, -5.0)]:
        on_rim = (np.abs(radius - rim) < 1e-9) & (np.abs(points[:, 2] - z) < 1e-9)
        rim_edges = on_rim[ends].all(axis=2) & (np.linalg.norm(np.diff(points[ends], axis=2)[..., 0, :], axis=2) < 8.0)
        rim_mids = np.unique(mids[rim_edges])
        assert rim_mids.size >= 2 * np.pi * rim / 4.0 * 0.8  # about one edge per h along the circle
        assert np.abs(radius[rim_mids] - rim).max() < 1e-8
        assert np.abs(points[rim_mids, 2] - z).max() < 1e-8


def test_a_failing_writer_names_the_users_path_not_the_staging_folder(tmp_path):
    # Messages showed internal temporary names such as "romnt/.fepre-export-n1zept6b".
    from fepre.export.atomic import STAGING_PREFIX, staged_files

    target = tmp_path / "part.stl"
    with pytest.raises(OSError) as caught:
        with staged_files(target, [target.name], overwrite=True) as stage:
            raise OSError(f"cannot write {stage / target.name}: disk full")
    assert str(caught.value) == f"cannot write {target}: disk full"
    assert STAGING_PREFIX not in str(caught.value) and list(tmp_path.iterdir()) == []
