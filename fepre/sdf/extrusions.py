"""Solids made from 2D shapes: extrude and revolve."""

from __future__ import annotations

__all__: list[str] = []
