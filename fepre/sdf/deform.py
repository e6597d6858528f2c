"""Deformations: offset, shell, elongate, twist, bend and repetition."""

from __future__ import annotations

__all__: list[str] = []
