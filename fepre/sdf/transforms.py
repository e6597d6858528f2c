"""Affine transforms: translate, rotate, scale, mirror and general matrices, collapsed into one node."""

from __future__ import annotations

__all__: list[str] = []
