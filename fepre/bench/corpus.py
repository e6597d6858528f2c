"""The random-part corpus: fepre and pytetwild on every part, a table by category.

Each part of :func:`fepre.corpus.parts` (``--seed``, ``--per-category`` parts per category) is
meshed with ``fepre.distmesh`` at default options and, right after it (interleaved, one run),
with pytetwild at its defaults (``edge_length_abs=h``) on the part's reference surface
(:func:`fepre.references.reference_surface` at spacing h/2). Every mesh is checked by the
independent validator (:func:`fepre.corpus.check_mesh`: own volumes, dihedral angles, radius
ratios, conformity, closed manifold boundary), volumes against the construction or a Monte Carlo
estimate of the model's volume.

fepre's verdict (:func:`fepre.corpus.run.judge`): a valid mesh; on parts whose features are at
least h apart, worst dihedral >= 25 deg, largest <= 150 deg, radius ratio >= 0.25, and (flat faces,
walls of 2 h or more) volume within 0.5%; on the other flat-faced parts no volume lost or added above 2% without
a ResolutionWarning; the part's components. (Curved parts lose volume to their chords at a
coarse h; the table shows it.) pytetwild's boundary is not on the model's zero set (it meshes a surface
within its envelope), so its rows show shape and volume only. ``--parts`` prints a line per part.

``--surfaces`` also extracts every part's surface with the five methods at spacings h/2 and 0.37 h
(the odd-numbered parts of the aligned categories have their faces on the h/2 grid planes) and
prints, per category and method, how many are closed, manifold and of the part's components
(not for lattices, whose enclosed voids have surfaces of their own) with no degenerate triangle;
"+k thin" counts the surfaces whose only fault is extra components that the surface check
reports as thinner than the grid (``thin_components``: an acute wedge's tip caught here and there).
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np


def _pytetwild(part, check_mesh):
    from ..references import pytetwild_mesh, reference_surface

    surface = reference_surface(part.model, part.h / 2)
    start = time.perf_counter()
    try:
        mesh = pytetwild_mesh(surface, part.h)
    except Exception as exc:  # reported in the table, the run goes on
        return None, time.perf_counter() - start, f"{type(exc).__name__}: {exc}"
    seconds = time.perf_counter() - start
    return check_mesh(np.asarray(mesh.points), mesh.cells_dict[10], part.model, part.h), seconds, None


def main(argv: list[str]) -> int:
    from ..corpus import CATEGORIES, check_mesh, parts
    from ..corpus.run import mesh_part, true_volume

    parser = argparse.ArgumentParser(prog="fepre bench corpus", description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="corpus seed (default 0)")
    parser.add_argument("--per-category", type=int, default=4, help="parts per category (default 4)")
    parser.add_argument("--categories", nargs="+", choices=CATEGORIES, help="only these categories")
    parser.add_argument("--no-pytetwild", action="store_true", help="fepre only")
    parser.add_argument("--parts", action="store_true", help="print a line per part")
    parser.add_argument("--surfaces", action="store_true", help="also check the five surface methods on every part")
    args = parser.parse_args(argv)
    if args.per_category < 1:
        parser.error(f"--per-category must be a positive integer; got {args.per_category}")

    corpus = parts(args.seed, args.per_category, args.categories)
    print(f"fepre bench corpus: {len(corpus)} parts (seed {args.seed}), fepre.distmesh default options; "
          + ("pytetwild defaults (edge_length_abs=h) on the reference surface at h/2" if not args.no_pytetwild else "no peer"))
    rows: dict[str, list] = {}
    for part in corpus:
        volume = true_volume(part)
        ours = mesh_part(part, volume)
        peer = (None, float("nan"), "skipped") if args.no_pytetwild else _pytetwild(part, check_mesh)
        rows.setdefault(part.category, []).append((part, volume, ours, peer))
        if args.parts:
            c = ours.check
            line = f"  {part.name:14s} h={part.h:<6g} "
            if c is None:
                line += f"fepre ERROR {ours.error}"
            else:
                line += (f"fepre {c.cells:7d} cells {c.min_dihedral:5.1f}/{c.max_dihedral:5.1f} deg rr {c.min_radius_ratio:.3f} "
                         f"vol {100 * ours.volume_error:+6.2f}% {ours.seconds:6.2f} s {'pass' if ours.passed else 'FAIL ' + '; '.join(ours.failures)}")
            if peer[0] is not None:
                p = peer[0]
                line += f" | pytetwild {p.cells:7d} cells {p.min_dihedral:5.1f}/{p.max_dihedral:5.1f} deg rr {p.min_radius_ratio:.3f} vol {100 * (p.volume / volume - 1):+6.2f}% {peer[1]:6.2f} s"
            elif peer[2] != "skipped":
                line += f" | pytetwild ERROR {peer[2][:80]}"
            print(line, flush=True)

    header = ("category", "parts", "fepre pass", "min dih", "max dih", "min rr", "max |dV|", "ms/1k cells",
              "ptw min dih", "ptw max dih", "ptw min rr", "ptw max |dV|", "ptw ms/1k cells")
    table = []
    for category in CATEGORIES:
        if category not in rows:
            continue
        group = rows[category]
        meshed = [r for r in group if r[2].check is not None]
        passed = sum(r[2].passed for r in group)

        def worst(values, pick):
            return pick(values) if values else float("nan")

        ours = [r[2].check for r in meshed]
        ours_dv = [abs(r[2].volume_error) for r in meshed]
        ours_rate = [1e3 * r[2].seconds / max(r[2].check.cells, 1) for r in meshed]
        peers = [(r[3][0], r[1], r[3][1]) for r in group if r[3][0] is not None]
        table.append((
            category, str(len(group)), f"{passed}/{len(group)}",
            f"{worst([c.min_dihedral for c in ours], min):.1f}", f"{worst([c.max_dihedral for c in ours], max):.1f}",
            f"{worst([c.min_radius_ratio for c in ours], min):.3f}", f"{100 * worst(ours_dv, max):.2f}%",
            f"{statistics.median(ours_rate):.1f}" if ours_rate else "-",
            f"{worst([p.min_dihedral for p, _, _ in peers], min):.1f}" if peers else "-",
            f"{worst([p.max_dihedral for p, _, _ in peers], max):.1f}" if peers else "-",
            f"{worst([p.min_radius_ratio for p, _, _ in peers], min):.3f}" if peers else "-",
            f"{100 * worst([abs(p.volume / v - 1) for p, v, _ in peers], max):.2f}%" if peers else "-",
            f"{statistics.median([1e3 * s / max(p.cells, 1) for p, _, s in peers]):.1f}" if peers else "-",
        ))
    widths = [max(len(str(row[k])) for row in [header, *table]) for k in range(len(header))]
    print()
    for row in [header, tuple("-" * w for w in widths), *table]:
        print("  ".join(str(v).rjust(w) if k else str(v).ljust(w) for k, (v, w) in enumerate(zip(row, widths))))
    if args.surfaces:
        _surface_table(corpus)
    failed = [r[2] for group in rows.values() for r in group if not r[2].passed]
    print(f"\nfepre: {len(corpus) - len(failed)} of {len(corpus)} parts pass (ms per 1000 cells: median over the category's parts)")
    for result in failed:
        print(f"  {result.part.name}: {result.error or '; '.join(result.failures)}")
    return 0


METHODS = ("flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets", "dual_contouring")


def _cell(tally: list[int]) -> str:
    good, flagged, total = tally
    return f"{good}/{total}" + (f" +{flagged} thin" if flagged else "")


def _surface_table(corpus) -> None:
    """Closed, manifold surfaces with the part's components, per category and method."""
    from .. import check_surface, isosurface
    from ..corpus import CATEGORIES

    counts: dict[tuple[str, str], list[int]] = {}
    misses: list[str] = []
    for part in corpus:
        for spacing in (0.5 * part.h, 0.37 * part.h):
            for method in METHODS:
                check = check_surface(isosurface(part.model, method=method, spacing=spacing))
                good = check.watertight and check.manifold and check.degenerate_triangles == 0
                flagged = False
                # a lattice infill's closed cells are voids: its surface has more pieces than the part
                if part.components is not None and part.category != "lattice" and check.components != part.components:
                    # extra pieces thinner than the grid are reported by the check (thin_components)
                    flagged = good and check.components - check.thin_components == part.components
                    good = False
                tally = counts.setdefault((part.category, method), [0, 0, 0])
                tally[0] += int(good)
                tally[1] += int(flagged)
                tally[2] += 1
                if not good:
                    misses.append(f"{part.name} {method} spacing {spacing:g}: watertight {check.watertight}, "
                                  f"manifold {check.manifold}, components {check.components} "
                                  f"({check.thin_components} thinner than the grid), degenerate {check.degenerate_triangles}")
    header = ("surfaces", *METHODS)
    table = [header]
    for category in CATEGORIES:
        if any((category, m) in counts for m in METHODS):
            table.append((category, *(_cell(counts[(category, m)]) for m in METHODS)))
    widths = [max(len(row[k]) for row in table) for k in range(len(header))]
    print()
    for index, row in enumerate(table):
        print("  ".join(v.rjust(w) if k else v.ljust(w) for k, (v, w) in enumerate(zip(row, widths))))
        if index == 0:
            print("  ".join("-" * w for w in widths))
    for miss in misses:
        print(f"  {miss}")
