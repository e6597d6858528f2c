"""PyVista views of models and meshes: the interior of a tetrahedral mesh coloured by quality.

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> fepre.plot_model(sdf.sphere(1.0), screenshot="sphere.png")   # doctest: +SKIP
>>> fepre.plot(mesh, metric="radius_ratio")                        # doctest: +SKIP
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .arguments import choice

__all__ = ["plot", "plot_model", "quality_plotter", "QUALITY_METRICS"]

# metric -> (colour bar title, colour range, low values are bad)
QUALITY_METRICS: dict[str, tuple[str, tuple[float, float] | None]] = {
    "min_dihedral_angle": ("worst dihedral angle [deg]", (0.0, 70.528779)),
    "max_dihedral_angle": ("largest dihedral angle [deg]", (70.528779, 180.0)),
    "radius_ratio": ("radius ratio 3 r_in / R_circ", (0.0, 1.0)),
    "volume_edge_ratio": ("volume-edge ratio", (0.0, 1.0)),
    "volume": ("volume", None),
    "region_id": ("region", None),  # the material regions of fepre.distmesh(..., regions=)
}


def _with_quality(mesh: Any, metric: str) -> Any:
    """``mesh`` with ``metric`` in its cell data (computed by fepre.quality when missing)."""
    if metric in mesh.cell_data:
        return mesh
    if metric == "region_id":
        raise ValueError("metric 'region_id': the mesh has no regions (cell data 'region_id'); mesh with regions= to have them")
    from .quality import add_quality

    return add_quality(mesh)


def has_display() -> bool:
    """True when a window can be opened (not a headless POSIX machine, not ``pyvista.OFF_SCREEN``)."""
    import pyvista as pv

    headless = os.name == "posix" and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY")
    return not (headless or pv.OFF_SCREEN)


def _display_offscreen(off_screen: bool | None) -> bool:
    """Whether to render off screen; on a machine without a display, also quiets VTK's X warning."""
    import pyvista as pv

    headless = os.name == "posix" and not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY")
    if headless:
        import vtk

        vtk.vtkLogger.SetStderrVerbosity(vtk.vtkLogger.VERBOSITY_ERROR)
    if off_screen is not None:
        return bool(off_screen)
    return bool(pv.OFF_SCREEN) or headless


def quality_plotter(
    mesh: Any,
    *,
    metric: str = "min_dihedral_angle",
    clip: bool = True,
    off_screen: bool | None = None,
    window_size: tuple[int, int] = (900, 700),
    title: str = "",
    clim: tuple[float, float] | None = None,
    worst: float | None = 15.0,
    normal: str = "x",
    origin: Any = None,
    slice: bool = False,
):
    """A ``pyvista.Plotter`` showing ``mesh`` coloured by the cell quality ``metric``.

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
        Tetrahedra (quality arrays are computed when missing).
    metric : str
        One of :data:`QUALITY_METRICS`.
    clip : bool
        Cut the mesh with a plane (``normal``, through ``origin``), keeping whole cells, so the
        interior shows.
    off_screen : bool, optional
        Render without a window (default: off screen when there is no display).
    window_size : (int, int)
    title : str
        Text in the upper left corner.
    clim : (float, float), optional
        Colour range (default: the metric's natural range, so the worst elements stand out).
    worst : float or None
        For ``min_dihedral_angle``: also draw, opaque and outlined, every cell of the *whole*
        mesh whose worst dihedral is below this angle (None: don't).
    normal : {"x", "y", "z"}
        Normal of the clipping or slicing plane.
    origin : (3,) float, optional
        A point of that plane (default: the mesh's centre).
    slice : bool
        Show only the cut through the cells on that plane (a lattice infill's walls in section).

    Returns
    -------
    pyvista.Plotter
    """
    import pyvista as pv

    choice(metric, "metric", tuple(QUALITY_METRICS))
    if not isinstance(mesh, pv.UnstructuredGrid):
        raise TypeError(f"mesh must be a pyvista.UnstructuredGrid of tetrahedra; got {type(mesh).__name__}")
    tetrahedra = tetrahedra_of(mesh)  # a VTU written by fepre.export also holds its boundary triangles
    if tetrahedra is not None:
        mesh = tetrahedra
    mesh = _with_quality(mesh, metric)
    bar_title, natural = QUALITY_METRICS[metric]
    if clim is None:
        values = np.asarray(mesh.cell_data[metric])
        clim = natural if natural is not None else (float(values.min()), float(values.max()))
    choice(normal, "normal", ("x", "y", "z"))
    origin = mesh.center if origin is None else [float(v) for v in origin]
    if slice:
        shown = mesh.slice(normal=normal, origin=origin)
        if shown.n_cells == 0:
            raise ValueError(f"the plane through {origin} with normal {normal} does not cut the mesh")
        clip = False
    else:
        shown = mesh.clip(normal=normal, origin=origin, crinkle=True) if clip else mesh
    if shown.n_cells == 0:
        shown = mesh
    plotter = pv.Plotter(off_screen=_display_offscreen(off_screen), window_size=list(window_size))
    plotter.set_background("white")
    cmap = "RdYlBu" if metric != "max_dihedral_angle" else "RdYlBu_r"
    scalar_bar = dict(title=bar_title + "\n", color="black", vertical=False, position_x=0.15, position_y=0.03,
                      width=0.7, height=0.1, title_font_size=15, label_font_size=13, n_labels=6, fmt="%.0f"
                      if metric.endswith("angle") else "%.2f")
    categorical = {}
    if metric == "region_id":  # one colour per region, named in the bar
        names = [str(n) for n in np.asarray(mesh.field_data["region_names"]).tolist()] if "region_names" in mesh.field_data else []
        count = max(len(names), int(np.asarray(mesh.cell_data[metric]).max()) + 1)
        palette = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"]
        cmap, clim = [palette[k % len(palette)] for k in range(count)], (-0.5, count - 0.5)
        scalar_bar.update(n_labels=0, fmt="%.0f")
        categorical = dict(categories=True, annotations={k: n for k, n in enumerate(names)})
    plotter.add_mesh(shown, scalars=metric, cmap=cmap, clim=clim, show_edges=True, edge_color="#444444",
                     line_width=0.6, scalar_bar_args=scalar_bar, preference="cell", ambient=0.35, diffuse=0.75,
                     specular=0.0, **categorical)
    if clip:
        removed = mesh.clip(normal="x", origin=mesh.center, invert=False).extract_surface(algorithm="dataset_surface")
        if removed.n_cells:
            plotter.add_mesh(removed, color="#bbbbbb", opacity=0.15, show_scalar_bar=False)
    if worst is not None and metric == "min_dihedral_angle":
        bad = np.flatnonzero(np.asarray(mesh.cell_data[metric]) < worst)
        if bad.size:
            plotter.add_mesh(mesh.extract_cells(bad), color="#d62728", show_edges=True, edge_color="black",
                             line_width=1.0, ambient=0.35)
            plotter.add_text(f"red, opaque: {bad.size} cell{'s' if bad.size > 1 else ''} below {worst:g} deg",
                             position="upper_right", font_size=9, color="#d62728")
    if title:
        plotter.add_text(title, font_size=11, color="black")
    _fit_view(plotter, np.asarray(mesh.points), direction=(3.0, 1.3, 1.6), window_size=window_size)
    return plotter


