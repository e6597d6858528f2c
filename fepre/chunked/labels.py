"""Label images beyond memory: ``sdf.labels`` of a zarr store or a dask array, chunk by chunk.

The in-memory path (:func:`fepre.sdf.imagemodel.multilabel.label_surface`) pads the label
indices, smooths every label's indicator, takes each node's largest, joins up the faces whose
label sits on one diagonal only, finds the crossed edges and gives every crossed cell a vertex;
then it makes the triangles, the sharp planes and the relaxed vertices of that one surface. The
first part needs the image, the second only the surface. So here:

1. one pass over the chunks reads the label values present (refusing non-integer labels and a
   single label before any smoothing) and the six border slabs (whether a label reaches the
   border, so the grid is padded by copies of it);
2. one task per chunk of the padded grid's nodes reads its window (the Gaussian's reach and a
   node beyond it; the padding is made where the window meets the border) and gives the counts
   of its nodes' smoothed labels, its faces with a label on one diagonal only, and its cells'
   crossings (:class:`~fepre.sdf.imagemodel.multilabel.CellPieces`); a window of one label is
   skipped before any smoothing;
3. the joins (the larger region, ranked by the whole grid's counts, takes a diagonal face's
   node, round after round) run on boxes about those faces, merged until no two are within two
   nodes, each grown until no node it changes lies within two nodes of its sides: then every
   face that is ever joined lies inside one box and the boxes give what the whole grid gives;
   the chunks holding a changed node are taken again with the changes;
4. the pieces are put in the whole grid's order and the surface is assembled as in memory.

Every step is the in-memory one on the same numbers, so the triangles are the same bit for bit.
What is held is the surface's cells and quads (proportional to the surface), never the image.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..sdf.imagemodel.labelmodel import (BORDER_COPIES, ITERATIONS, LabelPlan, LabelRegions, label_plan,
                                         label_regions, non_integer_message)
from ..sdf.imagemodel.multilabel import (CellPieces, assemble, cell_pieces, clear_ring, diagonal_faces, label_rank,
                                         no_diagonal_faces, smoothed_labels, swap_fields)
from ..sdf.imagemodel.read import Image, ImageInputError
from .cluster import in_completion_order
from .image import open_image
from .layout import ChunkLayout, as_chunks

__all__ = ["labels_chunked", "label_surface_chunked", "DEFAULT_CHUNKS", "JOIN_REACH"]

#: nodes per chunk along each axis when none are given
DEFAULT_CHUNKS = 128
#: nodes about a diagonal face that its join box first holds (doubled until the joins stay
#: two nodes inside it)
JOIN_REACH = 4


@dataclass(frozen=True)
class _Plan:
    """What every chunk task needs: the labels, the padded grid and the Gaussian."""

    labels: LabelPlan
    shape: tuple  # samples per axis
    border: int  # copies of the border beyond it (BORDER_COPIES when a label reaches it)
    nodes: tuple  # nodes of the padded grid per axis: samples + 2 border + 2
    sigma: np.ndarray  # Gaussian per axis, in voxels
    margin: np.ndarray  # nodes a block's window reads beyond it: the Gaussian's reach + 1

    @property
    def count(self) -> int:
        return len(self.labels.order)


def _sample_range(lo: np.ndarray, hi: np.ndarray, plan: _Plan) -> tuple[np.ndarray, np.ndarray]:
    """The samples ``[s_lo, s_hi)`` that padded nodes ``[lo, hi)`` (any integers) take."""
    last = np.array(plan.shape) - 1
    return np.clip(lo - 1 - plan.border, 0, last), np.clip(hi - 2 - plan.border, 0, last) + 1


def _window_indices(samples: np.ndarray, s_lo: np.ndarray, lo: np.ndarray, hi: np.ndarray, plan: _Plan) -> np.ndarray:
    """Label indices of padded nodes ``[lo, hi)``, the padding (border copies, then one node of
    background, then that node again: ``mode="nearest"`` beyond the grid) made here."""
    indices = plan.labels.indices(np.asarray(samples))
    last = np.array(plan.shape) - 1
    take = [np.clip(np.arange(lo[k], hi[k]) - 1 - plan.border, 0, last[k]) - s_lo[k] for k in range(3)]
    window = indices[np.ix_(*take)]
    for axis in range(3):
        node = np.arange(lo[axis], hi[axis])
        ring = (node <= 0) | (node >= plan.nodes[axis] - 1)
        if ring.any():
            index = [slice(None)] * 3
            index[axis] = ring
            window[tuple(index)] = 0
    return window


def _block_labels(samples, s_lo, lo, hi, plan: _Plan, always: bool = False):
    """Smoothed fields (count, ...) and labels of padded nodes ``[lo, hi)``; ``None`` and the
    label when the window holds one label only (and ``always`` is not set)."""
    w_lo, w_hi = lo - plan.margin, hi + plan.margin
    window = _window_indices(samples, s_lo, w_lo, w_hi, plan)
    first = int(window.flat[0])
    if not always and not (window != first).any():
        return None, first
    fields, labels = smoothed_labels(window, plan.count, plan.sigma)
    inner = tuple(slice(int(m), int(m + h - l)) for m, l, h in zip(plan.margin, lo, hi))
    return np.ascontiguousarray(fields[(slice(None),) + inner]), np.ascontiguousarray(labels[inner])


def _chunk(samples, number: int, lo, hi, s_lo, plan: _Plan, changes=None):
    """One chunk's label counts, diagonal faces (first corners, global) and cell pieces."""
    nodes = np.array(plan.nodes)
    block_hi = np.minimum(hi + 1, nodes)
    fields, labels = _block_labels(samples, s_lo, lo, block_hi, plan, always=changes is not None)
    counts = np.zeros(plan.count, dtype=np.int64)
    if fields is None:
        counts[labels] = int(np.prod(hi - lo))
        return number, counts, np.zeros((0, 3), np.int64), CellPieces.empty(), True
    owned = tuple(slice(0, int(n)) for n in hi - lo)
    counts += np.bincount(labels[owned].ravel(), minlength=plan.count)
    corners = np.concatenate(diagonal_faces(labels)) + lo
    corners = corners[np.all(corners < hi, axis=1)]
    if changes is not None:
        flat, before, after = changes
        where = np.column_stack(np.unravel_index(flat, plan.nodes))
        inside = np.all((where >= lo) & (where < block_hi), axis=1)
        local = np.ravel_multi_index(tuple((where[inside] - lo).T), labels.shape)
        labels.ravel()[local] = after[inside]
        swap_fields(fields, local, before[inside], after[inside])
    clear_ring(labels, lo, plan.nodes, 0)
    return number, counts, corners, cell_pieces(fields, labels, lo, lo, hi, plan.nodes), False


