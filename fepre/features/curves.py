"""Feature curves: crease points chained into curves, ended at corners, resampled at spacing h.

Crease points of one pair of patches that lie within a few fine-grid spacings of each other form
one curve. Their order along the curve comes from a minimum spanning tree: the tree's longest
path runs from one end to the other, and the distance along the tree from one end orders the
points (short spurs of the tree sort next to where they branch off). A curve whose two ends are
close is closed; the ends of an open curve are moved onto the corners of its patches nearby.
Nodes are then placed at equal steps of ``integral dt / h(x)`` (equal length without a size
function) and put back on both patches by Newton's method.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .detect import Creases
from .newton import solve_on_patches

__all__ = ["FeatureCurve", "build_curves"]


@dataclass(frozen=True)
class FeatureCurve:
    """One feature curve: where two patches of the model meet at a sharp angle.

    Attributes
    ----------
    points : (M, 3) float array
        Nodes along the curve, about ``h`` apart (the first and last are corners when the curve
        ends at one; a closed curve does not repeat its first node).
    patches : (int, int)
        Labels of the two patches (:meth:`fepre.sdf.SDF.patch_labels`).
    closed : bool
        True for a loop (e.g. where a hole meets a face).
    angle : float
        Median crease angle along the curve, degrees (angle between the patches' normals).
    """

    points: np.ndarray
    patches: tuple[int, int]
    closed: bool
    angle: float

    @property
    def segments(self) -> np.ndarray:
        """Node pairs (S, 2) of consecutive nodes, the closing one included for a loop."""
        count = len(self.points)
        start = np.arange(count if self.closed and count > 2 else count - 1)
        return np.column_stack([start, (start + 1) % count])

    @property
    def length(self) -> float:
        """Length of the polyline through the nodes."""
        pairs = self.segments
        return float(np.linalg.norm(self.points[pairs[:, 1]] - self.points[pairs[:, 0]], axis=1).sum())


def _components(points: np.ndarray, link: float) -> tuple[int, np.ndarray]:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(link, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2)
    return connected_components(graph, directed=False)


def _order_along(points: np.ndarray, link: float) -> tuple[np.ndarray, np.ndarray]:
    """Order (P,) of one component's points along its curve and their distance from the start."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra, minimum_spanning_tree
    from scipy.spatial import cKDTree

    if len(points) == 1:
        return np.zeros(1, dtype=np.int64), np.zeros(1)
    pairs = cKDTree(points).query_pairs(link, output_type="ndarray")
    lengths = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1) + 1e-300
    graph = coo_matrix((lengths, (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2)
    tree = minimum_spanning_tree(graph)
    first = dijkstra(tree, directed=False, indices=0)
    end = int(np.argmax(np.where(np.isfinite(first), first, -1.0)))
    along = dijkstra(tree, directed=False, indices=end)
    along = np.where(np.isfinite(along), along, np.inf)
    order = np.argsort(along, kind="stable")
    return order, along[order]


def _corner_near(end: np.ndarray, pair: np.ndarray, corners: np.ndarray, corner_labels: np.ndarray, reach: float) -> int:
    """Index of the corner of the pair's patches (or a singular point) nearest ``end`` within reach, or -1."""
    if len(corners) == 0:
        return -1
    belongs = np.isin(corner_labels, pair).sum(axis=1) >= 2
    belongs |= (corner_labels < 0).all(axis=1)
    distance = np.where(belongs, np.linalg.norm(corners - end, axis=1), np.inf)
    best = int(np.argmin(distance))
    return best if distance[best] <= reach else -1


def _resample(
    model,
    polyline: np.ndarray,
    along: np.ndarray,
    closed: bool,
    pair: tuple[int, int],
    local_h: Callable[[np.ndarray], np.ndarray],
    scale: float,
    fixed_ends: tuple[bool, bool],
) -> np.ndarray:
    """Nodes at equal steps of ``integral dt / local_h(x)`` along ``polyline``, put back on both patches."""
    if closed:
        polyline = np.concatenate([polyline, polyline[:1]])
        along = np.concatenate([along, [along[-1] + np.linalg.norm(polyline[-1] - polyline[-2])]])
    spacing = local_h(polyline)
    density = 1.0 / spacing
    steps = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(along))])
    total = steps[-1]
    count = max(3 if closed else 1, int(round(total)))
    targets = np.linspace(0.0, total, count + 1)
    t = np.interp(targets, steps, along)
    nodes = np.column_stack([np.interp(t, along, polyline[:, k]) for k in range(3)])
    if closed:
        nodes = nodes[:-1]
        inner = np.ones(len(nodes), dtype=bool)
        inner[0] = not fixed_ends[0]
    else:
        inner = np.ones(len(nodes), dtype=bool)
        inner[0], inner[-1] = not fixed_ends[0], not fixed_ends[1]
    if inner.any():
        labels = np.tile(np.asarray(pair, dtype=np.int64), (int(inner.sum()), 1))
        reach = 0.5 * float(spacing.min())
        solved, ok = solve_on_patches(model, labels, nodes[inner], tol=1e-13 * scale, step=1e-6 * scale, reach=reach)
        moved = nodes[inner]
        moved[ok] = solved[ok]
        nodes[inner] = moved
    return _onto_surface(model, nodes, scale)


