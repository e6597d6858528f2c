"""Per-cell kernels over tetrahedra, compiled (numba, cached on disk) and run on every core when
the work pays for a parallel launch (:mod:`fepre.kernel_threads`), on one thread otherwise.

Each computes in one pass what the array form computes in a dozen (M, 6, 3) temporaries: the
quality arrays of a mesh, the DistMesh loop's volume-edge ratio and the packed face keys that
group a mesh's faces. The results equal the array forms' to rounding (tests compare them).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .kernel_threads import kernel_threads

__all__ = ["quality_arrays", "volume_edge_ratios", "packed_face_keys", "packed_edge_keys", "canonical_cells", "centroid_bounds", "face_uses", "shape_extremes",
           "ideal_positions", "corner_volumes", "cells_by_vertex"]

# faces opposite vertex 0..3 (outward for a positive cell); the two faces at edges 01 02 03 12 13 23
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int64)
_EDGE_FACES = np.array([[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]], dtype=np.int64)
_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)


@njit(cache=True, parallel=True)
def _quality(points, tets, faces, edge_faces, edges, out):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        c = np.empty((4, 3))
        for v in range(4):
            for a in range(3):
                c[v, a] = points[tets[t, v], a]
        ax, ay, az = c[1, 0] - c[0, 0], c[1, 1] - c[0, 1], c[1, 2] - c[0, 2]
        bx, by, bz = c[2, 0] - c[0, 0], c[2, 1] - c[0, 1], c[2, 2] - c[0, 2]
        cx, cy, cz = c[3, 0] - c[0, 0], c[3, 1] - c[0, 1], c[3, 2] - c[0, 2]
        volume = ((ay * bz - az * by) * cx + (az * bx - ax * bz) * cy + (ax * by - ay * bx) * cz) / 6.0
        lengths2 = np.empty(6)
        total2 = 0.0
        for e in range(6):
            dx = c[edges[e, 1], 0] - c[edges[e, 0], 0]
            dy = c[edges[e, 1], 1] - c[edges[e, 0], 1]
            dz = c[edges[e, 1], 2] - c[edges[e, 0], 2]
            lengths2[e] = dx * dx + dy * dy + dz * dz
            total2 += lengths2[e]
        normals = np.empty((4, 3))
        areas = np.empty(4)
        area_sum = 0.0
        for f in range(4):
            p, q, r = faces[f, 0], faces[f, 1], faces[f, 2]
            ux, uy, uz = c[q, 0] - c[p, 0], c[q, 1] - c[p, 1], c[q, 2] - c[p, 2]
            vx, vy, vz = c[r, 0] - c[p, 0], c[r, 1] - c[p, 1], c[r, 2] - c[p, 2]
            nx = 0.5 * (uy * vz - uz * vy)
            ny = 0.5 * (uz * vx - ux * vz)
            nz = 0.5 * (ux * vy - uy * vx)
            areas[f] = math.sqrt(nx * nx + ny * ny + nz * nz)
            area_sum += areas[f]
            normals[f, 0], normals[f, 1], normals[f, 2] = nx, ny, nz
        smallest, largest = np.inf, -np.inf
        for e in range(6):
            f, g = edge_faces[e, 0], edge_faces[e, 1]
            angle = 0.0
            if areas[f] > 0.0 and areas[g] > 0.0:
                cosine = -(normals[f, 0] * normals[g, 0] + normals[f, 1] * normals[g, 1] + normals[f, 2] * normals[g, 2])
                cosine /= areas[f] * areas[g]
                angle = math.degrees(math.acos(min(1.0, max(-1.0, cosine))))
            smallest = min(smallest, angle)
            largest = max(largest, angle)
        a = math.sqrt(lengths2[0] * lengths2[5])
        b = math.sqrt(lengths2[1] * lengths2[4])
        d = math.sqrt(lengths2[2] * lengths2[3])
        s = 0.5 * (a + b + d)
        heron = math.sqrt(max(s * (s - a) * (s - b) * (s - d), 0.0))
        denominator = area_sum * heron
        radius_ratio = 0.0
        if denominator > 0.0:
            radius_ratio = math.copysign(54.0 * volume * volume / denominator, volume) if volume != 0.0 else 0.0
        l_rms = math.sqrt(total2 / 6.0)
        volume_edge = 6.0 * math.sqrt(2.0) * volume / (l_rms * l_rms * l_rms) if l_rms > 0.0 else 0.0
        out[0, t] = smallest
        out[1, t] = largest
        out[2, t] = radius_ratio if math.isfinite(radius_ratio) else 0.0
        out[3, t] = volume_edge if math.isfinite(volume_edge) else 0.0
        out[4, t] = volume


def quality_arrays(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """(5, M): worst and largest dihedral angle (degrees), radius ratio, volume-edge ratio and
    signed volume of each cell (the formulas of :func:`fepre.quality.tet_quality`)."""
    out = np.empty((5, len(tets)))
    if len(tets):
        with kernel_threads(len(tets), 7e-8):
            _quality(np.ascontiguousarray(points, np.float64), np.ascontiguousarray(tets, np.int64), _FACES, _EDGE_FACES, _EDGES, out)
    return out


@njit(cache=True, parallel=True)
def _volume_edge(points, tets, out):  # pragma: no cover - compiled
    factor = 6.0 * math.sqrt(2.0)
    for t in prange(tets.shape[0]):
        i0, i1, i2, i3 = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
        ax, ay, az = points[i1, 0] - points[i0, 0], points[i1, 1] - points[i0, 1], points[i1, 2] - points[i0, 2]
        bx, by, bz = points[i2, 0] - points[i0, 0], points[i2, 1] - points[i0, 1], points[i2, 2] - points[i0, 2]
        cx, cy, cz = points[i3, 0] - points[i0, 0], points[i3, 1] - points[i0, 1], points[i3, 2] - points[i0, 2]
        volume = (ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)) / 6.0
        l2 = (
            ax * ax + ay * ay + az * az + bx * bx + by * by + bz * bz + cx * cx + cy * cy + cz * cz
            + (bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2
            + (cx - ax) ** 2 + (cy - ay) ** 2 + (cz - az) ** 2
            + (cx - bx) ** 2 + (cy - by) ** 2 + (cz - bz) ** 2
        ) / 6.0
        out[t] = factor * volume / (l2 * math.sqrt(l2))


def volume_edge_ratios(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """``6 sqrt(2) V / l_rms^3`` of each cell (M,)."""
    out = np.empty(len(tets))
    if len(tets):
        with kernel_threads(len(tets), 7e-9):
            _volume_edge(np.ascontiguousarray(points, np.float64), np.ascontiguousarray(tets, np.int64), out)
    return out


@njit(cache=True, inline="always")
def _sorted3(a, b, c):  # pragma: no cover - compiled
    if a > b:
        a, b = b, a
    if b > c:
        b, c = c, b
    if a > b:
        a, b = b, a
    return a, b, c


@njit(cache=True, parallel=True)
def _face_keys(tets, faces, n, out):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        for f in range(4):
            a, b, c = _sorted3(tets[t, faces[f, 0]], tets[t, faces[f, 1]], tets[t, faces[f, 2]])
            out[4 * t + f] = (a * n + b) * n + c


def packed_face_keys(tets: np.ndarray, n_points: int) -> np.ndarray:
    """(4 M,) int64 keys ``(s0 n + s1) n + s2`` of the sorted vertices of each cell's four faces
    (in the order opposite vertex 0, 1, 2, 3); ``n_points`` at most
    :data:`fepre.distmesh.tet_topology.MAX_PACKED_POINTS`."""
    out = np.empty(4 * len(tets), np.int64)
    if len(tets):
        with kernel_threads(len(tets), 5e-9):
            _face_keys(np.ascontiguousarray(tets, np.int64), _FACES, np.int64(n_points), out)
    return out


@njit(cache=True, parallel=True)
def _canonical(points, tets, volumes):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        a, b, c, d = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
        # sort four indices with five compare-swaps
        if a > b:
            a, b = b, a
        if c > d:
            c, d = d, c
        if a > c:
            a, c = c, a
        if b > d:
            b, d = d, b
        if b > c:
            b, c = c, b
        ax, ay, az = points[b, 0] - points[a, 0], points[b, 1] - points[a, 1], points[b, 2] - points[a, 2]
        bx, by, bz = points[c, 0] - points[a, 0], points[c, 1] - points[a, 1], points[c, 2] - points[a, 2]
        cx, cy, cz = points[d, 0] - points[a, 0], points[d, 1] - points[a, 1], points[d, 2] - points[a, 2]
        volume = ((ay * bz - az * by) * cx + (az * bx - ax * bz) * cy + (ax * by - ay * bx) * cz) / 6.0
        if volume < 0.0:
            c, d = d, c
        tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3] = a, b, c, d
        volumes[t] = volume


def canonical_cells(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Put each cell (in place, int64 (M, 4)) in canonical form: corners sorted, then the last two
    swapped where that makes the volume positive. Returns the signed volumes of the sorted
    corners (M,) (their absolute values are the cells' volumes)."""
    volumes = np.empty(len(tets))
    if len(tets):
        with kernel_threads(len(tets), 5e-9):
            _canonical(np.ascontiguousarray(points, np.float64), tets, volumes)
    return volumes


