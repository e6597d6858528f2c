"""Grid sampling of a six-node SDF model: fepre vs vtkSampleFunction vs a numpy copy.

The model is ``(box | sphere.translate) - cylinder`` (box, translated sphere, capped cylinder,
union, difference: six nodes), sampled on an N^3 float32 grid over [-2, 2]^3. The peer is
vtkSampleFunction on the equivalent VTK implicit functions (vtkImplicitBoolean of vtkBox, a
vtkSphere behind a vtkTransform, and vtkCylinder capped by two vtkPlanes) with the same bounds,
dimensions and float output. The memory floor is a numpy copy of an array of the grid's size.
"""

from __future__ import annotations

import argparse
import statistics
import time
import tracemalloc

import numpy as np

from ..config import config

BOUNDS = (-2.0, 2.0)


def fepre_model():
    """The benchmark model built with fepre.sdf."""
    from .. import sdf

    return (sdf.box((2.0, 2.0, 2.0)) | sdf.sphere(0.8).translate((1.0, 1.0, 1.0))) - sdf.cylinder(
        radius=0.5, height=3.0
    )


def vtk_model():
    """The same model as VTK implicit functions (returned with the objects it keeps alive)."""
    import vtk

    box = vtk.vtkBox()
    box.SetBounds(-1.0, 1.0, -1.0, 1.0, -1.0, 1.0)
    ball = vtk.vtkSphere()
    ball.SetRadius(0.8)
    move = vtk.vtkTransform()
    move.Translate(-1.0, -1.0, -1.0)  # implicit functions apply the transform to the point
    ball.SetTransform(move)
    solid = vtk.vtkImplicitBoolean()
    solid.SetOperationTypeToUnion()
    solid.AddFunction(box)
    solid.AddFunction(ball)

    tube = vtk.vtkCylinder()
    tube.SetRadius(0.5)
    tube.SetAxis(0.0, 0.0, 1.0)
    top, bottom = vtk.vtkPlane(), vtk.vtkPlane()
    top.SetOrigin(0.0, 0.0, 1.5)
    top.SetNormal(0.0, 0.0, 1.0)
    bottom.SetOrigin(0.0, 0.0, -1.5)
    bottom.SetNormal(0.0, 0.0, -1.0)
    capped = vtk.vtkImplicitBoolean()
    capped.SetOperationTypeToIntersection()
    for function in (tube, top, bottom):
        capped.AddFunction(function)

    part = vtk.vtkImplicitBoolean()
    part.SetOperationTypeToDifference()
    part.AddFunction(solid)
    part.AddFunction(capped)
    return part, (box, ball, move, solid, tube, top, bottom, capped)


def vtk_sampler(size: int):
    """A configured vtkSampleFunction for the VTK model on the benchmark grid."""
    import vtk

    part, keep = vtk_model()
    sampler = vtk.vtkSampleFunction()
    sampler.SetImplicitFunction(part)
    lo, hi = BOUNDS
    sampler.SetModelBounds(lo, hi, lo, hi, lo, hi)
    sampler.SetSampleDimensions(size, size, size)
    sampler.SetOutputScalarTypeToFloat()
    sampler.ComputeNormalsOff()
    sampler.CappingOff()
    sampler._fepre_keep = keep  # keep the Python wrappers of the functions alive
    return sampler


def use_vtk_backend(backend: str, threads: int) -> bool:
    """Switch vtkSMPTools to ``backend`` (with ``threads`` threads); False if unavailable."""
    import vtk

    if not vtk.vtkSMPTools.SetBackend(backend):
        return False
    vtk.vtkSMPTools.Initialize(1 if backend == "Sequential" else threads)
    return True


def interleaved_medians(
    functions: dict, repeat: int, warm_bytes: int = 0
) -> tuple[dict[str, float], dict[str, float]]:
    """Median wall and CPU (all threads) times of each function, in interleaved rounds.

    One warm-up round is not timed. Interleaving makes the ratios robust to load that changes
    during the run; CPU time measures the work done even when the machine is shared.

    With ``warm_bytes``, each timed call is preceded by an untimed allocate-and-fill of that
    many bytes, so every function allocates its output from memory in the same state. On a
    virtual machine that hands freed memory back to its host (virtio-balloon free page
    reporting), memory freed a second or more earlier costs up to 20x more to touch again
    (64 MiB: 5 ms right after a free, 15-126 ms after a 0.5-3 s pause): without this, the
    function that runs after slow peers pays for it and the one that follows it does not.
    """
    wall: dict[str, list[float]] = {name: [] for name in functions}
    cpu: dict[str, list[float]] = {name: [] for name in functions}
    for round_index in range(repeat + 1):
        for name, function in functions.items():
            if warm_bytes:
                np.empty(warm_bytes, dtype=np.uint8).fill(0)
            start, start_cpu = time.perf_counter(), time.process_time()
            function()
            if round_index:
                wall[name].append(time.perf_counter() - start)
                cpu[name].append(time.process_time() - start_cpu)
    return (
        {name: statistics.median(values) for name, values in wall.items()},
        {name: statistics.median(values) for name, values in cpu.items()},
    )


