"""Sharp features: corners, edges, Hausdorff distance and volume of CSG parts, with and without features.

Parts (``fepre.parts``): the cube with a hole of Kelly's DistMesh.jl study ([0,5]^3 minus a radius-1 cylinder along z
at x = y = 2.5) at h = 0.25, the L-bracket with a filleted inner edge and a bolt hole at h = 0.2,
and the box with a slot at h = 0.25. For each, ``fepre.distmesh`` runs with ``features=True``
(the default) and ``features=False``, and the table gives:

* corner gap: the largest distance from a part's corner to the nearest mesh node (target 1e-9);
* curve nodes off: the largest ``|patch value|`` of the two patches at the feature-curve nodes
  (the nodes lie on both surfaces; target 1e-9);
* Hausdorff / h: the two-sided distance of the mesh boundary to the true surface, in units of h,
  away from curved surfaces (the hole, the fillet), where chords are expected (target 0.01);
* volume error against the exact (or Monte Carlo) volume (target 0.5%), worst dihedral angle
  (target 12 degrees) and mean radius ratio, and the seconds of feature detection and meshing.

With dual contouring available in :func:`fepre.isosurface`, the same parts' surfaces at grid
spacing h/2 are measured too: the largest distance from a corner to the nearest surface vertex,
in units of the grid spacing (target 0.01), against flying edges on the same grid.
"""

from __future__ import annotations

import argparse
import time
import warnings
from typing import Any

import numpy as np



def parts() -> list[dict[str, Any]]:
    """The benchmark parts: name, model, h, corners, exact volume and the curved region left out."""
    from .. import sdf
    from ..parts import (
        CUBE_WITH_HOLE_VOLUME,
        L_BRACKET_VOLUME,
        SLOTTED_BOX_VOLUME,
        cube_with_hole,
        cube_with_hole_corners,
        l_bracket,
        l_bracket_corners,
        slotted_box,
        slotted_box_corners,
    )

    cube, hole = cube_with_hole()
    bracket, bolt_hole, _ = l_bracket()
    fillet = sdf.capsule((0.6, -1.0, 0.6), (0.6, 3.0, 0.6), 0.6)
    return [
        dict(name="cube with hole", model=cube, h=0.25, corners=cube_with_hole_corners(),
             volume=CUBE_WITH_HOLE_VOLUME, curved=hole),
        dict(name="L-bracket", model=bracket, h=0.2, corners=l_bracket_corners(), volume=L_BRACKET_VOLUME,
             curved=bolt_hole | fillet),
        dict(name="slotted box", model=slotted_box()[0], h=0.25, corners=slotted_box_corners(),
             volume=SLOTTED_BOX_VOLUME, curved=None),
    ]


def _corner_gap(points: np.ndarray, corners: np.ndarray) -> float:
    from scipy.spatial import cKDTree

    return float(cKDTree(points).query(corners)[0].max())


def _curve_nodes_off(mesh, model, features) -> float:
    """Largest |patch value| of both patches over the nodes flagged as feature-curve nodes."""
    if features is None or not features.curves:
        return float("nan")
    from ..features.geometry import nearest_on_segments

    nodes = np.asarray(mesh.points)[np.asarray(mesh["feature"]) == 1]
    if len(nodes) == 0:
        return float("nan")
    segments = np.concatenate([c.points[c.segments] for c in features.curves])
    owners = np.concatenate([np.full(len(c.segments), i) for i, c in enumerate(features.curves)])
    _, _, index = nearest_on_segments(nodes, segments, np.zeros((0, 3)), with_index=True)
    pairs = np.array([features.curves[i].patches for i in owners[index]])
    values = np.stack([model.patch_values(pairs[:, k], nodes) for k in range(2)], axis=1)
    return float(np.abs(values).max())


def measure(part: dict[str, Any], features: bool) -> dict[str, Any]:
    """Mesh one part and measure it."""
    import fepre

    from ..mesh_metrics import model_hausdorff

    model, h = part["model"], part["h"]
    found = fepre.features(model, h, warn=False) if features else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.perf_counter()
        mesh = fepre.distmesh(model, h, features=features)
        seconds = time.perf_counter() - start
    to_surface, from_surface = model_hausdorff(mesh, model, spacing=h / 8, exclude=part["curved"], margin=h)
    return {
        "corner gap": _corner_gap(np.asarray(mesh.points), part["corners"]),
        "curve nodes off": _curve_nodes_off(mesh, model, found),
        "Hausdorff/h": max(to_surface, from_surface) / h,
        "volume error": mesh.volume / part["volume"] - 1.0,
        "worst dihedral": float(mesh["min_dihedral_angle"].min()),
        "mean radius ratio": float(mesh["radius_ratio"].mean()),
        "features s": float(mesh.field_data["distmesh_features_seconds"][0]),
        "mesh s": seconds,
        "tets": mesh.n_cells,
    }


def surface_corners(part: dict[str, Any], method: str) -> tuple[float, float, int]:
    """Largest corner-to-vertex distance in grid spacings, seconds, and degenerate triangles."""
    import fepre

    spacing = part["h"] / 2
    start = time.perf_counter()
    surface = fepre.isosurface(part["model"], spacing=spacing, method=method)
    seconds = time.perf_counter() - start
    areas = surface.compute_cell_sizes(length=False, volume=False)["Area"]
    degenerate = int(np.count_nonzero(np.asarray(areas) <= 1e-12 * spacing**2))
    return _corner_gap(np.asarray(surface.points), part["corners"]) / spacing, seconds, degenerate


def _table(rows: list[list[str]]) -> str:
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))) for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench features", description=__doc__.splitlines()[0])
    parser.add_argument("--parts", nargs="*", help="part names to run (default all)")
    args = parser.parse_args(argv)
    from ..surface import METHODS

    chosen = [p for p in parts() if not args.parts or p["name"] in args.parts]
    keys = ["corner gap", "curve nodes off", "Hausdorff/h", "volume error", "worst dihedral", "mean radius ratio",
            "features s", "mesh s", "tets"]
    rows = [["part", "features"] + keys]
    for part in chosen:
        for features in (True, False):
            result = measure(part, features)
            row = [f"{part['name']} h={part['h']:g}", "on" if features else "off"]
            for key in keys:
                value = result[key]
                if key == "volume error":
                    row.append(f"{100 * value:+.3f}%")
                elif key in ("corner gap", "curve nodes off", "Hausdorff/h"):
                    row.append("-" if np.isnan(value) else f"{value:.2e}")
                elif key == "tets":
                    row.append(str(value))
                else:
                    row.append(f"{value:.3f}" if key != "worst dihedral" else f"{value:.1f}")
            rows.append(row)
    print("DistMesh on sharp CSG parts (targets: corner gap and curve nodes <= 1e-9, Hausdorff/h <= 0.01 "
          "away from curved surfaces, volume within 0.5%, worst dihedral >= 12 deg)")
    print(_table(rows))
    methods = [m for m in ("dual_contouring", "flying_edges") if m in METHODS]
    if methods:
        rows = [["part", "method", "corner gap / spacing", "seconds", "degenerate triangles"]]
        for part in chosen:
            for method in methods:
                gap, seconds, degenerate = surface_corners(part, method)
                rows.append([part["name"], method, f"{gap:.2e}", f"{seconds:.3f}", str(degenerate)])
        print("\nSurfaces at grid spacing h/2 (target for dual contouring: corner gap <= 0.01 spacing)")
        print(_table(rows))
    return 0
