"""No function over 120 lines and no module over 700 in fepre (tools/code_size.py, run by CI)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def code_size():
    spec = importlib.util.spec_from_file_location("code_size", ROOT / "tools" / "code_size.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


def test_fepre_keeps_the_sizes(code_size):
    assert code_size.oversized(ROOT / "fepre") == []


def test_a_long_function_and_a_long_module_are_named(code_size, tmp_path, capsys):
    package = tmp_path / "pkg"
    package.mkdir()
    body = "".join(f"    x{i} = {i}\n" for i in range(120))  # def line + 120 = 121 lines
    (package / "a.py").write_text(f"def long():\n{body}\n\ndef short():\n    return 1\n")
    (package / "b.py").write_text("x = 1\n" * 701)
    found = code_size.oversized(package)
    assert found == ["pkg/a.py::long (line 1): 121 lines (function limit 120)",
                     "pkg/b.py: 701 lines (module limit 700)"]
    assert code_size.main([str(package)]) == 1
    assert "2 over the limits" in capsys.readouterr().out
