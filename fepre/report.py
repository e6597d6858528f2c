"""Self-contained HTML reports of comparisons: tables, histograms and clipped mesh pictures.

Every image is a PNG embedded as a ``data:image/png;base64`` URI, so the report is one file
that can be mailed or archived. Histograms are drawn with matplotlib (Agg backend), pictures
off-screen with PyVista.

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> result = fepre.compare(sdf.sphere(1.0), h=0.3)        # doctest: +SKIP
>>> write_report({"sphere": result}, "report.html")        # doctest: +SKIP
"""

from __future__ import annotations

import base64
import datetime
import html
import io
import os
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .comparison_table import TABLE_ROWS, as_plain, format_metric, versions

__all__ = ["write_report", "render_report", "mesh_picture", "quality_histograms"]

# one colour per mesher, the same in every figure
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e")
REGULAR_DIHEDRAL = 70.528779365509308

_STYLE = """
body { font-family: -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; margin: 2em auto;
       max-width: 1250px; color: #222; line-height: 1.4; padding: 0 1em; }
h1 { border-bottom: 2px solid #1f77b4; padding-bottom: .2em; }
h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: .8em 0; font-size: 0.93em; }
th, td { border: 1px solid #ccc; padding: .25em .7em; }
th { background: #f2f4f7; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
td.best { font-weight: bold; background: #eaf6ea; }
.figures { display: flex; flex-wrap: wrap; gap: 12px; }
.figures figure { margin: 0; }
figcaption { font-size: 0.9em; color: #555; text-align: center; }
pre { background: #f7f7f7; padding: .6em; overflow-x: auto; font-size: 0.88em; }
.note { color: #555; font-size: 0.92em; }
.bad { color: #b00; font-weight: bold; }
"""

# rows where larger is better (True), smaller is better (False) or no ranking (None)
_BETTER = {
    "volume_error": "abs",
    "inverted": False,
    "boundary_sdf_max": False,
    "boundary_sdf_mean": False,
    "hausdorff": False,
    "min_dihedral_angle_min": True,
    "min_dihedral_angle_p1": True,
    "min_dihedral_angle_mean": True,
    "max_dihedral_angle_max": False,
    "below_10": False,
    "below_15": False,
    "radius_ratio_min": True,
    "radius_ratio_p1": True,
    "radius_ratio_mean": True,
    "volume_edge_ratio_min": True,
    "volume_edge_ratio_mean": True,
    "seconds": False,
}


def png_data_uri(png: bytes) -> str:
    """``data:image/png;base64,...`` for PNG bytes."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def quality_histograms(comparison: Any) -> bytes:
    """PNG of per-mesher histograms of the worst dihedral angle and the radius ratio, side by side."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    from .mesh_metrics import tetra_cells
    from .quality import tet_quality

    figure = Figure(figsize=(11.5, 3.8), dpi=100)
    figure.subplots_adjust(left=0.055, right=0.99, bottom=0.14, top=0.92, wspace=0.16)
    left, right = figure.subplots(1, 2)
    angle_bins = np.linspace(0.0, 90.0, 46)
    ratio_bins = np.linspace(0.0, 1.0, 41)
    for index, result in enumerate(comparison.results):
        if result.mesh is None:
            continue
        quality = tet_quality(np.asarray(result.mesh.points, dtype=np.float64), tetra_cells(result.mesh))
        colour = COLOURS[index % len(COLOURS)]
        weights = np.full(len(quality["volume"]), 100.0 / max(1, len(quality["volume"])))
        left.hist(quality["min_dihedral_angle"], bins=angle_bins, weights=weights, histtype="step",
                  linewidth=1.8, color=colour, label=f"{result.name} (min {quality['min_dihedral_angle'].min():.1f}°)")
        right.hist(quality["radius_ratio"], bins=ratio_bins, weights=weights, histtype="step",
                   linewidth=1.8, color=colour, label=f"{result.name} (mean {quality['radius_ratio'].mean():.3f})")
    for axis in (left, right):
        axis.set_ylabel("% of tetrahedra")
        axis.grid(alpha=0.3)
        axis.legend(loc="upper left", fontsize=9)
    left.axvspan(0, 10, color="#d62728", alpha=0.08)
    left.axvline(REGULAR_DIHEDRAL, color="#888", linestyle=":", linewidth=1)
    left.set_xlabel("worst dihedral angle per tetrahedron [deg] (regular: 70.5)")
    left.set_title("Worst dihedral angle (shaded: below 10°)")
    right.set_xlabel("radius ratio 3 r_in / R_circ (regular: 1)")
    right.set_title("Radius ratio")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return buffer.getvalue()


