"""Where dask runs the chunks: the user's ``dask.distributed`` client or scheduler setting, and
what that requires of a model (it must pickle to reach a worker process)."""

from __future__ import annotations

import os
import pickle
from typing import Any, Iterable

__all__ = ["distributed_client", "needs_pickling", "check_picklable", "require_dask", "in_completion_order"]


def require_dask(feature: str) -> None:
    """Raise a clear ImportError when dask (and zarr for stores) are missing."""
    try:
        import dask.array  # noqa: F401  (the import is the check)
    except ImportError:
        raise ImportError(
            f"{feature} needs dask: pip install 'fepre[dask]' (dask[array], distributed, zarr)"
        ) from None


def distributed_client():
    """The current ``dask.distributed`` client, or None."""
    try:
        from distributed import default_client
    except ImportError:
        return None
    try:
        return default_client()
    except ValueError:
        return None


def needs_pickling() -> bool:
    """Whether tasks leave this process: a distributed client, or dask's process scheduler."""
    import dask

    if distributed_client() is not None:
        return True
    return dask.config.get("scheduler", None) in ("processes", "multiprocessing")


def _dumps(obj: Any) -> None:
    try:
        import cloudpickle

        cloudpickle.dumps(obj)
    except ImportError:  # pragma: no cover - distributed depends on cloudpickle
        pickle.dumps(obj)


def check_picklable(model: Any, name: str = "model") -> None:
    """Raise a TypeError naming the first node of ``model`` that cannot be pickled, and why.

    Examples
    --------
    >>> from fepre import sdf
    >>> check_picklable(sdf.sphere(1.0) - sdf.box((1, 1, 1)))
    """
    try:
        _dumps(model)
        return
    except Exception as exc:
        failure = exc
    path, node = name, model
    while True:
        children = list(getattr(node, "children", ()) or ())
        for index, child in enumerate(children):
            try:
                _dumps(child)
            except Exception as exc:
                path, node, failure = f"{path}.children[{index}]", child, exc
                break
        else:
            break
    raise TypeError(
        f"{name} cannot be sent to the dask workers: node {path} ({type(node).__name__}) does not "
        f"pickle: {type(failure).__name__}: {failure}. Models built from fepre.sdf pickle; a custom "
        f"node must keep only picklable attributes (no lambdas, open files or locks), or use the "
        f"threaded scheduler"
    )


def in_completion_order(tasks: list, window: int) -> Iterable:
    """Chunk results as they finish, with at most ``window`` chunks in flight (bounded memory)."""
    import dask

    client = distributed_client()
    if client is not None:
        from distributed import as_completed

        pending = iter(tasks)
        futures = as_completed([client.compute(t) for t in _take(pending, window)])
        for future in futures:
            result = future.result()
            future.release()
            for t in _take(pending, 1):
                futures.add(client.compute(t))
            yield result
        return
    if dask.config.get("scheduler", None) not in (None, "threads", "threading"):
        for start in range(0, len(tasks), window):  # the user's own scheduler, in waves
            yield from dask.compute(*tasks[start : start + window])
        return
    # dask's threads, as a sliding window: a new chunk starts as soon as one finishes
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    workers = int(dask.config.get("num_workers", None) or os.cpu_count() or 1)
    pending = iter(tasks)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        running = {pool.submit(dask.compute, t, scheduler="sync") for t in _take(pending, window)}
        while running:
            done, running = wait(running, return_when=FIRST_COMPLETED)
            running |= {pool.submit(dask.compute, t, scheduler="sync") for t in _take(pending, len(done))}
            for future in done:
                yield future.result()[0]


def _take(iterator, count: int) -> list:
    out = []
    for _ in range(count):
        try:
            out.append(next(iterator))
        except StopIteration:
            break
    return out
