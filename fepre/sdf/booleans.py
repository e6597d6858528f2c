"""Boolean operations: union, intersection, difference and complement, sharp or smooth."""

from __future__ import annotations

__all__: list[str] = []
