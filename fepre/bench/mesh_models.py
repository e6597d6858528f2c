"""Triangle-mesh inputs: distance queries, then every corpus mesh meshed by fepre and pytetwild.

Part 1 times ``sdf.mesh`` distance queries on a 100k-triangle CAD surface (1M points near the
surface, within two triangle sizes, and 1M points uniform in its box), both cores through
fepre's thread pool, against libigl's AABB tree (``igl.signed_distance`` with pseudonormals, its
own threads) on the same points.

Part 2 writes every input of :mod:`fepre.corpus.meshes` as a binary STL file (clean CAD, CSG,
lattice and blob surfaces, and dirty variants: holes up to 2% of the area, duplicated and
flipped triangles, overlapping shells, edges shared by four triangles, a million triangles),
then, interleaved per input, meshes the file with ``fepre.distmesh(sdf.mesh(file), h)`` and with
pytetwild at its defaults (``tetrahedralize_pv(surface, edge_length_abs=h)`` on the same file).
For each: cells, the worst and largest dihedral and the smallest radius ratio, validity
(:func:`fepre.corpus.check_mesh`, boundary-node distance left out for pytetwild, whose boundary
is an envelope), the volume error against the input's winding-number volume (Monte Carlo), how
far the input's sharp edges are from the mesh's boundary (in h) and the time.

``--real FOLDER`` runs :mod:`fepre.bench.real_models` instead: every model file in FOLDER
(real-world STL/OBJ/PLY/OFF, ``--cad`` adds tessellated CAD parts) at h = D/25, D/50, D/100 and
graded, fepre and pytetwild side by side.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
import warnings

import numpy as np


def _queries(seed: int = 0) -> None:
    import igl

    from ..corpus.meshes import _flange, _occ
    from ..sdf import mesh

    vertices, faces = _occ(_flange, 0.72)  # about 107k triangles
    model = mesh(_surface(vertices, faces))
    vertices, faces = model.vertices, model.faces
    rng = np.random.default_rng(seed)
    size = float(np.sqrt(2 * model._distance.areas.mean()))
    near = vertices[rng.integers(0, len(vertices), 1_000_000)] + rng.normal(0, size, (1_000_000, 3))
    lower, upper = (np.asarray(b) for b in model.bounds)
    box = rng.uniform(lower, upper, (1_000_000, 3))
    model(near[:1000])  # compile (or load) the kernel, build the tree
    print(f"distance queries: OpenCASCADE flange, {len(faces)} triangles, median of 3 runs, 1M points each")
    print(f"  {'points':10s} {'fepre M/s':>10s} {'libigl M/s':>11s} {'ratio':>6s} {'max |diff|':>11s}")
    for name, points in (("near", near), ("box", box)):
        ours, theirs = [], []
        for _ in range(3):
            start = time.perf_counter()
            values = model(points)
            ours.append(time.perf_counter() - start)
            start = time.perf_counter()
            reference = igl.signed_distance(points, vertices, faces, igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL)[0]
            theirs.append(time.perf_counter() - start)
        a, b = statistics.median(ours), statistics.median(theirs)
        print(f"  {name:10s} {len(points) / a / 1e6:10.2f} {len(points) / b / 1e6:11.2f} {b / a:5.1f}x "
              f"{float(np.abs(values - reference).max()):11.2e}")


def _surface(vertices, faces):
    import pyvista as pv

    return pv.PolyData(vertices, np.column_stack([np.full(len(faces), 3), faces]).ravel())


def _sharp_deviation(samples: np.ndarray, points: np.ndarray, tets: np.ndarray, h: float) -> float:
    """Largest distance from the input's sharp-edge samples to the mesh's boundary, in h."""
    if len(samples) == 0:
        return float("nan")
    from ..mesh_metrics import boundary_faces
    from ..sdf.meshmodel.bvh import TriangleTree

    boundary = boundary_faces(tets)
    squared = TriangleTree(points, boundary).query(samples)[0]
    return float(np.sqrt(squared.max()) / h)


def _measure(points, tets, model, h, volume, samples, pytetwild: bool) -> dict:
    from ..corpus import check_mesh

    check = check_mesh(points, tets, model, h)
    problems = [p for p in check.problems if not (pytetwild and "from the zero set" in p)]
    return dict(
        cells=check.cells, worst=check.min_dihedral, largest=check.max_dihedral, rr=check.min_radius_ratio,
        valid=not problems, problems=problems, volume=check.volume / volume - 1.0,
        sharp=_sharp_deviation(samples, points, tets, h),
    )


#: Defects that leave the part as it was: the clean input's winding-number volume is the truth
#: (flipped triangles and holes change the winding number of the file itself near them).
_SAME_PART = ("holes", "duplicates", "flipped")


def _reference_volume(item, seed: int) -> float:
    from ..corpus.meshes import mesh_inputs, winding_volume

    if item.dirt in _SAME_PART:
        item = mesh_inputs(seed=seed, names=[item.name.split("+")[0]])[0]
    return winding_volume(item.vertices, item.faces, 1_000_000)[0]


def _sharp_samples(item, seed: int) -> np.ndarray:
    """Points along the input's sharp edges: of the file as given (vertices merged, nothing
    repaired), or of the clean input where only the triangles' order or orientation changed."""
    from ..corpus.meshes import feature_edges, mesh_inputs
    from ..sdf.meshmodel.repair import _merge_vertices

    if item.dirt in ("duplicates", "flipped"):
        item = mesh_inputs(seed=seed, names=[item.name.split("+")[0]])[0]
    vertices, faces, _ = _merge_vertices(item.vertices, item.faces)
    return feature_edges(vertices, faces, step=item.h / 4)


