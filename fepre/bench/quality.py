"""Sliver-free quality: fepre's DistMesh + quality stage vs pytetwild and gmsh: worst angles and time on spheres, a torus and CAD-style parts.

For each target model (unit sphere at h = 0.2, 0.1, 0.05; torus R=1, r=0.4 at h=0.1; Persson's
cylinder with a spherical hole, graded; a smooth union of two capsules; the gyroid infill block of
:func:`fepre.parts.gyroid_block` at h = 0.05, where its sheet (0.15) holds three elements and its
shell (0.2) four; the revolved stepped shaft at h=2 and a flange at h=4) one run
measures:

* fepre: ``fepre.distmesh`` with the default options, the main loop's time and the quality
  stage's time (from the mesh's field data), and the worst dihedral angle before the stage
  (the stage's own record);
* pytetwild (``edge_length_abs=h``) and gmsh (when installed) on the same flying-edges surface
  (spacing h/2; :func:`fepre.compare` uses h/4, which makes pytetwild several times slower);

and prints, per mesher, time, points, cells, worst smallest dihedral angle, largest dihedral
angle, smallest radius ratio, 1st-percentile smallest angle and mean radius ratio, with fepre's
ratios to each peer. ``--out DIR`` writes one PNG per model with histograms of the smallest
dihedral angle and of the radius ratio of every cell, the three meshers side by side (as Fig. 13
of Kelly's DistMesh.jl study).
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from typing import Any, Callable

import numpy as np

from . import save_figure


def _cylinder_size(points: np.ndarray) -> np.ndarray:
    return 1.0 + 1.5 * np.maximum(np.linalg.norm(points, axis=1) - 0.5, 0.0)


def target_models(quick: bool = False) -> list[tuple[str, Any, float, Callable | None]]:
    """The benchmark's models as ``(name, model, h, size)``; ``quick`` drops the sphere at h=0.05."""
    from .. import parts, sdf

    ball = sdf.sphere(1.0)
    capsules = sdf.union(
        sdf.capsule((-0.6, 0, 0), (0.6, 0, 0), 0.3), sdf.capsule((0, -0.6, 0), (0, 0.6, 0.3), 0.3), k=0.2
    )
    models = [("sphere h=0.2", ball, 0.2, None), ("sphere h=0.1", ball, 0.1, None)]
    if not quick:
        models.append(("sphere h=0.05", ball, 0.05, None))
    models += [
        ("torus h=0.1", sdf.torus(1.0, 0.4), 0.1, None),
        ("cylinder-hole graded h=0.1", sdf.cylinder(radius=1.0, height=2.0) - sdf.sphere(0.5), 0.1, _cylinder_size),
        ("capsules h=0.1", capsules, 0.1, None),
        # sheet 0.15 and shell 0.2 thick at h = 0.05: three and four elements across. (A gyroid
        # sheet of period 1 thicker than 0.276 fills all space: the earlier infill with a 0.3
        # sheet was a plain box.)
        ("gyroid block h=0.05", parts.gyroid_block(), 0.05, None),
        # CAD-style parts: a revolved stepped shaft and a flange with bore and bolt holes
        ("stepped shaft h=2", sdf.revolve(sdf.polygon([(0, 0), (10, 0), (10, 40), (6, 40), (6, 80), (0, 80)])), 2.0, None),
        ("flange h=4", _flange(), 4.0, None),
    ]
    return models


def _flange():
    """Disk r50 (z 0-10) and hub r25 (to z 40), bore r12, six r4 bolt holes on a r38 circle."""
    from .. import sdf

    body = sdf.cylinder(radius=50, height=10, center=(0, 0, 5)) | sdf.cylinder(radius=25, height=30, center=(0, 0, 25))
    body = body - sdf.cylinder(radius=12, height=60, center=(0, 0, 20))
    for k in range(6):
        angle = k * np.pi / 3
        body = body - sdf.cylinder(radius=4, height=30, center=(38 * np.cos(angle), 38 * np.sin(angle), 5))
    return body


def _fepre(model, h: float, size) -> dict[str, Any]:
    import fepre

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fepre.ConvergenceWarning)
        mesh = fepre.distmesh(model, h, size=size)
    fields = mesh.field_data
    return {
        "mesh": mesh,
        "seconds": float(fields["distmesh_seconds"][0]),
        "loop": float(fields["distmesh_loop_seconds"][0]),
        "stage": float(fields["distmesh_slivers_seconds"][0]),
    }


def _peer(name: str, model, h: float) -> dict[str, Any]:
    from ..quality import add_quality
    from ..references import reference_surface, run_reference

    try:
        surface = reference_surface(model, spacing=h / 2)
        mesh, seconds = run_reference(name, surface, h)
    except Exception as exc:  # noqa: BLE001 - a failing peer is reported, not fatal
        return {"error": f"{type(exc).__name__}: {exc}"[:120]}
    return {"mesh": add_quality(mesh), "seconds": float(seconds)}


