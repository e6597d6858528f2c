"""Images as models: partial-volume and label phantoms of analytic parts at several resolutions, meshed.

Grey phantoms (each voxel's partial volume of the part, :mod:`fepre.sdf.imagemodel.phantoms`): a
torus and a gyroid lattice in a box, each at 3-4 voxel sizes, as ``sdf.image(level=0.5)`` and (rows
``+pv``) with ``partial_volume=True``, the level moved so that the part holds the shares' volume. Printed
per phantom and voxel size: the image model's time and triangles, the largest distance of its
triangles' vertices from the true surface and the volume they enclose against the analytic one,
then its mesh at a fixed ``h``: the largest distance of a boundary node from the true surface (in
voxels, target 0.5), the mesh volume against the mesh of the analytic part at the same ``h``
(both lose the same chords) and against the part's exact volume (target 1%; the gyroid's sampled
at 330^3 points, to about 1e-5), the worst dihedral angles and radius ratio (targets 25, 150,
0.25) and the seconds.

Label phantoms (the label of each voxel's centre): a cube with a spherical inclusion, as
``sdf.labels``, meshed with ``regions=``: each region's volume against the analytic one and
against the analytic regions' mesh at the same ``h`` (target 2%), the interface nodes' largest
distance from the true interface, whether every interface is closed (its rim on the part's
surface), the worst angle of each region, seconds.

``--speed`` meshes a 256^3 label image with three labels (a block, a ball and a cylinder in it)
at the ``h`` that gives about 500k cells and prints the time of each step (target: 2 minutes on
2 cores).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np


def sampled_volume(model, lower, upper, samples: int = 330) -> float:
    """The volume where ``model`` is negative in the box ``lower``..``upper`` (a cube), from
    ``samples``^3 cell centres, each counted by the share of its cell the zero set leaves inside
    (``clip(0.5 - value / spacing, 0, 1)``): the gyroid phantom's 0.721540 at 330 samples, 0.721535
    at 440, 0.721601 at 110."""
    step = (float(upper) - float(lower)) / samples
    centres = float(lower) + (np.arange(samples) + 0.5) * step
    total = 0.0
    for start in range(0, samples, 8):
        x, y, z = np.meshgrid(centres[start:start + 8], centres, centres, indexing="ij")
        values = np.asarray(model(np.column_stack([x.ravel(), y.ravel(), z.ravel()])), dtype=float)
        total += float(np.clip(0.5 - values / step, 0.0, 1.0).sum())
    return total * step**3


def _grey_phantoms(quick: bool):
    from .. import sdf

    torus = sdf.torus(0.6, 0.3)
    gyroid = sdf.box(1.0) & sdf.gyroid(period=1.0, thickness=0.2)
    phantoms = [
        ("torus R0.6 r0.3", torus, ((-1, -1, -0.4), (1, 1, 0.4)), 2 * np.pi**2 * 0.6 * 0.09, 0.1,
         (0.1, 0.05, 0.033, 0.025) if not quick else (0.1, 0.05)),
        ("gyroid lattice in a box", gyroid, ((-0.55,) * 3, (0.55,) * 3), sampled_volume(gyroid, -0.55, 0.55), 0.05,
         (0.05, 0.033, 0.025) if not quick else (0.033,)),
    ]
    return phantoms


def _quality(mesh, chosen=None) -> tuple[float, float, float]:
    chosen = slice(None) if chosen is None else chosen
    return (float(mesh["min_dihedral_angle"][chosen].min()), float(mesh["max_dihedral_angle"][chosen].max()),
            float(mesh["radius_ratio"][chosen].min()))


def _grey(quick: bool) -> None:
    import fepre
    from .. import sdf
    from ..sdf.imagemodel.phantoms import partial_volume

    print("grey phantoms: partial volumes, sdf.image(level=0.5) and, +pv, with partial_volume=True (the level moved so that the "
          "part holds the shares' volume), meshed at a fixed h against the analytic part's mesh")
    print(f"{'phantom':25s} {'voxel':>6s} {'image s':>7s} {'tris':>7s} {'vert/vox':>8s} {'vol err':>8s} {'h':>5s} "
          f"{'cells':>7s} {'node/vox':>8s} {'vs mesh':>8s} {'vs exact':>8s} {'min':>5s} {'max':>6s} {'rr':>5s} {'mesh s':>6s}")
    for name, model, (lower, upper), volume, h, voxels in _grey_phantoms(quick):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            exact = fepre.distmesh(model, h, progress=False)
        for voxel, shares in ((voxel, shares) for voxel in voxels for shares in (False, True)):
            grid = partial_volume(model, lower, upper, voxel)
            start = time.perf_counter()
            image = sdf.image(grid, level=0.5, partial_volume=shares)
            image_seconds = time.perf_counter() - start
            surface = image if isinstance(image, sdf.ImageModel) else image.children[0]
            vertex = float(np.abs(model(surface.vertices)).max()) / voxel
            error = surface.volume / volume - 1
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mesh = fepre.distmesh(image, h, progress=False)
            seconds = time.perf_counter() - start
            nodes = np.asarray(mesh.points)[np.asarray(mesh["boundary"]) == 1]
            node = float(np.abs(model(nodes)).max()) / voxel
            versus = float(mesh["volume"].sum() / exact["volume"].sum() - 1)
            truth = float(mesh["volume"].sum() / volume - 1)
            low, high, ratio = _quality(mesh)
            print(f"{name + (' +pv' if shares else ''):25s} {voxel:6.3f} {image_seconds:7.2f} {len(surface.faces):7d} {vertex:8.3f} {error:8.4f} "
                  f"{h:5.3f} {mesh.n_cells:7d} {node:8.3f} {versus:8.4f} {truth:8.4f} {low:5.1f} {high:6.1f} {ratio:5.2f} {seconds:6.1f}")


def _interfaces_closed(mesh, part, h: float) -> bool:
    """Every interface's open edges lie on the part's surface (or where a third region meets)."""
    from ..regions import interface_faces

    ids = np.asarray(mesh["region_id"])
    faces, first, second = interface_faces(np.asarray(mesh.cells_dict[10]), ids, mesh.n_points)
    points = np.asarray(mesh.points)
    for a, b in set(zip(ids[first].tolist(), ids[second].tolist())):
        pair = faces[(ids[first] == a) & (ids[second] == b)]
        edges = np.sort(pair[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        unique, counts = np.unique(edges, axis=0, return_counts=True)
        rim = unique[counts == 1].ravel()
        if len(rim) and np.abs(part(points[rim])).max() > 1e-3 * h and len(set(ids.tolist())) < 3:
            return False
    return True


def _labels(quick: bool) -> None:
    import fepre
    from .. import sdf
    from ..sdf.imagemodel.phantoms import label_image

    cube, ball = sdf.box(1.0), sdf.sphere(0.3)
    exact_volumes = np.array([1 - 4 / 3 * np.pi * 0.027, 4 / 3 * np.pi * 0.027])
    h = 0.1
    print()
    print("label phantom: cube 1 with a ball r=0.3 inside, sdf.labels, regions= at h = 0.1, against the analytic regions' mesh")
    print(f"{'voxel':>6s} {'labels s':>8s} {'model vol err (cube, ball)':>27s} {'mesh vs mesh':>15s} {'mesh vs exact':>15s} "
          f"{'iface/vox':>9s} {'closed':>6s} {'min (per region)':>16s} {'cells':>6s} {'mesh s':>6s}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exact = fepre.distmesh(cube, h, regions={"matrix": cube - ball, "inclusion": ball}, progress=False)
    reference = np.bincount(exact["region_id"], exact["volume"])
    # voxel sizes that divide 0.1: the cube's faces are voxel faces (at 0.033 the image's cube is 31
    # voxels of 0.033, 7% over the cube)
    for voxel in ((0.05, 0.025) if quick else (0.05, 1 / 30, 0.025, 1 / 60)):
        grid = label_image([cube, ball], (-0.6,) * 3, (0.6,) * 3, voxel)
        start = time.perf_counter()
        regions = sdf.labels(grid, names={1: "matrix", 2: "inclusion"})
        label_seconds = time.perf_counter() - start
        model_error = [regions[n].volume / v - 1 for n, v in zip(regions, exact_volumes)]
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mesh = fepre.distmesh(regions.part, h, regions=regions, progress=False)
        seconds = time.perf_counter() - start
        ids = np.asarray(mesh["region_id"])
        volumes = np.bincount(ids, mesh["volume"])
        interface = np.asarray(mesh.points)[np.asarray(mesh["interface"]).astype(bool)]
        off = float(np.abs(ball(interface)).max()) / voxel if len(interface) else float("nan")
        closed = _interfaces_closed(mesh, regions.part, h)
        worst = " ".join(f"{_quality(mesh, ids == k)[0]:.1f}" for k in range(2))
        print(f"{voxel:6.4f} {label_seconds:8.2f} {model_error[0]:13.4f} {model_error[1]:13.4f} "
              f"{' '.join(f'{v:7.4f}' for v in volumes / reference - 1)} {' '.join(f'{v:7.4f}' for v in volumes / exact_volumes - 1)} "
              f"{off:9.3f} {str(closed):>6s} {worst:>16s} {mesh.n_cells:6d} {seconds:6.1f}")


def _speed(size: int, cells: int, features: bool = True, output: str | None = None) -> None:
    import fepre
    from .. import sdf
    from ..sdf.imagemodel.phantoms import label_image

    block = sdf.box((1.6, 1.2, 1.2))
    models = [block, sdf.sphere(0.4, center=(-0.35, 0, 0)), sdf.cylinder(radius=0.25, height=1.0, center=(0.45, 0, 0))]
    voxel = 2.0 / size
    start = time.perf_counter()
    grid = label_image(models, (-1, -1, -1), (1, 1, 1), voxel)
    print(f"\nspeed: {grid.dimensions} label image, labels 1-3 (a block, a ball and a cylinder in it); phantom "
          f"{time.perf_counter() - start:.1f} s")
    start = time.perf_counter()
    regions = sdf.labels(grid, names={1: "block", 2: "ball", 3: "rod"})
    labelled = time.perf_counter() - start
    print(f"sdf.labels: {labelled:.1f} s, {len(regions.part.faces)} triangles on the part")
    volume = 1.6 * 1.2 * 1.2
    h = (volume * 8.3 / cells) ** (1 / 3)  # 8.3 cells per h^3 (fepre's estimate); 1.12 h gave 371k for 500k
    start = time.perf_counter()
    mesh = fepre.distmesh(regions.part, h, regions=regions, progress=True, features=features)
    seconds = time.perf_counter() - start
    ids = np.asarray(mesh["region_id"])
    worst = " ".join(f"{_quality(mesh, ids == k)[0]:.1f}" for k in range(3))
    print(f"mesh at h = {h:.4f}: {mesh.n_cells} cells in {seconds:.1f} s (total with sdf.labels {seconds + labelled:.1f} s); "
          f"worst dihedral per region {worst}")
    if output is not None:
        mesh.save(output)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fepre bench images", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two resolutions per phantom")
    parser.add_argument("--speed", action="store_true", help="only the 256^3 three-label speed run")
    parser.add_argument("--size", type=int, default=256, help="with --speed: voxels along x (default 256)")
    parser.add_argument("--cells", type=int, default=500_000, help="with --speed: about this many cells (default 500k)")
    parser.add_argument("--no-features", action="store_true",
                        help="with --speed: features=False (the fast path for smooth segmentations; the phantom's "
                             "block edges and rod caps are sharp voxel planes, which the features keep)")
    parser.add_argument("-o", "--output", help="with --speed: write the mesh here (.vtu) to look at its worst cells")
    args = parser.parse_args(argv)
    if args.output is not None and not args.output.endswith(".vtu"):
        parser.error(f"--output must name a .vtu file; got {args.output!r}")
    if args.speed:
        _speed(args.size, args.cells, not args.no_features, args.output)
        return 0
    _grey(args.quick)
    _labels(args.quick)
    return 0
