"""Real-world triangle meshes from a folder: fepre and pytetwild at the same h, in one run.

``fepre bench real-models FOLDER`` (also ``fepre bench mesh-models --real FOLDER``) meshes every
model in FOLDER (``.stl``, ``.obj``, ``.ply``, ``.off``; the models stay outside the package:
libigl's test data, scans, your own parts) with ``fepre.distmesh(sdf.mesh(path), h)`` and,
right after each, with pytetwild at its defaults (``tetrahedralize_pv(surface, edge_length_abs=h)``
on the same triangles), at ``h = D/k`` for each ``--sizes`` entry ``k`` (D: the diagonal of the
model's bounding box; default 25, 50, 100) and graded ``h=(D/a, D/b)`` for entries ``a:b``
(default 50:12 and 100:50, the second D/50 refined where the surface curves; fepre only:
pytetwild has no size range). ``--pytetwild-sizes`` limits the
uniform sizes pytetwild runs at (it takes minutes on large models at D/100).

Per model and size it prints, for each mesher: validity by the corpus validator
(:func:`fepre.corpus.check_mesh`: its own cell volumes, face and edge keys and fan count, not
fepre's meshing code: positive volumes, faces in at most two cells, a closed manifold boundary
without pinched vertices; for fepre also every boundary node on the model's zero set to 1e-3 h),
the cells, worst and largest dihedral angle and smallest radius ratio, the volume error
against the input (the divergence volume when the file's triangles are closed and consistently
oriented, else the volume where their generalised winding number exceeds 1/2, each piece
oriented consistently by libigl's ``bfs_orient`` first, 1M Monte Carlo samples), the largest
distance of a boundary node to the input's triangles in h (``bnd/h``) and the share of boundary nodes farther than 1e-3 h from them (``off%``: hole fills, spanned
openings, pytetwild's envelope), and the wall time. The summary line gives the median time
ratio fepre/pytetwild over the rows where both meshed.

``--inside auto`` (default) meshes an open surface that ``sdf.mesh`` refuses with
``inside="winding"`` and marks the row ``w``; ``closed`` reports the refusal instead.

``--cad`` first writes CAD parts of fepre's own, built in gmsh's OpenCASCADE kernel (a rounded
block with bolt holes and a slot, a flange with a filleted hub and bolt circle, an L-bracket
with a filleted inner corner and holes), each tessellated coarse and fine (``Mesh.MeshSizeMax``
and ``Mesh.MeshSizeFromCurvature``), as binary STL files into FOLDER.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

SUFFIXES = (".stl", ".obj", ".ply", ".off")
#: D/25, D/50 and D/100 uniform; graded up to D/12, and D/50 refined to D/100 where the surface
#: curves (the chord tolerance keeps the volume within 1% where D/50 uniform loses 1.3-2.7%)
DEFAULT_SIZES = ("25", "50", "100", "50:12", "100:50")
#: Boundary nodes farther than this (in h) from the input's triangles count as off the input.
OFF_INPUT = 1e-3


#: Seconds after which the bench stops a pytetwild run (fTetWild took over 15 minutes on a
#: 100k-triangle model, koala.obj, at D/50)
PYTETWILD_TIMEOUT = 600.0

@dataclass(frozen=True)
class Size:
    """A mesh size relative to the model's diagonal D: ``h = D/k``, or graded ``(D/a, D/b)``."""

    label: str
    fine: float
    coarse: float | None = None

    @classmethod
    def parse(cls, text: str) -> "Size":
        try:
            parts = [float(p) for p in text.split(":")]
        except ValueError:
            parts = []
        if len(parts) not in (1, 2) or not all(np.isfinite(p) and p > 0 for p in parts) or (len(parts) == 2 and parts[1] >= parts[0]):
            raise ValueError(f"--sizes: {text!r} is not K (h = D/K, K > 0) or A:B (graded h = (D/A, D/B), A > B > 0)")
        return cls(f"D/{text}" if len(parts) == 1 else f"D/{parts[0]:g}-D/{parts[1]:g}", parts[0], parts[1] if len(parts) == 2 else None)

    def h(self, diagonal: float):
        return diagonal / self.fine if self.coarse is None else (diagonal / self.fine, diagonal / self.coarse)


