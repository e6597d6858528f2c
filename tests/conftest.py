"""Test-suite wide settings: the long proofs (``@pytest.mark.slow``) stay out of the default run.

``pytest`` runs the default set (a few minutes on 2 cores); ``pytest -m slow`` runs the long proofs,
``pytest -m "slow or not slow"`` everything. A slow test named on the command line
(``pytest tests/test_demo.py::test_demo_writes_every_file_of_every_part``) runs without ``-m``.
"""

from __future__ import annotations

from pathlib import Path

import pytest


def _named(config: pytest.Config) -> list[tuple[Path, str]]:
    """The tests named on the command line as ``path::name``: (resolved path, name prefix)."""
    named = []
    for arg in config.args:
        if "::" in arg:
            path, name = arg.split("::", 1)
            named.append((Path(config.invocation_params.dir, path).resolve(), name))
    return named


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.option.markexpr:  # the user chose the set with -m
        return
    named = _named(config)
    slow = [
        item for item in items
        if item.get_closest_marker("slow") is not None
        and not any(Path(item.path).resolve() == path and item.nodeid.split("::", 1)[1].startswith(name)
                    for path, name in named)
    ]
    if slow:
        config.hook.pytest_deselected(items=slow)
        chosen = set(map(id, slow))
        items[:] = [item for item in items if id(item) not in chosen]


@pytest.fixture(autouse=True)
def _nothing_written_in_the_working_folder():
    """A test writes under its ``tmp_path``, never into the folder pytest runs in (pytetwild's
    ``__tracked_surface.stl`` was left in a clone's root)."""
    before = set(Path.cwd().iterdir())
    yield
    written = sorted(str(path.name) for path in set(Path.cwd().iterdir()) - before)
    assert not written, f"the test wrote {written} into the working folder {Path.cwd()}"
