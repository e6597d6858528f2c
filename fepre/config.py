"""Process-wide settings: thread count and memory limits.

Examples
--------
>>> import fepre
>>> fepre.config.workers = 1          # evaluate models on one thread
>>> fepre.config.max_grid_bytes > 0
True
"""

from __future__ import annotations

import os


def _machine_memory_bytes() -> int:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 8 * 1024**3


class Config:
    """Mutable settings shared by every fepre routine.

    Attributes
    ----------
    workers : int
        Threads used by routines whose ``workers`` argument is None. Default: all cores.
    max_grid_bytes : int
        Largest sampled grid, in bytes, that :func:`fepre.sample` will allocate.
        Default: half the machine's memory.
    chunk_points : int
        Points evaluated per block when a model is called on many points; sized so a block's
        temporaries stay in cache.
    """

    def __init__(self) -> None:
        self.workers: int = os.cpu_count() or 1
        self.max_grid_bytes: int = _machine_memory_bytes() // 2
        self.chunk_points: int = 32768

    def resolve_workers(self, workers: int | None) -> int:
        """Return ``workers`` checked, or the configured default when it is None."""
        if workers is None:
            return max(1, int(self.workers))
        if isinstance(workers, bool) or not isinstance(workers, (int,)) or workers < 1:
            from .arguments import shown

            raise ValueError(f"workers must be a positive integer or None; got {shown(workers)}")
        return int(workers)


config = Config()
