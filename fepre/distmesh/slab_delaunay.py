"""The DistMesh loop's Delaunay on both cores: two overlapping slabs, one in a worker process.

The loop needs a triangulation only for its bars (and the cells' quality for its history), so
two Delaunay triangulations of overlapping halves of the points, each keeping the cells whose
centroid lies on its own side of the cut, serve it: with an overlap of several edge lengths they
are the whole Delaunay triangulation except where the two halves break a tie (co-spherical
points) differently at the cut. Such a seam can hold overlapping cells, which is why the final
mesh never reuses it and takes one whole triangulation instead.
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import threading

import numpy as np

from ..errors import MeshingError
from .delaunay import _gmsh, gmsh_available

__all__ = ["split_delaunay", "tiles_hull", "close_worker", "PARALLEL_MIN_POINTS"]

#: below this many points a second process costs more (start, transfer) than it saves
PARALLEL_MIN_POINTS = 50_000
#: the slabs overlap by this many local edge lengths on each side of the cut
OVERLAP = 3.0
#: a slab may hold at most this share of the points (else the overlap is most of the part)
MAX_SHARE = 0.65


class _Worker:
    """The child process of :mod:`fepre.distmesh.delaunay_worker`, started on first use."""

    _lock = threading.Lock()
    #: held from a request to its answer; another thread meanwhile triangulates on its own
    busy = threading.Lock()
    _process: subprocess.Popen | None = None
    _owner = 0  # the process that started it: a forked child starts its own

    @classmethod
    def process(cls) -> subprocess.Popen:
        with cls._lock:
            if cls._process is None or cls._owner != os.getpid() or cls._process.poll() is not None:
                cls._owner = os.getpid()
                cls._process = subprocess.Popen(
                    [sys.executable, "-m", "fepre.distmesh.delaunay_worker"],
                    stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0,
                )
                atexit.register(cls.close)
            return cls._process

    @classmethod
    def close(cls) -> None:
        with cls._lock:
            if cls._process is not None and cls._owner == os.getpid() and cls._process.poll() is None:
                try:
                    cls._process.stdin.close()
                    cls._process.wait(timeout=5)
                except (OSError, subprocess.TimeoutExpired):
                    cls._process.kill()
            cls._process = None

    @staticmethod
    def _read(stream, size: int) -> bytes:
        data = bytearray()
        while len(data) < size:
            chunk = stream.read(size - len(data))
            if not chunk:
                raise MeshingError("the Delaunay worker process ended unexpectedly")
            data += chunk
        return bytes(data)

    @classmethod
    def submit(cls, points: np.ndarray) -> subprocess.Popen:
        process = cls.process()
        process.stdin.write(np.array([len(points)], np.int64).tobytes())
        process.stdin.write(np.ascontiguousarray(points, np.float64).tobytes())
        process.stdin.flush()
        return process

    @classmethod
    def result(cls, process: subprocess.Popen) -> np.ndarray:
        count = int(np.frombuffer(cls._read(process.stdout, 8), np.int64)[0])
        if count < 0:
            length = int(np.frombuffer(cls._read(process.stdout, 8), np.int64)[0])
            raise MeshingError(cls._read(process.stdout, length).decode(errors="replace"))
        return np.frombuffer(cls._read(process.stdout, 16 * count), np.int32).reshape(count, 4)


def close_worker() -> None:
    """End the worker process (it is started again when needed; it also ends with Python)."""
    _Worker.close()


def second_core() -> bool:
    """Whether the machine has a second core for the worker."""
    return (os.cpu_count() or 1) > 1


def split_delaunay(points: np.ndarray, spacing: float, backend: str) -> np.ndarray | None:
    """Delaunay cells (M, 4) of ``points`` from two overlapping slabs triangulated at once, or
    None where that does not pay (few points, one core, no gmsh, slabs mostly overlap) or
    another thread is using the worker.

    ``spacing`` is the largest edge length expected at the cut: the slabs overlap by
    ``OVERLAP * spacing`` on each side. Cells are returned in the backend's order (see
    :func:`~fepre.distmesh.delaunay.tetrahedralize` for the canonical form).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> split_delaunay(rng.random((100, 3)), 0.2, "gmsh") is None  # too few points to pay
    True
    """
    if backend not in ("gmsh", "auto") or not gmsh_available():
        return None
    if len(points) < PARALLEL_MIN_POINTS or not second_core():
        return None
    axis = int(np.argmax(np.ptp(points, axis=0)))
    coordinate = points[:, axis]
    cut = float(np.median(coordinate))
    reach = OVERLAP * spacing
    low = np.flatnonzero(coordinate <= cut + reach)
    high = np.flatnonzero(coordinate > cut - reach)
    if max(len(low), len(high)) > MAX_SHARE * len(points) or min(len(low), len(high)) < 4:
        return None
    if not _Worker.busy.acquire(blocking=False):
        return None
    try:
        process = _Worker.submit(points[high])
        own = low[_gmsh(points[low])]
        other = high[_Worker.result(process)]
    except (OSError, MeshingError):
        # the worker died or failed (its pipes closed, gmsh's error): triangulate here instead
        _Worker.close()
        return None
    finally:
        _Worker.busy.release()
    own = own[points[own, axis].mean(axis=1) <= cut] if len(own) else own
    other = other[points[other, axis].mean(axis=1) > cut] if len(other) else other
    return np.concatenate([own, other.astype(np.int64)])


def tiles_hull(points: np.ndarray, tets: np.ndarray) -> bool:
    """Whether positive cells ``tets`` fill the convex hull of ``points`` exactly once: their
    volumes add up to the hull's (to 1e-9). A seam where the two slabs broke ties differently
    overlaps or leaves a gap (a box with a hole: +0.3%); then the final mesh triangulates anew.

    Examples
    --------
    >>> cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    >>> tets = np.array([[0, 3, 1, 7], [0, 2, 3, 7], [0, 6, 2, 7], [0, 4, 6, 7], [0, 5, 4, 7], [0, 1, 5, 7]])
    >>> tiles_hull(cube, tets), tiles_hull(cube, tets[:5]), tiles_hull(cube, tets[[0, 0, 1, 2, 3, 4, 5]])
    (True, False, False)
    """
    from scipy.spatial import ConvexHull, QhullError

    from ..quality import signed_volumes

    volumes = signed_volumes(points, tets)
    if len(volumes) == 0 or volumes.min() <= 0:
        return False
    try:
        hull = ConvexHull(points).volume
    except QhullError:
        return False
    return abs(float(volumes.sum()) - hull) <= 1e-9 * hull
