"""Surface extraction on the torus R=1, r=0.4: fepre's methods vs vtkFlyingEdges3D, from a sampled array and straight from the model.

Part 1 repeats Tables 1 and 2 of Kelly's master's project at 81^3: every method from a pre-sampled array and
straight from the model (sampling included), on one thread and on all threads, plus the time to
sample the array. Part 2 runs at ``--size`` (256): fepre's marching cubes and surface nets against
vtkFlyingEdges3D on the same array, and sampling plus extraction end to end against flying edges
on a pre-sampled array plus the memory floor (a numpy copy of an array of the grid's size).
Part 3 samples at ``--band-size`` (512) densely and in a narrow band. Grids span the cube
[-1.5, 1.5]^3. All figures are medians
from this run; ratios compare against the peer measured in the same run.
"""

from __future__ import annotations

import argparse

import numpy as np

from . import median_time

METHODS = ("flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets")
SHORT = {"flying_edges": "FE (VTK)", "marching_cubes": "MC", "marching_tetrahedra": "MT", "surface_nets": "NS"}


#: the grid box: the cube [-1.5, 1.5]^3 around the torus, so the grid is isotropic
BOX = ((-1.5, -1.5, -1.5), (1.5, 1.5, 1.5))


def _torus():
    from .. import sdf

    return sdf.torus(1.0, 0.4)


def cpu_time(function, repeat: int) -> float:
    """Least process CPU time of ``function()`` over ``repeat`` runs (all threads summed).

    On a shared machine wall times swing with other processes' load; CPU time of one-thread runs
    is the steadier figure for ratios.
    """
    import time

    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        function()
        best = min(best, time.process_time() - start)
    return best


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:9.2f} ms"


def seed_tables(repeat: int, workers_all: int) -> list[str]:
    """Tables 1 and 2 of Kelly's master's project at 81^3."""
    import fepre

    model = _torus()
    lines = ["Tables 1 and 2 of Kelly's project: torus R=1, r=0.4 on 81^3 (median of %d)" % repeat]
    lines.append(f"{'method':<10} {'threads':>7} {'pre-sampled array':>18} {'from the function':>18}")
    for workers in (1, workers_all):
        grid = fepre.sample(model, shape=81, bounds=BOX, workers=workers)
        sampling = median_time(lambda: fepre.sample(model, shape=81, bounds=BOX, workers=workers), repeat)
        for method in METHODS:
            array = median_time(lambda: fepre.isosurface(grid, method=method, workers=workers), repeat)
            direct = median_time(
                lambda: fepre.isosurface(model, shape=81, bounds=BOX, method=method, workers=workers), repeat
            )
            lines.append(f"{SHORT[method]:<10} {workers:>7} {_ms(array):>18} {_ms(direct):>18}")
        lines.append(f"{'sampling':<10} {workers:>7} {_ms(sampling):>18} {'':>18}")
    lines.append("Meshing.jl (Julia, Table 2, MC): array 2.721 ms / 2.212 ms (1 / 6 threads), function 6.745 ms / 2.699 ms")
    return lines


def large_grid(size: int, repeat: int, workers: int) -> list[str]:
    """fepre's MC and NS against flying edges on one array, and end to end."""
    import fepre

    model = _torus()
    grid = fepre.sample(model, shape=size, bounds=BOX, workers=workers)
    values = np.asarray(grid["sdf"])
    times = {
        method: median_time(lambda: fepre.isosurface(grid, method=method, workers=workers), repeat)
        for method in METHODS
    }
    floor = median_time(values.copy, repeat)
    end_to_end = median_time(lambda: fepre.isosurface(model, shape=size, bounds=BOX, workers=workers), repeat)
    sampling = median_time(lambda: fepre.sample(model, shape=size, bounds=BOX, workers=workers), repeat)
    one_thread = {
        method: cpu_time(lambda: fepre.isosurface(grid, method=method, workers=1), repeat) for method in METHODS
    }
    floor_cpu = cpu_time(values.copy, repeat)
    end_to_end_cpu = cpu_time(lambda: fepre.isosurface(model, shape=size, bounds=BOX, workers=1), repeat)
    fe, fe_cpu = times["flying_edges"], one_thread["flying_edges"]
    lines = [f"Torus on {size}^3: wall time on {workers} threads (median of {repeat}); CPU time on 1 thread (least)"]
    lines.append(f"{'step':<40} {'wall':>12} {'ratio':>7} {'1-thread CPU':>13} {'ratio':>7} {'target':>7}")
    for method in METHODS:
        target = "<= 5" if method in ("marching_cubes", "surface_nets") else ""
        name = SHORT[method] + " on the pre-sampled array"
        lines.append(
            f"{name:<40} {_ms(times[method])} {times[method] / fe:7.2f} {_ms(one_thread[method]):>13} "
            f"{one_thread[method] / fe_cpu:7.2f} {target:>7}"
        )
    lines.append(f"{'memory floor (numpy copy of the grid)':<40} {_ms(floor)} {'':>7} {_ms(floor_cpu):>13}")
    lines.append(f"{'sampling alone':<40} {_ms(sampling)}")
    lines.append(
        f"{'sample + FE end to end vs FE + floor':<40} {_ms(end_to_end)} {end_to_end / (fe + floor):7.2f} "
        f"{_ms(end_to_end_cpu):>13} {end_to_end_cpu / (fe_cpu + floor_cpu):7.2f} {'<= 2':>7}"
    )
    return lines


