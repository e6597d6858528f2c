"""Every script in examples/ runs to completion (examples are also tests)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).parent.parent / "examples").glob("*.py"))


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(script, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(script), str(tmp_path)])
    runpy.run_path(str(script), run_name="__main__")
    assert any(tmp_path.iterdir()), f"{script.name} wrote nothing into its output folder"


def test_cube_with_hole_surface_is_closed_with_the_right_volume(tmp_path):
    namespace = runpy.run_path(str(EXAMPLES[[p.stem for p in EXAMPLES].index("cube_with_hole")]))
    check = namespace["main"](str(tmp_path))
    assert (tmp_path / "cube_with_hole.stl").stat().st_size > 10_000
    assert check.watertight and check.manifold and check.oriented
    assert check.genus == 1
    assert check.volume == pytest.approx(125 - 5 * 3.141592653589793, rel=5e-3)
