"""Sizes the design keeps: no function over 120 lines, no module over 700 (docs/design.md, Layout).

Standard library only; parses every module of ``fepre/`` and exits 1 when one is over, naming it.
A module or function that must be longer is listed in ``EXEMPT`` with the reason, which
docs/design.md repeats.

Usage: ``python tools/code_size.py [PACKAGE_DIR]``
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

MAX_FUNCTION_LINES = 120
MAX_MODULE_LINES = 700

#: "path" or "path::function" -> why it is longer
EXEMPT: dict[str, str] = {}


def oversized(package: Path) -> list[str]:
    """The functions and modules of ``package`` over the limits, as ``path[::name]: N lines``."""
    found = []
    root = package.parent
    for path in sorted(package.rglob("*.py")):
        name = path.relative_to(root).as_posix()
        text = path.read_text(encoding="utf-8")
        lines = len(text.splitlines())
        if lines > MAX_MODULE_LINES and name not in EXEMPT:
            found.append(f"{name}: {lines} lines (module limit {MAX_MODULE_LINES})")
        for node in ast.walk(ast.parse(text, filename=name)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                key = f"{name}::{node.name}"
                if length > MAX_FUNCTION_LINES and key not in EXEMPT:
                    found.append(f"{key} (line {node.lineno}): {length} lines (function limit {MAX_FUNCTION_LINES})")
    return found


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    package = Path(args[0]) if args else Path(__file__).resolve().parent.parent / "fepre"
    found = oversized(package)
    for line in found:
        print(line)
    print(f"{len(found)} over the limits")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
