"""``fepre demo``: the demo parts meshed end to end, with one HTML report.

Parts: the cube with a hole of Kelly's DistMesh.jl study, a sphere, a torus, an L-bracket with a filleted inner edge
(smooth union) and a bolt hole, a gyroid-infilled block, a CAD block read from an STL and a bone
read from a simulated CT scan (a noisy grey image, ``sdf.image`` with smoothing). For each part the demo writes the
surface (STL), the tetrahedral mesh (VTU) and a CalculiX/Abaqus solver file (INP, with named
boundary sets), compares the mesh with reference meshers, and finally writes ``report.html``.

Examples
--------
>>> from fepre.demo import demo_parts
>>> [part.name for part in demo_parts(quick=True)][:2]
['cube_with_hole', 'sphere']
"""

from __future__ import annotations

import html
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from . import sdf
from .errors import MeshingError
from .parts import GYROID_BLOCK_VOLUME, L_BRACKET_VOLUME, cube_with_hole, gyroid_block, l_bracket

__all__ = ["DemoPart", "demo_parts", "run_demo", "DemoResult", "time_left", "progress_note"]


@dataclass
class DemoPart:
    """One demo part and its settings.

    Attributes
    ----------
    name : str
    model : SDF
    h : float
        Target edge length.
    spacing : float
        Grid spacing of the STL surface.
    exact_volume : float or None
        The part's volume: exact, or a Monte Carlo reference where there is no closed form.
    boundaries : dict
        Named boundary sets written to the INP file.
    references : tuple of str
        Reference meshers it is compared with.
    description : str
    """

    name: str
    model: Any
    h: float
    spacing: float
    exact_volume: float | None = None
    boundaries: dict[str, Any] = field(default_factory=dict)
    references: tuple[str, ...] = ()
    description: str = ""
    #: Writes the part's input file to the path it is given (``<name>_input<input_suffix>`` in the
    #: output folder) and returns the model read from it (an imported part).
    build: Callable[[Path], Any] | None = None
    input_suffix: str = ".stl"


def demo_parts(quick: bool = False) -> list[DemoPart]:
    """The demo parts with edge lengths chosen so the whole demo takes under two minutes.

    ``quick=True`` uses coarse edge lengths (seconds; used by the tests).
    """
    cube, hole = cube_with_hole()
    bracket, bolt_hole, _ = l_bracket()
    scale = 2.0 if quick else 1.0
    parts = [
        DemoPart("cube_with_hole", cube, 0.5 * scale, 0.05 * scale, 125.0 - 5.0 * math.pi,
                 {"hole": hole, "bottom": sdf.plane((0, 0, -1), (0, 0, 0)), "top": sdf.plane((0, 0, 1), (0, 0, 5))},
                 ("gmsh",), "the first example of Kelly's DistMesh.jl study: [0,5]^3 minus a radius-1 cylinder"),
        # the sphere and the torus at the h that keeps their volume within 1% (chords' sag,
        # 3 h^2 / 8 r^2): at 0.2 and 0.15 they were 1.7% and 2.2% short, which the volume check names
        DemoPart("sphere", sdf.sphere(1.0), 0.14 * scale, 0.025 * scale, 4.0 * math.pi / 3.0, {},
                 ("gmsh",) if quick else ("pytetwild", "gmsh"), "unit sphere"),
        DemoPart("torus", sdf.torus(1.0, 0.4), 0.1 * scale, 0.02 * scale, 2.0 * math.pi**2 * 1.0 * 0.4**2, {},
                 ("gmsh",), "torus R=1, r=0.4"),
        DemoPart("l_bracket", bracket, 0.2 * scale, 0.03 * scale, L_BRACKET_VOLUME,
                 {"bolt_hole": bolt_hole, "mount": sdf.plane((-1, 0, 0), (0, 0, 0))},
                 ("gmsh",), "L-bracket, 0.3 fillet (smooth union), bolt hole"),
    ]
    if hasattr(sdf, "infill") and hasattr(sdf, "gyroid"):
        parts.append(DemoPart("gyroid_block", gyroid_block(), 0.15 if quick else 0.1, 0.02 * scale, GYROID_BLOCK_VOLUME, {},
                              ("gmsh",), "2x2x1 block, 0.2 wall, gyroid sheet infill (period 1)"))
    parts.append(DemoPart("imported_block", None, 3.0 if quick else 2.0, 0.5 * scale, None, {}, (),
                          "a CAD block written as STL (OpenCASCADE via gmsh), read with sdf.mesh, "
                          "gyroid core (period 16) under a skin 3 thick", build=_imported_block))
    parts.append(DemoPart("scanned_bone", None, 0.2 if quick else 0.12, 0.05 * scale, None, {}, (),
                          "a bone-like part (shaft and knuckles, smooth union) scanned as a noisy CT image "
                          "(voxels 0.05, noise 5% of the contrast), read with sdf.image(level=500, smoothing=0.5)",
                          build=_scanned_bone, input_suffix=".vti"))
    return parts


