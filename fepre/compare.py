"""Validation: fepre's tetrahedra measured side by side with independent meshers.

:func:`compare` meshes a model with fepre (or takes a given mesh) and with each reference mesher
(pytetwild, and gmsh when installed, both from the same fine surface: dual contouring for a part
with sharp features, flying edges otherwise), then measures
every mesh the same way: counts, volume error, boundary fidelity, element quality and time.

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> result = fepre.compare(sdf.sphere(1.0), h=0.3, exact_volume=4.18879)  # doctest: +SKIP
>>> print(result.table())                                                 # doctest: +SKIP
"""

from __future__ import annotations

import platform
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from .arguments import as_bounds, positive_float
from .callable_package import make_callable
from .comparison_table import TABLE_ROWS, as_plain as _as_plain, format_metric, versions  # noqa: F401  (also re-exported)
from .errors import MeshingError
from .mesh_metrics import mesh_metrics
from .references import REFERENCES, reference_surface, run_reference

__all__ = ["compare", "Comparison", "MeshResult"]

@dataclass
class MeshResult:
    """One mesher's mesh, its time and its measurements."""

    name: str
    mesh: Any
    seconds: float | None
    metrics: dict[str, float]
    error: str | None = None  #: why a reference mesher failed (then ``mesh`` is None)
    note: str | None = None  #: how a reference deviated from its usual method
    settings: str | None = None  #: how the mesher was run


@dataclass
class Comparison:
    """Meshes of one model by fepre and the reference meshers, measured the same way.

    Attributes
    ----------
    model : SDF
    h : float
    results : list of MeshResult
        fepre first, then each reference.
    surface : pyvista.PolyData
        The fine surface the references meshed (and the Hausdorff reference).
    surface_check : SurfaceCheck or None
        :func:`fepre.check_surface` of that surface.
    volume_reference : float
        Volume the errors are relative to.
    volume_source : str
        ``"exact"`` or how it was estimated.
    settings : dict
        The run's arguments and package versions.
    """

    model: Any
    h: float
    results: list[MeshResult]
    surface: Any
    surface_check: Any
    volume_reference: float
    volume_source: str
    settings: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> MeshResult:
        for result in self.results:
            if result.name == name:
                return result
        raise KeyError(f"no mesher named {name!r}; have {[r.name for r in self.results]}")

    @property
    def names(self) -> list[str]:
        """Mesher names in table order."""
        return [result.name for result in self.results]

    def table(self) -> str:
        """The measurements as a plain-text table (one column per mesher).

        Examples
        --------
        >>> print(cmp.table())  # doctest: +SKIP
        """
        header = ["", *self.names]
        rows = [header]
        for label, key, spec in TABLE_ROWS:
            rows.append([label, *(format_metric(r.metrics.get(key), spec) for r in self.results)])
        widths = [max(len(row[i]) for row in rows) for i in range(len(header))]
        lines = []
        for index, row in enumerate(rows):
            cells = [row[0].ljust(widths[0])] + [cell.rjust(width) for cell, width in zip(row[1:], widths[1:])]
            lines.append("  ".join(cells))
            if index == 0:
                lines.append("  ".join("-" * width for width in widths))
        for result in self.results:
            if result.settings:
                lines.append(f"{result.name}: {result.settings}")
        for result in self.results:
            if result.error:
                lines.append(f"{result.name} failed: {result.error}")
            if result.note:
                lines.append(f"{result.name}: {result.note}")
        lines.append(
            f"h = {self.h:g} (each mesher's mean edge length is in the table); volume reference {self.volume_reference:.6g} ({self.volume_source}); "
            f"Hausdorff against {self.surface_text()}"
        )
        return "\n".join(lines)

    def surface_text(self) -> str:
        """The surface every reference meshed, in words: the model's own triangles, or the
        extraction at a spacing."""
        method = str(self.settings.get("surface_method", "flying_edges"))
        if method == "input_triangles":
            return "the model's own triangles"
        return f"the {method.replace('_', '-')} surface at spacing {self.settings.get('surface_spacing', float('nan')):g}"

    def __str__(self) -> str:
        return self.table()

    def to_dict(self) -> dict[str, Any]:
        """Plain data (JSON-serialisable): model, settings, and each mesher's metrics."""
        check = self.surface_check
        return {
            "model": repr(self.model),
            "h": self.h,
            "volume_reference": self.volume_reference,
            "volume_source": self.volume_source,
            "settings": dict(self.settings),
            "surface_check": _as_plain(check) if check is not None else None,
            "meshes": {r.name: dict(r.metrics) for r in self.results},
            "failed": {r.name: r.error for r in self.results if r.error},
            "notes": {r.name: r.note for r in self.results if r.note},
            "mesher_settings": {r.name: r.settings for r in self.results if r.settings},
        }

    def to_html(self, path: Any, *, title: str | None = None) -> Any:
        """Write a self-contained HTML report (images embedded) to ``path``; returns the path."""
        from .report import write_report

        return write_report([self], path, title=title)