def _fit_view(plotter: Any, points: np.ndarray, direction: Any, window_size: tuple[int, int], fill: float = 0.78) -> None:
    """Parallel projection from ``direction`` that makes ``points`` fill ``fill`` of the window.

    The lower part of the window is kept free for the colour bar.
    """
    direction = np.asarray(direction, dtype=float)
    direction /= np.linalg.norm(direction)
    up = np.array([0.0, 0.0, 1.0]) - direction[2] * direction
    up /= np.linalg.norm(up)
    right = np.cross(direction, up)
    lo, hi = points.min(axis=0), points.max(axis=0)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    across, along = corners @ right, corners @ up
    width, height = np.ptp(across), np.ptp(along)
    aspect = window_size[0] / window_size[1]
    scale = 0.5 * max(height, width / aspect, 1e-12) / fill
    # centre the box in the window, shifted up by 6% of the view to clear the colour bar
    focus = 0.5 * (lo + hi) + right * (0.5 * (across.min() + across.max()) - (0.5 * (lo + hi)) @ right)
    focus += up * (0.5 * (along.min() + along.max()) - (0.5 * (lo + hi)) @ up) - up * 0.12 * scale
    distance = 4.0 * float(np.linalg.norm(hi - lo)) + 1.0
    plotter.enable_parallel_projection()
    plotter.camera_position = [tuple(focus + distance * direction), tuple(focus), tuple(up)]
    plotter.reset_camera_clipping_range()
    plotter.camera.parallel_scale = scale


def plot(
    mesh: Any,
    metric: str = "min_dihedral_angle",
    clip: bool = True,
    *,
    off_screen: bool | None = None,
    screenshot: str | os.PathLike | None = None,
    window_size: tuple[int, int] = (900, 700),
    clim: tuple[float, float] | None = None,
    title: str = "",
    normal: str = "x",
    origin: Any = None,
    slice: bool = False,
):
    """Show the interior of a tetrahedral mesh coloured by a quality metric.

    The colour range is the metric's natural range (0 to 70.5 degrees for the worst dihedral
    angle), so poor elements stand out in red; cells under 15 degrees are drawn on top.

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid
    metric : str
        ``"min_dihedral_angle"`` (default), ``"max_dihedral_angle"``, ``"radius_ratio"``,
        ``"volume_edge_ratio"`` or ``"volume"``.
    clip : bool
        Cut through the centre to show the interior (whole cells kept).
    off_screen : bool, optional
        No window (default: off screen only when there is no display).
    screenshot : path, optional
        Save a PNG of the view.
    window_size, clim, title, normal, origin, slice
        See :func:`quality_plotter`.

    Returns
    -------
    pathlib.Path or None
        The screenshot's path when one was written.

    Examples
    --------
    >>> import fepre
    >>> fepre.plot(mesh, screenshot="mesh.png", off_screen=True)  # doctest: +SKIP
    """
    plotter = quality_plotter(mesh, metric=metric, clip=clip, off_screen=_display_offscreen(off_screen),
                              window_size=window_size, clim=clim, title=title, normal=normal, origin=origin,
                              slice=slice)
    return _show(plotter, screenshot)


