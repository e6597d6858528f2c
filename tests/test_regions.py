"""fepre.distmesh(..., regions=): conformal multi-material meshes.

Every test checks what a solver relies on: each cell lies in one region, the faces between two
regions lie on the interface (nodes to 1e-3 h), the interface is closed (it ends only on the
part's surface), region volumes match the model's, and both regions meet the quality targets.
"""

from __future__ import annotations

import warnings

import meshio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fepre
from fepre import sdf
from fepre.regions import interface_faces

BAR = sdf.box((2, 1, 1), center=(1, 0.5, 0.5))
LEFT, RIGHT = sdf.box((1, 1, 1), center=(0.5, 0.5, 0.5)), sdf.box((1, 1, 1), center=(1.5, 0.5, 0.5))
MIN_DIHEDRAL = 25.0


def mesh_of(model, h, regions, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error", fepre.ConvergenceWarning)  # the quality targets are met
        return fepre.distmesh(model, h, regions=regions, **kwargs)


def arrays(mesh):
    return np.asarray(mesh.points), np.asarray(mesh.cells_dict[10], dtype=np.int64), np.asarray(mesh["region_id"])


def region_volumes(mesh):
    return np.bincount(mesh["region_id"], mesh["volume"], minlength=len(mesh.field_data["region_names"]))


def open_edges(faces):
    """Edges used by one face of ``faces`` only (the rim of that surface)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique[counts == 1], unique[counts > 2]


def check_region_mesh(mesh, model, regions, h, min_dihedral=MIN_DIHEDRAL):
    """Cells in one region each, interface faces on the interface, interface closed; returns the faces."""
    points, tets, region_ids = arrays(mesh)
    names = list(mesh.field_data["region_names"])
    assert names == list(regions)
    # every node of a cell is in the cell's region or on one of its interfaces (a cell whose
    # nodes all lie on a curved interface may have its centroid just across it)
    values = np.column_stack([regions[n](points) for n in names])
    owner = np.argmin(values, axis=1)
    owner[np.sort(np.abs(values), axis=1)[:, 1] <= 1e-3 * h] = -1
    assert ((owner[tets] == -1) | (owner[tets] == region_ids[:, None])).all()
    centroids = np.column_stack([regions[n](points[tets].mean(axis=1)) for n in names])
    assert (np.argmin(centroids, axis=1) == region_ids).mean() > 0.999
    faces, first, second = interface_faces(tets, region_ids, len(points))
    assert len(faces) > 0
    for a, b in set(zip(region_ids[first].tolist(), region_ids[second].tolist())):
        pair = faces[(region_ids[first] == a) & (region_ids[second] == b)]
        on = np.abs(np.column_stack([regions[names[a]](points[pair.ravel()]), regions[names[b]](points[pair.ravel()])]))
        assert on.max() <= 1e-3 * h
        rim, branching = open_edges(pair)
        assert len(branching) == 0
        # the interface ends only on the part's surface or where a third region meets it
        others = [regions[n](points[rim.ravel()]) for k, n in enumerate(names) if k not in (a, b)]
        ends = np.abs(model(points[rim.ravel()])) <= 1e-3 * h
        for value in others:
            ends |= np.abs(value) <= 1e-3 * h
        assert ends.all()
    assert np.array_equal(mesh["interface"].astype(bool), np.isin(np.arange(len(points)), faces))
    assert (mesh["volume"] > 0).all()
    for k in range(len(names)):
        assert mesh["min_dihedral_angle"][region_ids == k].min() >= min_dihedral
    return faces


def test_bar_in_two_halves():
    h = 0.2
    mesh = mesh_of(BAR, h, {"left": LEFT, "right": RIGHT})
    faces = check_region_mesh(mesh, BAR, {"left": LEFT, "right": RIGHT}, h)
    np.testing.assert_allclose(region_volumes(mesh), [1.0, 1.0], rtol=1e-12)
    points = np.asarray(mesh.points)
    area = 0.5 * np.linalg.norm(np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]]), axis=1)
    assert area.sum() == pytest.approx(1.0, rel=1e-12)  # the interface is the whole square x = 1
    assert int(mesh.field_data["distmesh_interface_faces"][0]) == len(faces)


def test_sphere_core_in_a_ball_has_a_closed_interface():
    h = 0.15
    model, core = sdf.sphere(1.0), sdf.sphere(0.6)
    regions = {"skin": model - core, "core": core}
    mesh = mesh_of(model, h, regions)
    faces = check_region_mesh(mesh, model, regions, h)
    assert len(open_edges(faces)[0]) == 0  # closed: no rim
    points = np.asarray(mesh.points)
    radius = np.linalg.norm(points[np.unique(faces)], axis=1)
    assert np.abs(radius - 0.6).max() <= 1e-3 * h
    exact = 4 / 3 * np.pi * 0.6**3
    core_volume = region_volumes(mesh)[1]
    assert 0.97 * exact < core_volume < exact  # an inscribed polyhedron


@pytest.mark.slow
def test_cube_core_keeps_its_edges_and_corners():
    # The interface's sharp edges are mesh edges: the core is exactly the unit cube.
    h = 0.12
    model, core = sdf.sphere(1.0), sdf.box(1.0)
    regions = {"skin": model - core, "core": core}
    mesh = mesh_of(model, h, regions)
    check_region_mesh(mesh, model, regions, h)
    assert region_volumes(mesh)[1] == pytest.approx(1.0, rel=1e-9)
    points = np.asarray(mesh.points)
    corners = np.array(np.meshgrid(*[[-0.5, 0.5]] * 3)).reshape(3, -1).T
    assert np.linalg.norm(points[:, None] - corners[None], axis=2).min(axis=0).max() <= 1e-9


def test_three_regions_meeting_on_a_line():
    h = 0.2
    regions = {"a": LEFT, "b": sdf.box((1, 0.5, 1), center=(1.5, 0.25, 0.5)), "c": sdf.box((1, 0.5, 1), center=(1.5, 0.75, 0.5))}
    mesh = mesh_of(BAR, h, regions)
    check_region_mesh(mesh, BAR, regions, h)
    np.testing.assert_allclose(region_volumes(mesh), [1.0, 0.5, 0.5], rtol=1e-12)


@pytest.mark.slow
def test_skin_and_gyroid_core():
    # A 1 mm skin around a gyroid core: the interface is the set of patches where the gyroid
    # touches the skin's inner faces; its rims lie on the part's surface.
    h = 0.08
    outer = sdf.box(1.0)
    skin = outer.shell(0.15)
    model = sdf.infill(outer, sdf.gyroid(period=1.0, thickness=0.25), wall=0.15)
    regions = {"skin": skin, "core": outer - skin}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.FeatureWarning)  # gyroid walls meet the skin in tiny steps
        mesh = mesh_of(model, h, regions)
    faces = check_region_mesh(mesh, model, regions, h)
    assert region_volumes(mesh)[0] == pytest.approx(1.0 - 0.7**3, rel=2e-4)  # planes kept; corners where the gyroid meets two faces are cut to h
    points = np.asarray(mesh.points)
    # every interface node lies on the skin's inner faces (|coordinate| = 0.35 for one axis)
    assert np.abs(np.abs(points[np.unique(faces)]).max(axis=1) - 0.35).max() <= 1e-3 * h
    assert len(open_edges(faces)[0]) > 0  # patches, whose rims are on the part's surface (checked above)


@pytest.mark.slow
@settings(max_examples=4, deadline=None, derandomize=True)
@given(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(0.8, 1.2))
def test_a_box_cut_by_a_random_plane(tilt_y, tilt_z, offset):
    # Region volumes against VTK's own clip of the box by the same plane.
    import pyvista as pv

    h = 0.25
    normal = np.array([1.0, tilt_y, tilt_z])
    normal /= np.linalg.norm(normal)
    origin = np.array([offset, 0.5, 0.5])
    below = sdf.plane(tuple(normal), tuple(origin))
    regions = {"below": below, "above": -below}
    mesh = mesh_of(BAR, h, regions, features=True)
    check_region_mesh(mesh, BAR, regions, h)
    box = pv.Box((0, 2, 0, 1, 0, 1)).triangulate()
    box.points = np.asarray(box.points, dtype=np.float64)  # pv.Box is float32
    clipped = box.clip_closed_surface(normal=tuple(normal), origin=tuple(origin))
    expected = 2.0 - clipped.volume
    np.testing.assert_allclose(region_volumes(mesh), [expected, 2.0 - expected], rtol=1e-9)


def test_export_writes_regions_sections_and_interfaces(tmp_path):
    mesh = mesh_of(BAR, 0.25, {"left": LEFT, "right": RIGHT})
    points, tets, region_ids = arrays(mesh)
    faces, _, _ = interface_faces(tets, region_ids, len(points))
    written = fepre.export(mesh, tmp_path / "bar.inp", materials={"left": (1000, 0.3), "right": {"E": 3000, "nu": 0.25}})
    text = (tmp_path / "bar.inp").read_text()
    assert "*SOLID SECTION, ELSET=left, MATERIAL=left" in text and "*SOLID SECTION, ELSET=right, MATERIAL=right" in text
    assert "*SURFACE, NAME=interface_left_right, TYPE=ELEMENT" in text
    assert "*DENSITY" not in text
    # a density, as a third entry or a key, goes into the material (for GRAV loads and dynamics)
    fepre.export(mesh, tmp_path / "heavy.inp", materials={"left": (1000, 0.3, 7.85e-9), "right": {"E": 3000, "nu": 0.25, "density": 2.7e-9}})
    heavy = (tmp_path / "heavy.inp").read_text()
    assert "*ELASTIC\n1.000000000000e+03, 3.000000000000e-01\n*DENSITY\n7.850000000000e-09\n*SOLID SECTION, ELSET=left" in heavy
    assert "*DENSITY\n2.700000000000e-09\n*SOLID SECTION, ELSET=right" in heavy
    with pytest.raises(ValueError, match=r"materials\['left'\] density"):
        fepre.export(mesh, tmp_path / "bad.inp", materials={"left": (1000, 0.3, -1.0), "right": (1000, 0.3)})
    names = list(written.field_data["boundary_names"])
    assert names == ["boundary", "interface_left_right"]
    table = written.field_data["boundary_faces"]
    interface_rows = table[table[:, 2] == 1]
    assert len(interface_rows) == len(faces)
    assert (region_ids[interface_rows[:, 0]] == 0).all()  # given from the first region's side
    # gmsh: physical volumes per region, a physical surface for the interface
    fepre.export(mesh, tmp_path / "bar.msh")
    read = meshio.read(tmp_path / "bar.msh")
    tags = dict(zip([c.type for c in read.cells], read.cell_data["gmsh:physical"]))
    assert sorted(np.unique(tags["tetra"]).tolist()) == [1, 2]
    assert (np.asarray(tags["triangle"]) == 2).sum() == len(faces)  # boundary is 1, the interface 2
    assert np.bincount(np.asarray(tags["tetra"]) - 1).tolist() == np.bincount(region_ids).tolist()
    # XDMF: cell tags and facet tags
    fepre.export(mesh, tmp_path / "bar.xdmf")
    facets = meshio.read(tmp_path / "bar_facets.xdmf")
    assert (np.asarray(facets.cell_data["boundary_id"][0]) == 2).sum() == len(faces)


def test_bad_regions_are_refused():
    with pytest.raises(ValueError, match="'a' and 'b' overlap"):
        fepre.distmesh(BAR, 0.25, regions={"a": sdf.box((1.4, 1, 1), center=(0.7, 0.5, 0.5)), "b": RIGHT})
    with pytest.raises(ValueError, match="uncovered"):
        fepre.distmesh(BAR, 0.25, regions={"a": sdf.box((0.8, 1, 1), center=(0.4, 0.5, 0.5)), "b": RIGHT})
    with pytest.raises(ValueError, match="at least two"):
        fepre.distmesh(BAR, 0.25, regions={"a": LEFT})
    with pytest.raises(TypeError, match="must be a dict"):
        fepre.distmesh(BAR, 0.25, regions=[LEFT, RIGHT])
    with pytest.raises(TypeError, match=r"regions\['b'\] must be a 3D fepre.sdf.SDF"):
        fepre.distmesh(BAR, 0.25, regions={"a": LEFT, "b": lambda p: p[:, 0]})
    with pytest.raises(TypeError, match=r"regions\['b'\] must be a 3D fepre.sdf.SDF"):  # before the regions' size fields
        fepre.distmesh(BAR, (0.1, 0.3), regions={"a": LEFT, "b": 3})
    with pytest.raises(ValueError, match="'1a' is not accepted"):
        fepre.distmesh(BAR, 0.25, regions={"1a": LEFT, "b": RIGHT})
    with pytest.raises(ValueError, match="hold no part of the model"):
        fepre.distmesh(BAR, 0.25, regions={"a": BAR, "b": sdf.sphere(0.2, center=(5, 5, 5))})
    with pytest.raises(ValueError, match="cannot be combined"):
        fepre.distmesh(BAR, 0.25, regions={"a": LEFT, "b": RIGHT}, periodic=2)


def test_bad_materials_are_refused(tmp_path):
    mesh = mesh_of(BAR, 0.3, {"left": LEFT, "right": RIGHT})
    with pytest.raises(ValueError, match=r"missing \['right'\]"):
        fepre.export(mesh, tmp_path / "a.inp", materials={"left": (1, 0.3)})
    with pytest.raises(ValueError, match=r"unknown \['middle'\]"):
        fepre.export(mesh, tmp_path / "a.inp", materials={"left": (1, 0.3), "right": (1, 0.3), "middle": (1, 0.3)})
    with pytest.raises(ValueError, match="only the Abaqus"):
        fepre.export(mesh, tmp_path / "a.msh", materials={"left": (1, 0.3), "right": (1, 0.3)})
    with pytest.raises(ValueError, match=r"materials\['left'\] nu must lie in"):
        fepre.export(mesh, tmp_path / "a.inp", materials={"left": (1, 0.5), "right": (1, 0.3)})
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.slow  # 4 s of the default run on 2 cores
def test_graded_mesh_with_regions():
    # the automatic size field (fine near the ball's surface) with a cube core: edges kept, targets met
    ball, core = sdf.sphere(1.0), sdf.box(0.8)
    regions = {"skin": ball - core, "core": core}
    mesh = mesh_of(ball, (0.06, 0.25), regions)
    check_region_mesh(mesh, ball, regions, 0.06)
    assert region_volumes(mesh)[1] == pytest.approx(0.512, rel=1e-9)


def test_interface_node_under_the_surface_goes_onto_the_rim(monkeypatch):
    # an interface meeting the part's face at 10 degrees (a label meeting a crop's face): a node
    # of it 0.07 h under the face goes onto the rim, 0.071 h away; at RIM_SNAP = 0.05 it stayed,
    # and the whole mesh had it on its boundary, a fixed node off the zero set (MeshingError)
    import fepre.regions.interface as interface
    from fepre.regions.partition import RegionSet

    box, h = sdf.box(1.0), 0.1
    normal = np.array([0.0, np.sin(np.radians(80)), np.cos(np.radians(80))])
    cut = sdf.plane(normal=tuple(normal), point=(0, 0, 0.5))
    regions = RegionSet(("a", "b"), (box & cut, box - cut))
    z = 0.5 - 0.07 * h
    node = np.array([[0.1, -(z - 0.5) * normal[2] / normal[1], z]])
    moved = interface.snap_to_rims(node.copy(), box, regions, (0, 1), h)
    assert np.allclose(moved, [[0.1, 0.0, 0.5]], atol=1e-9)
    assert np.linalg.norm(moved - node) / h == pytest.approx(0.0711, abs=1e-4)
    monkeypatch.setattr(interface, "RIM_SNAP", 0.05)
    assert np.array_equal(interface.snap_to_rims(node.copy(), box, regions, (0, 1), h), node)


def test_graded_regions_name_a_thin_wall_once():
    # the part's size field and each region's see the same plate 1 thick (3 elements need 0.33):
    # one warning names it, where each field used to warn on its own
    plate = sdf.box((12.0, 8.0, 1.0))
    regions = {"left": plate & sdf.box((6.0, 10.0, 3.0), (-3.0, 0.0, 0.0)),
               "right": plate & sdf.box((6.0, 10.0, 3.0), (3.0, 0.0, 0.0))}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = fepre.distmesh(plate, (0.5, 2.0), regions=regions, progress=False)
    fields = [str(w.message) for w in caught if "the size field stops at hmin" in str(w.message)]
    assert len(fields) == 1, fields
    assert "a wall 1 thick" in fields[0] and "would need 0.333" in fields[0]
    assert mesh["volume"].sum() == pytest.approx(96.0, rel=1e-9)
