"""How many threads a compiled kernel runs on: one unless the work pays for a parallel launch.

fepre's numba kernels (``parallel=True``) and gmsh's HXT Delaunay kernel run their threads in
the same OpenMP pool (libgomp, numba's default threading layer where it is installed). A
parallel launch costs about 5 microseconds on free cores, but libgomp's threads busy-wait
(about 300,000 spins, 8-12 ms on the machines measured) before they sleep: when every core is
taken (other processes, a shared machine), a thread that waits for a descheduled peer at the
launch's barrier spins that whole budget first. Measured on a shared 2-core machine with both
cores busy: 8-12 ms per launch of a trivial kernel against 3 us free (``OMP_WAIT_POLICY=passive``:
12 us; numba's workqueue layer: 70 us), which made a 1,641-cell mesh take 15 s instead of 0.6 s.

So a kernel runs on one thread unless its serial work, ``items * seconds_per_item``, is large
enough that the threads' share of it saves more than twice the launch cost measured now: a
trivial parallel launch timed at most once per :data:`PROBE_INTERVAL` seconds (under
contention the probe costs ~10 ms a second, 1%). Small work (under :data:`SERIAL_SECONDS`)
never probes. The kernels' results do not depend on the thread count (each writes its own
items; the chunked counting sorts are the same for any number of chunks), so the choice
changes time, never a mesh.

Examples
--------
>>> from fepre.kernel_threads import kernel_threads
>>> with kernel_threads(100) as threads:   # 100 items: far too little work for a launch
...     threads
1
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from typing import Iterator

import numpy as np
import numba
from numba import njit, prange

__all__ = ["kernel_threads", "one_blas_thread", "choose_threads", "launch_seconds", "PROBE_INTERVAL", "SERIAL_SECONDS"]

#: serial work (seconds) below which a kernel always runs on one thread, without a probe
SERIAL_SECONDS = 1.0e-4
#: seconds a measured launch cost is trusted before the next probe
PROBE_INTERVAL = 1.0
#: the serial cost of one item when a caller does not say (the cheapest per-cell kernels: 5-7 ns)
SECONDS_PER_ITEM = 1.0e-8

_probe_state = {"threads": 0, "seconds": math.inf, "at": -math.inf}


@njit(cache=True, parallel=True)
def _probe(out):  # pragma: no cover - compiled
    for i in prange(out.shape[0]):
        out[i] = i


def _set_threads(threads: int) -> None:
    if numba.get_num_threads() != threads:
        numba.set_num_threads(threads)


def launch_seconds(threads: int) -> float:
    """The cost (seconds) of a parallel launch on ``threads`` threads now: a trivial kernel
    timed (once per :data:`PROBE_INTERVAL`; the last figure in between)."""
    now = time.perf_counter()
    state = _probe_state
    if state["threads"] == threads and now - state["at"] < PROBE_INTERVAL:
        return state["seconds"]
    previous = numba.get_num_threads()
    out = np.empty(threads)
    try:
        _set_threads(threads)
        if state["threads"] == 0:
            _probe(out)  # load the compiled probe once, untimed
        started = time.perf_counter()
        _probe(out)
        seconds = time.perf_counter() - started
    finally:
        _set_threads(previous)
    state.update(threads=threads, seconds=seconds, at=time.perf_counter())
    return seconds


def choose_threads(items: int, seconds_per_item: float = SECONDS_PER_ITEM, most: int | None = None) -> int:
    """Threads for a kernel over ``items`` items of ``seconds_per_item`` serial work each: ``most``
    (default: numba's current thread count) when their share of the work,
    ``items * seconds_per_item * (1 - 1/most)``, is more than twice :func:`launch_seconds`, else 1.

    Examples
    --------
    >>> choose_threads(10)
    1
    """
    most = numba.get_num_threads() if most is None else int(most)
    work = float(items) * float(seconds_per_item)
    if most <= 1 or work < SERIAL_SECONDS:
        return 1
    probe_threads = min(most, numba.config.NUMBA_NUM_THREADS)
    saving = work * (1.0 - 1.0 / most)
    return most if saving > 2.0 * launch_seconds(probe_threads) else 1


@contextmanager
def kernel_threads(items: int, seconds_per_item: float = SECONDS_PER_ITEM) -> Iterator[int]:
    """Run the numba kernels in the ``with`` block on :func:`choose_threads` threads (numba's
    thread count is set for the calling thread and put back); yields the count, which chunked
    kernels take as their number of chunks.

    Examples
    --------
    >>> import numba
    >>> before = numba.get_num_threads()
    >>> with kernel_threads(10) as threads:
    ...     numba.get_num_threads() == threads == 1
    True
    >>> numba.get_num_threads() == before
    True
    """
    previous = numba.get_num_threads()
    threads = choose_threads(items, seconds_per_item, previous)
    _set_threads(threads)
    try:
        yield threads
    finally:
        _set_threads(previous)


_blas_state: dict = {}


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """BLAS (numpy's OpenBLAS) on one thread inside the block, as it was after it.

    OpenBLAS's threads spin-wait like libgomp's: with both cores of the shared machine busy a
    ``(300000, 3) @ (3, 3)`` product took 110-340 ms against 15 ms on one thread (the same
    numbers bit for bit: each row is the same three-term product on any thread). A product with
    an inner dimension of 3 is memory-bound, so one thread loses nothing on free cores either.
    Uses ``threadpoolctl`` (its controller made once); without it, the block runs as it is.

    Examples
    --------
    >>> import numpy as np
    >>> with one_blas_thread():
    ...     float((np.ones((4, 3)) @ np.eye(3)).sum())
    12.0
    """
    if "controller" not in _blas_state:
        try:
            from threadpoolctl import ThreadpoolController

            _blas_state["controller"] = ThreadpoolController()
        except ImportError:  # pragma: no cover - threadpoolctl is a dependency
            _blas_state["controller"] = None
    controller = _blas_state["controller"]
    if controller is None:
        yield
        return
    with controller.limit(limits=1, user_api="blas"):
        yield
