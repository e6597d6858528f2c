"""Features a mesh cannot resolve: thin walls, tiny steps, small holes, nearly tangent surfaces.

A mesh with edge length ``h`` cannot hold two feature nodes much closer than ``h/2`` without
tiny or flat elements. Corners are kept first, then the nodes of the longest curves: a node
within ``h/2`` of a node already kept, or of an earlier node of its own curve, is skipped, and
curves are cut where their nodes were skipped. Curves where two surfaces meet nearly tangentially with opposite sides (a knife edge,
or a crevice between a face and a part barely touching it: crease angle above ``180 - angle``)
are skipped too: the solid or the gap along them is thinner than any element. Every skip is
reported in words for a warning.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .curves import FeatureCurve

__all__ = ["resolve_conflicts"]

#: Feature nodes closer than this (times the local h) to another one are skipped.
MIN_SEPARATION = 0.5
#: Of a curve that doubles back, nodes closer than this times MIN_SEPARATION h are skipped.
DOUBLING_BACK = 0.5


def _pieces(curve: FeatureCurve, keep: np.ndarray) -> list[FeatureCurve]:
    """The runs of kept nodes of ``curve`` with at least two nodes, as curves of their own."""
    if keep.all():
        return [curve]
    count = len(keep)
    if curve.closed:
        # start the runs just after a skipped node so that no run wraps around
        shift = int(np.flatnonzero(~keep)[0]) + 1
        order = np.roll(np.arange(count), -shift)
    else:
        order = np.arange(count)
    kept = keep[order]
    edges = np.diff(np.concatenate([[0], kept.view(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [
        FeatureCurve(curve.points[order[a:b]], curve.patches, False, curve.angle)
        for a, b in zip(starts, ends)
        if b - a >= 2
    ]


def _apart_along(points: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Mask of a curve's nodes to keep: of two nodes of the curve too close, the later goes.

    Resampled nodes are about h apart. Two neighbours closer than the smaller of their
    ``radius`` (h/2) are a curve shorter than h/2 (on truck.obj at D/50 pairs 0.004-0.024 h
    apart, both fixed: cells of 0.0 degrees). Two nodes further apart along the curve are a
    curve that doubles back, and they go only when closer than half that (h/4): a crease's
    hairpin 0.28-0.5 h wide on bunny_small.off is resolved by the mesh when kept whole (26.1 deg
    at ``h=(D/50, D/12)``), while cutting it left an 11.0 deg cell at the cut."""
    from scipy.spatial import cKDTree

    keep = np.ones(len(points), dtype=bool)
    pairs = cKDTree(points).query_pairs(float(radius.max()), output_type="ndarray")
    if len(pairs):
        limit = np.minimum(radius[pairs[:, 0]], radius[pairs[:, 1]])
        limit[np.abs(pairs[:, 0] - pairs[:, 1]) > 1] *= DOUBLING_BACK
        close = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1) < limit
        keep[pairs[close].max(axis=1)] = False
    return keep


def resolve_conflicts(
    corners: np.ndarray,
    curves: list[FeatureCurve],
    local_h: Callable[[np.ndarray], np.ndarray],
    scale: float,
    angle: float,
) -> tuple[np.ndarray, list[FeatureCurve], list[str]]:
    """Corners and curves with the nodes too close to other features removed, and what was
    skipped; ``local_h`` gives the mesh's edge length at (N, 3) points."""
    from scipy.spatial import cKDTree

    skipped: list[str] = []
    same = 1e-9 * scale

    # corners: greedy, in order (the first of a close pair wins)
    kept_corners = np.zeros(len(corners), dtype=bool)
    if len(corners):
        radius = MIN_SEPARATION * local_h(corners)
        tree = cKDTree(corners)
        for i in range(len(corners)):  # corners are few: a handful per part
            near = tree.query_ball_point(corners[i], radius[i])
            if not any(kept_corners[j] for j in near if j != i):
                kept_corners[i] = True
        dropped = int((~kept_corners).sum())
        if dropped:
            skipped.append(
                f"{dropped} corner(s) closer than {MIN_SEPARATION:g} h to another corner (tiny steps): not kept as nodes"
            )
    accepted = [corners[kept_corners]]

    result: list[FeatureCurve] = []
    dropped_nodes = 0
    small_loops = 0
    knife = [c for c in curves if c.angle > 180.0 - angle]
    if knife:
        skipped.append(
            f"{len(knife)} feature curve(s) where surfaces meet nearly tangentially (crease angle above "
            f"{180.0 - angle:g} deg: knife edges or crevices): not kept"
        )
    curves = [c for c in curves if c.angle <= 180.0 - angle]
    for curve in sorted(curves, key=lambda c: -c.length):  # one pass per curve, longest first
        radius = MIN_SEPARATION * local_h(curve.points)
        if curve.closed and curve.length < 1.5 * float(np.mean(radius)) / MIN_SEPARATION:
            small_loops += 1
            continue
        previous = np.concatenate(accepted)
        keep = _apart_along(curve.points, radius)
        if len(previous):
            distance, _ = cKDTree(previous).query(curve.points)
            keep &= (distance >= radius) | (distance <= same)
        dropped_nodes += int((~keep).sum())
        pieces = _pieces(curve, keep)
        lone = int(keep.sum()) - sum(len(p.points) for p in pieces)
        dropped_nodes += lone
        for piece in pieces:
            result.append(piece)
            accepted.append(piece.points)
    if small_loops:
        skipped.append(f"{small_loops} closed feature curve(s) shorter than 1.5 h (small holes or bosses): not kept")
    if dropped_nodes:
        skipped.append(
            f"{dropped_nodes} feature curve node(s) within {MIN_SEPARATION:g} h of another feature "
            "(thin walls, tiny steps): not kept"
        )
    return corners[kept_corners], result, skipped