def _figures(mesh) -> dict[str, float]:
    angle = np.asarray(mesh.cell_data["min_dihedral_angle"])
    ratio = np.asarray(mesh.cell_data["radius_ratio"])
    return {
        "points": mesh.n_points,
        "cells": mesh.n_cells,
        "worst": float(angle.min()),
        "largest": float(np.asarray(mesh.cell_data["max_dihedral_angle"]).max()),
        "min_rr": float(ratio.min()),
        "p1": float(np.percentile(angle, 1)),
        "mean_rr": float(ratio.mean()),
        "inverted": int((np.asarray(mesh.cell_data["volume"]) <= 0).sum()),
    }


def _histograms(title: str, results: dict[str, dict[str, Any]], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for name, result in results.items():
        if "mesh" not in result:
            continue
        mesh = result["mesh"]
        axes[0].hist(mesh.cell_data["min_dihedral_angle"], bins=np.linspace(0, 75, 76), histtype="step", density=True, label=name, linewidth=1.5)
        axes[1].hist(mesh.cell_data["radius_ratio"], bins=np.linspace(0, 1, 51), histtype="step", density=True, label=name, linewidth=1.5)
    axes[0].set_xlabel("smallest dihedral angle per cell (deg)")
    axes[1].set_xlabel("radius ratio 3 r_in / R_circ")
    for ax in axes:
        ax.set_yscale("log")
        ax.set_ylabel("density (log)")
        ax.legend()
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def run(quick: bool, out: str | None, peers: list[str]) -> list[str]:
    """Measure every target model; returns the printed lines."""
    lines = [
        f"{'model':28} {'mesher':10} {'seconds':>8} {'loop':>7} {'stage':>7} {'stage%':>6} {'points':>7} "
        f"{'cells':>8} {'worst':>6} {'max':>6} {'min rr':>6} {'p1':>6} {'mean rr':>7}  ratios fepre/peer (worst, mean rr, time per cell)"
    ]
    print(lines[0], flush=True)
    for name, model, h, size in target_models(quick):
        try:
            results: dict[str, dict[str, Any]] = {"fepre": _fepre(model, h, size)}
        except Exception as exc:  # noqa: BLE001 - report the failure and go on with the next model
            line = f"{name:28} {'fepre':10} failed: {type(exc).__name__}: {exc}"[:160]
            lines.append(line)
            print(line, flush=True)
            continue
        for peer in peers:
            results[peer] = _peer(peer, model, h)
        mine = _figures(results["fepre"]["mesh"])
        for mesher, result in results.items():
            if "error" in result:
                line = f"{name:28} {mesher:10} failed: {result['error']}"
            else:
                f = _figures(result["mesh"])
                loop = result.get("loop")
                stage = result.get("stage")
                timing = (
                    f"{result['seconds']:8.2f} {loop:7.2f} {stage:7.2f} {100 * stage / loop:5.0f}%"
                    if loop is not None
                    else f"{result['seconds']:8.2f} {'':7} {'':7} {'':6}"
                )
                line = (
                    f"{name:28} {mesher:10} {timing} {f['points']:7d} {f['cells']:8d} {f['worst']:6.2f} {f['largest']:6.1f} "
                    f"{f['min_rr']:6.3f} "
                    f"{f['p1']:6.2f} {f['mean_rr']:7.4f}"
                )
                if mesher != "fepre":
                    line += (
                        f"  {mine['worst'] / f['worst']:.2f}x, {mine['mean_rr'] / f['mean_rr']:.3f}x, "
                        f"{(results['fepre']['seconds'] / mine['cells']) / (result['seconds'] / f['cells']):.2f}x"
                    )
                if f["inverted"]:
                    line += f"  ({f['inverted']} inverted cells)"
            lines.append(line)
            print(line, flush=True)
        if out:
            slug = name.replace(" ", "_").replace("=", "").replace(".", "p")
            _histograms(name, results, os.path.join(out, f"quality_{slug}.png"))
    return lines


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench quality", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the sphere at h=0.05")
    parser.add_argument("--out", default=None, help="directory for the PNG histograms (default: none written)")
    parser.add_argument(
        "--peers",
        default=None,
        help="comma-separated peers to run (default: every installed one of pytetwild, gmsh; '' for none)",
    )
    args = parser.parse_args(argv)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
    from ..references import available_references

    installed = available_references()
    if args.peers is None:
        peers = installed
    else:
        peers = [name for name in args.peers.split(",") if name]
        unknown = [name for name in peers if name not in installed]
        if unknown:
            parser.error(f"--peers must name installed peers ({', '.join(installed)}); got {', '.join(unknown)}")
    start = time.perf_counter()
    run(args.quick, args.out, peers)
    from ..references import REFERENCE_SETTINGS

    for peer in peers:
        print(f"{peer}: {REFERENCE_SETTINGS[peer]}")
    print("time ratio: fepre's time per cell / the peer's (< 1: fepre faster per cell)")
    print(f"total {time.perf_counter() - start:.1f} s")
    return 0