def compare(
    model: Any,
    h: float,
    *,
    mesh: Any = None,
    seconds: float | None = None,
    references: tuple[str, ...] | list[str] = ("pytetwild",),
    surface_spacing: float | None = None,
    exact_volume: float | None = None,
    bounds: Any = None,
    seed: int = 0,
    progress: Callable[[str], None] | bool = False,
    **distmesh_options: Any,
) -> Comparison:
    """Mesh ``model`` with fepre and with independent meshers, and measure all meshes alike.

    Parameters
    ----------
    model : SDF
        The part.
    h : float
        Target edge length, passed to every mesher (pytetwild's ``edge_length_abs``).
    mesh : pyvista.UnstructuredGrid, optional
        fepre's mesh, if already made; otherwise ``fepre.distmesh(model, h)`` runs and is timed.
    seconds : float, optional
        Time it took to make ``mesh`` (default: its ``distmesh_seconds`` field data, if any).
    references : sequence of str
        Reference meshers: ``"pytetwild"``, ``"gmsh"``. Each meshes the same surface: a closed
        triangle-mesh model's own triangles (as its user would give them), else a fine surface
        of the model.
    surface_spacing : float, optional
        Grid spacing of that fine surface (default ``h / 4``; given, a triangle-mesh model is
        resampled too).
    exact_volume : float, optional
        The part's exact volume; without it, the volume enclosed by the surface the references
        mesh is used.
    bounds : ((min...), (max...)), optional
        Meshing box for unbounded models.
    seed : int
        Seed of every randomised mesher.
    progress : bool or callable
        True prints a line per step; a callable receives each step's message.
    **distmesh_options
        Passed to :func:`fepre.distmesh` when ``mesh`` is None.

    Returns
    -------
    Comparison

    Examples
    --------
    >>> import math, fepre
    >>> from fepre import sdf
    >>> result = fepre.compare(sdf.sphere(1.0), h=0.3, exact_volume=4 * math.pi / 3)  # doctest: +SKIP
    >>> result["pytetwild"].metrics["elements"] > 0                                   # doctest: +SKIP
    True
    """
    import pyvista as pv

    from .sdf import SDF

    if not isinstance(model, SDF):
        raise TypeError(f"model must be an fepre SDF; got {type(model).__name__}")
    h = positive_float(h, "h")
    spacing = h / 4 if surface_spacing is None else positive_float(surface_spacing, "surface_spacing")
    if isinstance(references, str):
        references = (references,)
    for name in references:
        if name not in REFERENCES:
            raise ValueError(f"references must name {', '.join(map(repr, REFERENCES))}; got {name!r}")
    if mesh is not None and not isinstance(mesh, pv.UnstructuredGrid):
        raise TypeError(f"mesh must be a pyvista.UnstructuredGrid; got {type(mesh).__name__}")
    if exact_volume is not None:
        exact_volume = positive_float(exact_volume, "exact_volume")
    if bounds is not None:
        bounds = as_bounds(bounds)
    report = progress if callable(progress) else (lambda message: print(message, flush=True)) if progress else (lambda message: None)

    surface = _input_triangles(model) if surface_spacing is None and bounds is None else None
    if surface is None:
        report(f"compare: fine surface at spacing {spacing:g} ...")
        surface = reference_surface(model, spacing, bounds)
    else:
        spacing = None
        report(f"compare: the model's own {surface.n_cells} triangles for the references ...")
    surface_check = _check_surface(surface, model)
    if exact_volume is not None:
        volume, source = exact_volume, "exact"
    elif spacing is None:
        volume, source = float(abs(surface.volume)), "enclosed by the model's own triangles"
    else:
        volume, source = float(abs(surface.volume)), f"enclosed by the {_method_of(surface).replace('_', '-')} surface at spacing {spacing:g}"

    results = [_fepre_result(model, h, mesh, seconds, bounds, seed, distmesh_options, surface, volume, report)]
    results += _reference_results(references, model, h, seed, surface, volume, report)

    settings = {
        "h": h,
        "surface_spacing": spacing,
        "surface_method": _method_of(surface),
        "references": list(references),
        "seed": int(seed),
        "bounds": bounds if bounds is not None else model.bounds,
        "distmesh_options": {k: repr(v) for k, v in distmesh_options.items()},
        "versions": versions(),
        "machine": f"{platform.machine()}, {platform.system()}, {__import__('os').cpu_count()} cores",
    }
    return Comparison(model, h, results, surface, surface_check, volume, source, settings)


