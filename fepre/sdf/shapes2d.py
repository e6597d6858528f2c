"""Two-dimensional shapes (circle, rectangle, polygon) for extrusion and revolution."""

from __future__ import annotations

__all__: list[str] = []
