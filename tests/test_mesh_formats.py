"""Triangle-mesh models from the files users have: STL (ASCII and binary, several solids), OBJ
(polygons, negative indices, groups), PLY (ASCII and binary, faces or triangle strips,
``vertex_indices`` or ``vertex_index``, extra properties), OFF and VTK formats. Every file here
holds the unit cube, so each reads to volume 1 and the unit box; so do volume meshes of it
(Medit, gmsh, Abaqus/CalculiX, VTU), whose boundary is the model."""

from __future__ import annotations

import struct
import subprocess
import sys

import numpy as np
import pytest
import pyvista as pv

from fepre import sdf
from fepre.sdf.meshmodel import MeshInputError
from fepre.sdf.meshmodel.formats import strip_triangles

VERTICES = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
QUADS = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [1, 2, 6, 5], [3, 0, 4, 7]]  # outward
TRIANGLES = [t for q in QUADS for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])]
STRIPS = [i for q in QUADS for i in (q[0], q[1], q[3], q[2], -1)]  # one strip of two triangles a quad


def _ply_header(fmt: str, faces: str, vertex_extra: str = "", face_extra: str = "") -> str:
    return (f"ply\nformat {fmt} 1.0\ncomment made by fepre's tests\nelement vertex 8\nproperty float x\n"
            f"property float y\nproperty float z\n{vertex_extra}{faces}{face_extra}end_header\n")


def write_ply_ascii(path, key="vertex_indices", extra=False):
    header = _ply_header("ascii", f"element face 6\nproperty list uchar int {key}\n",
                         "property uchar red\nproperty float confidence\n" if extra else "",
                         "property uchar flags\n" if extra else "")
    rows = [" ".join(map(str, v)) + (" 255 0.5" if extra else "") for v in VERTICES]
    rows += ["4 " + " ".join(map(str, q)) + (" 1" if extra else "") for q in QUADS]
    path.write_text(header + "\n".join(rows) + "\n")


def write_ply_binary(path):
    header = _ply_header("binary_little_endian", "element face 6\nproperty list uchar int vertex_indices\n",
                         "property double quality\n")
    vertex = np.zeros(8, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("quality", "<f8")])
    for k, axis in enumerate("xyz"):
        vertex[axis] = VERTICES[:, k]
    faces = b"".join(struct.pack("<B4i", 4, *q) for q in QUADS)
    path.write_bytes(header.encode() + vertex.tobytes() + faces)


def write_ply_strips(path, binary):
    fmt = "binary_little_endian" if binary else "ascii"
    header = _ply_header(fmt, "element tristrips 1\nproperty list int int vertex_indices\n")
    if binary:
        body = VERTICES.astype("<f4").tobytes() + struct.pack("<i", len(STRIPS)) + np.array(STRIPS, "<i4").tobytes()
        path.write_bytes(header.encode() + body)
    else:
        rows = [" ".join(map(str, v)) for v in VERTICES] + [f"{len(STRIPS)} " + " ".join(map(str, STRIPS))]
        path.write_text(header + "\n".join(rows) + "\n")


def write_obj(path):
    rows = ["# the unit cube", "o cube", *("v " + " ".join(map(str, v)) for v in VERTICES), "vt 0 0", "vn 0 0 1"]
    for k, quad in enumerate(QUADS):
        if k % 2 == 0:
            rows.append(f"g side{k}")
        # negative indices count back from the last vertex; v/vt/vn triplets on odd faces
        rows.append("f " + " ".join(str(i - 8) if k % 2 == 0 else f"{i + 1}/1/1" for i in quad))
    path.write_text("\n".join(rows) + "\n")


def write_rhino_obj(path):
    """The unit cube as Rhino writes OBJ files: a material library, an empty material name (VTK's
    reader fails on it) and faces continued over lines ending in a backslash."""
    rows = ["# Rhino", "", "mtllib 00.mtl", "usemtl ", *("v " + " ".join(map(str, v)) for v in VERTICES), "vt 0 0", "vn 0 0 1"]
    for quad in QUADS:
        corners = [f"{i + 1}/1/1" for i in quad]
        rows += ["f " + " ".join(corners[:2]) + " \\", " ".join(corners[2:])]
    path.write_text("\n".join(rows) + "\n")