#: Curve nodes farther than this (times the model's size) from its zero set are projected onto it.
ON_SURFACE = 1e-9


def _onto_surface(model, nodes: np.ndarray, scale: float) -> np.ndarray:
    """``nodes`` moved onto the model's zero set where they are off it.

    The two patches' functions meet on the surface where the patches share the feature (a CSG
    part's primitives, a closed triangle mesh's facets across an edge). A triangle mesh whose
    pieces meet without shared edges (the spans of an open surface against its rims, shells cut
    at a seam) has facets whose planes cross a little off the surface: a node there is not on
    the zero set, and a fixed node off it is an interior node to the mesher (its whole star is
    kept, cells outside and all).
    """
    off = np.abs(np.asarray(model(nodes), np.float64)) > ON_SURFACE * scale
    if off.any():
        nodes = nodes.copy()
        nodes[off] = model.project(nodes[off], iterations=30, tol=0.1 * ON_SURFACE * scale, warn=False)
    return nodes


@dataclass
class _Chain:
    """A curve before resampling: ordered crease points and what its ends are attached to."""

    polyline: np.ndarray
    along: np.ndarray
    pair: tuple[int, int]
    closed: bool
    angle: float
    fixed_ends: list[bool]

    def extend(self, at_start: bool, point: np.ndarray) -> None:
        """Add ``point`` at one end (a corner or a junction), which then stays where it is."""
        if at_start:
            self.polyline = np.concatenate([point[None], self.polyline])
            self.along = np.concatenate([[0.0], self.along + np.linalg.norm(self.polyline[1] - point)])
        else:
            self.polyline = np.concatenate([self.polyline, point[None]])
            self.along = np.concatenate([self.along, [self.along[-1] + np.linalg.norm(point - self.polyline[-2])]])
        self.fixed_ends[0 if at_start else 1] = True


def _chains(creases: Creases) -> list[_Chain]:
    """One chain per connected group of crease points of one pair, ends attached to corners."""
    chains: list[_Chain] = []
    link = 2.5 * creases.spacing
    reach = 3.0 * creases.spacing
    pair_keys, pair_index = np.unique(creases.pairs, axis=0, return_inverse=True)
    pair_index = pair_index.reshape(-1)
    for key_index, pair in enumerate(pair_keys):  # a few dozen pairs per part
        members = np.flatnonzero(pair_index == key_index)
        count, component = _components(creases.points[members], link)
        for c in range(count):
            index = members[component == c]
            order, along = _order_along(creases.points[index], link)
            polyline = creases.points[index][order]
            length = float(along[-1])
            closed = len(polyline) > 3 and np.linalg.norm(polyline[-1] - polyline[0]) < link and length > 2 * link
            chain = _Chain(polyline, along, (int(pair[0]), int(pair[1])), bool(closed),
                           float(np.median(creases.angles[index])), [False, False])
            if not closed:
                first = _corner_near(polyline[0], pair, creases.corners, creases.corner_labels, reach)
                last = _corner_near(polyline[-1], pair, creases.corners, creases.corner_labels, reach)
                if first >= 0 and first == last:
                    if length < reach:
                        continue  # a stub of crease points at one corner, no curve
                    chain.closed = True  # a loop through one corner: it starts there
                    chain.extend(True, creases.corners[first])
                else:
                    if first >= 0:
                        chain.extend(True, creases.corners[first])
                    if last >= 0:
                        chain.extend(False, creases.corners[last])
            chains.append(chain)
    return chains