def _scan(data: Image, background: int) -> tuple[np.ndarray, bool]:
    """The label values present and whether one other than ``background`` lies on the image's
    border, in one pass over the chunks; non-integer values refused."""
    import dask
    import dask.array as da

    values = data.values
    wanted = [da.unique(values)]
    for axis in range(3):
        for end in (0, values.shape[axis] - 1):
            index = [slice(None)] * 3
            index[axis] = slice(end, end + 1)
            wanted.append(da.unique(values[tuple(index)]))
    floating = not (np.issubdtype(np.dtype(values.dtype), np.integer) or values.dtype == bool)
    if floating:
        wanted.append((values != da.round(values)).any())
    found = dask.compute(*wanted)
    if floating and bool(found[-1]):
        raise ImageInputError(non_integer_message(data.name, values.dtype))
    border = np.unique(np.concatenate(found[1:7]))
    return np.asarray(found[0]), bool((border != background).any())


def _boxes(corners: np.ndarray, reach: int, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Boxes ``[lo, hi)`` holding every face (first corner, +1 along the other axes) with
    ``reach`` nodes about it, merged until no two lie within two nodes of each other."""
    from scipy import sparse
    from scipy.sparse import csgraph

    coarse = np.unique(corners // (reach + 2), axis=0, return_inverse=True)[1].reshape(-1)
    lo = np.full((coarse.max() + 1, 3), np.iinfo(np.int64).max)
    hi = np.full((coarse.max() + 1, 3), np.iinfo(np.int64).min)
    np.minimum.at(lo, coarse, corners - reach)
    np.maximum.at(hi, coarse, corners + 2 + reach)
    lo, hi = np.clip(lo, 0, nodes), np.clip(hi, 0, nodes)
    while len(lo) > 1:
        near = np.all((lo[:, None, :] <= hi[None, :, :] + 2) & (lo[None, :, :] <= hi[:, None, :] + 2), axis=2)
        count, component = csgraph.connected_components(sparse.csr_matrix(near), directed=False)
        if count == len(lo):
            break
        merged_lo = np.full((count, 3), np.iinfo(np.int64).max)
        merged_hi = np.full((count, 3), np.iinfo(np.int64).min)
        np.minimum.at(merged_lo, component, lo)
        np.maximum.at(merged_hi, component, hi)
        lo, hi = merged_lo, merged_hi
    return lo, hi


def _joins(values, corners: np.ndarray, rank: np.ndarray, plan: _Plan):
    """The nodes the joins change (flat, sorted), their labels before and after; and the
    boxes' largest node count (what the joins held at once)."""
    none = np.zeros(0, np.int64)
    if len(corners) == 0:
        return (none, none.astype(np.int16), none.astype(np.int16)), 0
    nodes = np.array(plan.nodes)
    unrank = np.argsort(rank).astype(np.int16)
    reach = JOIN_REACH
    while True:
        lo, hi = _boxes(corners, reach, nodes)
        changed, before, after, held, ok = [], [], [], 0, True
        for box_lo, box_hi in zip(lo, hi):
            s_lo, s_hi = _sample_range(box_lo - plan.margin, box_hi + plan.margin, plan)
            samples = np.asarray(values[s_lo[0]:s_hi[0], s_lo[1]:s_hi[1], s_lo[2]:s_hi[2]])
            _, labels = _block_labels(samples, s_lo, box_lo, box_hi, plan, always=True)
            held = max(held, labels.size)
            joined = unrank[no_diagonal_faces(rank[labels])]
            where = np.argwhere(joined != labels)
            low_ok = (where >= 2) | (box_lo == 0)
            high_ok = (where < box_hi - box_lo - 2) | (box_hi == nodes)
            if not (low_ok & high_ok).all():
                ok = False
                break
            changed.append(np.ravel_multi_index(tuple((where + box_lo).T), plan.nodes))
            before.append(labels[tuple(where.T)])
            after.append(joined[tuple(where.T)])
        if ok or (lo == 0).all() and (hi == nodes).all():
            break
        reach *= 2
    flat = np.concatenate(changed)
    order = np.argsort(flat)
    return (flat[order], np.concatenate(before)[order], np.concatenate(after)[order]), held


@dataclass
class LabelSurfaceChunked:
    """The label surface of an image taken chunk by chunk, and what it took.

    Attributes
    ----------
    surface : fepre.sdf.imagemodel.multilabel.LabelSurface
    image : Image
        The image (its values a lazy dask array).
    plan : LabelPlan
    reaches : bool
        Whether a label reaches the image's border (the surface then closes beyond it).
    chunks, skipped, retaken : int
        Chunks processed; of them those of one label (skipped before smoothing) and those taken
        again with the joins' changes.
    joined : int
        Nodes the joins changed.
    """

    surface: Any
    image: Image
    plan: LabelPlan
    reaches: bool
    chunks: int = 0
    skipped: int = 0
    retaken: int = 0
    joined: int = 0


def label_surface_chunked(source: Any, *, names: dict | None = None, background: int = 0, keep_background: bool = False,
                          smoothing: float = 0.5, spacing: Any = None, origin: Any = None, array: str | None = None,
                          chunks: Any = None, window: int | None = None) -> LabelSurfaceChunked:
    """The label surface of :func:`fepre.sdf.labels`, chunk by chunk (see the module).

    Parameters are those of :func:`fepre.sdf.labels`; ``window`` is the number of chunks in
    flight (default twice dask's worker threads).

    Examples
    --------
    >>> import numpy as np, dask.array as da
    >>> values = np.zeros((20, 20, 20), np.uint8); values[4:16, 4:16, 4:16] = 1; values[8:12, 8:12, 8:12] = 2
    >>> found = label_surface_chunked(da.from_array(values, chunks=10), chunks=8)
    >>> found.chunks, len(found.surface.faces) > 0, found.reaches
    (8, True, False)
    """
    import dask

    chunks = as_chunks(DEFAULT_CHUNKS if chunks is None else chunks)
    data = open_image(source, spacing=spacing, origin=origin, array=array)
    present, on_border = _scan(data, background)
    labels = label_plan(data, present, names, background, keep_background)
    reaches = not keep_background and on_border
    border = BORDER_COPIES if reaches else 0
    shape = tuple(int(n) for n in data.values.shape)
    spacing = np.asarray(data.spacing, dtype=np.float64)
    sigma = smoothing * float(spacing.min()) / spacing
    reach = np.array([int(4.0 * s + 0.5) if sigma.max() > 0 else 0 for s in sigma])  # scipy's truncate 4
    plan = _Plan(labels, shape, border, tuple(n + 2 * border + 2 for n in shape), sigma, reach + 1)
    task = dask.delayed(_chunk, pure=True)
    layout = ChunkLayout.of(plan.nodes, chunks)
    ranges, tasks = [], []
    for number, (_, lo, hi) in enumerate(layout):
        s_lo, s_hi = _sample_range(lo - plan.margin, np.minimum(hi + 1, plan.nodes) + plan.margin, plan)
        ranges.append((lo, hi, s_lo, s_hi))
        tasks.append(task(data.values[s_lo[0]:s_hi[0], s_lo[1]:s_hi[1], s_lo[2]:s_hi[2]], number, lo, hi, s_lo, plan))
    workers = int(dask.config.get("num_workers", None) or os.cpu_count() or 1)
    results = sorted(in_completion_order(tasks, window or 2 * workers), key=lambda r: r[0])
    rank = label_rank(np.sum([r[1] for r in results], axis=0))
    changes, _ = _joins(data.values, np.concatenate([r[2] for r in results]), rank, plan)
    pieces = [r[3] for r in results]
    skipped = sum(r[4] for r in results)
    del results
    where = np.column_stack(np.unravel_index(changes[0], plan.nodes))
    again = []
    for number, (lo, hi, s_lo, s_hi) in enumerate(ranges):
        if len(where) and np.all((where >= lo) & (where < np.minimum(hi + 1, plan.nodes)), axis=1).any():
            samples = data.values[s_lo[0]:s_hi[0], s_lo[1]:s_hi[1], s_lo[2]:s_hi[2]]
            again.append(task(samples, number, lo, hi, s_lo, plan, changes))
    for number, _, _, piece, _ in in_completion_order(again, window or 2 * workers):
        pieces[number] = piece
    origin = np.asarray(data.origin, dtype=np.float64)
    if reaches:
        origin = origin - BORDER_COPIES * spacing
    surface = assemble(CellPieces.joined(pieces), plan.nodes, data.spacing, origin - data.spacing, ITERATIONS)
    return LabelSurfaceChunked(surface, data, labels, reaches, len(pieces), skipped, len(again), len(changes[0]))


def labels_chunked(source: Any, *, names: dict | None = None, background: int = 0, keep_background: bool = False,
                   smoothing: float = 0.5, spacing: Any = None, origin: Any = None, array: str | None = None,
                   chunks: Any = None, window: int | None = None) -> LabelRegions:
    """``sdf.labels`` chunk by chunk (options already checked by :func:`fepre.sdf.labels`): the
    same regions as the in-memory path, never holding the image."""
    found = label_surface_chunked(source, names=names, background=background, keep_background=keep_background,
                                  smoothing=smoothing, spacing=spacing, origin=origin, array=array, chunks=chunks,
                                  window=window)
    return label_regions(found.surface, found.image, found.plan, found.reaches)
