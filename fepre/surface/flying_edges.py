"""The reference extractor: VTK's vtkFlyingEdges3D, run with vtkSMPTools' thread backend."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from ..config import config

__all__ = ["flying_edges", "use_smp_threads", "sequential_smp"]

_smp_workers: int | None = None


def use_smp_threads(workers: int | None = None) -> int:
    """Switch VTK's SMP tools to the STDThread backend with ``workers`` threads (once per count)."""
    global _smp_workers
    workers = config.resolve_workers(workers)
    if _smp_workers != workers:
        from vtkmodules.vtkCommonCore import vtkSMPTools

        tools = vtkSMPTools()
        tools.SetBackend("STDThread")
        tools.Initialize(workers)
        _smp_workers = workers
    return workers


@contextmanager
def sequential_smp():
    """Run the VTK filters inside on one thread (vtkSMPTools' Sequential backend), then put the
    backend back. For filters whose result depends on how points are shared among threads:
    probing a mesh at points on a face between two cells gives whichever cell each thread's
    search met first (a background size field came out different on every run)."""
    from vtkmodules.vtkCommonCore import vtkSMPTools

    tools = vtkSMPTools()
    before = tools.GetBackend()
    tools.SetBackend("Sequential")
    try:
        yield
    finally:
        tools.SetBackend(before)
        if before == "STDThread" and _smp_workers is not None:
            tools.Initialize(_smp_workers)


def flying_edges(grid, scalars: str, level: float, workers: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points (V, 3) and outward triangles (T, 3) from vtkFlyingEdges3D on ``grid[scalars]``.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> grid = pv.ImageData(dimensions=(9, 9, 9), spacing=(0.25,) * 3, origin=(-1,) * 3)
    >>> grid["sdf"] = np.linalg.norm(grid.points, axis=1) - 0.6
    >>> points, triangles = flying_edges(grid, "sdf", 0.0)
    >>> triangles.shape[1]
    3
    """
    from vtkmodules.vtkCommonDataModel import vtkDataObject
    from vtkmodules.vtkFiltersCore import vtkFlyingEdges3D
    from vtkmodules.util.numpy_support import vtk_to_numpy

    use_smp_threads(workers)
    # vtkFlyingEdges3D writes float32 points: far from the origin (a part placed at 1e4) they
    # lose their last digits and triangles collapse. Extract about the origin, shift in float64.
    from vtkmodules.vtkCommonDataModel import vtkImageData

    local = vtkImageData()
    local.ShallowCopy(grid)
    origin = np.array(grid.GetOrigin(), dtype=np.float64)
    local.SetOrigin(0.0, 0.0, 0.0)
    fe = vtkFlyingEdges3D()
    fe.SetInputData(local)
    fe.SetInputArrayToProcess(0, 0, 0, vtkDataObject.FIELD_ASSOCIATION_POINTS, scalars)
    fe.SetValue(0, float(level))
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.ComputeScalarsOff()
    fe.InterpolateAttributesOff()
    fe.Update()
    output = fe.GetOutput()
    if output.GetNumberOfPoints() == 0:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    points = vtk_to_numpy(output.GetPoints().GetData()).astype(np.float64) + origin
    connectivity = vtk_to_numpy(output.GetPolys().GetConnectivityArray())
    # flying edges orders triangles with normals towards lower values: reverse for outward
    return points, connectivity.reshape(-1, 3)[:, ::-1]