def vtk_values(sampler) -> np.ndarray:
    from vtk.util.numpy_support import vtk_to_numpy

    sampler.Modified()
    sampler.Update()
    return vtk_to_numpy(sampler.GetOutput().GetPointData().GetScalars())


def run(size: int, repeat: int, workers: int | None = None) -> dict[str, float]:
    """Measure the three figures and the sign agreement; returns them in a dict."""
    model = fepre_model()
    axis = np.linspace(BOUNDS[0], BOUNDS[1], size)
    sample = lambda: model.values_on_axes(axis, axis, axis, dtype=np.float32, workers=workers)  # noqa: E731
    sampler = vtk_sampler(size)
    floor_source = np.ones((size, size, size), dtype=np.float32)

    threads = config.resolve_workers(workers)

    def vtk_with(backend: str):
        def sample_vtk():
            use_vtk_backend(backend, threads)
            return vtk_values(sampler)

        return sample_vtk

    functions = {"fepre": sample, "copy": floor_source.copy}
    for backend in ("Sequential", "STDThread"):
        if use_vtk_backend(backend, threads):
            functions[f"vtk {backend}"] = vtk_with(backend)
    medians, cpu = interleaved_medians(functions, repeat, warm_bytes=floor_source.nbytes)
    vtk_times = {name.split()[1]: seconds for name, seconds in medians.items() if name.startswith("vtk ")}
    vtk_cpu = {name.split()[1]: seconds for name, seconds in cpu.items() if name.startswith("vtk ")}
    vtk_backend = min(vtk_times, key=vtk_times.get)
    fepre_time, copy_time = medians["fepre"], medians["copy"]

    tracemalloc.start()
    ours = sample().ravel()
    peak_bytes = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    theirs = vtk_values(sampler)
    agree = float(np.mean((ours < 0) == (theirs < 0)))
    return {
        "points": float(size**3),
        "fepre": fepre_time,
        "vtk": vtk_times[vtk_backend],
        "vtk_backend": vtk_backend,
        "vtk_times": vtk_times,
        "vtk_cpu": vtk_cpu,
        "fepre_cpu": cpu["fepre"],
        "copy_cpu": cpu["copy"],
        "copy": copy_time,
        "sign_agreement": agree,
        "peak_bytes": float(peak_bytes),
        "grid_bytes": float(ours.nbytes),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench sdf", description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256, help="grid points per axis (default 256)")
    parser.add_argument("--repeat", type=int, default=5, help="timed runs per method (median; default 5)")
    parser.add_argument("--workers", type=int, default=None, help="fepre threads (default fepre.config.workers)")
    args = parser.parse_args(argv)
    if args.size < 2 or args.repeat < 1:
        parser.error("--size must be >= 2 and --repeat >= 1")
    figures = run(args.size, args.repeat, args.workers)
    print(f"model: {fepre_model().describe()} with {sum(1 for _ in fepre_model().walk())} nodes")
    print(f"grid: {args.size}^3 = {int(figures['points']):,} points, float32, median of {args.repeat}")
    print(f"{'method':34s} {'median s':>10s} {'Mpts/s':>9s} {'cpu s':>8s} {'ratio (wall)':>24s}")
    threads = config.resolve_workers(args.workers)
    rows = [(f"fepre values_on_axes ({threads} threads)", figures["fepre"], figures["fepre_cpu"], "")]
    for backend, seconds in figures["vtk_times"].items():
        rows.append(
            (f"vtkSampleFunction ({backend})", seconds, figures["vtk_cpu"][backend], f"{seconds / figures['fepre']:.1f}x fepre")
        )
    rows.append(
        (
            "numpy copy (memory floor)",
            figures["copy"],
            figures["copy_cpu"],
            f"fepre = {figures['fepre'] / figures['copy']:.2f}x floor",
        )
    )
    for name, seconds, cpu_seconds, ratio in rows:
        print(f"{name:34s} {seconds:10.4f} {figures['points'] / seconds / 1e6:9.1f} {cpu_seconds:8.3f} {ratio:>24s}")
    print(
        f"speed-up over VTK's fastest backend ({figures['vtk_backend']}): "
        f"{figures['vtk'] / figures['fepre']:.1f}x (target >= 10x)"
    )
    print(f"fepre / memory floor: {figures['fepre'] / figures['copy']:.2f}x (target <= 5x)")
    print(
        f"CPU work (all threads): fepre {figures['fepre_cpu'] / figures['copy_cpu']:.2f}x the copy, "
        f"VTK {min(figures['vtk_cpu'].values()) / figures['fepre_cpu']:.1f}x fepre"
    )
    print(
        f"fepre peak memory: {figures['peak_bytes'] / 2**20:.1f} MiB for a {figures['grid_bytes'] / 2**20:.1f} MiB grid "
        f"({figures['peak_bytes'] / figures['grid_bytes']:.2f}x)"
    )
    print(f"inside/outside agreement with VTK: {100 * figures['sign_agreement']:.3f}% of nodes (need > 99.9%)")
    return 0 if figures["sign_agreement"] > 0.999 else 1