def main(argv: list[str]) -> int:
    if "--real" in argv:  # a folder of real-world models: fepre.bench.real_models
        from .real_models import main as real

        at = argv.index("--real")
        if at + 1 >= len(argv):
            print("fepre bench mesh-models: error: --real needs a FOLDER")
            return 2
        return real(argv[:at] + argv[at + 1:], prog="fepre bench mesh-models --real")
    import pyvista as pv

    import fepre
    from ..corpus.meshes import mesh_inputs
    from ..references import pytetwild_mesh
    from ..sdf import mesh

    parser = argparse.ArgumentParser(prog="fepre bench mesh-models", description=__doc__.splitlines()[0])
    parser.add_argument("--inputs", nargs="+", help="only these inputs (names, or words they start with)")
    parser.add_argument("--no-pytetwild", action="store_true", help="fepre only")
    parser.add_argument("--no-queries", action="store_true", help="skip the distance-query timing")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random defects (default 0)")
    parser.add_argument("--real", metavar="FOLDER",
                        help="instead, mesh every model in FOLDER (see `fepre bench real-models --help` for its options)")
    args = parser.parse_args(argv)
    from ..corpus.meshes import CLEAN, _DIRTY

    every = list(CLEAN) + [f"{b}+{d}" for d, bases in _DIRTY.items() for b in bases]
    names = [n for n in every if not args.inputs or any(n == w or n.startswith(w) for w in args.inputs)]
    if not names:
        parser.error(f"--inputs matched nothing; available: {', '.join(every)}")
    if not args.no_queries:
        _queries()
    print(f"\nmesh inputs: {len(names)} STL files; fepre.distmesh(sdf.mesh(file), h) at default options"
          + ("" if args.no_pytetwild else "; pytetwild.tetrahedralize_pv(surface, edge_length_abs=h) at its defaults"))
    header = (f"{'input':34s} {'tris':>8s} {'h':>5s} | {'fepre cells':>11s} {'worst':>5s} {'max':>6s} {'rr':>5s} "
              f"{'vol err':>8s} {'edge/h':>6s} {'s':>6s} | {'ptw cells':>9s} {'worst':>5s} {'max':>6s} {'rr':>5s} "
              f"{'vol err':>8s} {'edge/h':>6s} {'s':>6s}")
    print(header)
    ratios = []
    with tempfile.TemporaryDirectory(prefix="fepre-bench-meshes-") as folder:
        for item in mesh_inputs(seed=args.seed, names=names):
            path = os.path.join(folder, item.name.replace("+", "_") + ".stl")
            item.to_polydata().save(path, binary=True)
            volume = _reference_volume(item, args.seed)
            start = time.perf_counter()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    model = mesh(path)
                    grid = fepre.distmesh(model, h=item.h)
                    error = None
                except Exception as exc:  # noqa: BLE001 - a bench reports every failure and goes on
                    error = f"{type(exc).__name__}: {exc}"
            seconds = time.perf_counter() - start
            samples = _sharp_samples(item, args.seed) if error is None and item.sharp else np.zeros((0, 3))
            if len(samples):  # edges on the part's surface (not the inner walls of overlapping shells)
                samples = samples[np.abs(model(samples)) <= 1e-6 * model.length_scale]
            row = f"{item.name:34s} {len(item.faces):8d} {item.h:5.3g} | "
            if error is None:
                tets = grid.cells_dict[10].astype(np.int64)
                ours = _measure(np.asarray(grid.points, float), tets, model, item.h, volume, samples, False)
                row += (f"{ours['cells']:11d} {ours['worst']:5.1f} {ours['largest']:6.1f} {ours['rr']:5.3f} "
                        f"{100 * ours['volume']:+7.2f}% {ours['sharp']:6.2f} {seconds:6.1f}"
                        + ("" if ours["valid"] else " INVALID"))
            else:
                row += f"failed: {error[:60]}"
            if not args.no_pytetwild:
                start = time.perf_counter()
                try:
                    peer = pytetwild_mesh(pv.read(path), item.h)
                    points, tets = np.asarray(peer.points, float), peer.cells_dict[10].astype(np.int64)
                    peer_error = None
                except Exception as exc:  # noqa: BLE001
                    peer_error = f"{type(exc).__name__}: {exc}"
                peer_seconds = time.perf_counter() - start
                if peer_error is None and error is None:
                    theirs = _measure(points, tets, model, item.h, volume, samples, True)
                    row += (f" | {theirs['cells']:9d} {theirs['worst']:5.1f} {theirs['largest']:6.1f} {theirs['rr']:5.3f} "
                            f"{100 * theirs['volume']:+7.2f}% {theirs['sharp']:6.2f} {peer_seconds:6.1f}"
                            + ("" if theirs["valid"] else " INVALID"))
                    ratios.append((seconds / max(ours["cells"], 1)) / (peer_seconds / max(theirs["cells"], 1)))
                else:
                    row += f" | failed: {(peer_error or '')[:60]} {peer_seconds:.1f}s"
            print(row, flush=True)
            if error is None:
                kinds = sorted({type(w.message).__name__ for w in caught})
                if kinds:
                    print(f"{'':34s}   fepre warned: {', '.join(kinds)}")
                if not ours["valid"]:
                    print(f"{'':34s}   fepre problems: {'; '.join(ours['problems'])}")
    if ratios:
        print(f"\nfepre time per cell over pytetwild's: median {statistics.median(ratios):.2f}x "
              f"(range {min(ratios):.2f}-{max(ratios):.2f}x) over {len(ratios)} inputs")
    return 0
