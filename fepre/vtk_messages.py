"""Reading files with VTK without its error output on the user's terminal.

A VTK reader that fails prints its error through VTK's output window, which PyVista forwards to
Python's logging: a corrupt STL printed ten lines of reader internals ("Premature EOF while
reading header", the failed request's vtkInformation) before fepre's own one-line message.
:func:`vtk_messages_kept` keeps those messages for the caller instead, for the duration of a read
only. This module imports nothing of fepre.
"""

from __future__ import annotations

import contextlib
import logging
from typing import Iterator

__all__ = ["vtk_messages_kept"]


class _Keep(logging.Filter):
    """Drops the records PyVista logs for VTK (its observers log through the root logger) and keeps
    their text."""

    def __init__(self, kept: list[str]) -> None:
        super().__init__()
        self.kept = kept

    def filter(self, record: logging.LogRecord) -> bool:
        if "pyvista" in record.pathname.replace("\\", "/").split("/"):
            self.kept.append(record.getMessage())
            return False
        return True


@contextlib.contextmanager
def vtk_messages_kept() -> Iterator[list[str]]:
    """Inside the block, VTK's error and warning messages are collected in the yielded list instead
    of printed (VTK's output window and PyVista's logging of it); both are restored afterwards.

    Examples
    --------
    >>> import pyvista as pv
    >>> with vtk_messages_kept() as messages:
    ...     sphere = pv.Sphere()
    >>> messages
    []
    """
    from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

    kept: list[str] = []
    keep = _Keep(kept)
    window = vtkStringOutputWindow()
    original = vtkOutputWindow.GetInstance()
    vtkOutputWindow.SetInstance(window)
    root = logging.getLogger()
    root.addFilter(keep)
    try:
        yield kept
    finally:
        root.removeFilter(keep)
        vtkOutputWindow.SetInstance(original)
        kept.extend(line for line in window.GetOutput().splitlines() if line.strip())
