"""Reproducible benchmarks against peers, run by ``fepre bench NAME``.

Each module in this package is one benchmark: it defines ``main(argv) -> int`` and its module
docstring's first line is the description that ``fepre bench --list`` prints. Figures are
printed as a table measured in one run, with ratios against the peer from the same run.
"""

from __future__ import annotations

import importlib
import pkgutil
import statistics
import time
from typing import Callable


def available() -> dict[str, str]:
    """Benchmark names and their one-line descriptions."""
    names = {}
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        names[info.name.replace("_", "-")] = (module.__doc__ or "").strip().splitlines()[0] if module.__doc__ else ""
    return names


def run(name: str, argv: list[str]) -> int:
    """Run benchmark ``name`` with its own command-line arguments."""
    names = available()
    if name not in names:
        raise ValueError(f"unknown benchmark {name!r}; available: {', '.join(sorted(names))}")
    module = importlib.import_module(f"{__name__}.{name.replace('-', '_')}")
    return int(module.main(argv) or 0)


def save_figure(figure, path: str, dpi: int = 100) -> str:
    """Write a matplotlib ``figure`` to ``path`` as PNG atomically, close it and return the path."""
    import os

    import matplotlib.pyplot as plt

    temporary = path + ".tmp.png"
    figure.savefig(temporary, dpi=dpi)
    plt.close(figure)
    os.replace(temporary, path)
    return path


def median_time(function: Callable[[], object], repeat: int = 5, warmup: int = 1) -> float:
    """Median wall time of ``function()`` in seconds over ``repeat`` runs after ``warmup`` runs."""
    for _ in range(warmup):
        function()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)
