"""Work run in a fresh Python interpreter: gmsh, OpenCASCADE and fTetWild can abort or hang
the process they run in, which must not be the user's.

A child is ``python -m MODULE ... OUT`` that writes its result to ``OUT`` or a message to
``OUT.error``; :func:`run_child` starts it, stops it after a timeout and turns each way it can
fail into one exception naming the tool. :func:`gmsh_cells` reads the current gmsh model's
nodes and elements as arrays, in the child.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np

__all__ = ["run_child", "gmsh_cells"]


def run_child(command: list[str], out: str, *, timeout: float, cwd: str, tool: str, doing: str,
              error: type[Exception] = RuntimeError) -> None:
    """Run ``command`` in ``cwd`` and raise ``error`` unless it wrote ``out``: when it ran over
    ``timeout`` seconds (stopped), wrote ``out + ".error"`` (its message) or died.

    Examples
    --------
    >>> import sys, tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     run_child([sys.executable, "-c", "pass"], folder + "/out.npz", timeout=60, cwd=folder,
    ...               tool="python", doing="doing nothing")
    Traceback (most recent call last):
    RuntimeError: python's process died doing nothing (exit code 0: no message)
    """
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout, cwd=cwd)
    except subprocess.TimeoutExpired:
        raise error(f"{tool} did not finish {doing} within {timeout:g} s (stopped)") from None
    if os.path.exists(out + ".error"):
        raise error(f"{tool} failed {doing}: {Path(out + '.error').read_text(encoding='utf-8')}")
    if done.returncode != 0 or not os.path.exists(out):
        last = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no message"]
        raise error(f"{tool}'s process died {doing} (exit code {done.returncode}: {last[0][:200]})")


def gmsh_cells(dimension: int, element_type: int, corners: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The current gmsh model's nodes (N, 3) and its elements of ``element_type`` in
    ``dimension`` as (M, ``corners``) indices into them, or None when it has none."""
    import gmsh

    tags, coordinates, _ = gmsh.model.mesh.getNodes()
    types, _, nodes = gmsh.model.mesh.getElements(dimension)
    if element_type not in list(types):
        return None
    cells = np.asarray(nodes[list(types).index(element_type)], dtype=np.int64).reshape(-1, corners)
    order = np.argsort(tags)
    return np.asarray(coordinates, dtype=np.float64).reshape(-1, 3)[order], np.searchsorted(tags[order], cells)
