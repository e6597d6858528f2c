"""Parts thinner than an element given up where they leave cells below the quality targets.

Where a fin, a knife edge or a sliver of a wall is thinner than the element size, the mesh holds
it with one layer of cells whose nodes all lie on its surface, and no move, flip, split or
collapse makes such cells well shaped (:mod:`~fepre.distmesh.thin_cells`): a regular tetrahedron
of edge ``h`` is ``0.82 h`` high. The issue's fidelity rule lets the mesh leave out parts thinner
than ``h`` (the automatic size field resolves them; the warning names the ``hmin`` that would),
so the quality targets hold by construction: the cells below the targets in parts thinner than
``TRIM_SHARE`` local sizes are removed, with as few neighbours as keep the boundary a closed
manifold whose nodes all lie on the surface, and the stage runs again on the cells left bad.

A *zone* starts as a face-connected group of such cells and grows by the cells around the
vertices where removing it would leave a boundary edge in other than two faces, a pinched vertex
or an inner node on the boundary; every cell added must also be in a part thinner than
``TRIM_SHARE`` sizes. A zone is given up whole or not at all: not when it needs more than
``GROWTH`` steps or its volume is over ``ZONE_SHARE`` of the mesh's, and the zones together hold
at most ``TOTAL_SHARE`` of it. A thin wall that is most of a part is therefore kept (with its flat
cells and the warning that names the ``hmin`` resolving it), while knife edges, fin tips and the
slivers a box leaves of a lattice's wall go. A zone whose removal would cut the mesh in pieces is
kept, unless what it cuts off is thinner than an element throughout and fits a zone's share: then
that goes with it (a hook's lip, never a rib thicker than an element held by a thin root).

On a gyroid lattice cut by a box at ``h = 0.05`` (three cells of 19.3 deg in slivers 0.1 h thick)
the mesh goes to 25.8 deg for 0.001% of the volume.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tet_shape import ShapeTargets
from .tet_topology import FACE_OF_TET

__all__ = ["Trimmed", "trim_thin_zones", "trimmed_message", "TRIM_SHARE", "ZONE_SHARE", "TOTAL_SHARE"]

#: cells are given up only where the part is thinner than this many local element sizes
TRIM_SHARE = 1.0
#: a zone holds at most this share of the mesh's volume
ZONE_SHARE = 2e-3
#: the zones of one mesh hold at most this share of its volume together
TOTAL_SHARE = 1e-2
#: steps a zone may grow to keep the boundary a manifold
GROWTH = 8
#: an inner node this close to the zero set (local sizes) may be exposed and put on it
SHALLOW = 0.25
#: a fixed inner node this close to the zero set (local sizes) is on it already
ON_SURFACE = 1e-3
#: searches for zones, each without the seeds of zones that cut the mesh in pieces in the last
JOIN_TRIES = 3


@dataclass(frozen=True)
class Trimmed:
    """What :func:`trim_thin_zones` gave up.

    Attributes
    ----------
    cells : int
        Cells removed.
    volume : float
        Their volume.
    centres : (Z, 3) ndarray
        A point of each zone removed (its cells' mean centroid).
    thickness : (Z,) ndarray
        The part's thickness there (the median over the zone's bad cells).
    size : (Z,) ndarray
        The element size there.
    """

    cells: int
    volume: float
    centres: np.ndarray
    thickness: np.ndarray
    size: np.ndarray

    @staticmethod
    def none() -> "Trimmed":
        return Trimmed(0, 0.0, np.zeros((0, 3)), np.zeros(0), np.zeros(0))

    def __add__(self, other: "Trimmed") -> "Trimmed":
        return Trimmed(self.cells + other.cells, self.volume + other.volume, np.concatenate([self.centres, other.centres]),
                       np.concatenate([self.thickness, other.thickness]), np.concatenate([self.size, other.size]))


class _Incidence:
    """The cells around each node (CSR), for stars of a few nodes without a pass over the mesh."""

    def __init__(self, tets: np.ndarray, n: int) -> None:
        flat = tets.ravel()
        self.order = np.argsort(flat, kind="stable") // 4
        self.start = np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=n))])

    def cells_of(self, nodes: np.ndarray) -> np.ndarray:
        first, count = self.start[nodes], self.start[nodes + 1] - self.start[nodes]
        offsets = np.repeat(first - np.concatenate([[0], np.cumsum(count)[:-1]]), count)
        return np.unique(self.order[offsets + np.arange(int(count.sum()))])


def _face_components(tets: np.ndarray, cells: np.ndarray) -> list[np.ndarray]:
    """``cells`` grouped into face-connected components."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.sort(tets[cells][:, FACE_OF_TET], axis=2).reshape(-1, 3)
    _, key = np.unique(faces, axis=0, return_inverse=True)
    key = key.ravel()
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order[1:]] == key[order[:-1]])
    first, second = order[same] // 4, order[same + 1] // 4
    m = len(cells)
    labels = connected_components(coo_matrix((np.ones(len(first)), (first, second)), shape=(m, m)), directed=False)[1]
    return [cells[labels == label] for label in np.unique(labels)]


