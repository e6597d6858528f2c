"""Images beyond memory: sdf.image of a zarr store chunk by chunk, its time and peak memory, and its agreement with the in-memory path.

Two parts:

1. Agreement (``--small N``, default 96): a partial-volume torus of N^3 voxels as a numpy array
   (``sdf.image`` in memory) and written to a zarr store (``sdf.image`` of the store, chunks of
   ``--small-chunks``): vertices, triangles and enclosed volume compared (the design says: the
   same bits).
2. Scale (``--size N``, default 1024): a torus (R = 0.25, r = 0.06 in a unit box) written chunk by
   chunk to a zarr store as each voxel's partial volume, then ``sdf.image(store, level=0.5)``
   (refine 2) in a fresh process: wall time, the process's peak resident memory (``getrusage``),
   triangles, the enclosed volume against the torus's (2 pi^2 R r^2), and the value at the tube's
   centre against -r. ``--h H`` also meshes the model with ``fepre.distmesh``. N = 1024 is a
   4 GB float32 image, 34 GB refined twice. The store goes to a temporary folder, removed after,
   unless ``--keep FOLDER`` names one.
3. Labels (``--labels N``, default off): the three-label speed phantom of ``fepre bench images``
   (a block with a ball and a rod in it) at N^3 voxels written chunk by chunk to a uint8 zarr
   store, then ``sdf.labels`` of the store (chunks of ``--label-chunks``) in a fresh process, and
   of the same image loaded as a numpy array in another: wall time, peak resident memory
   (``getrusage``, which includes the interpreter and the imports, about 250 MB), triangles,
   region volumes against the analytic ones, and whether the two give the same triangles (bits).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RADII = (0.25, 0.06)


def agreement(size: int, chunks: int, folder: Path) -> dict:
    """The in-memory and the chunked model of a torus phantom of ``size``^3 voxels."""
    from .. import sdf
    from ..chunked.phantom_store import write_partial_volume
    from ..sdf.imagemodel.phantoms import partial_volume

    part, box = sdf.torus(0.6, 0.25), 1.0
    grid = partial_volume(part, (-box,) * 3, (box,) * 3, 2 * box / size)
    values = np.asarray(grid["density"]).reshape(grid.dimensions, order="F")
    store = write_partial_volume(part, folder / "small.zarr", (-box,) * 3, (box,) * 3, 2 * box / size, chunks=chunks)
    start = time.perf_counter()
    whole = sdf.image(values, level=0.5, spacing=grid.spacing, origin=grid.origin, refine=2)
    middle = time.perf_counter()
    chunked = sdf.image(store, level=0.5, chunks=chunks)
    end = time.perf_counter()
    a, b = whole.vertices, chunked.vertices
    same_vertices = a.shape == b.shape and np.array_equal(a[np.lexsort(a.T[::-1])], b[np.lexsort(b.T[::-1])])
    return {
        "voxels": size, "chunks": chunks, "in_memory_s": middle - start, "chunked_s": end - middle,
        "triangles": [len(whole.faces), len(chunked.faces)], "same_vertices": bool(same_vertices),
        "volume": [whole.volume, chunked.volume],
    }


def _scale_child(store: str, h: float | None, radii: tuple[float, float], refine: int, chunks: int | None = None) -> None:
    """In a fresh process: the model of the store, its time and the process's peak memory (after
    building the model, and after its first evaluation, which builds its search tree)."""
    import resource

    from ..chunked.image import level_set_triangles, model_of

    start = time.perf_counter()
    found = level_set_triangles(store, 0.5, refine=refine, chunks=chunks)  # what sdf.image(store, level=0.5) does, in two steps
    triangles_seconds = time.perf_counter() - start
    triangles_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    model = model_of(found)
    found_chunks = (found.chunks, found.skipped)
    del found
    seconds = time.perf_counter() - start
    built = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    R, r = radii
    result = {
        "seconds": seconds, "triangles": len(model.faces), "volume": model.volume, "model_rss_mb": built,
        "triangles_seconds": triangles_seconds, "triangles_rss_mb": triangles_rss,
        "chunks": found_chunks,
        "exact_volume": 2 * math.pi**2 * R * r**2, "centre_value": float(model([R, 0.0, 0.0])), "r": r,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    if h is not None:
        import fepre

        start = time.perf_counter()
        mesh = fepre.distmesh(model, h, progress=False)
        result.update(mesh_seconds=time.perf_counter() - start, cells=mesh.n_cells,
                      mesh_volume=float(mesh.cell_data["volume"].sum()),
                      mesh_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    print(json.dumps(result))


def scale(size: int, chunks: int, folder: Path, h: float | None, radii=RADII, refine: int = 2,
          process_chunks: int | None = None) -> dict:
    """Write the torus phantom of ``size``^3 voxels and model it in a fresh process."""
    from .. import sdf
    from ..chunked.phantom_store import write_partial_volume

    path = folder / f"torus{size}_{radii[0]:g}_{radii[1]:g}.zarr"
    start = time.perf_counter()
    if not path.exists():
        write_partial_volume(sdf.torus(*radii), path, (-0.5,) * 3, (0.5,) * 3, 1.0 / size, chunks=chunks)
    written = time.perf_counter() - start
    code = (f"from fepre.bench.image_chunks import _scale_child; "
            f"_scale_child({str(path)!r}, {h!r}, {tuple(radii)!r}, {refine!r}, {process_chunks!r})")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if run.returncode:
        raise RuntimeError(f"the scale run failed:\n{run.stderr[-3000:]}")
    result = json.loads(run.stdout.strip().splitlines()[-1])
    result.update(voxels=size, write_seconds=written, image_gb=size**3 * 4 / 1e9,
                  refined_gb=(2 * size - 1) ** 3 * 4 / 1e9)
    return result


def _label_models():
    from .. import sdf

    return [sdf.box((1.6, 1.2, 1.2)), sdf.sphere(0.4, center=(-0.35, 0, 0)),
            sdf.cylinder(radius=0.25, height=1.0, center=(0.45, 0, 0))]


def _labels_child(store: str, mode: str, chunks: int | None, output: str) -> None:
    """In a fresh process: ``sdf.labels`` of the store (``mode="chunked"``) or of its image read
    whole (``"memory"``), its time and peak memory; the triangles saved to ``output``."""
    import resource

    import zarr

    from .. import sdf

    start = time.perf_counter()
    surface = {}
    if mode == "chunked":  # what sdf.labels(store, chunks=chunks) does, in two steps
        from ..chunked.labels import label_surface_chunked
        from ..sdf.imagemodel.labelmodel import label_regions

        found = label_surface_chunked(store, chunks=chunks)
        surface = {"surface_seconds": time.perf_counter() - start, "chunks": [found.chunks, found.skipped, found.retaken],
                   "surface_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
        regions = label_regions(found.surface, found.image, found.plan, found.reaches)
        del found
    else:
        array = zarr.open_array(store, mode="r")
        regions = sdf.labels(np.asarray(array[:]), spacing=array.attrs["spacing"], origin=array.attrs["origin"])
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    part = regions.part if hasattr(regions.part, "faces") else regions.part.children[0]
    volumes = {name: float(model.volume) for name, model in regions.items()}
    np.savez(output, vertices=part.vertices, faces=part.faces)
    voxels = np.bincount(np.asarray(zarr.open_array(store, mode="r")[:]).ravel())  # (after the peak was read)
    cell = float(np.prod(zarr.open_array(store, mode="r").attrs["spacing"]))
    counted = {name: float(voxels[label]) * cell for name, label in regions.labels.items()}
    print(json.dumps({"seconds": seconds, "peak_rss_mb": peak, "triangles": len(part.faces), "volumes": volumes,
                      "voxel_volumes": counted, **surface}))


def _run(code: str) -> dict:
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if run.returncode:
        raise RuntimeError(f"the run failed:\n{run.stderr[-3000:]}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def labels_scale(size: int, chunks: int, folder: Path, process_chunks: int | None, memory: bool = True) -> dict:
    """Write the three-label phantom of ``size``^3 voxels and label it chunked and in memory,
    each in a fresh process."""
    from ..chunked.phantom_store import write_label_image

    path = folder / f"labels{size}.zarr"
    start = time.perf_counter()
    if not path.exists():
        write_label_image(_label_models(), path, (-1, -1, -1), (1, 1, 1), 2.0 / size, chunks=chunks)
    written = time.perf_counter() - start
    result = {"voxels": size, "write_seconds": written}
    for mode in ("chunked", "memory") if memory else ("chunked",):
        code = (f"from fepre.bench.image_chunks import _labels_child; "
                f"_labels_child({str(path)!r}, {mode!r}, {process_chunks!r}, {str(folder / (mode + '.npz'))!r})")
        result[mode] = _run(code)
    if memory:
        a, b = np.load(folder / "chunked.npz"), np.load(folder / "memory.npz")
        result["same"] = all(np.array_equal(a[k], b[k]) for k in ("vertices", "faces"))
    ball, rod = 4 / 3 * math.pi * 0.4**3, math.pi * 0.25**2 * 1.0
    result["exact"] = {"label_1": 1.6 * 1.2 * 1.2 - ball - rod, "label_2": ball, "label_3": rod}
    return result


def _print_labels(big: dict, chunks: int | None) -> None:
    found = big["chunked"]
    errors = " ".join(f"{name} {100 * (found['volumes'][name] / exact - 1):+.2f}%" for name, exact in big["exact"].items())
    counted = " ".join(f"{name} {100 * (found['volumes'][name] / found['voxel_volumes'][name] - 1):+.2f}%"
                       for name in big["exact"])
    print(f"labels, {big['voxels']}^3 block with a ball and a rod (3 labels, {big['voxels']**3 / 1e6:.0f} MB uint8), "
          f"zarr written in {big['write_seconds']:.0f} s; sdf.labels of the store (chunks of {chunks or 'default'}) "
          f"{found['seconds']:.1f} s, peak RSS {found['peak_rss_mb']:.0f} MB (the surface {found['surface_seconds']:.1f} s, "
          f"{found['surface_rss_mb']:.0f} MB; chunks, one-label skipped, retaken for joins: {found['chunks']}), "
          f"{found['triangles']} triangles on the part; region volumes {errors} from the analytic ones, {counted} from "
          f"the voxel counts")
    if "memory" in big:
        whole = big["memory"]
        print(f"  in memory: {whole['seconds']:.1f} s, peak RSS {whole['peak_rss_mb']:.0f} MB; "
              f"the same triangles (bits): {big['same']}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench image-chunks", description=__doc__.splitlines()[0])
    parser.add_argument("--small", type=int, default=96, help="voxels per axis of the agreement image")
    parser.add_argument("--small-chunks", type=int, default=32, help="voxels per chunk of the agreement image")
    parser.add_argument("--size", type=int, default=1024, help="voxels per axis of the scale image (0: skip)")
    parser.add_argument("--chunks", type=int, default=128, help="voxels per zarr chunk of the scale image")
    parser.add_argument("--radii", type=float, nargs=2, default=RADII, metavar=("R", "r"),
                        help="the scale torus's radii in the unit box (default 0.25 0.06)")
    parser.add_argument("--refine", type=int, default=2, help="refine of the scale model (default 2)")
    parser.add_argument("--image-chunks", type=int, default=None,
                        help="samples per chunk sdf.image processes (default fepre.chunked.image.DEFAULT_CHUNKS)")
    parser.add_argument("--h", type=float, default=None, help="also mesh the scale model at this h")
    parser.add_argument("--labels", type=int, default=0,
                        help="voxels per axis of the three-label phantom labelled from a store (0: skip, the default)")
    parser.add_argument("--label-chunks", type=int, default=None,
                        help="nodes per chunk sdf.labels processes (default fepre.chunked.labels.DEFAULT_CHUNKS)")
    parser.add_argument("--no-memory", action="store_true", help="with --labels: skip the in-memory run")
    parser.add_argument("--keep", default=None, help="folder for the zarr stores (kept; default a temporary one)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as temporary:
        folder = Path(args.keep) if args.keep else Path(temporary)
        if args.small:
            small = agreement(args.small, args.small_chunks, Path(temporary))
            print(f"agreement, {small['voxels']}^3 torus, chunks of {small['chunks']}: in memory "
                  f"{small['in_memory_s']:.2f} s, chunked {small['chunked_s']:.2f} s; triangles {small['triangles']}; "
                  f"same vertices (bits): {small['same_vertices']}; volumes {small['volume'][0]:.9f} "
                  f"{small['volume'][1]:.9f}")
        if args.size:
            big = scale(args.size, args.chunks, folder, args.h, tuple(args.radii), args.refine, args.image_chunks)
            print(f"scale, {big['voxels']}^3 torus ({big['image_gb']:.1f} GB float32, {big['refined_gb']:.1f} GB "
                  f"refined), R {args.radii[0]:g} r {args.radii[1]:g}, refine {args.refine}, chunks of "
                  f"{args.image_chunks or 'default'}: zarr written in "
                  f"{big['write_seconds']:.0f} s; sdf.image {big['seconds']:.0f} s (triangles {big['triangles_seconds']:.0f} s, "
                  f"peak RSS {big['triangles_rss_mb']:.0f} MB; {big['chunks'][1]} of {big['chunks'][0]} chunks skipped by "
                  f"the bound), peak RSS {big['model_rss_mb']:.0f} MB "
                  f"(after the first evaluation {big['peak_rss_mb']:.0f} MB), {big['triangles']} triangles, "
                  f"volume {big['volume']:.6f} "
                  f"(torus {big['exact_volume']:.6f}, {100 * (big['volume'] / big['exact_volume'] - 1):+.3f}%), "
                  f"value at the tube's centre {big['centre_value']:.5f} (-r = {-big['r']})")
            if "cells" in big:
                print(f"  distmesh h={args.h}: {big['cells']} cells in {big['mesh_seconds']:.0f} s, volume "
                      f"{big['mesh_volume']:.6f}, peak RSS {big['mesh_rss_mb']:.0f} MB")
        if args.labels:
            big = labels_scale(args.labels, args.chunks, folder, args.label_chunks, not args.no_memory)
            _print_labels(big, args.label_chunks)
    return 0
