"""The compiled closest-point kernel of :mod:`fepre.sdf.meshmodel.bvh` (numba, cached on disk)."""

from __future__ import annotations

import numpy as np
from numba import njit

_STACK = 128


@njit(cache=True, nogil=True, inline="always")
def _box_squared(px, py, pz, lower, upper, node):
    dx = max(lower[node, 0] - px, 0.0, px - upper[node, 0])
    dy = max(lower[node, 1] - py, 0.0, py - upper[node, 1])
    dz = max(lower[node, 2] - pz, 0.0, pz - upper[node, 2])
    return dx * dx + dy * dy + dz * dz


@njit(cache=True, nogil=True)
def _closest_on_sides(px, py, pz, tri, out):
    """The closest point on the three sides of a triangle of zero area (collinear or coincident
    corners); writes it into out[0:3] and returns the side's region code (3: ab, 4: bc, 5: ca)."""
    best = np.inf
    region = 3
    for side in range(3):
        s, e = side, (side + 1) % 3
        ex, ey, ez = tri[e, 0] - tri[s, 0], tri[e, 1] - tri[s, 1], tri[e, 2] - tri[s, 2]
        length = ex * ex + ey * ey + ez * ez
        t = ((px - tri[s, 0]) * ex + (py - tri[s, 1]) * ey + (pz - tri[s, 2]) * ez) / length if length > 0.0 else 0.0
        t = min(max(t, 0.0), 1.0)
        qx, qy, qz = tri[s, 0] + t * ex, tri[s, 1] + t * ey, tri[s, 2] + t * ez
        squared = (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2
        if squared < best:
            best = squared
            out[0], out[1], out[2] = qx, qy, qz
            region = (3, 4, 5)[side]
    return region


@njit(cache=True, nogil=True)
def _closest_on_triangle(px, py, pz, tri, out):
    """Ericson's closest point on a triangle (Real-Time Collision Detection, 5.1.5): writes the
    point into out[0:3] and returns the region code (0-2 corner, 3-5 side, 6 interior)."""
    ax, ay, az = tri[0, 0], tri[0, 1], tri[0, 2]
    bx, by, bz = tri[1, 0], tri[1, 1], tri[1, 2]
    cx, cy, cz = tri[2, 0], tri[2, 1], tri[2, 2]
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        out[0], out[1], out[2] = ax, ay, az
        return 0
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        out[0], out[1], out[2] = bx, by, bz
        return 1
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        if d1 <= d3:  # d1 - d3 = |ab|^2: a and b coincide
            return -1
        v = d1 / (d1 - d3)
        out[0], out[1], out[2] = ax + v * abx, ay + v * aby, az + v * abz
        return 3
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        out[0], out[1], out[2] = cx, cy, cz
        return 2
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        if d2 <= d6:  # |ac|^2
            return -1
        w = d2 / (d2 - d6)
        out[0], out[1], out[2] = ax + w * acx, ay + w * acy, az + w * acz
        return 5
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        side = (d4 - d3) + (d5 - d6)  # |bc|^2
        if side <= 0.0:
            return -1
        w = (d4 - d3) / side
        out[0], out[1], out[2] = bx + w * (cx - bx), by + w * (cy - by), bz + w * (cz - bz)
        return 4
    total = va + vb + vc
    if total == 0.0:  # collinear corners
        return -1
    v = vb / total
    w = vc / total
    out[0] = ax + abx * v + acx * w
    out[1] = ay + aby * v + acy * w
    out[2] = az + abz * v + acz * w
    return 6


@njit(cache=True, nogil=True, inline="always")
def _squared_to(px, py, pz, tri, scratch):
    region = _closest_on_triangle(px, py, pz, tri, scratch)
    if region < 0:  # a triangle of zero area: its sides hold the closest point
        region = _closest_on_sides(px, py, pz, tri, scratch)
    dx, dy, dz = px - scratch[0], py - scratch[1], pz - scratch[2]
    return dx * dx + dy * dy + dz * dz, region


@njit(cache=True, nogil=True)
def closest_points(points, lower, upper, triangles, spheres, width, leaf_start, squared, face, closest, region):
    """For each point: the squared distance to the nearest triangle, its index (in tree order),
    the closest point and its region. Fills the output arrays. ``spheres`` (F, 4) bound each
    triangle (centre, radius): a triangle whose sphere is already farther than the best is
    skipped without the closest-point computation."""
    stack = np.empty(_STACK, dtype=np.int64)
    bounds = np.empty(_STACK)  # each stacked node's box distance, computed when it was pushed
    scratch = np.empty(3)
    previous = 0
    for q in range(points.shape[0]):
        px, py, pz = points[q, 0], points[q, 1], points[q, 2]
        # the previous point's triangle bounds the search from the start
        best, best_region = _squared_to(px, py, pz, triangles[previous], scratch)
        best_face = previous
        bx, by, bz = scratch[0], scratch[1], scratch[2]
        stack[0] = 1
        bounds[0] = 0.0
        top = 1
        while top > 0:
            top -= 1
            if bounds[top] >= best:
                continue
            node = stack[top]
            if node >= width:
                for t in range(leaf_start[node - width], leaf_start[node - width + 1]):
                    sx, sy, sz = px - spheres[t, 0], py - spheres[t, 1], pz - spheres[t, 2]
                    gap = np.sqrt(sx * sx + sy * sy + sz * sz) - spheres[t, 3]
                    if gap > 0.0 and gap * gap >= best:
                        continue
                    d, r = _squared_to(px, py, pz, triangles[t], scratch)
                    if d < best:
                        best, best_face, best_region = d, t, r
                        bx, by, bz = scratch[0], scratch[1], scratch[2]
                continue
            left = 2 * node
            right = left + 1
            dl = _box_squared(px, py, pz, lower, upper, left)
            dr = _box_squared(px, py, pz, lower, upper, right)
            if dl > dr:  # the nearer child goes on top
                left, right, dl, dr = right, left, dr, dl
            if dr < best:
                stack[top] = right
                bounds[top] = dr
                top += 1
            if dl < best:
                stack[top] = left
                bounds[top] = dl
                top += 1
        squared[q] = best
        face[q] = best_face
        closest[q, 0], closest[q, 1], closest[q, 2] = bx, by, bz
        region[q] = best_region
        previous = best_face


@njit(cache=True, nogil=True)
def morton_codes(points, lower, scale, out):
    """30-bit Z-order codes (10 bits per axis) of ``points``: cell ``(p - lower) * scale``."""
    for q in range(points.shape[0]):
        code = 0
        for axis in range(3):
            v = int((points[q, axis] - lower[axis]) * scale)
            v = min(max(v, 0), 1023)
            v = (v | (v << 16)) & 0x030000FF
            v = (v | (v << 8)) & 0x0300F00F
            v = (v | (v << 4)) & 0x030C30C3
            v = (v | (v << 2)) & 0x09249249
            code |= v << axis
        out[q] = code
