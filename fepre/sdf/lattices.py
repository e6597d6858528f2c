"""Triply periodic minimal surface lattices (gyroid, Schwarz P/D, Neovius) and infill."""

from __future__ import annotations

__all__: list[str] = []