def narrow_band(size: int, repeat: int, workers: int) -> list[str]:
    """Dense against narrow-band sampling, on the torus and on the six-node CSG model of
    ``fepre bench sdf`` (where evaluating the model, not writing the grid, is the cost)."""
    from .sdf import fepre_model

    lines: list[str] = []
    for name, model in (("torus", _torus()), ("six-node CSG model", fepre_model())):
        lines += _narrow_band_rows(name, model, size, repeat, workers)
    return lines


def _narrow_band_rows(name: str, model, size: int, repeat: int, workers: int) -> list[str]:
    import fepre

    from .sdf import interleaved_medians

    box = BOX if name == "torus" else ((-2.0,) * 3, (2.0,) * 3)
    banded_grid = fepre.sample(model, shape=size, bounds=box, band=0.0, workers=workers)
    fraction = float(banded_grid.field_data["sdf_evaluated_fraction"][0])
    shape = tuple(reversed(banded_grid.dimensions))
    del banded_grid
    # interleaved rounds after a warm-up round: a burst of load on a shared machine hits all three
    wall, _ = interleaved_medians(
        {
            "dense": lambda: fepre.sample(model, shape=size, bounds=box, workers=workers),
            "banded": lambda: fepre.sample(model, shape=size, bounds=box, band=0.0, workers=workers),
            "floor": lambda: np.empty(shape, dtype=np.float32).fill(1.0),
        },
        repeat,
        warm_bytes=4 * int(np.prod(shape)),
    )
    dense, banded, floor = wall["dense"], wall["banded"], wall["floor"]
    dense_cpu = cpu_time(lambda: fepre.sample(model, shape=size, bounds=box, workers=1), repeat)
    banded_cpu = cpu_time(lambda: fepre.sample(model, shape=size, bounds=box, band=0.0, workers=1), repeat)
    floor_cpu = cpu_time(lambda: np.empty(shape, dtype=np.float32).fill(1.0), repeat)
    return [
        f"Narrow band (one cell diagonal), {name}, {size}^3: wall on {workers} threads (median of {repeat} "
        f"interleaved rounds); 1-thread CPU (least of {repeat})",
        f"{'step':<40} {'wall':>12} {'1-thread CPU':>13}",
        f"{'dense sampling':<40} {_ms(dense)} {_ms(dense_cpu):>13}",
        f"{'banded sampling':<40} {_ms(banded)} {_ms(banded_cpu):>13}",
        f"{'memory floor (allocate + fill the grid)':<40} {_ms(floor)} {_ms(floor_cpu):>13}",
        f"{'dense / banded (target >= 4)':<40} {dense / banded:12.2f} {dense_cpu / banded_cpu:13.2f}",
        f"{'dense / floor (bound on that ratio)':<40} {dense / floor:12.2f} {dense_cpu / floor_cpu:13.2f}",
        f"{'nodes evaluated (target <= 15 %)':<40} {100 * fraction:11.2f}%",
        "",
    ]


def main(argv: list[str]) -> int:
    """Run the benchmark and print its tables."""
    import fepre

    parser = argparse.ArgumentParser(prog="fepre bench surface", description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256, help="grid size for part 2 (default 256)")
    parser.add_argument("--band-size", type=int, default=512, help="grid size for part 3 (default 512)")
    parser.add_argument("--repeat", type=int, default=5, help="runs per median (default 5)")
    parser.add_argument("--workers", type=int, default=None, help="threads (default all cores)")
    parser.add_argument("--skip", choices=["seed", "large", "band"], action="append", default=[], help="skip a part (seed: the 81^3 tables of Kelly's master's project; large: --size; band: --band-size)")
    args = parser.parse_args(argv)
    workers = fepre.config.resolve_workers(args.workers)
    parts = []
    if "seed" not in args.skip:
        parts.append(seed_tables(args.repeat, workers))
    if "large" not in args.skip:
        parts.append(large_grid(args.size, args.repeat, workers))
    if "band" not in args.skip:
        parts.append(narrow_band(args.band_size, args.repeat, workers))
    print("\n\n".join("\n".join(part) for part in parts))
    return 0