def _scanned_bone(path: Path):
    from .parts import bone, write_scan

    return sdf.image(write_scan(bone(), path, 0.05), level=500.0, smoothing=0.5)


def _imported_block(path: Path):
    from .parts import imported_infill, write_mounting_block_stl

    return imported_infill(write_mounting_block_stl(path))


@dataclass
class DemoResult:
    """What the demo wrote: per part its files and comparison, and the report."""

    outdir: Path
    files: dict[str, list[Path]]
    comparisons: dict[str, Any]
    report: Path
    seconds: float
    failures: dict[str, str] = field(default_factory=dict)


def _summary_rows(parts: list[DemoPart], comparisons: dict[str, Any]) -> list[list[str]]:
    rows = [["part", "h", "tets", "nodes", "fepre s", "min dihedral", "max dihedral", "min radius ratio",
             "mean radius ratio", "volume error", "Hausdorff"]]
    for part in parts:
        metrics = comparisons[part.name]["fepre"].metrics
        error = metrics["volume_error"]
        rows.append([
            part.name, f"{part.h:g}", str(metrics["elements"]), str(metrics["nodes"]), f"{metrics['seconds']:.1f}",
            f"{metrics['min_dihedral_angle_min']:.1f}", f"{metrics['max_dihedral_angle_max']:.1f}",
            f"{metrics['radius_ratio_min']:.3f}", f"{metrics['radius_ratio_mean']:.3f}",
            "-" if math.isnan(error) else f"{error:+.2%}", f"{metrics['hausdorff']:.2e}",
        ])
    return rows


def _text_table(rows: list[list[str]]) -> str:
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))) for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _html_table(rows: list[list[str]], parts: list[DemoPart]) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in rows[0])
    body = "".join(
        f'<tr><th><a href="#{html.escape(row[0])}">{html.escape(row[0])}</a><br><span class="note">'
        f"{html.escape(part.description)}</span></th>" + "".join(f'<td class="num">{html.escape(c)}</td>' for c in row[1:]) + "</tr>"
        for row, part in zip(rows[1:], parts)
    )
    return f"<h2>Summary</h2><table><tr>{head}</tr>{body}</table>"


def estimated_cells(part: DemoPart) -> float | None:
    """About how many tetrahedra ``part`` gets (what its time scales with); None for a part whose
    model is only built during the run."""
    if part.model is None:
        return None
    from .arguments import domain_bounds
    from .sizing.estimate import estimated_cells as cells_in_box

    lower, upper = (np.asarray(v, dtype=np.float64) for v in domain_bounds(part.model, None))
    return cells_in_box(part.model, None, part.h, lower, upper, False)


def time_left(done: Sequence[tuple[float, float]], ahead: Sequence[float]) -> float | None:
    """Seconds left: the estimated cells ``ahead`` (one figure per part still to run) at the seconds
    per estimated cell measured on the parts ``done`` ((estimated cells, seconds) each). None before
    a rate is known. Parts differ tenfold in size, so a mean time per part misleads."""
    cells = sum(c for c, _ in done)
    if not done or cells <= 0:
        return None
    return sum(s for _, s in done) / cells * float(sum(ahead))


def progress_note(elapsed: float, done: int, total: int, left: float | None, unestimated: Sequence[str]) -> str:
    """``"12 s in, 2 of 6 parts done; about 30 s left for the demo"``, with the parts the figure
    leaves out named."""
    note = f"{elapsed:.0f} s in, {done} of {total} parts done"
    if left is None:
        return f"{note}; no estimate for {', '.join(unestimated)}" if unestimated else note
    besides = f"not counting {', '.join(unestimated)}, " if unestimated else ""
    return f"{note}; {besides}about {left:.0f} s left for the demo"


