"""Chunked grids on dask: chunked surfaces equal to single-grid ones, throughput per node, and a surface beyond memory.

Three parts, each printed as a table:

1. Equality: the torus, the cube with hole and the gyroid block, every method, chunked (dask's
   threads; ``--cluster`` adds a ``LocalCluster`` of two worker processes) against the single
   grid: "same" means the same arrays (fepre's methods) or the same vertices and triangles
   (flying edges, whose order is VTK's).
2. Throughput on a grid that fits (``--nodes`` per axis, a gyroid-infilled part): the single-grid
   path ``fepre.isosurface(model, spacing=..., band=...)`` and the chunked path with
   ``chunks=`` and the same band, interleaved, medians of ``--repeat`` runs, time per node and
   the ratio chunked / single.
3. Scale (``--scale N``): the gyroid-infilled part on an N^3 grid streamed to an STL file by
   ``fepre.chunked.write_isosurface`` in a fresh process on dask's threads; wall time, CPU time
   over wall time (cores busy), the process's peak resident memory, triangles and whether the
   seams close. N = 2048 is 8.6 G nodes (34 GB as a dense float32 grid).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

EQUALITY_PARTS = ("torus", "cube_with_hole", "gyroid_block")


def _equality_model(name: str):
    from .. import parts, sdf

    if name == "torus":
        return sdf.torus(1.0, 0.3), 0.05
    if name == "cube_with_hole":
        return parts.cube_with_hole()[0], 0.125
    return parts.gyroid_block(), 0.04


def infilled_part(size: float = 100.0):
    """A cube of side ``size`` with a bore, a 2 %-of-size wall and a gyroid sheet infill (period
    a fifth of the size, sheet 1 % of it): the part of the throughput and scale runs."""
    from .. import sdf

    outer = sdf.box((size,) * 3) - sdf.cylinder(0.2 * size, 1.2 * size)
    return sdf.infill(outer, sdf.gyroid(0.2 * size, 0.01 * size), wall=0.02 * size)


def _grid(nodes: int, size: float = 100.0):
    half = 0.52 * size
    return 2 * half / (nodes - 1), ((-half,) * 3, (half,) * 3)


def _same(chunked, whole, method: str) -> bool:
    if method != "flying_edges":
        return bool(
            np.array_equal(np.asarray(chunked.points), np.asarray(whole.points))
            and np.array_equal(chunked.regular_faces, whole.regular_faces)
        )
    if chunked.n_cells != whole.n_cells or chunked.n_points != whole.n_points:
        return False

    def rows(surface):
        corners = np.asarray(surface.points)[surface.regular_faces].reshape(-1, 9)
        return corners[np.lexsort(corners.T[::-1])]

    return bool(np.array_equal(np.sort(rows(chunked), axis=0), np.sort(rows(whole), axis=0)))


def equality(chunks: int, cluster: bool) -> list[str]:
    """Part 1 (small grids of 17 to 60 nodes per axis, so ``chunks`` should be small)."""
    import fepre
    from ..surface import METHODS

    lines = [f"1. chunked (chunks={chunks}) against single-grid surfaces", f"{'part':16s} {'method':20s} {'triangles':>10s} {'threads':>8s}" + (f" {'cluster':>8s}" if cluster else "")]
    client = None
    if cluster:
        from distributed import Client, LocalCluster

        local = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(local)
    try:
        for name in EQUALITY_PARTS:
            model, spacing = _equality_model(name)
            for method in METHODS:
                whole = fepre.isosurface(model, spacing=spacing, method=method)
                row = f"{name:16s} {method:20s} {whole.n_cells:10d}"
                import dask

                with dask.config.set(scheduler="threads"):
                    row += f" {'same' if _same(fepre.isosurface(model, spacing=spacing, method=method, chunks=chunks), whole, method) else 'DIFFER':>8s}"
                if client is not None:
                    with dask.config.set(scheduler=client.get):
                        row += f" {'same' if _same(fepre.isosurface(model, spacing=spacing, method=method, chunks=chunks), whole, method) else 'DIFFER':>8s}"
                lines.append(row)
    finally:
        if client is not None:
            client.close()
            local.close()
    return lines


def throughput(nodes: int, chunks: int, methods: list[str], repeat: int) -> list[str]:
    import fepre

    model = infilled_part()
    spacing, bounds = _grid(nodes)
    band = 2.0 * float(np.sqrt(3.0)) * spacing
    total = nodes**3
    lines = [
        f"2. throughput: gyroid-infilled part on {nodes}^3 = {total / 1e6:.1f} M nodes, band {band:.3g}, "
        f"chunks={chunks}, medians of {repeat} interleaved runs",
        f"{'method':20s} {'single s':>9s} {'chunked s':>10s} {'single ns/node':>15s} {'chunked ns/node':>16s} {'ratio':>6s} {'triangles':>11s}",
    ]
    for method in methods:
        single, chunked = [], []
        count = 0
        for _ in range(repeat):
            start = time.perf_counter()
            surface = fepre.isosurface(model, spacing=spacing, bounds=bounds, band=band, method=method)
            single.append(time.perf_counter() - start)
            start = time.perf_counter()
            stitched = fepre.isosurface(model, spacing=spacing, bounds=bounds, band=band, method=method, chunks=chunks)
            chunked.append(time.perf_counter() - start)
            count = stitched.n_cells
            if count != surface.n_cells:
                raise RuntimeError(f"{method}: chunked surface has {count} triangles, single grid {surface.n_cells}")
        a, b = statistics.median(single), statistics.median(chunked)
        lines.append(
            f"{method:20s} {a:9.2f} {b:10.2f} {a / total * 1e9:15.1f} {b / total * 1e9:16.1f} {b / a:6.2f} {count:11,d}"
        )
    return lines


def _scale_child(nodes: int, chunks: int, method: str, path: str) -> dict:
    from ..chunked import write_isosurface

    spacing, bounds = _grid(nodes)
    start, cpu = time.perf_counter(), time.process_time()
    written = write_isosurface(infilled_part(), path, method=method, spacing=spacing, bounds=bounds, chunks=chunks)
    wall = time.perf_counter() - start
    return {
        "wall": wall,
        "cpu": time.process_time() - cpu,
        "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
        "triangles": written.n_triangles,
        "closed": written.closed,
        "open": written.open_edges,
        "nonmanifold": written.nonmanifold_edges,
        "seams": written.seam_edges,
        "bytes": os.path.getsize(path),
    }


def scale(nodes: int, chunks: int, method: str, folder: str | None) -> list[str]:
    folder = folder or tempfile.mkdtemp(prefix="fepre-bench-chunks-")
    path = os.path.join(folder, f"gyroid-part-{nodes}.stl")
    command = [sys.executable, "-m", "fepre.bench.chunks", "--child", str(nodes), str(chunks), method, path]
    done = subprocess.run(command, capture_output=True, text=True, env=dict(os.environ, PYTHONWARNINGS="ignore"))
    if done.returncode != 0:
        raise RuntimeError(f"the scale run failed:\n{done.stderr[-2000:]}")
    result = json.loads(done.stdout.strip().splitlines()[-1])
    os.remove(path)
    total = nodes**3
    state = "closed, manifold" if result["closed"] else f"{result['open']} open, {result['nonmanifold']} non-manifold edges"
    return [
        f"3. scale: gyroid-infilled part on {nodes}^3 = {total / 1e9:.2f} G nodes ({total * 4 / 1e9:.1f} GB as dense float32), "
        f"{method}, chunks={chunks}, streamed to STL on dask's threads (fresh process)",
        f"wall {result['wall']:.0f} s ({result['wall'] / total * 1e9:.1f} ns/node), CPU/wall {result['cpu'] / result['wall']:.2f} "
        f"on {os.cpu_count()} cores, peak memory {result['peak'] / 1e9:.2f} GB",
        f"{result['triangles']:,} triangles ({result['bytes'] / 1e9:.1f} GB file), {result['seams']:,} seam edges, {state}",
    ]


def main(argv: list[str]) -> int:
    """Run the benchmark and print its tables."""
    from ..surface import METHODS

    parser = argparse.ArgumentParser(prog="fepre bench chunks", description=__doc__.splitlines()[0])
    parser.add_argument("--chunks", type=int, default=64, help="nodes per chunk for part 2 (default 64)")
    parser.add_argument("--cluster", action="store_true", help="part 1 on a LocalCluster of two processes as well")
    parser.add_argument("--equality-chunks", type=int, default=12, help="nodes per chunk for part 1 (default 12)")
    parser.add_argument("--nodes", type=int, default=320, help="grid nodes per axis for part 2 (default 320)")
    parser.add_argument("--methods", default="flying_edges,marching_cubes,surface_nets",
                        help="methods for part 2, comma-separated (default flying_edges,marching_cubes,surface_nets)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per median in part 2 (default 3)")
    parser.add_argument("--scale", type=int, help="part 3: nodes per axis (2048 is the target; minutes)")
    parser.add_argument("--scale-chunks", type=int, default=128, help="nodes per chunk for part 3 (default 128)")
    parser.add_argument("--scale-method", default="flying_edges", choices=METHODS, help="method for part 3 (default flying_edges)")
    parser.add_argument("--folder", help="where part 3 writes its STL (removed after; default a temporary folder)")
    parser.add_argument("--skip", choices=["equality", "throughput"], action="append", default=[])
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    for method in methods:
        if method not in METHODS:
            parser.error(f"--methods: unknown method {method!r}; known: {', '.join(METHODS)}")
    if args.nodes < 16 or args.chunks < 8 or (args.scale is not None and args.scale < 16):
        parser.error("--nodes and --scale must be at least 16, --chunks at least 8")
    sections = []
    if "equality" not in args.skip:
        sections.append(equality(args.equality_chunks, args.cluster))
    if "throughput" not in args.skip:
        sections.append(throughput(args.nodes, args.chunks, methods, args.repeat))
    if args.scale is not None:
        sections.append(scale(args.scale, args.scale_chunks, args.scale_method, args.folder))
    print("\n\n".join("\n".join(section) for section in sections))
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        nodes, chunks, method, path = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
        print(json.dumps(_scale_child(nodes, chunks, method, path)))
    else:
        sys.exit(main(sys.argv[1:]))