def mesh_picture(mesh: Any, *, metric: str = "min_dihedral_angle", title: str = "",
                 window_size: tuple[int, int] = (560, 460), clim: tuple[float, float] | None = None) -> bytes:
    """PNG of ``mesh`` clipped through its centre (whole cells kept), coloured by ``metric``."""
    from PIL import Image

    from .plotting import quality_plotter

    plotter = quality_plotter(mesh, metric=metric, clip=True, off_screen=True, window_size=window_size,
                              title=title, clim=clim)
    try:
        image = plotter.screenshot(return_img=True)
    finally:
        plotter.close()
    buffer = io.BytesIO()
    Image.fromarray(np.asarray(image)).save(buffer, format="PNG", optimize=True)
    return buffer.getvalue()


def _metrics_table(comparison: Any) -> str:
    names = comparison.names
    rows = ["<table><tr><th></th>" + "".join(f"<th>{html.escape(n)}</th>" for n in names) + "</tr>"]
    for label, key, spec in TABLE_ROWS:
        values = [r.metrics.get(key) for r in comparison.results]
        best = _best(values, _BETTER.get(key))
        cells = []
        for index, value in enumerate(values):
            css = "num best" if index in best and len(values) > 1 else "num"
            cells.append(f'<td class="{css}">{html.escape(format_metric(value, spec))}</td>')
        rows.append(f"<tr><th>{html.escape(label)}</th>{''.join(cells)}</tr>")
    rows.append("</table>")
    return "\n".join(rows)


def _best(values: Sequence[Any], rule: Any) -> set[int]:
    numbers = [float(v) if v is not None else float("nan") for v in values]
    valid = [i for i, v in enumerate(numbers) if np.isfinite(v)]
    if rule is None or len(valid) < 2:
        return set()
    keyed = {i: (abs(numbers[i]) if rule == "abs" else -numbers[i] if rule is True else numbers[i]) for i in valid}
    target = min(keyed.values())
    return {i for i, v in keyed.items() if v == target}


def _surface_check_table(check: Any) -> str:
    if check is None:
        return '<p class="note">No surface check (fepre.check_surface is not available).</p>'
    rows = []
    for key, value in as_plain(check).items():
        text = f"{value:.6g}" if isinstance(value, float) else str(value)
        css = ' class="bad"' if value is False else ""
        rows.append(f"<tr><th>{html.escape(key)}</th><td{css}>{html.escape(text)}</td></tr>")
    return "<table>" + "".join(rows) + "</table>"


def _settings_table(settings: Mapping[str, Any]) -> str:
    rows = []
    for key, value in settings.items():
        if key == "versions":
            continue
        rows.append(f"<tr><th>{html.escape(str(key))}</th><td>{html.escape(str(value))}</td></tr>")
    return "<table>" + "".join(rows) + "</table>"


