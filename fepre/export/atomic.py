"""Atomic writing: files are written into a staging directory, then renamed into place.

A writer never leaves a half-written file at the destination: it writes every file of a format
(some formats write several, e.g. XDMF with its HDF5 sidecars) into a temporary directory next
to the destination, and only after all of them are complete are they renamed into place
(``os.replace``, or a no-clobber link when ``overwrite`` is false). On any error the staging
directory is removed.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

__all__ = ["check_destination", "staged_files"]

STAGING_PREFIX = ".fepre-export-"


def check_destination(path: Path, names: list[str], overwrite: bool) -> None:
    """Raise a clear error if the files ``names`` cannot be written next to ``path``."""
    directory = path.parent
    if not directory.exists():
        raise FileNotFoundError(f"path: directory {str(directory)!r} does not exist (for {str(path)!r})")
    if not directory.is_dir():
        raise NotADirectoryError(f"path: {str(directory)!r} is not a directory (for {str(path)!r})")
    if not overwrite:
        existing = [name for name in names if (directory / name).exists()]
        if existing:
            raise FileExistsError(
                f"path: {', '.join(repr(str(directory / n)) for n in existing)} already exists and "
                f"overwrite=False; pass overwrite=True to replace it"
            )


@contextlib.contextmanager
def staged_files(path: Path, names: list[str], overwrite: bool) -> Iterator[Path]:
    """Yield a staging directory; on success move the files ``names`` from it next to ``path``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with staged_files(target, ["a.txt"], overwrite=True) as stage:
    ...     _ = (stage / "a.txt").write_text("done")
    >>> target.read_text()
    'done'
    """
    check_destination(path, names, overwrite)
    directory = path.parent
    try:
        stage = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=directory))
    except PermissionError as exc:
        raise PermissionError(f"path: no permission to write in directory {str(directory)!r}") from exc
    try:
        try:
            yield stage
        except Exception as exc:
            # a writer's message names the staged file: show the user's path instead
            text = str(exc)
            if str(stage) in text:
                cleaned = text.replace(str(stage / path.name), str(path)).replace(str(stage), str(directory))
                try:
                    replacement = type(exc)(cleaned)
                except Exception:  # noqa: BLE001 - an exception type that takes other arguments
                    replacement = None
                if replacement is not None:
                    raise replacement from None
            raise
        missing = [name for name in names if not (stage / name).is_file()]
        if missing:
            raise RuntimeError(f"writer did not produce {missing}")  # a bug in fepre, not user input
        for name in names:
            source, target = stage / name, directory / name
            if overwrite:
                os.replace(source, target)
            else:
                try:
                    os.link(source, target)  # fails if target appeared meanwhile: never clobbers
                except FileExistsError as exc:
                    raise FileExistsError(
                        f"path: {str(target)!r} already exists and overwrite=False"
                    ) from exc
    finally:
        shutil.rmtree(stage, ignore_errors=True)