@njit(cache=True, parallel=True)
def _centroid_reach(points, tets, bound, centroids, reach):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        for a in range(3):
            centroids[t, a] = 0.25 * (points[tets[t, 0], a] + points[tets[t, 1], a] + points[tets[t, 2], a] + points[tets[t, 3], a])
        smallest = np.inf
        for v in range(4):
            i = tets[t, v]
            dx = points[i, 0] - centroids[t, 0]
            dy = points[i, 1] - centroids[t, 1]
            dz = points[i, 2] - centroids[t, 2]
            smallest = min(smallest, math.sqrt(dx * dx + dy * dy + dz * dz) + bound[i])
        reach[t] = smallest


def centroid_bounds(points: np.ndarray, tets: np.ndarray, bound: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroids (M, 3) of the cells and an upper bound (M,) of a 1-Lipschitz function there,
    ``min_i bound_i + |c - p_i|`` over the corners ``p_i`` (``bound`` per point)."""
    centroids = np.empty((len(tets), 3))
    reach = np.empty(len(tets))
    if len(tets):
        with kernel_threads(len(tets), 7e-9):
            _centroid_reach(np.ascontiguousarray(points, np.float64), np.ascontiguousarray(tets, np.int64),
                            np.ascontiguousarray(bound, np.float64), centroids, reach)
    return centroids, reach


@njit(cache=True, parallel=True)
def _edge_keys(tets, edges, n, out):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        for e in range(6):
            a, b = tets[t, edges[e, 0]], tets[t, edges[e, 1]]
            out[6 * t + e] = a * n + b if a < b else b * n + a


def packed_edge_keys(tets: np.ndarray, n_points: int) -> np.ndarray:
    """(6 M,) int64 keys ``lo n + hi`` of each cell's six edges."""
    out = np.empty(6 * len(tets), np.int64)
    if len(tets):
        with kernel_threads(len(tets), 5e-9):
            _edge_keys(np.ascontiguousarray(tets, np.int64), _EDGES, np.int64(n_points), out)
    return out


@njit(cache=True, parallel=True)
def _sorted_faces(tets, faces, lo, mid, hi):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        for f in range(4):
            slot = 4 * t + f
            lo[slot], mid[slot], hi[slot] = _sorted3(tets[t, faces[f, 0]], tets[t, faces[f, 1]], tets[t, faces[f, 2]])


@njit(cache=True)
def chunk_offsets(fill):  # pragma: no cover - compiled
    """Turn per-chunk counts ``fill[c, v]`` of a counting sort into each chunk's first position
    in group ``v`` (in place); returns the groups' starts (n + 1,)."""
    chunks, n_points = fill.shape
    start = np.zeros(n_points + 1, np.int64)
    for v in range(n_points):
        total = start[v]
        for c in range(chunks):
            count = fill[c, v]
            fill[c, v] = total
            total += count
        start[v + 1] = total
    return start


@njit(cache=True, parallel=True)
def _bucket_by_lowest(lo, mid, hi, n_points, chunks):  # pragma: no cover - compiled
    # a stable counting sort by lowest vertex: each chunk of slots counts, then fills, its own
    # share of every bucket (the same result for any number of chunks)
    m = lo.shape[0]
    size = (m + chunks - 1) // chunks
    fill = np.zeros((chunks, n_points), np.int64)
    for c in prange(chunks):
        for slot in range(c * size, min(m, (c + 1) * size)):
            fill[c, lo[slot]] += 1
    start = chunk_offsets(fill)
    key = np.empty(m, np.int64)
    slots = np.empty(m, np.int64)
    for c in prange(chunks):
        for slot in range(c * size, min(m, (c + 1) * size)):  # ascending slots within each bucket
            position = fill[c, lo[slot]]
            key[position] = np.int64(mid[slot]) * n_points + hi[slot]
            slots[position] = slot
            fill[c, lo[slot]] = position + 1
    return start, key, slots


@njit(cache=True, parallel=True)
def _match(start, key, slots, mate, uses):  # pragma: no cover - compiled
    for v in prange(start.shape[0] - 1):
        s, e = start[v], start[v + 1]
        for i in range(s + 1, e):  # insertion sort of the bucket by key, stable
            k, slot = key[i], slots[i]
            j = i - 1
            while j >= s and key[j] > k:
                key[j + 1], slots[j + 1] = key[j], slots[j]
                j -= 1
            key[j + 1], slots[j + 1] = k, slot
        i = s
        while i < e:
            j = i + 1
            while j < e and key[j] == key[i]:
                j += 1
            # slots i..j-1 hold one face, in ascending order: each one's mate is the lowest other
            for r in range(i, j):
                uses[slots[r]] = j - i
                if j - i > 1:
                    mate[slots[r]] = slots[i + 1] if r == i else slots[i]
            i = j


def face_uses(tets: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """For each face slot ``4 t + i`` (the face opposite vertex ``i`` of cell ``t``): the lowest
    other slot holding the same three vertices (-1 if none) and how many slots hold them.

    Faces are grouped by their lowest vertex and sorted within the group (a few dozen slots),
    instead of sorting all ``4 M`` face keys together.
    """
    m = len(tets)
    mate = np.full(4 * m, -1, np.int64)
    uses = np.ones(4 * m, np.int32)
    if m:
        n_points = max(int(n_points), int(tets.max()) + 1)  # the groups are indexed by vertex
        small = np.int32 if n_points < 2**31 else np.int64  # the three corners: memory at millions of cells
        lo, mid, hi = (np.empty(4 * m, small) for _ in range(3))
        with kernel_threads(m, 1e-7) as threads:
            _sorted_faces(np.ascontiguousarray(tets, np.int64), _FACES, lo, mid, hi)
            start, key, slots = _bucket_by_lowest(lo, mid, hi, np.int64(n_points), np.int64(threads))
            del lo, mid, hi
            _match(start, key, slots, mate, uses)
    return mate, uses


@njit(cache=True, parallel=True)
def _shape_extremes(corners, flat_volume, smallest, largest, ratio, valid):  # pragma: no cover - compiled
    for t in prange(corners.shape[0]):
        ax, ay, az = corners[t, 0, 0], corners[t, 0, 1], corners[t, 0, 2]
        ux, uy, uz = corners[t, 1, 0] - ax, corners[t, 1, 1] - ay, corners[t, 1, 2] - az
        vx, vy, vz = corners[t, 2, 0] - ax, corners[t, 2, 1] - ay, corners[t, 2, 2] - az
        wx, wy, wz = corners[t, 3, 0] - ax, corners[t, 3, 1] - ay, corners[t, 3, 2] - az
        bcx, bcy, bcz = vx - ux, vy - uy, vz - uz
        bdx, bdy, bdz = wx - ux, wy - uy, wz - uz
        cdx, cdy, cdz = wx - vx, wy - vy, wz - vz
        n = np.empty((4, 3))
        n[0, 0], n[0, 1], n[0, 2] = bdy * bcz - bdz * bcy, bdz * bcx - bdx * bcz, bdx * bcy - bdy * bcx
        n[1, 0], n[1, 1], n[1, 2] = vy * wz - vz * wy, vz * wx - vx * wz, vx * wy - vy * wx
        n[2, 0], n[2, 1], n[2, 2] = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
        n[3, 0], n[3, 1], n[3, 2] = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        norm = np.empty(4)
        inverse = np.empty(4)
        for i in range(4):
            norm[i] = math.sqrt(n[i, 0] * n[i, 0] + n[i, 1] * n[i, 1] + n[i, 2] * n[i, 2])
            inverse[i] = 1.0 / (norm[i] if norm[i] > 0 else 1.0)
        largest_cos = smallest_cos = 0.0
        first = True
        for i in range(4):
            for j in range(i + 1, 4):
                cos = -(n[i, 0] * n[j, 0] + n[i, 1] * n[j, 1] + n[i, 2] * n[j, 2]) * (inverse[i] * inverse[j])
                if first:
                    largest_cos = smallest_cos = cos
                    first = False
                else:
                    largest_cos = max(largest_cos, cos)
                    smallest_cos = min(smallest_cos, cos)
        lu = math.sqrt(ux * ux + uy * uy + uz * uz)
        lv = math.sqrt(vx * vx + vy * vy + vz * vz)
        lw = math.sqrt(wx * wx + wy * wy + wz * wz)
        lbc = math.sqrt(bcx * bcx + bcy * bcy + bcz * bcz)
        lbd = math.sqrt(bdx * bdx + bdy * bdy + bdz * bdz)
        lcd = math.sqrt(cdx * cdx + cdy * cdy + cdz * cdz)
        p, q, r = lu * lcd, lv * lbd, lw * lbc
        s = 0.5 * (p + q + r)
        heron = math.sqrt(max(s * (s - p) * (s - q) * (s - r), 0.0))
        volume6 = ux * n[1, 0] + uy * n[1, 1] + uz * n[1, 2]
        denominator = (norm[0] + norm[1] + norm[2] + norm[3]) * heron
        mean_edge = (lu + lv + lw + lbc + lbd + lcd) / 6.0
        # the angles are left as cosines: numpy's arccos, as in the array form
        smallest[t], largest[t] = largest_cos, smallest_cos
        ratio[t] = 3.0 * (volume6 * volume6) / (denominator if denominator > 0 else 1.0)
        valid[t] = volume6 > 6.0 * flat_volume * mean_edge**3


def shape_extremes(corners: np.ndarray, flat_volume: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smallest and largest dihedral angle (degrees) and radius ratio of (K, 4, 3) ``corners``,
    ``-1`` for all three where the cell's volume is at most ``flat_volume`` times its mean
    edge length cubed (inverted or flat): :func:`fepre.distmesh.tet_shape.dihedral_extremes`
    in one pass."""
    corners = np.ascontiguousarray(corners, np.float64).reshape(-1, 4, 3)
    largest_cos, smallest_cos, ratio = (np.empty(len(corners)) for _ in range(3))
    valid = np.empty(len(corners), bool)
    if len(corners):
        with kernel_threads(len(corners), 5e-8):
            _shape_extremes(corners, float(flat_volume), largest_cos, smallest_cos, ratio, valid)
    smallest = np.degrees(np.arccos(np.clip(largest_cos, -1.0, 1.0)))
    largest = np.degrees(np.arccos(np.clip(smallest_cos, -1.0, 1.0)))
    return np.where(valid, smallest, -1.0), np.where(valid, largest, -1.0), np.where(valid, ratio, -1.0)


@njit(cache=True, parallel=True)
def _ideal(points, tets, third_height, out):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        a0, a1, a2 = points[tets[t, 0], 0], points[tets[t, 0], 1], points[tets[t, 0], 2]
        b0, b1, b2 = points[tets[t, 1], 0], points[tets[t, 1], 1], points[tets[t, 1], 2]
        c0, c1, c2 = points[tets[t, 2], 0], points[tets[t, 2], 1], points[tets[t, 2], 2]
        d0, d1, d2 = points[tets[t, 3], 0], points[tets[t, 3], 1], points[tets[t, 3], 2]
        u0, u1, u2 = b0 - a0, b1 - a1, b2 - a2
        v0, v1, v2 = c0 - a0, c1 - a1, c2 - a2
        w0, w1, w2 = d0 - a0, d1 - a1, d2 - a2
        bc0, bc1, bc2 = v0 - u0, v1 - u1, v2 - u2
        bd0, bd1, bd2 = w0 - u0, w1 - u1, w2 - u2
        cd0, cd1, cd2 = w0 - v0, w1 - v1, w2 - v2
        lu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        lv = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        lw = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        lbc = math.sqrt(bc0 * bc0 + bc1 * bc1 + bc2 * bc2)
        lbd = math.sqrt(bd0 * bd0 + bd1 * bd1 + bd2 * bd2)
        lcd = math.sqrt(cd0 * cd0 + cd1 * cd1 + cd2 * cd2)
        total0, total1, total2 = a0 + b0 + c0 + d0, a1 + b1 + c1 + d1, a2 + b2 + c2 + d2
        for i in range(4):
            # the face opposite vertex i: its mean edge and its normal towards vertex i
            if i == 0:
                mean = lbc + lbd + lcd
                n0, n1, n2 = bd1 * bc2 - bd2 * bc1, bd2 * bc0 - bd0 * bc2, bd0 * bc1 - bd1 * bc0
                p0, p1, p2 = a0, a1, a2
            elif i == 1:
                mean = lv + lw + lcd
                n0, n1, n2 = v1 * w2 - v2 * w1, v2 * w0 - v0 * w2, v0 * w1 - v1 * w0
                p0, p1, p2 = b0, b1, b2
            elif i == 2:
                mean = lu + lw + lbd
                n0, n1, n2 = w1 * u2 - w2 * u1, w2 * u0 - w0 * u2, w0 * u1 - w1 * u0
                p0, p1, p2 = c0, c1, c2
            else:
                mean = lu + lv + lbc
                n0, n1, n2 = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
                p0, p1, p2 = d0, d1, d2
            norm = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            scale = third_height * mean / (norm if norm > 0 else 1.0)
            out[i, 0, t] = (total0 - p0) / 3.0 + scale * n0
            out[i, 1, t] = (total1 - p1) / 3.0 + scale * n1
            out[i, 2, t] = (total2 - p2) / 3.0 + scale * n2


def ideal_positions(points: np.ndarray, tets: np.ndarray, height: float) -> np.ndarray:
    """For each cell and vertex, where that vertex would make the cell regular: (4, 3, M).

    Entry ``[i, :, k]`` is the point above the centroid of the face of cell ``k`` opposite its
    vertex ``i``, on the vertex's side, ``height`` times that face's mean edge length above it
    (:func:`fepre.distmesh.tet_shape.ideal_vertex_positions`)."""
    out = np.empty((4, 3, len(tets)))
    if len(tets):
        with kernel_threads(len(tets), 3e-8):
            _ideal(np.ascontiguousarray(points, np.float64), np.ascontiguousarray(tets, np.int64), float(height) / 3.0, out)
    return out


@njit(cache=True, parallel=True)
def _volumes(points, tets, out):  # pragma: no cover - compiled
    for t in prange(tets.shape[0]):
        i0, i1, i2, i3 = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
        u0, u1, u2 = points[i1, 0] - points[i0, 0], points[i1, 1] - points[i0, 1], points[i1, 2] - points[i0, 2]
        v0, v1, v2 = points[i2, 0] - points[i0, 0], points[i2, 1] - points[i0, 1], points[i2, 2] - points[i0, 2]
        w0, w1, w2 = points[i3, 0] - points[i0, 0], points[i3, 1] - points[i0, 1], points[i3, 2] - points[i0, 2]
        out[t] = (u0 * (v1 * w2 - v2 * w1) + u1 * (v2 * w0 - v0 * w2) + u2 * (v0 * w1 - v1 * w0)) / 6.0


def corner_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes (M,) of the cells, positive in VTK's convention:
    :func:`fepre.distmesh.tet_shape.signed_volume` of ``points[tets]`` (bit-identical) without
    the (M, 4, 3) copy of the corners."""
    out = np.empty(len(tets))
    if len(tets):
        with kernel_threads(len(tets), 5e-9):
            _volumes(np.ascontiguousarray(points, np.float64), np.ascontiguousarray(tets, np.int64), out)
    return out


@njit(cache=True)
def _cells_by_vertex(tets, offsets, out):  # pragma: no cover - compiled
    fill = offsets[:-1].copy()
    for t in range(tets.shape[0]):
        for k in range(tets.shape[1]):
            v = tets[t, k]
            out[fill[v]] = t
            fill[v] += 1


def cells_by_vertex(tets: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the cells around each vertex, ``(offsets (N+1,), cells)``, each vertex's
    cells in increasing order: ``np.argsort(tets.ravel(), kind="stable") // k`` and its counts
    (bit-identical) by one counting pass instead of a sort (8 ms for 65k cells, paid after
    every change in the quality stage's collapse rounds)."""
    tets = np.ascontiguousarray(tets, np.int64)
    offsets = np.zeros(n_points + 1, dtype=np.int64)
    np.cumsum(np.bincount(tets.ravel(), minlength=n_points), out=offsets[1:])
    cells = np.empty(tets.size, dtype=np.int64)
    if tets.size:
        _cells_by_vertex(tets, offsets, cells)
    return offsets, cells