def write_cad_stl(path):
    """The unit cube as an ASCII STL whose writer gave the vertices at z = 0 coordinates that differ
    in the last bits from triangle to triangle (0, -2.7e-16, 5.8e-20), as CAD exports do."""
    noise = [0.0, -2.73184801e-16, 5.82611532e-20]
    rows = ["solid cad"]
    for k, t in enumerate(TRIANGLES):
        p = VERTICES[t].copy()
        p[:, 2] = np.where(p[:, 2] == 0, noise[k % 3], p[:, 2])
        rows += [" facet normal 0 0 0", "  outer loop", *(f"   vertex {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in p),
                 "  endloop", " endfacet"]
    path.write_text("\n".join(rows + ["endsolid cad"]) + "\n")


def write_off(path, header="OFF"):
    colour = " 0.5 0.5 0.5 1" if "C" in header else ""
    rows = [header, "# a comment", "8 6 0", *(" ".join(map(str, v)) + colour for v in VERTICES)]
    rows += ["4 " + " ".join(map(str, q)) + (" 255 0 0" if "C" in header else "") for q in QUADS]
    path.write_text("\n".join(rows) + "\n")


def write_stl_two_solids(path):
    rows = []
    for name, offset in (("a", 0.0), ("b", 3.0)):
        rows.append(f"solid {name}")
        for t in TRIANGLES:
            p = VERTICES[t] + [offset, 0, 0]
            n = np.cross(p[1] - p[0], p[2] - p[0])
            rows += [f" facet normal {n[0]} {n[1]} {n[2]}", "  outer loop", *(f"   vertex {x} {y} {z}" for x, y, z in p),
                     "  endloop", " endfacet"]
        rows.append(f"endsolid {name}")
    path.write_text("\n".join(rows) + "\n")


KUHN = np.array([[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]])  # positive


def write_volume(path, kind="tetra", file_format=None):
    """The unit cube as a volume mesh: six tetrahedra (with its boundary triangles and an inner
    triangle tagged, as Medit and gmsh files carry them) or one hexahedron."""
    import meshio

    if kind == "tetra":
        inner = np.array([[0, 2, 6]])  # a tagged face inside the part: must not become a sheet
        cells = [("tetra", KUHN), ("triangle", np.concatenate([np.array(TRIANGLES), inner]))]
    else:
        cells = [("hexahedron", np.array([[0, 1, 2, 3, 4, 5, 6, 7]]))]
    meshio.write(path, meshio.Mesh(VERTICES, cells), file_format=file_format)


WRITERS = {
    "ascii.ply": write_ply_ascii,
    "vertex_index.ply": lambda p: write_ply_ascii(p, key="vertex_index"),
    "extra.ply": lambda p: write_ply_ascii(p, extra=True),
    "binary.ply": write_ply_binary,
    "strips.ply": lambda p: write_ply_strips(p, binary=False),
    "strips_binary.ply": lambda p: write_ply_strips(p, binary=True),
    "groups.obj": write_obj,
    "rhino.obj": write_rhino_obj,
    "cad.stl": write_cad_stl,
    "cube.off": write_off,
    "colours.off": lambda p: write_off(p, "COFF"),
    "binary.stl": lambda p: pv.PolyData.from_regular_faces(VERTICES, np.array(TRIANGLES)).save(p, binary=True),
    "cube.vtp": lambda p: pv.PolyData.from_regular_faces(VERTICES, np.array(TRIANGLES)).strip().save(p),
    "tets.mesh": write_volume,
    "tets.msh": lambda p: write_volume(p, file_format="gmsh22"),
    "tets.inp": lambda p: write_volume(p, file_format="abaqus"),
    "hexahedron.vtu": lambda p: write_volume(p, kind="hexahedron"),
}


@pytest.mark.parametrize("name", list(WRITERS))
def test_every_format_reads_the_unit_cube(name, tmp_path):
    path = tmp_path / name
    WRITERS[name](path)
    model = sdf.mesh(path)
    assert model.volume == pytest.approx(1.0, abs=1e-6)
    assert np.allclose(model.bounds, ((0, 0, 0), (1, 1, 1)))
    assert model([[0.5, 0.5, 0.5]])[0] == pytest.approx(-0.5, abs=1e-6)  # inside, half a side from every face
    assert model([[2.0, 0.5, 0.5]])[0] == pytest.approx(1.0, abs=1e-6)


def test_an_stl_of_two_solids_is_both(tmp_path):
    path = tmp_path / "two.stl"
    write_stl_two_solids(path)
    model = sdf.mesh(path)
    assert model.volume == pytest.approx(2.0, abs=1e-6)
    assert np.allclose(model.bounds, ((0, 0, 0), (4, 1, 1)))


def test_vertices_differing_in_the_last_bits_are_one_and_close_the_surface(tmp_path):
    path = tmp_path / "cad.stl"
    write_cad_stl(path)
    model = sdf.mesh(path)
    assert model.repaired.closed and model.repaired.holes == 0 and not model.repaired.changed
    assert model.repaired.merged == 8  # each corner at z = 0 came in three versions


def test_vertices_a_millionth_of_the_part_apart_stay_apart():
    from fepre.sdf.meshmodel.tables import weld_vertices

    points = np.array([[0.0, 0, 0], [100, 0, 0], [1e-4, 0, 0], [100, 1e-7, 0]])  # 1e-6 and 1e-9 of D
    welded = weld_vertices(points)
    assert welded[2].tolist() == [1e-4, 0, 0] and welded[3].tolist() == [100, 0, 0]


def test_triangle_strips_unroll_with_one_orientation():
    assert strip_triangles(np.array([0, 1, 2, 3, 4, -1, 5, 6, 7])).tolist() == [[0, 1, 2], [2, 1, 3], [2, 3, 4], [5, 6, 7]]
    # a repeated index turns the strip: its degenerate triangles are dropped, the parity goes on
    assert strip_triangles(np.array([0, 1, 2, 2, 3, 4])).tolist() == [[0, 1, 2], [3, 2, 4]]
    assert strip_triangles(np.array([0, 1, -1])).shape == (0, 3)


@pytest.mark.parametrize(
    "text, words",
    [
        ("OFF\n8 6 0\n0 0 0\n", "ends after 1 of 8"),
        ("4OFF\n1 1 0\n", "not an OFF file"),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "outside 0..2"),
        ("OFF\n", "counts are missing"),
    ],
)
def test_a_broken_off_file_names_the_file_and_the_problem(tmp_path, text, words):
    path = tmp_path / "broken.off"
    path.write_text(text)
    with pytest.raises(MeshInputError, match="broken.off") as caught:
        sdf.mesh(path)
    assert words in str(caught.value)


