"""Scratch arrays and the thread pool of block-wise evaluation.

Grid sampling evaluates a model block by block on a shared pool of threads; within a block,
nodes take their temporaries with :func:`take_scratch` and hand them back with
:func:`give_scratch`, so the next block of the same thread reuses them. This module sits below
:mod:`fepre.sdf.core` and the nodes that use it (booleans, orthants, touching solids) and knows
nothing of models.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

import numpy as np

__all__ = ["ScratchArenas", "take_scratch", "give_scratch", "thread_pool"]

_pools: dict[int, ThreadPoolExecutor] = {}

_scratch = threading.local()


def take_scratch(shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """A C-contiguous array of ``shape`` and ``dtype`` with undefined contents.

    Inside :class:`ScratchArenas` (grid sampling), arrays handed back with :func:`give_scratch`
    are reused by the next blocks of the same thread, whatever their shapes: full-size
    temporaries are then not allocated per block. Blocks are large, so fresh temporaries would
    come from ``mmap`` and be unmapped on release, and the page faults (and, with several
    threads, TLB shoot-downs) cost more than the arithmetic. Elsewhere this is ``np.empty``.
    """
    free = getattr(_scratch, "free", None)
    if free is not None:
        stack = free.get(dtype)
        if stack:
            size = 1
            for n in shape:
                size *= n
            buffer = stack.pop()
            if buffer.size >= size:
                return buffer[:size].reshape(shape)
    return np.empty(shape, dtype=dtype)


def give_scratch(array: np.ndarray) -> None:
    """Hand back an array from :func:`take_scratch` once its contents are no longer needed."""
    free = getattr(_scratch, "free", None)
    if free is not None:
        owner = array if array.base is None else array.base
        free.setdefault(owner.dtype, []).append(owner.reshape(-1))


class ScratchArenas:
    """Per-thread reuse of scratch arrays (see :func:`take_scratch`) during one sampling call.

    The arrays are released with the object.
    """

    def __init__(self) -> None:
        self._free: dict[int, dict] = {}

    def run(self, function: Callable[..., Any], *args: Any) -> Any:
        """Call ``function(*args)`` with this thread's scratch arrays available for reuse."""
        previous = getattr(_scratch, "free", None)
        _scratch.free = self._free.setdefault(threading.get_ident(), {})
        try:
            return function(*args)
        finally:
            _scratch.free = previous


def thread_pool(workers: int) -> ThreadPoolExecutor:
    """A shared pool with ``workers`` threads (created once per size)."""
    pool = _pools.get(workers)
    if pool is None:
        pool = _pools[workers] = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="fepre")
    return pool

