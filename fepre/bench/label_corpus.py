"""Seeded random label images: a block with one to three random inclusions, meshed uniform and graded.

Each seed draws one to three inclusions (balls, cylinders, boxes; later ones over earlier ones,
some cutting the block's faces) in a 12 x 10 x 8 block, rasterises them with
:func:`fepre.sdf.imagemodel.phantoms.label_image` at ``--voxel`` and meshes ``sdf.labels`` of it
at ``--h`` and at ``(--h / 2, 2 --h)``. Printed per seed and size: each region's voxel volume and
the radius of the largest ball it holds (its half-thickness), then the cells, each region's worst
dihedral angle and the time, or the error. A robustness corpus, not a benchmark against a peer:
inputs nobody chose, with regions about one element thick where the draws overlap.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

BLOCK = (12.0, 10.0, 8.0)


def phantom(seed: int, voxel: float):
    """The label image of ``seed``: the block (label 1) and its inclusions (labels 2, 3, ...)."""
    from .. import sdf
    from ..sdf.imagemodel.phantoms import label_image

    rng = np.random.default_rng(seed)
    half = np.array(BLOCK) / 2
    shapes = [sdf.box(BLOCK)]
    for _ in range(int(rng.integers(1, 4))):
        centre = tuple(rng.uniform(-half + 1, half - 1))
        kind = int(rng.integers(3))
        if kind == 0:
            shapes.append(sdf.sphere(float(rng.uniform(1.2, 2.5)), center=centre))
        elif kind == 1:
            shapes.append(sdf.cylinder(float(rng.uniform(0.8, 1.8)), float(rng.uniform(3, 10))).translate(centre))
        else:
            shapes.append(sdf.box(tuple(rng.uniform(1.5, 4, 3)), center=centre))
    return label_image(shapes, tuple(-half - 0.6), tuple(half + 0.6), voxel)


def _regions_shape(grid, voxel: float) -> str:
    """Each label's volume and largest inscribed radius, from its voxels."""
    from scipy import ndimage

    values = np.asarray(grid["labels"]).reshape(grid.dimensions, order="F")
    shown = []
    for label in np.unique(values)[1:]:
        inside = values == label
        radius = float(ndimage.distance_transform_edt(inside).max()) * voxel
        shown.append(f"{label}: {inside.sum() * voxel**3:.0f}, r {radius:.2f}")
    return "; ".join(shown)


def main(argv: list[str] | None = None) -> int:
    import fepre
    from fepre import sdf

    parser = argparse.ArgumentParser(prog="fepre bench label-corpus", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8, help="seeds 1..N (default 8)")
    parser.add_argument("--h", type=float, default=1.0, help="uniform edge length (default 1)")
    parser.add_argument("--voxel", type=float, default=0.25, help="voxel size (default 0.25)")
    args = parser.parse_args(argv)
    print(f"{args.seeds} random label images of a {BLOCK} block, voxel {args.voxel:g}; "
          f"fepre.distmesh(regions.part, h, regions=sdf.labels(image)) at h = {args.h:g} and ({args.h / 2:g}, {2 * args.h:g})")
    print("seed  regions (label: voxel volume, largest inscribed radius)")
    meshed = failed = 0
    for seed in range(1, args.seeds + 1):
        grid = phantom(seed, args.voxel)
        print(f"{seed:4d}  {_regions_shape(grid, args.voxel)}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            regions = sdf.labels(grid)
            for h in (args.h, (args.h / 2, 2 * args.h)):
                started = time.perf_counter()
                try:
                    mesh = fepre.distmesh(regions.part, h, regions=regions, progress=False)
                except Exception as exc:  # a robustness corpus: every failure is a finding
                    failed += 1
                    print(f"      h {h}: FAILED {type(exc).__name__}: {str(exc)[:240]}")
                    continue
                meshed += 1
                ids = np.asarray(mesh["region_id"])
                worst = " ".join(f"{float(mesh['min_dihedral_angle'][ids == k].min()):.1f}" for k in range(len(regions)))
                print(f"      h {h}: {mesh.n_cells} cells, worst per region {worst}, {time.perf_counter() - started:.1f} s")
    print(f"\n{meshed} of {meshed + failed} meshes made")
    return 0