def _section(name: str, comparison: Any, progress: Any) -> str:
    progress(f"report: {name}: histograms ...")
    histogram = png_data_uri(quality_histograms(comparison))
    pictures = []
    for index, result in enumerate(comparison.results):
        if result.mesh is None:
            continue
        progress(f"report: {name}: picture of the {result.name} mesh ...")
        png = mesh_picture(result.mesh, title=f"{result.name}: {result.mesh.n_cells} tetrahedra", clim=(0.0, REGULAR_DIHEDRAL))
        pictures.append(
            f'<figure><img src="{png_data_uri(png)}" alt="{html.escape(result.name)} mesh, clipped" width="560">'
            f"<figcaption>{html.escape(result.name)}: clipped through the centre, coloured by worst dihedral angle"
            "</figcaption></figure>"
        )
    volume_note = f"Volume error relative to {comparison.volume_reference:.6g} ({html.escape(comparison.volume_source)})."
    failures = "".join(
        f'<p class="bad">{html.escape(r.name)} failed: {html.escape(r.error)}</p>' for r in comparison.results if r.error
    ) + "".join(f'<p class="note">{html.escape(r.name)}: {html.escape(r.note)}</p>' for r in comparison.results if r.note) + (
        "<p>How each mesher ran:</p><ul>"
        + "".join(f"<li>{html.escape(r.name)}: {html.escape(r.settings)}</li>" for r in comparison.results if r.settings)
        + "</ul>"
    )
    return f"""
<h2 id="{html.escape(name)}">{html.escape(name)}</h2>
<p>Target edge length h = {comparison.h:g}. {volume_note} Boundary fidelity: |model| at the boundary
nodes of each mesh, and the two-sided Hausdorff distance between the mesh boundary and
{html.escape(comparison.surface_text())} (the surface every reference meshed). Best values in bold.</p>
{_metrics_table(comparison)}
{failures}
<h3>Element quality</h3>
<figure><img src="{histogram}" alt="quality histograms" width="1150"></figure>
<h3>Interior of each mesh</h3>
<div class="figures">{''.join(pictures)}</div>
<details><summary>Model tree</summary><pre>{html.escape(repr(comparison.model))}</pre></details>
<h3>Surface check of the extracted surface</h3>
{_surface_check_table(comparison.surface_check)}
<h3>Settings</h3>
{_settings_table(comparison.settings)}
"""


def _short(text: str, width: int = 70) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


def render_report(comparisons: Mapping[str, Any] | Sequence[Any], *, title: str | None = None,
                  summary_html: str = "", progress: Any = None) -> str:
    """The report's HTML text (see :func:`write_report`)."""
    if not isinstance(comparisons, Mapping):
        comparisons = {f"{i + 1}. {_short(c.model.describe())}": c for i, c in enumerate(comparisons)}
    if not comparisons:
        raise ValueError("comparisons must hold at least one Comparison; got none")
    progress = progress or (lambda message: None)
    title = title or "fepre mesh comparison"
    contents = "".join(f'<li><a href="#{html.escape(n)}">{html.escape(n)}</a></li>' for n in comparisons)
    sections = "".join(_section(name, comparison, progress) for name, comparison in comparisons.items())
    version_rows = "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in versions().items())
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{_STYLE}</style></head>
<body>
<h1>{html.escape(title)}</h1>
<p class="note">Generated by fepre on {stamp}. Every mesh is measured by the same code
(fepre.quality and fepre.compare); references mesh the same fine surface of the model.</p>
{summary_html or f"<ul>{contents}</ul>"}
{sections}
<h2>Versions</h2>
<table>{version_rows}</table>
</body></html>
"""


def write_report(comparisons: Mapping[str, Any] | Sequence[Any], path: str | os.PathLike, *,
                 title: str | None = None, summary_html: str = "", progress: Any = None) -> Path:
    """Write a self-contained HTML report of one or more comparisons.

    Parameters
    ----------
    comparisons : mapping name -> Comparison, or a sequence of Comparison
    path : str or path-like
        The ``.html`` file; written atomically (temporary file, then rename).
    title : str, optional
    summary_html : str, optional
        HTML inserted under the title (the demo's summary table).
    progress : callable, optional
        Receives a message before each slow step.

    Returns
    -------
    Path

    Examples
    --------
    >>> write_report({"sphere": result}, "report.html")  # doctest: +SKIP
    PosixPath('report.html')
    """
    path = Path(path)
    if not path.parent.exists():
        raise FileNotFoundError(f"report folder {path.parent} does not exist")
    text = render_report(comparisons, title=title, summary_html=summary_html, progress=progress)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        temporary.write_text(text, encoding="utf-8")
        os.replace(temporary, path)
    finally:
        if temporary.exists():
            temporary.unlink()
    return path