@dataclass
class Reference:
    """The input as given: its triangles, reference volume and how it was measured."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    volume: float
    closed: bool
    overlapping: bool = False

    @property
    def diagonal(self) -> float:
        used = self.vertices[np.unique(self.faces)]
        return float(np.linalg.norm(used.max(axis=0) - used.min(axis=0)))

    def surface(self):
        import pyvista as pv

        return pv.PolyData(self.vertices, np.column_stack([np.full(len(self.faces), 3), self.faces]).ravel())


def _closed_and_oriented(faces: np.ndarray) -> bool:
    """Every edge in exactly two triangles, traversed once each way (sorted directed-edge keys)."""
    directed = faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2)
    forward = np.unique(directed, axis=0, return_counts=True)
    if (forward[1] != 1).any():
        return False
    backward = np.unique(directed[:, ::-1], axis=0)
    return len(backward) == len(forward[0]) and bool((backward == forward[0]).all())


def reference(path: Path, samples: int = 1_000_000) -> Reference:
    """The input's triangles (vertices with equal coordinates merged) and reference volume."""
    from ..corpus.meshes import winding_volume
    from ..sdf.meshmodel.read import read_triangles
    from ..sdf.meshmodel.tables import weld_vertices

    vertices, faces, _ = read_triangles(path)
    rounded, inverse = np.unique(weld_vertices(vertices), axis=0, return_inverse=True)
    faces = inverse.reshape(-1)[faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    closed = _closed_and_oriented(faces)
    if closed:
        a, b, c = (rounded[faces[:, k]] for k in range(3))
        if np.einsum("ij,ij->i", a, np.cross(b, c)).sum() < 0:  # written inside out: its winding number is -1
            faces = faces[:, ::-1]
    overlapping = closed and _overlaps(rounded, faces, max(samples // 10, 10_000))
    if closed and not overlapping:
        a, b, c = (rounded[faces[:, k]] for k in range(3))
        volume = abs(float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0))
    elif closed:
        # shells that overlap: the divergence volume counts the overlap twice, the solid once
        volume = winding_volume(rounded, faces, samples)[0]
    else:
        # triangles flipped against their neighbours make the file's own winding number
        # meaningless there: orient each piece consistently first (libigl's breadth-first
        # orientation, which keeps each piece's seed triangle; not fepre's repair)
        import igl

        oriented, piece = (np.asarray(x, dtype=np.int64).reshape(-1) for x in igl.bfs_orient(faces))
        oriented = oriented.reshape(-1, 3)
        # each closed piece turned so that it encloses positive volume (its seed may face inward)
        a, b, c = (rounded[oriented[:, k]] for k in range(3))
        signed = np.bincount(piece, np.einsum("ij,ij->i", a, np.cross(b, c)))
        edges = np.sort(oriented[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        _, edge, uses = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
        open_piece = np.bincount(np.repeat(piece, 3), uses[edge.reshape(-1)] != 2, minlength=len(signed)) > 0
        flip = (signed < 0) & ~open_piece
        oriented = np.where(flip[piece][:, None], oriented[:, ::-1], oriented)
        volume = winding_volume(rounded, oriented, samples)[0]
    return Reference(path.name, rounded, faces, volume, closed, overlapping)


def _overlaps(vertices: np.ndarray, faces: np.ndarray, samples: int) -> bool:
    """Whether a closed surface's shells overlap: its winding number reaches 2 (or -1) at ten or
    more of ``samples`` uniform points in its box."""
    from ..sdf.meshmodel.tables import winding_numbers

    points = np.random.default_rng(1).uniform(vertices.min(axis=0), vertices.max(axis=0), (samples, 3))
    w = winding_numbers(vertices, faces, points)
    return int(np.count_nonzero((w > 1.5) | (w < -0.5))) >= 10


def _zero(points):
    return np.zeros(len(points))


def measure(points: np.ndarray, tets: np.ndarray, model, h: float, ref: Reference, seconds: float) -> dict:
    """The figures of one mesh: validity (``model`` None skips the zero-set check), shape,
    volume error against ``ref``, boundary nodes' distance to the input's triangles in h."""
    from ..corpus import check_mesh
    from ..mesh_metrics import boundary_faces
    from ..sdf.meshmodel.bvh import TriangleTree

    check = check_mesh(points, tets, model if model is not None else _zero, h)
    nodes = np.unique(boundary_faces(tets))
    distance = np.sqrt(TriangleTree(ref.vertices, ref.faces).query(points[nodes])[0]) / h if len(nodes) else np.zeros(1)
    return dict(
        cells=check.cells, valid=check.valid, problems=check.problems, worst=check.min_dihedral,
        largest=check.max_dihedral, rr=check.min_radius_ratio,
        volume=check.volume / ref.volume - 1.0 if ref.volume > 0 else math.nan,
        boundary=float(distance.max()), off=float(np.mean(distance > OFF_INPUT)), seconds=seconds,
    )


def _fepre(path: Path, size: Size, ref: Reference, inside: str) -> dict:
    import fepre
    from ..sdf import mesh
    from ..sdf.meshmodel import MeshInputError

    h = size.h(ref.diagonal)
    start = time.perf_counter()
    used = "closed" if inside == "auto" else inside
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            try:
                model = mesh(path, inside=used)
            except MeshInputError as exc:
                if inside != "auto" or "open surface" not in str(exc):
                    raise
                used = "winding"
                model = mesh(path, inside=used)
            grid = fepre.distmesh(model, h=h)
        except Exception as exc:  # noqa: BLE001 - a bench reports every failure and goes on
            return dict(error=f"{type(exc).__name__}: {exc}", seconds=time.perf_counter() - start, inside=used)
    seconds = time.perf_counter() - start
    fine = h if np.isscalar(h) else h[0]
    row = measure(np.asarray(grid.points, float), grid.cells_dict[10].astype(np.int64), model, fine, ref, seconds)
    row["inside"] = used
    row["warnings"] = sorted({type(w.message).__name__ for w in caught})
    return row


def _pytetwild(ref: Reference, h: float, timeout: float | None = None) -> dict:
    from ..references import pytetwild_mesh

    surface = ref.surface()
    start = time.perf_counter()
    try:
        grid = pytetwild_mesh(surface, h, timeout=timeout)
    except Exception as exc:  # noqa: BLE001
        return dict(error=f"{type(exc).__name__}: {exc}", seconds=time.perf_counter() - start)
    seconds = float(grid.field_data["reference_seconds"][0]) if "reference_seconds" in grid.field_data else (
        time.perf_counter() - start)
    return measure(np.asarray(grid.points, float), grid.cells_dict[10].astype(np.int64), None, h, ref, seconds)


def _warm_up(pytetwild: bool) -> None:
    """Compile (or load) fepre's numba kernels and load pytetwild before the first timed run."""
    import pyvista as pv

    import fepre
    from ..sdf import mesh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fepre.distmesh(mesh(pv.Cube().triangulate()), h=0.3)
        if pytetwild:
            from ..references import pytetwild_mesh

            pytetwild_mesh(pv.Cube().triangulate(), 0.5)


def _percent(fraction: float) -> str:
    return f"{'-':>7s}" if math.isnan(fraction) else f"{100 * fraction:+6.2f}%"


def _cells(row: dict | None) -> str:
    if row is None:
        return f"{'-':>50s}"
    if "error" in row:
        return f"failed: {row['error'][:60]:43s}"
    return (f"{'ok ' if row['valid'] else 'BAD'} {row['cells']:7d} {row['worst']:5.1f} {row['largest']:5.1f} {row['rr']:5.3f} "
            f"{_percent(row['volume'])} {row['boundary']:6.3f} {100 * row['off']:5.1f} {row['seconds']:6.1f}")


HEADER = (f"{'model':34s} {'tris':>6s} {'h':>12s} | {'fepre':3s} {'cells':>7s} {'worst':>5s} {'max':>5s} {'rr':>5s} "
          f"{'dV':>7s} {'bnd/h':>6s} {'off%':>5s} {'s':>6s} | {'ptw':3s} {'cells':>7s} {'worst':>5s} {'max':>5s} {'rr':>5s} "
          f"{'dV':>7s} {'bnd/h':>6s} {'off%':>5s} {'s':>6s}")


def models_in(folder: Path, names: list[str] | None = None) -> list[Path]:
    """The model files of ``folder`` (sorted), only those whose name starts with one of ``names``."""
    found = sorted(p for p in folder.iterdir() if p.suffix.lower() in SUFFIXES and p.is_file())
    if names:
        found = [p for p in found if any(p.name.startswith(n) for n in names)]
    return found


def bench_folder(folder, sizes=DEFAULT_SIZES, *, pytetwild: bool = True, pytetwild_sizes=None, names=None,
                 inside: str = "auto", out: Callable[[str], None] = print, samples: int = 1_000_000,
                 warm_up: bool = True, pytetwild_timeout: float | None = PYTETWILD_TIMEOUT) -> list[dict]:
    """Mesh every model of ``folder`` at every size with fepre and pytetwild; print a row per
    model and size and return the rows (dicts: ``model``, ``size``, ``triangles``, ``h``,
    ``fepre`` and ``pytetwild`` figures, see :func:`measure`, or ``None`` when not run).
    ``samples``: Monte Carlo samples of an open input's winding-number volume; ``warm_up``:
    compile fepre's kernels and load pytetwild on a cube first, so the first model's time is
    not the compiler's; ``pytetwild_timeout``: seconds after which a pytetwild run (in its own
    process, timed there) is stopped and reported as failed (None: in this process, no limit).

    Examples
    --------
    >>> rows = bench_folder("models", ["25"], pytetwild=False)   # doctest: +SKIP
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"--real: {folder} is not a folder")
    sizes = [s if isinstance(s, Size) else Size.parse(str(s)) for s in sizes]
    paths = models_in(folder, names)
    if not paths:
        raise ValueError(f"--real: {folder} holds no model ({', '.join(SUFFIXES)})" + (f" starting with {names}" if names else ""))
    peer_sizes = None if pytetwild_sizes is None else {Size.parse(str(s)).label for s in pytetwild_sizes}
    out(f"{len(paths)} models in {folder}; fepre.distmesh(sdf.mesh(file), h) at default options"
        + ("; pytetwild.tetrahedralize_pv(surface, edge_length_abs=h) at its defaults" if pytetwild else "")
        + "\nvalidity: fepre.corpus.check_mesh; dV against the closed input's volume or its winding-number volume; "
          "bnd/h: farthest boundary node from the input's triangles; off%: boundary nodes farther than 1e-3 h\n")
    if warm_up:
        _warm_up(pytetwild)
    out(HEADER)
    rows = []
    for path in paths:
        try:
            ref = reference(path, samples)
        except Exception as exc:  # noqa: BLE001
            out(f"{path.name:34s} unreadable: {type(exc).__name__}: {exc}")
            continue
        for size in sizes:
            ours = _fepre(path, size, ref, inside)
            run_peer = pytetwild and size.coarse is None and (peer_sizes is None or size.label in peer_sizes)
            theirs = _pytetwild(ref, size.h(ref.diagonal), pytetwild_timeout) if run_peer else None
            name = (ref.name + ("" if ref.closed else " (open)") + (" (overlaps)" if ref.overlapping else "")
                    + (" w" if ours.get("inside") == "winding" else ""))
            h = size.h(ref.diagonal)
            out(f"{name[:34]:34s} {len(ref.faces):6d} {size.label:>12s} | {_cells(ours)} | {_cells(theirs)}")
            if ours.get("problems"):
                out(f"{'':34s}   fepre problems: {'; '.join(ours['problems'])}")
            if ours.get("warnings"):
                out(f"{'':34s}   fepre warned: {', '.join(ours['warnings'])}")
            if theirs and theirs.get("problems"):
                out(f"{'':34s}   pytetwild problems: {'; '.join(theirs['problems'])}")
            rows.append(dict(model=ref.name, size=size.label, triangles=len(ref.faces), h=h, closed=ref.closed,
                             reference_volume=ref.volume, fepre=ours, pytetwild=theirs))
    ratios = [r["fepre"]["seconds"] / r["pytetwild"]["seconds"] for r in rows
              if r["pytetwild"] and "error" not in r["pytetwild"] and "error" not in r["fepre"]]
    fepre_rows = [r["fepre"] for r in rows if "error" not in r["fepre"]]
    summary = (f"\nfepre: {sum(r['valid'] for r in fepre_rows)} of {len(rows)} meshes valid, worst dihedral "
               f"{min((r['worst'] for r in fepre_rows), default=float('nan')):.1f} deg")
    if ratios:
        summary += (f"; time fepre/pytetwild: median {statistics.median(ratios):.2f}x "
                    f"(range {min(ratios):.2f}-{max(ratios):.2f}x) over {len(ratios)} runs")
    out(summary)
    return rows


# ---------------------------------------------------------------------------- CAD parts
def _rounded_block(occ):
    block = occ.addBox(0, 0, 0, 40, 30, 20)
    occ.synchronize()
    block = occ.fillet([block], [tag for _, tag in occ.getEntities(1)], [3.0])[0][1]
    cutters = [(3, occ.addCylinder(x, 10, -1, 0, 0, 22, 4)) for x in (10, 30)] + [(3, occ.addBox(-1, 18, 14, 42, 8, 7))]
    occ.cut([(3, block)], cutters)


def _flange(occ):
    disc = occ.addCylinder(0, 0, 0, 0, 0, 8, 30)
    hub = occ.addCylinder(0, 0, 0, 0, 0, 22, 12)
    fused = occ.fuse([(3, disc)], [(3, hub)])[0]
    occ.synchronize()
    # the circle where the hub meets the disc's top face: fillet it
    joint = [tag for _, tag in occ.getEntitiesInBoundingBox(-12.5, -12.5, 7.9, 12.5, 12.5, 8.1, 1)]
    fused = occ.fillet([t for _, t in fused], joint, [3.0])
    holes = [(3, occ.addCylinder(0, 0, -1, 0, 0, 24, 6))]
    holes += [(3, occ.addCylinder(21 * np.cos(a), 21 * np.sin(a), -1, 0, 0, 10, 3)) for a in np.arange(6) * np.pi / 3]
    occ.cut(fused, holes)


def _bracket(occ):
    base = occ.addBox(0, 0, 0, 50, 30, 6)
    wall = occ.addBox(0, 0, 0, 6, 30, 40)
    fused = occ.fuse([(3, base)], [(3, wall)])[0]
    occ.synchronize()
    corner = [tag for _, tag in occ.getEntitiesInBoundingBox(5.9, -0.1, 5.9, 6.1, 30.1, 6.1, 1)]
    fused = occ.fillet([t for _, t in fused], corner, [4.0])
    holes = [(3, occ.addCylinder(x, 15, -1, 0, 0, 8, 4)) for x in (22, 40)] + [(3, occ.addCylinder(-1, 15, 28, 8, 0, 0, 5))]
    occ.cut(fused, holes)


CAD_PARTS = {"cad-block": _rounded_block, "cad-flange": _flange, "cad-bracket": _bracket}
#: (MeshSizeMax as a fraction of the part's diagonal, elements per 2 pi of curvature)
TESSELLATIONS = {"coarse": (0.2, 8), "fine": (0.03, 36)}


def tessellate(build, size: float, per_turn: int) -> tuple[np.ndarray, np.ndarray]:
    """Surface triangles of the OpenCASCADE solid ``build(occ)`` meshed by gmsh."""
    import gmsh

    from ..distmesh.delaunay import initialize_gmsh

    initialize_gmsh()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("cad")
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", per_turn)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, nodes = gmsh.model.mesh.getElementsByType(2)
    finally:
        gmsh.finalize()
    index = np.zeros(int(np.max(tags)) + 1, dtype=np.int64)
    index[np.asarray(tags, np.int64)] = np.arange(len(tags))
    return np.asarray(coords, float).reshape(-1, 3), index[np.asarray(nodes, np.int64).reshape(-1, 3)]


def write_cad(folder) -> list[Path]:
    """Write every CAD part at every tessellation into ``folder`` as binary STL; the paths."""
    import pyvista as pv

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, build in CAD_PARTS.items():
        for level, (fraction, per_turn) in TESSELLATIONS.items():
            probe_vertices, _ = tessellate(build, 1e9, 4)
            diagonal = float(np.linalg.norm(np.ptp(probe_vertices, axis=0)))
            vertices, faces = tessellate(build, fraction * diagonal, per_turn)
            path = folder / f"{name}-{level}.stl"
            pv.PolyData(vertices, np.column_stack([np.full(len(faces), 3), faces]).ravel()).save(path, binary=True)
            written.append(path)
    return written


def main(argv: list[str], prog: str = "fepre bench real-models") -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("folder", metavar="FOLDER", help="folder of models (.stl, .obj, .ply, .off)")
    parser.add_argument("--sizes", nargs="+", default=list(DEFAULT_SIZES),
                        help="K for h = D/K, A:B for graded h = (D/A, D/B) (default: 25 50 100 50:12 100:50)")
    parser.add_argument("--pytetwild-sizes", nargs="+", help="the uniform sizes pytetwild runs at (default: all)")
    parser.add_argument("--no-pytetwild", action="store_true", help="fepre only")
    parser.add_argument("--pytetwild-timeout", type=float, default=PYTETWILD_TIMEOUT, metavar="SECONDS",
                        help=f"stop a pytetwild run after this long (default: {PYTETWILD_TIMEOUT:g})")
    parser.add_argument("--models", nargs="+", help="only models whose file name starts with one of these")
    parser.add_argument("--inside", choices=("auto", "closed", "winding"), default="auto",
                        help="sdf.mesh(inside=): auto (default) retries an open surface with winding")
    parser.add_argument("--cad", action="store_true", help="first write the tessellated CAD parts into FOLDER")
    args = parser.parse_args(argv)
    folder = Path(args.folder)
    try:
        sizes = [Size.parse(s) for s in args.sizes]
        if args.pytetwild_sizes:
            [Size.parse(s) for s in args.pytetwild_sizes]
    except ValueError as exc:
        parser.error(str(exc))
    if not args.pytetwild_timeout > 0:
        parser.error(f"--pytetwild-timeout must be a positive number of seconds; got {args.pytetwild_timeout:g}")
    if args.cad:
        for path in write_cad(folder):
            print(f"wrote {path}")
    elif not folder.is_dir():
        parser.error(f"FOLDER {folder} is not a folder")
    try:
        bench_folder(folder, sizes, pytetwild=not args.no_pytetwild, pytetwild_sizes=args.pytetwild_sizes,
                     names=args.models, inside=args.inside, pytetwild_timeout=args.pytetwild_timeout)
    except ValueError as exc:
        parser.error(str(exc))
    return 0

