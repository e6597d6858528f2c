"""Images beyond memory as models: ``sdf.image`` of a zarr store or a dask array, chunk by chunk.

The in-memory path (:mod:`fepre.sdf.imagemodel.levelset`) smooths, refines by the cubic
B-spline, pads and contours the whole image. Here each chunk of samples does the same to a window
of the image read ``smoothing radius + SPLINE_HALO + 2`` samples beyond it (the Gaussian's reach,
then the prefilter's: a sample's weight on a coefficient 40 samples away is below 1e-22, so the
window's coefficients are the whole image's bit for bit), evaluates the refined field at the
refined nodes it owns and the next node plane, pads it where it meets the image's border, and
extracts its triangles by flying edges with whole-grid extents and keys
(:func:`fepre.chunked.chunk_surface.extract_chunk`); the pieces are stitched by key
(:func:`fepre.chunked.stitch.stitch`). A chunk whose window's samples bound the interpolant to one
side of the level (:func:`fepre.sdf.imagemodel.bspline.certainly_one_side`) is skipped before any
filtering. Only a few windows are in memory at once; the image and its refined copy never are.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..arguments import shown
from ..sdf.imagemodel.bspline import SPLINE_HALO, refine_samples, refined_count
from ..sdf.imagemodel.levelset import (BORDER_PAD, border_depth, field_tolerance, needs_padding, outside_value, side_of,
                                       signed_field, smoothed, smoothing_radius)
from ..sdf.imagemodel.model import checked_level, image_model
from ..sdf.imagemodel.read import Image, ImageInputError, read_image
from .chunk_surface import ChunkSurface, extract_chunk
from .cluster import in_completion_order, require_dask
from .layout import ChunkLayout, as_chunks

__all__ = ["image_chunked", "level_set_triangles", "model_of", "LevelSetTriangles", "open_image", "DEFAULT_CHUNKS"]

#: samples per chunk along each axis when none are given
DEFAULT_CHUNKS = 128


def _zarr_array(path: Path, array: str | None):
    import zarr

    if not path.exists():
        raise ImageInputError(f"image store {path} does not exist")
    try:
        opened = zarr.open(str(path), mode="r")
    except Exception as exc:  # zarr raises several types for a foreign store
        raise ImageInputError(f"image store {path} could not be read as zarr ({type(exc).__name__}: {exc})") from None
    if isinstance(opened, zarr.Array):
        return opened
    names = sorted(name for name, _ in opened.arrays())
    if array is None and len(names) == 1:
        array = names[0]
    if array is None or array not in names:
        raise ImageInputError(
            f"image store {path} is a zarr group with arrays {', '.join(map(repr, names)) or 'none'}; "
            "name one with array=" + (f" (no array {array!r})" if array is not None else "")
        )
    return opened[array]


def _from_zarr(store: Any, name: str, spacing: Any, origin: Any):
    """A zarr array as (dask array indexed x, y, z; spacing; origin). A grid written by
    ``fepre.sample(store=)`` is (z, y, x) with its geometry in the attributes."""
    import dask.array as da

    attrs = dict(store.attrs)
    values = da.from_zarr(store)
    if attrs.get("fepre") == "sdf-grid":
        values = values.transpose(2, 1, 0)
    if spacing is None and "spacing" in attrs:
        spacing = attrs["spacing"]
    if origin is None and "origin" in attrs:
        origin = attrs["origin"]
    return values, spacing, origin


def _geometry(value: Any, default: float, name: str, what: str) -> np.ndarray:
    try:
        array = np.full(3, default) if value is None else np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    except (TypeError, ValueError):
        raise ImageInputError(f"{name}: {what} must be a number or three numbers; got {shown(value)}") from None
    return array


def open_image(source: Any, *, spacing: Any = None, origin: Any = None, array: str | None = None) -> Image:
    """An image whose ``values`` are a lazy dask array (indexed x, y, z), checked without reading
    its samples.

    Parameters
    ----------
    source : str, path-like, zarr.Array, dask.array.Array, numpy array or pyvista.ImageData
        A ``.zarr`` store (an array, or a group with ``array=`` naming one), a zarr or dask
        array, or anything :func:`fepre.sdf.imagemodel.read_image` reads (then held in memory,
        processed in chunks).
    spacing, origin : float or (3,) floats, optional
        Distance between samples (default the store's ``spacing`` attribute, else 1) and position
        of sample (0, 0, 0) (default its ``origin`` attribute, else 0).

    Examples
    --------
    >>> import dask.array as da
    >>> image = open_image(da.zeros((40, 30, 20), chunks=16), spacing=0.5)
    >>> image.values.shape, image.upper.tolist()
    ((40, 30, 20), [19.5, 14.5, 9.5])
    """
    require_dask("images beyond memory")
    import dask.array as da

    module = type(source).__module__.split(".")[0]
    if isinstance(source, (str, os.PathLike)) or module == "zarr":
        name = str(source) if module != "zarr" else "zarr array"
        store = _zarr_array(Path(source), array) if module != "zarr" else source
        values, spacing, origin = _from_zarr(store, name, spacing, origin)
    elif isinstance(source, da.Array):
        name, values = "dask array", source
    else:
        data = read_image(source, spacing=spacing, origin=origin, array=array)
        return Image(da.from_array(np.asarray(data.values)), data.spacing, data.origin, data.name)
    if values.ndim != 3 or min(values.shape) < 2:
        raise ImageInputError(
            f"{name} is not a 3D image (shape {tuple(values.shape)}); give a volume of at least 2 samples along "
            "each axis (stack 2D slices into one 3D array)"
        )
    dtype = np.dtype(values.dtype)
    if not (np.issubdtype(dtype, np.number) or dtype == bool) or np.iscomplexobj(np.empty(0, dtype)):
        raise ImageInputError(f"{name} holds {dtype} values; give a real-valued scalar image")
    spacing, origin = _geometry(spacing, 1.0, name, "spacing"), _geometry(origin, 0.0, name, "origin")
    if not np.isfinite(spacing).all() or (spacing <= 0).any():
        raise ImageInputError(f"{name}: spacing must be three positive numbers; got {shown(spacing)}")
    if not np.isfinite(origin).all():
        raise ImageInputError(f"{name}: origin must be three finite numbers; got {shown(origin)}")
    return Image(values, spacing, origin, name)


def _scan(image: Image, depth: int) -> tuple[float, float, list[tuple[float, float]]]:
    """The image's smallest and largest values and each face slab's, in one pass over the chunks;
    non-finite values refused."""
    import dask
    import dask.array as da

    values = image.values
    wanted = [values.min(), values.max()]
    for axis in range(3):
        n = values.shape[axis]
        for part in (slice(0, min(depth, n)), slice(max(0, n - depth), n)):
            index = [slice(None)] * 3
            index[axis] = part
            wanted += [values[tuple(index)].min(), values[tuple(index)].max()]
    floating = np.issubdtype(np.dtype(values.dtype), np.floating)
    if floating:
        wanted.append((~da.isfinite(values)).sum())
    found = [float(v) for v in dask.compute(*wanted)]
    if floating and found[-1] > 0:
        raise ImageInputError(f"{image.name} has {int(found[-1])} non-finite values (NaN or inf)")
    return found[0], found[1], list(zip(found[2:14:2], found[3:14:2]))


@dataclass(frozen=True)
class _Plan:
    """What every chunk task needs: the field's definition and the padded refined grid."""

    level: float
    inside: str
    smoothing: float
    refine: int
    spacing: np.ndarray  # the image's
    fine: np.ndarray  # the refined grid's spacing
    origin: np.ndarray  # of the padded refined grid
    counts: np.ndarray  # refined nodes per axis (unpadded)
    pad: int  # BORDER_PAD when the surface is closed beyond the border, else 0
    outside: np.float32
    tolerance: float
    reach: int  # samples a chunk reads beyond the coefficients it uses


def _layout(shape: tuple[int, ...], chunks: np.ndarray, plan: _Plan) -> ChunkLayout:
    """The padded refined grid cut where the image's chunks are cut."""
    sizes = []
    for axis in range(3):
        samples = ChunkLayout.of(shape, chunks).sizes[axis]
        cuts = plan.pad + plan.refine * np.cumsum(samples)[:-1]
        total = int(plan.counts[axis]) + 2 * plan.pad
        edges = np.concatenate([[0], cuts, [total]])
        sizes.append(tuple(int(s) for s in np.diff(edges)))
    counts = tuple(int(c) + 2 * plan.pad for c in plan.counts)
    return ChunkLayout(counts, tuple(sizes))


def _window(lo: np.ndarray, hi: np.ndarray, plan: _Plan, shape) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For a chunk owning padded nodes ``[lo, hi)``: the unpadded refined nodes it evaluates
    ``[q_lo, q_hi)`` (its own and the next plane) and the samples it reads ``[w_lo, w_hi)``."""
    counts_padded = plan.counts + 2 * plan.pad
    q_lo = np.maximum(lo - plan.pad, 0)
    q_hi = np.minimum(np.minimum(hi + 1, counts_padded) - plan.pad, plan.counts)
    w_lo = np.maximum(q_lo // plan.refine - 1 - plan.reach, 0)
    w_hi = np.minimum((q_hi - 1) // plan.refine + 3 + plan.reach, np.array(shape))
    return q_lo, q_hi, w_lo, w_hi


def _chunk(samples: np.ndarray, index: int, lo, hi, q_lo, q_hi, w_lo, plan: _Plan) -> tuple[int, ChunkSurface, bool, bool]:
    """One chunk's triangles, whether its refined field is negative on the image's border and
    whether it was skipped by the bound."""
    counts_padded = plan.counts + 2 * plan.pad
    read_lo, read_hi = lo, np.minimum(hi + 1, counts_padded)
    low_side, high_side = read_lo < plan.pad, read_hi > plan.counts + plan.pad
    on_border = bool(((q_lo == 0) | (q_hi == plan.counts)).any())
    raw = np.asarray(samples, dtype=np.float32)
    del samples
    field_range = np.array([plan.level - raw.max(), plan.level - raw.min()] if plan.inside == "above"
                           else [raw.min() - plan.level, raw.max() - plan.level], dtype=float)
    side = side_of(float(field_range[0]), float(field_range[1]), plan.refine, plan.tolerance)
    if side == 1 or (side == -1 and not (low_side.any() or high_side.any()) and not on_border):
        return index, ChunkSurface.empty(), False, True
    data = smoothed(raw, plan.spacing, plan.smoothing)
    del raw
    if plan.refine > 1:
        data = refine_samples(data, w_lo, q_lo, q_hi, plan.refine)
    else:
        data = data[tuple(slice(int(a - w), int(b - w)) for a, b, w in zip(q_lo, q_hi, w_lo))]
    field = signed_field(data, plan.level, plan.inside)
    touches = False
    for axis in range(3):
        for at_border, face in ((q_lo[axis] == 0, 0), (q_hi[axis] == plan.counts[axis], -1)):
            if at_border:
                touches |= bool((np.take(field, face, axis=axis) < 0).any())
    if plan.pad:
        widths = [(int(a), int(b)) for a, b in zip(low_side, high_side)]
        outer = [(a * (plan.pad - 1), b * (plan.pad - 1)) for a, b in widths]
        field = np.pad(np.pad(field, widths, mode="edge"), outer, constant_values=plan.outside)
    piece = extract_chunk(
        np.ascontiguousarray(field.transpose(2, 1, 0)), read_lo, lo, hi, method="flying_edges", level=0.0,
        origin=plan.origin, spacing=plan.fine, counts=counts_padded, named=True,
    )
    return index, piece, touches, False


def _surface(values, plan: _Plan, chunks: np.ndarray, window: int):
    """Every chunk's triangles, at most ``window`` chunks in flight, stitched in chunk order;
    whether the solid reaches the border, whether a node is exactly on the level, and the
    chunks (count, skipped)."""
    import dask

    from .stitch import stitch

    shape = tuple(int(n) for n in values.shape)
    task = dask.delayed(_chunk, pure=True)
    tasks = []
    for number, (_, lo, hi) in enumerate(_layout(shape, chunks, plan)):
        q_lo, q_hi, w_lo, w_hi = _window(lo, hi, plan, shape)
        samples = values[w_lo[0]:w_hi[0], w_lo[1]:w_hi[1], w_lo[2]:w_hi[2]]
        tasks.append(task(samples, number, lo, hi, q_lo, q_hi, w_lo, plan))
    results = sorted(in_completion_order(tasks, window), key=lambda r: r[0])
    touches = any(r[2] for r in results)
    counted = (len(results), sum(r[3] for r in results))
    pieces = [r[1] for r in results]
    del results
    vertices, faces, on_level = stitch(pieces)
    return vertices, faces, touches, on_level, counted


@dataclass
class LevelSetTriangles:
    """The level-set triangles of an image taken chunk by chunk (what :class:`ImageModel` is
    built from).

    Attributes
    ----------
    vertices, faces : ndarray
        (V, 3) float64 and (F, 3) int64, outward.
    image : Image
        The image (its values a lazy dask array).
    level, refine : float, int
    touches : bool
        Whether the solid reaches the image's border (then closed beyond it).
    on_level : bool
        Whether a refined node is exactly on the level (crossings may then coincide).
    chunks, skipped : int
        Chunks processed, and of them those skipped before any filtering (the samples bound
        the interpolant to one side of the level).
    """

    vertices: np.ndarray
    faces: np.ndarray
    image: Image
    level: float
    refine: int
    touches: bool
    on_level: bool
    chunks: int = 0
    skipped: int = 0


def level_set_triangles(source: Any, level: Any, *, inside: str = "above", smoothing: float = 0.0,
                        refine: int | None = None, spacing: Any = None, origin: Any = None, array: str | None = None,
                        chunks: Any = None, window: int | None = None) -> LevelSetTriangles:
    """The triangles of :func:`fepre.sdf.image`'s level set, chunk by chunk (see the module).

    Parameters are those of :func:`fepre.sdf.image`; ``window`` is the number of chunks in
    flight (default twice dask's worker threads).

    Examples
    --------
    >>> import numpy as np, dask.array as da
    >>> x, y, z = np.mgrid[-1:1:33j, -1:1:33j, -1:1:33j]
    >>> ball = da.from_array(1.0 - np.sqrt(x**2 + y**2 + z**2), chunks=16)
    >>> found = level_set_triangles(ball, 0.3, spacing=1 / 16, origin=-1.0, chunks=12)
    >>> bool(np.allclose(np.linalg.norm(found.vertices, axis=1), 0.7, atol=2e-3)), found.touches
    (True, False)
    """
    import dask

    chunks = as_chunks(DEFAULT_CHUNKS if chunks is None else chunks)
    data = open_image(source, spacing=spacing, origin=origin, array=array)
    refine = 2 if refine is None else int(refine)
    low, high, slabs = _scan(data, border_depth(data.spacing, smoothing, refine))
    level = checked_level(data.name, level, low, high)
    shape = tuple(int(n) for n in data.values.shape)
    counts = np.array([refined_count(n, refine) for n in shape])
    pad = BORDER_PAD if needs_padding(slabs, level, inside, refine, low, high) else 0
    fine = data.spacing / refine
    plan = _Plan(level, inside, smoothing, refine, data.spacing, fine, data.origin - pad * fine, counts, pad,
                 outside_value(low, high, level), field_tolerance(low, high, level),
                 smoothing_radius(data.spacing, smoothing) + (SPLINE_HALO if refine > 1 else 0))
    workers = int(dask.config.get("num_workers", None) or os.cpu_count() or 1)
    vertices, faces, touches, on_level, counted = _surface(data.values, plan, chunks, window or 2 * workers)
    if touches and not pad:  # pragma: no cover - the border slabs' bound makes this impossible
        plan = replace(plan, pad=BORDER_PAD, origin=data.origin - BORDER_PAD * fine)
        vertices, faces, touches, on_level, counted = _surface(data.values, plan, chunks, window or 2 * workers)
    if faces.shape[0] == 0:
        raise ImageInputError(
            f"{data.name}: after smoothing by {shown(smoothing)} voxels the interpolant does not cross level "
            f"{shown(level)}; give less smoothing or another level"
        )
    return LevelSetTriangles(vertices, faces, data, level, refine, touches, on_level, *counted)


def image_chunked(source: Any, level: Any, *, inside: str = "above", smoothing: float = 0.0, refine: int | None = None,
                  features: float = 0.0, spacing: Any = None, origin: Any = None, array: str | None = None,
                  chunks: Any = None, window: int | None = None):
    """``sdf.image`` chunk by chunk (options already checked by :func:`fepre.sdf.image`): the
    same model as the in-memory path, never holding the image or its refined copy."""
    found = level_set_triangles(source, level, inside=inside, smoothing=smoothing, refine=refine, spacing=spacing,
                                origin=origin, array=array, chunks=chunks, window=window)
    return model_of(found, inside=inside, smoothing=smoothing, features=features)


def model_of(found: LevelSetTriangles, *, inside: str = "above", smoothing: float = 0.0, features: float = 0.0):
    """The :class:`ImageModel` of :func:`level_set_triangles` (cut by the voxels' box when the
    solid reaches the border)."""
    return image_model(found.vertices, found.faces, found.image, found.touches, level=found.level, inside=inside,
                       smoothing=smoothing, refine=found.refine, features=features, on_level=found.on_level)