def _trouble(tets: np.ndarray, around: np.ndarray, zone: np.ndarray, on_boundary: np.ndarray,
             shallow: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where removing ``zone`` leaves the boundary other than a closed manifold through surface
    nodes: its boundary edges not in exactly two faces (E, 2), its pinched vertices and deep
    inner nodes still in a kept cell; and its ``shallow`` inner nodes still in a kept cell (put
    on the surface when the zone goes). ``around``: every cell with a node in the zone."""
    from .topology import face_uses, _faces_used_once, nonmanifold_items

    nodes = np.unique(tets[zone])
    kept = np.setdiff1d(around, zone, assume_unique=True)
    if kept.size == 0:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    local, numbered = np.unique(tets[kept], return_inverse=True)
    star = numbered.reshape(-1, 4)
    _, uses = face_uses(star, len(local))
    edges, pinched = nonmanifold_items(_faces_used_once(star, uses), len(local))
    edges = local[np.asarray(edges, dtype=np.int64).reshape(-1, 2)]
    pinched = local[np.asarray(pinched, dtype=np.int64).ravel()]
    exposed = nodes[~on_boundary[nodes] & np.isin(nodes, local)]
    deep = exposed[~shallow[exposed]]
    return edges[np.isin(edges, nodes).all(axis=1)], np.union1d(pinched[np.isin(pinched, nodes)], deep), exposed[shallow[exposed]]


def _cells_at(tets: np.ndarray, incidence: "_Incidence", edges: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The cells around ``edges`` (E, 2) and around ``nodes``."""
    found = [incidence.cells_of(nodes)]
    if len(edges):
        ring = incidence.cells_of(np.unique(edges))
        pairs = np.sort(edges, axis=1)
        has = np.zeros(len(ring), dtype=bool)
        for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
            ends = np.sort(tets[ring][:, [a, b]], axis=1)
            has |= (ends[:, None, :] == pairs[None, :, :]).all(axis=2).any(axis=1)
        found.append(ring[has])
    return np.unique(np.concatenate(found))


def _zone(tets: np.ndarray, incidence: _Incidence, seed: np.ndarray, removed: np.ndarray, on_boundary: np.ndarray,
          shallow: np.ndarray, thin, volumes: np.ndarray, cap: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The zone grown from ``seed`` (see the module docstring) and the shallow inner nodes it
    exposes, or None: each step adds the thin cells around the edges and vertices where removing
    it would leave the boundary unsound."""
    zone = seed
    for _ in range(GROWTH + 1):
        around = incidence.cells_of(np.unique(tets[zone]))
        around = around[~removed[around]]
        edges, nodes, exposed = _trouble(tets, around, zone, on_boundary, shallow)
        if len(edges) == 0 and len(nodes) == 0:
            return (zone, exposed) if volumes[zone].sum() <= cap else None
        more = np.setdiff1d(_cells_at(tets, incidence, edges, nodes), zone)
        more = more[~removed[more]]
        th = thin(more) if more.size else np.zeros(0, bool)
        more = more[th]
        if more.size == 0 or volumes[zone].sum() + volumes[more].sum() > cap:
            return None
        zone = np.union1d(zone, more)
    return None


def _surfaced(points: np.ndarray, tets: np.ndarray, incidence: _Incidence, removed: np.ndarray, nodes: np.ndarray,
              model) -> np.ndarray | None:
    """``points`` with the inner ``nodes`` a zone exposes projected onto the zero set, or None
    when that would turn a kept cell around them over or flat."""
    from ..quality import signed_volumes

    if nodes.size == 0:
        return points
    moved = points.copy()
    moved[nodes] = model.project(points[nodes], iterations=20, warn=False)
    cells = incidence.cells_of(nodes)
    cells = cells[~removed[cells]]
    before, after = signed_volumes(points, tets[cells]), signed_volumes(moved, tets[cells])
    return moved if (after > 0.05 * before).all() else None


def _cutting(tets: np.ndarray, n_points: int, removed: np.ndarray, zones: list) -> np.ndarray:
    """(Z,) mask of the ``zones`` (cell index arrays, all in ``removed``) whose removal cuts the
    mesh into more pieces (a rib's root thinner than an element: the rib would float free, and a
    solver needs every piece held): the zones next to two pieces, put back until the count is
    the mesh's own."""
    from .pieces import mesh_pieces
    from .tet_topology import face_neighbours

    pieces = len(mesh_pieces(tets, n_points)[1])
    neighbours = face_neighbours(tets, n_points)
    removed = removed.copy()
    cutting = np.zeros(len(zones), dtype=bool)
    while True:
        labels, counts = mesh_pieces(tets[~removed], n_points)
        if len(counts) <= pieces:
            return cutting
        piece = np.full(len(tets), -1)
        piece[~removed] = labels
        found = np.zeros(len(zones), dtype=bool)
        for index in np.flatnonzero(~cutting):
            across = neighbours[zones[index]].ravel()
            found[index] = (np.unique(piece[across[across >= 0]]) >= 0).sum() > 1
        if not found.any():
            return np.ones(len(zones), dtype=bool)  # cut, but by no zone alone: none is given up
        cutting |= found
        for index in np.flatnonzero(found):
            removed[zones[index]] = False


def _thin_fragments(tets: np.ndarray, n_points: int, removed: np.ndarray, thin, volumes: np.ndarray, cap: float,
                    budget: float, held: np.ndarray) -> np.ndarray:
    """(M,) mask of the cells of the pieces that removing ``removed`` cuts off a piece of the mesh
    (all but the largest of what is left of it) where every cell is in a part thinner than
    ``TRIM_SHARE`` sizes and no node is ``held``, each of at most ``cap`` volume, smallest first
    while they fit ``budget`` together: the lip of a hook held by a zone (ur3_upperarm.stl at D/50,
    six cells 0.5 h thick) goes with it."""
    from .pieces import mesh_pieces

    fragments = np.zeros(len(tets), dtype=bool)
    kept = np.flatnonzero(~removed)
    before, _ = mesh_pieces(tets, n_points)
    after, counts = mesh_pieces(tets[kept], n_points)
    if len(counts) <= before.max() + 1:
        return fragments
    origin = np.zeros(len(counts), dtype=np.int64)
    origin[after] = before[kept]
    largest = np.zeros(len(counts), dtype=bool)
    for source in np.unique(origin):  # pieces are numbered largest first
        largest[np.flatnonzero(origin == source)[0]] = True
    spent = 0.0
    for label in np.flatnonzero(~largest)[::-1]:
        cells = kept[after == label]
        volume = float(volumes[cells].sum())
        if volume > cap or spent + volume > budget or held[tets[cells]].any() or not thin(cells).all():
            continue
        fragments[cells] = True
        spent += volume
    return fragments


def trim_thin_zones(points: np.ndarray, tets: np.ndarray, model, h: float, local_size=None,
                    targets: ShapeTargets | None = None, budget: float | None = None,
                    fixed_mask: np.ndarray | None = None,
                    held: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, Trimmed]:
    """``points`` (inner nodes a zone exposes put on the zero set) and ``tets`` without the
    zones of cells below the targets in parts thinner than ``TRIM_SHARE`` local sizes (see the
    module docstring), and what went.

    Parameters
    ----------
    points, tets : the mesh, (N, 3) and (M, 4), a valid solid
    model : fepre.sdf.SDF
    h : float
        The element size (uniform meshes).
    local_size : callable, optional
        The graded mesh's element size at points, in units of length.
    targets : ShapeTargets, optional
        The quality targets (default: the plain-mesh targets).
    budget : float, optional
        The volume the zones may hold together (default ``TOTAL_SHARE`` of the mesh's).
    fixed_mask : (N,) bool, optional
        Nodes that must not move (never exposed from the inside).
    held : (N,) bool, optional
        Nodes whose piece must stay whole (the user's fixed points): a piece a zone cuts off
        the mesh goes with the zone when it is thinner than an element throughout, unless it
        holds one of them.

    Examples
    --------
    >>> import numpy as np
    >>> from fepre import sdf
    >>> slab = sdf.box((4.0, 4.0, 0.2))                      # 0.2 thick, one flat cell
    >>> flat = np.array([[0, 0, -0.1], [1, 0, -0.1], [0.5, 1, 0.1], [0.5, -1, 0.1]])
    >>> _, kept, trimmed = trim_thin_zones(flat, np.array([[0, 1, 2, 3]]), slab, h=1.0)
    >>> len(kept), trimmed.cells                             # the whole mesh: over ZONE_SHARE, kept
    (1, 0)
    """
    from ..quality import signed_volumes
    from .thin_cells import cell_thickness, sizes_at
    from .topology import boundary_faces

    targets = ShapeTargets() if targets is None else targets
    bad = np.flatnonzero(targets.score(points[tets]) < targets.min_dihedral)
    if bad.size == 0:
        return points, tets, Trimmed.none()
    centroids = points[tets].mean(axis=1)

    def thickness_of(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        size = sizes_at(centroids[cells], h, local_size)
        return cell_thickness(model, points, tets, cells, size)[0], size

    def thin(cells: np.ndarray) -> np.ndarray:
        thickness, size = thickness_of(cells)
        return thickness < TRIM_SHARE * size

    thickness, size = thickness_of(bad)
    seeds = thickness < TRIM_SHARE * size
    if not seeds.any():
        return points, tets, Trimmed.none()
    volumes = signed_volumes(points, tets)
    total = float(volumes.sum())
    budget = TOTAL_SHARE * total if budget is None else float(budget)
    on_boundary = np.zeros(len(points), dtype=bool)
    on_boundary[boundary_faces(tets).ravel()] = True
    shallow = np.zeros(len(points), dtype=bool)
    inner = np.flatnonzero(~on_boundary)
    depth, size_there = -np.asarray(model(points[inner]), dtype=float), sizes_at(points[inner], h, local_size)
    shallow[inner] = depth <= SHALLOW * size_there
    if fixed_mask is not None:  # a fixed node is exposed only where it lies on the surface already
        shallow[inner] &= ~fixed_mask[inner] | (np.abs(depth) <= ON_SURFACE * size_there)
    fixed = np.zeros(len(points), dtype=bool) if fixed_mask is None else fixed_mask
    incidence = _Incidence(tets, len(points))
    by_cell = dict(zip(bad[seeds].tolist(), zip(thickness[seeds].tolist(), size[seeds].tolist())))
    ordered = sorted(_face_components(tets, bad[seeds]), key=lambda cells: float(volumes[cells].sum()))

    def search(banned: np.ndarray) -> tuple:
        """The zones grown from the seeds not ``banned``, one after the other, each on the
        boundary the ones before it left."""
        moved, removed, surface = points, np.zeros(len(tets), dtype=bool), on_boundary.copy()
        found, zones, used = [], [], []
        for number, seed in enumerate(ordered):
            if banned[number] or removed[seed].any():
                continue
            spent = float(volumes[removed].sum())
            grown = _zone(tets, incidence, seed, removed, surface, shallow, thin, volumes,
                          min(ZONE_SHARE * total, budget - spent))
            if grown is None:
                continue
            zone, exposed = grown
            trial = removed.copy()
            trial[zone] = True
            surfaced = _surfaced(moved, tets, incidence, trial, exposed[~fixed[exposed]], model)
            if surfaced is None:
                continue
            moved, removed = surfaced, trial
            surface[exposed] = True
            measured = np.array([by_cell[c] for c in seed.tolist()])
            found.append((centroids[zone].mean(axis=0), float(np.median(measured[:, 0])), float(measured[:, 1].max())))
            zones.append(zone)
            used.append(number)
        return moved, removed, found, zones, used

    # a zone that cuts the mesh in pieces is never given up: its seed is left out and the zones
    # are grown again (put back alone, a zone grown after it could leave a pinch where they met)
    banned = np.zeros(len(ordered), dtype=bool)
    for _ in range(JOIN_TRIES):
        moved, removed, found, zones, used = search(banned)
        if not found:
            return points, tets, Trimmed.none()
        removed |= _thin_fragments(tets, len(points), removed, thin, volumes, ZONE_SHARE * total,
                                   budget - float(volumes[removed].sum()), np.zeros_like(fixed) if held is None else held)
        cutting = _cutting(tets, len(points), removed, zones)
        if not cutting.any():
            break
        banned[np.asarray(used)[cutting]] = True
    else:
        return points, tets, Trimmed.none()
    points = moved
    centres, thick, sizes = (np.array(column) for column in zip(*found))
    return points, tets[~removed], Trimmed(int(removed.sum()), float(volumes[removed].sum()), centres.reshape(-1, 3), thick, sizes)


def trimmed_message(trimmed: Trimmed, total_volume: float, h: float | None, offset=None) -> str | None:
    """One line naming the places given up (thinnest first), their volume and the ``h`` that
    keeps them (half the thinnest place's thickness: two elements across), or None when nothing
    went. A place of thickness 0 is a flat cell on the surface (no sample of it inside)."""
    if trimmed.cells == 0:
        return None
    offset = np.zeros(3) if offset is None else np.asarray(offset, dtype=float)
    order = np.argsort(trimmed.thickness, kind="stable")

    def place(i: int) -> str:
        where = ", ".join(f"{c:.4g}" for c in trimmed.centres[i] + offset)
        thick = f"{trimmed.thickness[i]:.3g} thick" if trimmed.thickness[i] > 0 else "flat on the surface"
        return f"near ({where}), {thick} against a size of {trimmed.size[i]:.3g}"

    measured = order[trimmed.thickness[order] > 0]
    shown = "; ".join(place(i) for i in (measured if len(measured) else order)[:3])
    more = f" and {len(order) - min(3, len(measured) or len(order))} more" if len(order) > 3 else ""
    share = 100.0 * trimmed.volume / total_volume if total_volume > 0 else 0.0
    if not len(measured):  # a shaft's groove: cells across its mouth, outside the part
        return (f"{trimmed.cells} flat cell(s) on the surface in {len(order)} place(s) were removed so that the cells "
                f"there meet the quality targets, {trimmed.volume:.3g} of volume ({share:.3g}% of the mesh) with no "
                f"material of the model in it (cells lying on a face or across a groove's mouth): {shown}{more}; "
                "thin_parts='keep' (fepre mesh --keep-thin) keeps them")
    fine = 0.5 * float(trimmed.thickness[measured[0]])
    keep = (f"mesh with h=({fine:.2g}, {h:.4g}) (the automatic size field) to keep them" if h is not None
            else f"mesh with a smaller hmin (about {fine:.2g}) to keep them")
    return (f"{trimmed.cells} cell(s) in {len(order)} place(s) thinner than an element were left out so that the "
            f"cells there meet the quality targets, {trimmed.volume:.3g} of volume ({share:.3g}% of the mesh): "
            f"{shown}{more}; {keep}, or pass thin_parts='keep' (fepre mesh --keep-thin) to keep them with flat cells")