def _on_patches(model, pair: np.ndarray, point: np.ndarray, tol: float) -> np.ndarray:
    """True where ``point[i]`` lies on both patches ``pair[i]``."""
    values = np.stack([model._patch_values(pair[:, k], point) for k in range(2)], axis=1)
    return np.abs(values).max(axis=1) <= tol


def _join_junctions(model, chains: list[_Chain], reach: float, tol: float) -> None:
    """Free ends of chains of different pairs, within ``reach``, that continue each other meet.

    Where a crease runs on from one pair of patches into another without a corner (a box edge
    running into a tangent fillet: the pairs share a patch; or a shared face whose patches
    alternate: one end lies on the other's patches), the two chains end close together; both
    are extended to the same end point, one of the two ends (exactly on its own curve and the
    surface).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    ends = [(i, side) for i, chain in enumerate(chains) if not chain.closed for side in (0, 1) if not chain.fixed_ends[side]]
    if len(ends) < 2:
        return
    points = np.array([chains[i].polyline[0 if side == 0 else -1] for i, side in ends])
    pairs = np.array([chains[i].pair for i, _ in ends])
    owner = np.array([i for i, _ in ends])
    close = cKDTree(points).query_pairs(reach, output_type="ndarray")
    close = close[owner[close[:, 0]] != owner[close[:, 1]]]
    shares = (pairs[close[:, 0], :, None] == pairs[close[:, 1], None, :]).any(axis=(1, 2))
    if len(close):
        shares |= _on_patches(model, pairs[close[:, 1]], points[close[:, 0]], tol)
        shares |= _on_patches(model, pairs[close[:, 0]], points[close[:, 1]], tol)
    close = close[shares]
    if len(close) == 0:
        return
    graph = coo_matrix((np.ones(len(close)), (close[:, 0], close[:, 1])), shape=(len(ends),) * 2)
    _, group = connected_components(graph, directed=False)
    sizes = np.bincount(group)
    _, representative = np.unique(group, return_index=True)
    junction = points[representative].copy()
    # two chains of three patches in all (two sides and a face of a polygon prism that turns
    # less than the crease angle): their patches meet at one point, found exactly
    members = np.argsort(group, kind="stable")
    starts = np.searchsorted(group[members], np.arange(len(sizes)))
    two = np.flatnonzero(sizes == 2)
    if len(two):
        labels = np.sort(np.concatenate([pairs[members[starts[two]]], pairs[members[starts[two] + 1]]], axis=1), axis=1)
        first_of_run = np.concatenate([np.ones((len(two), 1), bool), labels[:, 1:] != labels[:, :-1]], axis=1)
        three = first_of_run.sum(axis=1) == 3
        if three.any():
            triple = labels[three][first_of_run[three]].reshape(-1, 3)
            solved, ok = solve_on_patches(model, triple, junction[two[three]], tol=0.1 * tol, step=1e-6 * reach / 3.0,
                                          reach=reach)
            ok &= np.abs(model(solved)) <= 100 * tol
            junction[two[three][ok]] = solved[ok]
    for end_index, (chain_index, side) in enumerate(ends):  # loops over curve ends, a few per curve
        if sizes[group[end_index]] < 2:
            continue
        chain = chains[chain_index]
        target = junction[group[end_index]]
        if representative[group[end_index]] == end_index and np.array_equal(target, points[end_index]):
            chain.fixed_ends[side] = True
        else:
            chain.extend(side == 0, target)


def build_curves(
    model, creases: Creases, local_h: Callable[[np.ndarray], np.ndarray], scale: float
) -> list[FeatureCurve]:
    """Feature curves of ``creases``, with nodes about ``local_h(x)`` apart ((N, 3) -> (N,))."""
    if len(creases.points) == 0:
        return []
    chains = _chains(creases)
    _join_junctions(model, chains, 3.0 * creases.spacing, 1e-9 * scale)
    curves = []
    for chain in chains:
        if len(chain.polyline) < 2:
            continue
        nodes = _resample(model, chain.polyline, chain.along, chain.closed, chain.pair, local_h, scale,
                          tuple(chain.fixed_ends))
        curves.append(FeatureCurve(nodes, chain.pair, chain.closed, chain.angle))
    return curves