def _fepre_result(model, h, mesh, seconds, bounds, seed, distmesh_options, surface, volume, report) -> MeshResult:
    """fepre's mesh (made and timed here unless given) and its measurements."""
    given = mesh
    if mesh is None:
        from .distmesh import distmesh

        report(f"compare: fepre.distmesh h={h:g} ...")
        start = time.perf_counter()
        mesh = distmesh(model, h, bounds=bounds, **({"seed": seed} | distmesh_options))
        seconds = time.perf_counter() - start
    elif seconds is None:
        stored = mesh.field_data.get("distmesh_seconds")
        seconds = float(np.asarray(stored).ravel()[-1]) if stored is not None and np.size(stored) else None
    else:
        seconds = positive_float(seconds, "seconds")
    if given is None:
        options = ", ".join(f"{k}={v!r}" for k, v in distmesh_options.items())
        how = f"fepre.distmesh at h = {h:g} with its quality stage" + (f" ({options})" if options else "")
    else:
        how = "the mesh passed to compare (mesh=)"
    report(f"compare: measuring fepre ({mesh.n_cells} cells) ...")
    metrics = mesh_metrics(mesh, model, reference=surface, volume=volume, seconds=seconds)
    return MeshResult("fepre", mesh, seconds, metrics, settings=how)


def _reference_results(references, model, h, seed, surface, volume, report) -> list[MeshResult]:
    """Each reference mesher's mesh of the fine surface and its measurements (or its failure)."""
    results = []
    for name in references:
        report(f"compare: {name} h={h:g} ...")
        try:
            reference_mesh, seconds = run_reference(name, surface, h, seed=seed)
        except MeshingError as exc:  # a reference's failure is a finding, not the end of the comparison
            report(f"compare: {name} failed: {exc}")
            results.append(MeshResult(name, None, None, {}, error=str(exc)))
            continue
        report(f"compare: measuring {name} ({reference_mesh.n_cells} cells, {seconds:.1f} s) ...")
        metrics = mesh_metrics(reference_mesh, model, reference=surface, volume=volume, seconds=seconds)
        note = reference_mesh.field_data.get("reference_note")
        how = str(reference_mesh.field_data["reference_settings"][0])
        results.append(
            MeshResult(name, reference_mesh, seconds, metrics, note=str(note[0]) if note is not None else None, settings=how)
        )
    return results


def _input_triangles(model: Any):
    """A closed triangle-mesh model's own triangles, as its user would give them to a reference
    mesher (a surface resampled at h/4 cost pytetwild 35 s against 14 s on a torus STL, and its
    volume was not the file's), or None."""
    from .sdf.meshmodel import MeshModel
    from .surface.extract import triangle_polydata

    if not isinstance(model, MeshModel) or model.inside != "closed" or not model.repaired.closed:
        return None
    surface = triangle_polydata(np.asarray(model.vertices, dtype=np.float64), np.asarray(model.faces))
    surface.field_data["surface_method"] = np.array(["input_triangles"])
    return surface


def _method_of(surface: Any) -> str:
    """The extraction method recorded in a surface's field data."""
    method = surface.field_data.get("surface_method")
    return str(np.asarray(method).ravel()[0]) if method is not None and np.size(method) else "flying_edges"


def _check_surface(surface: Any, model: Any) -> Any:
    from .surface import check_surface

    return check_surface(surface, model)


make_callable(__name__, compare)  # importing the module sets fepre.compare to it: it calls compare()
