"""Where dask runs the chunks: the user's ``dask.distributed`` client or scheduler setting, and
what that requires of a model (it must pickle to reach a worker process)."""

from __future__ import annotations

import pickle
from typing import Any

__all__ = ["distributed_client", "needs_pickling", "check_picklable", "require_dask"]


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