def _show(plotter: Any, screenshot: str | os.PathLike | None):
    from pathlib import Path

    if screenshot is None:
        plotter.show()
        return None
    path = Path(screenshot)
    if not path.parent.exists():
        plotter.close()
        raise FileNotFoundError(f"screenshot folder {path.parent} does not exist")
    if plotter.off_screen:
        plotter.screenshot(str(path))
        plotter.close()
    else:
        plotter.show(screenshot=str(path))
    return path


def plot_model(
    model: Any,
    *,
    spacing: float | None = None,
    bounds: Any = None,
    off_screen: bool | None = None,
    screenshot: str | os.PathLike | None = None,
    window_size: tuple[int, int] = (900, 700),
    color: str = "#8fb4d9",
    clip: bool = False,
):
    """Show a model's surface quickly (flying edges on a grid of about 100 cells per side).

    Parameters
    ----------
    model : SDF
    spacing : float, optional
        Grid spacing (default: the largest extent / 100).
    bounds : ((min...), (max...)), optional
        Needed for unbounded models.
    off_screen, screenshot, window_size
        See :func:`plot`.
    color : str
    clip : bool
        Cut away the half x > centre to show the inside (infill, holes); the cut shows the
        surface's inner side in a darker colour.

    Returns
    -------
    pathlib.Path or None

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> fepre.plot_model(sdf.sphere(1.0), screenshot="ball.png", off_screen=True)  # doctest: +SKIP
    """
    import pyvista as pv

    from .arguments import as_bounds, positive_float
    from .references import reference_surface

    box = bounds if bounds is not None else model.bounds
    if box is None:
        raise ValueError("bounds must be given for an unbounded model (its bounds are None)")
    lo, hi = as_bounds(box)
    spacing = max(np.subtract(hi, lo)) / 100 if spacing is None else positive_float(spacing, "spacing")
    surface = reference_surface(model, spacing, (lo, hi))
    if clip:
        surface = surface.clip(normal="x", origin=surface.center)
    plotter = pv.Plotter(off_screen=_display_offscreen(off_screen), window_size=list(window_size))
    plotter.set_background("white")
    plotter.add_mesh(surface, color=color, smooth_shading=True, specular=0.3,
                     backface_params={"color": "#c0504d"} if clip else None)
    plotter.add_axes()
    plotter.view_isometric()
    return _show(plotter, screenshot)


def is_tetrahedral(mesh: Any) -> bool:
    """True for an UnstructuredGrid whose cells are all (linear or quadratic) tetrahedra."""
    import pyvista as pv

    if not isinstance(mesh, pv.UnstructuredGrid) or mesh.n_cells == 0:
        return False
    kinds = set(np.unique(np.asarray(mesh.celltypes)).tolist())
    return len(kinds) == 1 and kinds <= {int(pv.CellType.TETRA), int(pv.CellType.QUADRATIC_TETRA)}


def tetrahedra_of(mesh: Any) -> Any:
    """The tetrahedral cells of a mixed grid (e.g. a VTU with tagged boundary triangles), or None."""
    import pyvista as pv

    if not isinstance(mesh, pv.UnstructuredGrid):
        return None
    if is_tetrahedral(mesh):
        return mesh
    types = np.asarray(mesh.celltypes)
    for kind in (pv.CellType.TETRA, pv.CellType.QUADRATIC_TETRA):
        cells = np.flatnonzero(types == int(kind))
        if cells.size:
            return mesh.extract_cells(cells)
    return None


def plot_surface(
    dataset: Any,
    *,
    off_screen: bool | None = None,
    screenshot: str | os.PathLike | None = None,
    window_size: tuple[int, int] = (900, 700),
    title: str = "",
    color: str = "#8fb4d9",
):
    """Show any dataset (a surface, or a mesh of other cells) with its edges.

    Examples
    --------
    >>> import pyvista as pv
    >>> plot_surface(pv.Sphere(), screenshot="s.png", off_screen=True)  # doctest: +SKIP
    """
    import pyvista as pv

    plotter = pv.Plotter(off_screen=_display_offscreen(off_screen), window_size=list(window_size))
    plotter.set_background("white")
    plotter.add_mesh(dataset, color=color, show_edges=dataset.n_cells < 200_000, edge_color="#555555", line_width=0.4)
    if title:
        plotter.add_text(title, font_size=11, color="black")
    plotter.add_axes()
    plotter.view_isometric()
    return _show(plotter, screenshot)