def test_a_ply_of_strips_cut_short_names_the_file(tmp_path):
    # a new user's igea.ply cut to 1.5 MB gave plyfile's traceback ("early end-of-file")
    whole, cut = tmp_path / "strips.ply", tmp_path / "cut.ply"
    write_ply_strips(whole, binary=True)
    data = whole.read_bytes()
    cut.write_bytes(data[: data.index(b"end_header") + 11 + (len(data) - data.index(b"end_header") - 11) // 2])
    with pytest.raises(MeshInputError, match=r"mesh file .*cut\.ply could not be read: not a readable PLY file"):
        sdf.mesh(cut)


def test_a_binary_ply_cut_short_is_refused_before_vtk_reads_it(tmp_path):
    # horse.ply cut to 300 kB crashed the process in VTK's reader (a segmentation fault, no
    # message); read in a child process, so that a crash fails this test and not the run
    whole = tmp_path / "ball.ply"
    pv.Sphere(theta_resolution=16, phi_resolution=16).save(whole, binary=True)
    data = whole.read_bytes()
    body = data.index(b"end_header") + 11
    for name, end in (("vertices", body + 100), ("faces", len(data) - 7)):
        (tmp_path / f"cut_in_{name}.ply").write_bytes(data[:end])
    script = (
        "import sys\nfrom fepre import sdf\n"
        "for path in sys.argv[1:]:\n"
        "    try:\n        print(len(sdf.mesh(path).faces))\n"
        "    except sdf.MeshInputError as exc:\n        print(exc)\n"
    )
    # an ASCII one cut in its last line reached numpy's "cannot reshape array of size 1786 into shape (4)"
    text = tmp_path / "ball_ascii.ply"
    pv.Sphere(theta_resolution=16, phi_resolution=16).save(text, binary=False)
    (tmp_path / "cut_ascii.ply").write_bytes(text.read_bytes().rstrip()[:-2])
    paths = [str(tmp_path / name) for name in ("cut_in_vertices.ply", "cut_in_faces.ply", "ball.ply", "cut_ascii.ply",
                                               "ball_ascii.ply")]
    done = subprocess.run([sys.executable, "-c", script, *paths], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.strip().splitlines()
    for line, path in zip(lines[:2], paths):
        assert line.startswith(f"mesh file {path} is a damaged binary PLY: its header declares 226 'vertex' "
                               "and 448 'face' elements")
        assert line.endswith(f"but the file has {len(open(path, 'rb').read())} bytes; it was cut short")
    assert lines[2] == lines[4] == "448"
    assert lines[3] == (f"mesh file {paths[3]} is a damaged ASCII PLY: its header declares 226 'vertex' and 448 'face' "
                        "elements, one line each (674 lines), but the file ends in line 674 of them; it was cut short")


@pytest.mark.slow  # 8 s of the default run on 2 cores
def test_the_cli_meshes_an_off_file_and_a_ply_of_strips(tmp_path):
    for name in ("cube.off", "strips.ply"):
        WRITERS[name](tmp_path / name)
        out = tmp_path / f"{name}.vtu"
        done = subprocess.run([sys.executable, "-m", "fepre", "mesh", str(tmp_path / name), "--h", "0.25",
                               "-o", str(out), "--quiet"], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert pv.read(out).volume == pytest.approx(1.0, rel=1e-3)


@pytest.mark.slow  # 8 s of the default run on 2 cores
def test_the_cli_remeshes_its_own_calculix_file(tmp_path):
    """A volume mesh fepre wrote (CalculiX .inp) is a model again: its boundary, remeshed."""
    write_volume(tmp_path / "cube.mesh")
    first, second = tmp_path / "cube.inp", tmp_path / "again.vtu"
    for source, out, h in ((tmp_path / "cube.mesh", first, "0.25"), (first, second, "0.2")):
        done = subprocess.run([sys.executable, "-m", "fepre", "mesh", str(source), "--h", h, "-o", str(out), "--quiet"],
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    assert pv.read(second).volume == pytest.approx(1.0, rel=1e-3)


def _write_touching_boxes(path, contact_twice: bool) -> None:
    """A 2 x 2 x 1 slab with a unit cube standing on it, fragmented by gmsh's OpenCASCADE so the
    contact square is one patch of the slab's top, written once (a multi-volume export) or, with
    ``contact_twice``, once more reversed (each body's boundary written whole)."""
    import gmsh
    import pyvista as pv

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        slab, cube = occ.addBox(0, 0, 0, 2, 2, 1), occ.addBox(0.5, 0.5, 1, 1, 1, 1)
        occ.fragment([(3, slab)], [(3, cube)])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    surface = pv.read(path)
    points, faces = np.asarray(surface.points), surface.faces.reshape(-1, 4)[:, 1:]
    corners = points[faces]
    contact = (np.abs(corners[..., 2] - 1) < 1e-9).all(axis=1) & ((corners[..., :2] >= 0.5 - 1e-9) & (corners[..., :2] <= 1.5 + 1e-9)).all(axis=(1, 2))
    assert contact.sum() >= 2
    if contact_twice:
        faces = np.concatenate([faces, faces[contact][:, ::-1]])
    pv.PolyData(points, np.column_stack([np.full(len(faces), 3), faces]).ravel()).save(path)


@pytest.mark.parametrize("contact_twice", [False, True], ids=["contact once", "contact twice"])
def test_touching_bodies_that_share_their_contact_face_are_their_union(tmp_path, contact_twice):
    # the contact square is bounded by edges of three triangles; kept, it split the cube's foot
    # from the rest: points just above it read as outside and the volume came out short
    path = tmp_path / "slab_and_cube.stl"
    _write_touching_boxes(path, contact_twice)
    model = sdf.mesh(path)
    assert model.repaired.contacts >= 2 and model.repaired.closed
    assert model.volume == pytest.approx(5.0, abs=1e-9)
    assert model([[1.0, 1.0, 1.05]])[0] == pytest.approx(-0.5, abs=1e-9)  # in the cube, above the contact
    assert model([[1.0, 1.0, 0.95]])[0] == pytest.approx(-np.hypot(0.5, 0.05), abs=1e-9)  # in the slab: to the contact's rim
    assert model([[0.25, 0.25, 1.05]])[0] == pytest.approx(0.05, abs=1e-9)  # above the slab, beside the cube


@pytest.mark.parametrize("count, stagger", [(2, 0.0), (3, 0.3)])
def test_contacts_that_meet_each_other_are_dropped_too(tmp_path, count, stagger):
    # stacks of fragmented unit cubes (every other column raised by `stagger`): contact squares
    # meet along lines, where edges hold four to six triangles. The arrangement's cells say which
    # faces have material on both sides; before, the winding number left 7.39 of 8 and 20.7 of 27
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        cubes = [(3, occ.addBox(i, j, k + stagger * (i % 2), 1, 1, 1))
                 for i in range(count) for j in range(count) for k in range(count)]
        occ.fragment(cubes[:1], cubes[1:])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(tmp_path / "stack.stl"))
    finally:
        gmsh.finalize()
    model = sdf.mesh(tmp_path / "stack.stl")
    assert model.repaired.contacts > 0 and model.repaired.closed
    assert model.volume == pytest.approx(count**3, rel=1e-6)  # the STL's float32 coordinates
    on_contacts = np.array([[1.0, 1.0, 0.5], [1.0, 0.5, 1.0]])
    assert (model(on_contacts) < -0.1).all()  # inside, as far from the surface as the cubes allow


def _cylinders_on_one_ring(n: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Two closed cylinders of radius 0.5 standing on one ring of vertices at z = 0, a short one
    (0.2 high) inside a tall one (1.2 high): their walls lie over each other, and their bottoms
    (a fan from the centre, a fan from a ring vertex) overlap without being duplicates."""
    turn = 2 * np.pi * np.arange(n) / n
    ring = np.stack([0.5 * np.cos(turn), 0.5 * np.sin(turn), np.zeros(n)], axis=1)
    vertices = np.concatenate([ring, ring + [0, 0, 0.2], ring + [0, 0, 1.2], [[0, 0, 0], [0, 0, 0.2], [0, 0, 1.2]]])
    r, s, t, centre, short_top, tall_top = 0, n, 2 * n, 3 * n, 3 * n + 1, 3 * n + 2
    faces = []
    for k in range(n):
        j = (k + 1) % n
        faces += [[r + k, r + j, s + j], [r + k, s + j, s + k], [r + k, r + j, t + j], [r + k, t + j, t + k],
                  [centre, r + j, r + k], [short_top, s + k, s + j], [tall_top, t + k, t + j]]
    faces += [[r, r + k + 1, r + k] for k in range(1, n - 1)]
    return vertices, np.array(faces)


def test_a_body_beside_the_lowest_one_is_not_taken_for_material():
    """The cylinders share 24 edges of four triangles, so the contact step runs. It took the one
    cell outside the whole surface from the face lowest in x, a box's beside them: the cylinders'
    own outer cell, whose faces do not all look into it (their walls lie over each other), read as
    material, every face of theirs had material on both sides, and the cylinders vanished (inside
    volume 0; a UR20 forearm's STL lost 10%). Each piece now has its own outside cell."""
    import pyvista as pv

    vertices, faces = _cylinders_on_one_ring()
    box = pv.Box(bounds=(-3, -2, -0.5, 0.5, 0, 1)).triangulate()
    box_faces = box.faces.reshape(-1, 4)[:, 1:] + len(vertices)
    surface = pv.PolyData.from_regular_faces(np.concatenate([vertices, box.points]), np.concatenate([faces, box_faces]))
    model = sdf.mesh(surface)
    assert model.repaired.contacts == 0
    prism = 24 * 0.5 * 0.25 * np.sin(2 * np.pi / 24) * 1.2
    axis, height = np.linspace(-0.6, 0.6, 61), np.linspace(-0.1, 1.3, 71)
    points = np.stack(np.meshgrid(axis, axis, height, indexing="ij"), -1).reshape(-1, 3)
    inside = np.count_nonzero(model(points) < 0) * (axis[1] - axis[0]) ** 2 * (height[1] - height[0])
    assert inside == pytest.approx(prism, rel=0.02)
    assert model([[-2.5, 0.0, 0.5]])[0] == pytest.approx(-0.5, abs=1e-9)  # the box kept too


def test_a_contact_face_is_dropped_only_where_the_surface_left_encloses_it(tmp_path, monkeypatch):
    """The guard behind the arrangement's cells: faces the cells wrongly call material on both
    sides (here, made so: the slab's bottom) stay unless the winding number of the surface left
    is above 3/4 on both sides of them; the real contact square still goes."""
    import importlib

    repair = importlib.import_module("fepre.sdf.meshmodel.repair")
    path = tmp_path / "slab_and_cube.stl"
    _write_touching_boxes(path, contact_twice=False)
    honest = sdf.mesh(path).repaired.contacts
    true_sides = repair._material_sides

    def with_the_bottom(vertices, faces, *args):
        sides = true_sides(vertices, faces, *args)
        sides[(np.abs(vertices[faces][..., 2]) < 1e-9).all(axis=1)] = True
        return sides

    monkeypatch.setattr(repair, "_material_sides", with_the_bottom)
    model = sdf.mesh(path)
    assert model.repaired.contacts == honest >= 2 and model.repaired.closed
    assert model.volume == pytest.approx(5.0, abs=1e-9)