def run_demo(
    outdir: str | Path = "fepre-demo",
    *,
    quick: bool = False,
    references: bool = True,
    parts: list[DemoPart] | None = None,
    progress: Callable[[str], None] | None = print,
) -> DemoResult:
    """Mesh every demo part; write STL, VTU, INP files and ``report.html`` into ``outdir``.

    Parameters
    ----------
    outdir : path
        Created if missing.
    quick : bool
        Coarse settings (used by the tests).
    references : bool
        Compare with the reference meshers (pytetwild for the sphere, gmsh for every part).
    parts : list of DemoPart, optional
        Default :func:`demo_parts`.
    progress : callable or None
        Receives a message before every long step.

    Returns
    -------
    DemoResult

    Examples
    --------
    >>> result = run_demo("fepre-demo", quick=True)  # doctest: +SKIP
    """
    from .report import write_report

    say = progress or (lambda message: None)
    start = time.perf_counter()
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    parts = demo_parts(quick) if parts is None else parts
    files: dict[str, list[Path]] = {}
    comparisons: dict[str, Any] = {}
    failures: dict[str, str] = {}
    cells = [estimated_cells(part) for part in parts]
    measured: list[tuple[float, float]] = []  # (estimated cells, seconds) of each part done
    for index, part in enumerate(parts, 1):
        label = f"demo [{index}/{len(parts)}] {part.name}"
        if index > 1:
            ahead = cells[index - 1:]
            estimated = [c for c in ahead if c is not None]
            left = time_left(measured, estimated) if estimated else None
            unestimated = [p.name for p, c in zip(parts[index - 1:], ahead) if c is None]
            note = progress_note(time.perf_counter() - start, index - 1, len(parts), left, unestimated)
            say(f"{label}: starting ({note})")
        part_start = time.perf_counter()
        try:
            files[part.name], comparisons[part.name] = _run_part(part, outdir, label, references, say)
        except MeshingError as exc:  # one part's failure is reported; the others still run
            failures[part.name] = str(exc)
            say(f"{label}: FAILED: {exc}")
            continue
        seconds = time.perf_counter() - part_start
        # a part built during the run has its model now: its time joins the measured rate
        weight = cells[index - 1] if cells[index - 1] is not None else estimated_cells(part)
        if weight is not None:
            measured.append((weight, seconds))
    done = [part for part in parts if part.name in comparisons]
    if not done:
        raise MeshingError(f"every demo part failed: {failures}")
    rows = _summary_rows(done, comparisons)
    failed_html = "".join(f'<p class="bad">{html.escape(n)} failed: {html.escape(e)}</p>' for n, e in failures.items())
    report = write_report(comparisons, outdir / "report.html", title="fepre demo: meshes of the demo parts",
                          summary_html=_html_table(rows, done) + failed_html, progress=say)
    print(_text_table(rows))
    for name, error in failures.items():
        print(f"{name} FAILED: {error}")
    total = time.perf_counter() - start
    print(f"\nwrote {sum(len(f) for f in files.values())} files and {report} into {outdir} in {total:.0f} s")
    return DemoResult(outdir, files, comparisons, report, total, failures)


def _run_part(part: DemoPart, outdir: Path, label: str, references: bool, say: Callable[[str], None]):
    """Surface, mesh, solver files and comparison of one part; returns (files, comparison)."""
    import fepre

    from .compare import compare
    from .export.atomic import staged_files

    from .references import reference_surface

    inputs = []
    if part.build is not None:
        inputs.append(outdir / f"{part.name}_input{part.input_suffix}")
        say(f"{label}: writing and reading {inputs[0].name} ...")
        part.model = part.build(inputs[0])
    say(f"{label}: surface (spacing {part.spacing:g}) ...")
    # dual contouring keeps sharp edges and corners; flying edges for smooth parts
    surface = reference_surface(part.model, part.spacing)
    stl = outdir / f"{part.name}.stl"
    with staged_files(stl, [stl.name], overwrite=True) as stage:
        surface.save(str(stage / stl.name))
    say(f"{label}: DistMesh h={part.h:g} ...")
    mesh_start = time.perf_counter()
    mesh = fepre.distmesh(part.model, part.h, progress=True)
    seconds = time.perf_counter() - mesh_start
    say(f"{label}: {mesh.n_cells} tetrahedra in {seconds:.1f} s; writing VTU and INP ...")
    vtu, inp = outdir / f"{part.name}.vtu", outdir / f"{part.name}.inp"
    fepre.export(mesh, vtu, boundaries=part.boundaries or None, model=part.model)
    fepre.export(mesh, inp, boundaries=part.boundaries or None, model=part.model)
    chosen = part.references if references else ()
    # the references mesh a surface at spacing h/2: fine against h, and affordable for pytetwild
    comparison = compare(part.model, part.h, mesh=mesh, seconds=seconds, references=chosen, surface_spacing=part.h / 2,
                         exact_volume=part.exact_volume, progress=lambda message: say(f"{label}: {message}"))
    return inputs + [stl, vtu, inp], comparison

