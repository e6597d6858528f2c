"""A segmented label image as region models for ``fepre.distmesh(..., regions=)``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ...arguments import check_names, nonnegative_float, shown
from ..meshmodel.model import MeshModel
from ..meshmodel.repair import Repair, _is_closed, repair
from .multilabel import label_surface
from .read import Image, ImageInputError, read_image

__all__ = ["LabelRegions", "LabelModel", "LabelPlan", "labels", "label_plan", "label_regions", "BORDER_COPIES", "ITERATIONS"]

ITERATIONS = 30
#: Copies of the border voxels added beyond the image's border where a label reaches it, so that
#: the regions' surfaces close two voxels outside the voxels' box that cuts them. Closed on the
#: border itself (one background node beyond it), a region's surface ran in and out of the box's
#: face by a fraction of a voxel: slivers and knife edges under h where an interface met a crop's
#: face (a 1 mm crop of the MNI brain at h = 2.5 mm failed with a fixed interface node on the
#: final mesh's boundary, 0.33 h inside the part).
BORDER_COPIES = 2


class LabelModel(MeshModel):
    """One label's region (or the whole part) of a label image: the exact distance to its
    triangles of the shared interface surface, negative inside."""

    #: its creases are the edges between its patches (voxel planes, the part's surface and the
    #: interfaces): read from the triangles, not searched for on a grid of h/4
    creases_from_triangles = True
    #: it is cut from one surface shared with the other labels' regions: no gap stands between
    #: them (:func:`fepre.regions.clearance.narrow_clearances` need not look for one)
    from_shared_surface = True

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, name: str, source: Image, label: Any,
                 other: np.ndarray | None = None, plane: np.ndarray | None = None) -> None:
        repaired = _closed_or_repaired(vertices, faces)
        super().__init__(repaired, name, sign="winding", features=0.0)
        self.image = source
        self.label = label
        #: the part this region lies in (set by :func:`labels`): meshing that part, the regions
        #: need no intersection with it
        self.within = None
        #: whether the label stays inside the image (touches no border voxel): its surface is
        #: then closed within the image and its volume the region's, whatever the others do
        self.inside_image = False
        if plane is not None and other is not None and len(repaired.faces) == len(faces):
            self._set_patches(plane, other == 0)

    def _set_patches(self, plane: np.ndarray, outside: np.ndarray) -> None:
        """Patches for the feature search: each voxel-aligned plane that meets another at a sharp
        edge (:mod:`.sharp`), and the rest split into the triangles on the part's surface (the
        background on their other side) and those on interfaces, so a rim, where an interface
        meets the surface, is a crease. A region inside the part with no such planes (a ball in a
        block) has one patch, and the feature search passes it by."""
        from ..meshmodel.patches import PatchPlanes

        key = np.where(plane >= 0, plane, np.where(outside, -1, -2))
        _, patch = np.unique(key, return_inverse=True)
        self._face_patch = patch.reshape(-1).astype(np.int64)
        self._patch_count = int(self._face_patch.max()) + 1 if len(patch) else 1
        self._planes = PatchPlanes(self.vertices, self.faces, self._distance.normals, self._face_patch)

    def _parameters(self) -> dict[str, Any]:
        return {"source": self.name, "label": self.label, "triangles": len(self.faces)}

    def _label(self) -> str:
        return "labels"


def _closed_or_repaired(vertices: np.ndarray, faces: np.ndarray) -> Repair:
    """The surface as it is when every edge has two triangles traversing it in opposite
    directions (as the label surface is but where a label touches itself along an edge);
    otherwise the mesh model's repair. (The repair of a closed surface of several pieces, a
    block with cavities, checks every triangle's winding number: 3 of 8.6 s at 160^3.)"""
    used, faces = np.unique(faces, return_inverse=True)
    faces = faces.reshape(-1, 3).astype(np.int64)
    if not _is_closed(faces):
        return repair(vertices[used], faces)
    return Repair(vertices=np.ascontiguousarray(vertices[used], dtype=np.float64), faces=faces, merged=0, degenerate=0,
                  duplicates=0, flipped=0, holes=0, hole_area=0.0, internal=0, open_edges=0, closed=True,
                  filled=np.zeros(len(faces), dtype=bool))


def _touches_border(indices: np.ndarray) -> bool:
    """True when a label other than the background (index 0) lies on a face of the grid."""
    return any(bool((np.take(indices, end, axis=axis) != 0).any()) for axis in range(3) for end in (0, -1))


class LabelRegions(dict):
    """Region name -> model of a label image (a dict, for ``regions=``), with the whole part.

    Attributes
    ----------
    part : fepre.sdf.SDF
        The union of the regions as one model (its surface is the triangles next to the
        background; cut by the voxels' box when a region reaches the image's border): the
        model to mesh.
    labels : dict
        Region name -> label value in the image.
    image : Image
        The label image read.
    """

    part: Any
    labels: dict
    image: Image


def _names(values: np.ndarray, names: Any, image: Image, background: int) -> dict:
    default = {int(v): "background" if int(v) == background else f"label_{int(v)}" for v in values}
    if names is None:
        return default
    if not isinstance(names, dict):
        raise TypeError(f"names must be a dict of label value -> region name (e.g. {{1: 'bone'}}); got {type(names).__name__}")
    found = {int(v) for v in values}
    unknown = [k for k in names if k not in found]
    if unknown:
        raise ImageInputError(
            f"{image.name}: names (fepre mesh --label VALUE=NAME) gives labels {shown(unknown)} that the image does "
            f"not hold (it holds {shown(sorted(found))})"
        )
    return {int(v): str(names.get(int(v), default[int(v)])) for v in values}


def labels(
    source: Any,
    *,
    names: dict | None = None,
    background: int = 0,
    keep_background: bool = False,
    smoothing: float = 0.5,
    spacing: Any = None,
    origin: Any = None,
    array: str | None = None,
    chunks: Any = None,
    fill_cracks: bool = False,
) -> LabelRegions:
    """A segmented label image (CT or MRI segmentation, phases of a material) as the regions of
    one conformal mesh.

    Each label's indicator is smoothed (a Gaussian of ``smoothing`` voxels), and the interfaces
    between labels are taken where the smoothed indicators of the two labels are equal, as one
    triangle surface that every region shares (see :mod:`fepre.sdf.imagemodel.multilabel`).
    Every region's model is the exact distance to its triangles, so two regions are both zero
    on their interface, and the regions split the part without gaps or overlaps.

    Parameters
    ----------
    source : pyvista.ImageData, str, path-like, array_like, zarr.Array or dask.array.Array
        A label image: a grid, an image file (``.vti``, NIfTI, TIFF), a 3D integer array, or
        an image beyond memory: a ``.zarr`` store (a group with ``array=``), a zarr or dask
        array (indexed x, y, z), read chunk by chunk (:mod:`fepre.chunked.labels`).
    names : dict, optional
        Label value -> region name (solver-safe: letters, digits, ``_``); the others are
        named ``label_<value>``.
    background : int
        The label that is not part of the part (default 0).
    keep_background : bool
        Mesh the background too, as a region ``background`` (named by ``names`` if given), the
        part being the whole box the voxels fill.
    smoothing : float
        Width of the Gaussian in voxels of the finest axis (default 0.5; 0 keeps the voxels'
        staircase).
    spacing, origin, array : optional
        As for :func:`fepre.sdf.image` (a store's ``spacing`` and ``origin`` attributes are
        taken when not given).
    chunks : int or (3,) ints, optional
        Nodes per chunk along x, y, z: the image is then processed chunk by chunk, never held
        whole, with the same triangles bit for bit (default 128 for a zarr store or a dask
        array, which are always processed so).
    fill_cracks : bool
        Give each background voxel that lies between two different labels along an axis (a
        crack one voxel wide between two materials, :mod:`fepre.sdf.imagemodel.cracks`) the
        smaller of the two labels. Without it such voxels are warned of
        (:class:`fepre.ResolutionWarning`): a crack that thin through the part is beyond any mesh
        coarser than the voxels. Images in memory only.

    Returns
    -------
    LabelRegions
        Region name -> model (a dict, for ``fepre.distmesh(regions=)``), with ``.part``, the
        model to mesh, and ``.labels`` (name -> label value).

    Raises
    ------
    fepre.sdf.imagemodel.ImageInputError
        Unreadable file, not 3D, no scalar array, non-integer labels, fewer than two regions
        (for a store, found by one pass over its chunks before any smoothing).

    Examples
    --------
    >>> from fepre import sdf
    >>> from fepre.sdf.imagemodel.phantoms import label_image
    >>> grid = label_image([sdf.box(1.0), sdf.sphere(0.3)], (-0.6,) * 3, (0.6,) * 3, 0.05)
    >>> regions = sdf.labels(grid, names={1: "matrix", 2: "inclusion"})
    >>> list(regions), regions.labels
    (['matrix', 'inclusion'], {'matrix': 1, 'inclusion': 2})
    >>> # mesh = fepre.distmesh(regions.part, 0.1, regions=regions)
    """
    smoothing = nonnegative_float(smoothing, "smoothing")
    from .model import is_chunked_source

    if chunks is not None or is_chunked_source(source):
        if fill_cracks:
            raise ValueError("fill_cracks=True needs the image in memory; it is not done chunk by chunk "
                             "(read the image whole, or fill its cracks before)")
        from ...backends import provided

        return provided("labels_chunked")(source, names=names, background=background, keep_background=keep_background,
                                          smoothing=smoothing, spacing=spacing, origin=origin, array=array,
                                          chunks=chunks)
    data = read_image(source, spacing=spacing, origin=origin, array=array)
    values = data.values
    if not (np.issubdtype(values.dtype, np.integer) or values.dtype == bool):
        if not np.array_equal(values, np.round(values)):
            raise ImageInputError(non_integer_message(data.name, values.dtype))
    if not keep_background:
        values = _cracks_handled(data, values, background, fill_cracks)
    plan = label_plan(data, np.unique(values), names, background, keep_background)
    indices = plan.indices(values)
    origin = np.asarray(data.origin, dtype=np.float64)
    reaches = not keep_background and _touches_border(indices)
    if reaches:  # the regions run on beyond the image's border, to be cut by the voxels' box
        indices = np.pad(indices, BORDER_COPIES, mode="edge")
        origin = origin - BORDER_COPIES * np.asarray(data.spacing, dtype=np.float64)
    surface = label_surface(indices, len(plan.order), data.spacing, origin, smoothing, 0, ITERATIONS)
    return label_regions(surface, data, plan, reaches, values)


def _cracks_handled(data: Image, values: np.ndarray, background: int, fill: bool) -> np.ndarray:
    """``values`` with the background voxels between two labels filled (``fill``), or warned of."""
    from ...errors import ResolutionWarning, warn_user
    from .cracks import background_cracks, filled_cracks

    if fill:
        return filled_cracks(values, background)[0]
    count, first, pairs = background_cracks(values, background)
    if count:
        where = ", ".join(f"{v:.6g}" for v in np.asarray(data.origin) + np.asarray(data.spacing) * first)
        between = ", ".join(f"{a} and {b}" for a, b in pairs[:4].tolist()) + (" and more" if len(pairs) > 4 else "")
        warn_user(
            f"{data.name}: {count} background voxel(s) lie one voxel wide between two labels ({between}; e.g. "
            f"at ({where})): a crack through the part between those regions, which no mesh coarser than "
            "the voxels resolves (meshing fails or bridges it); if the materials touch there, pass "
            "fill_cracks=True (fepre mesh: --fill-cracks) to give each the smaller of its two labels",
            ResolutionWarning)
    return values


def non_integer_message(name: str, dtype) -> str:
    return (f"{name} holds non-integer values ({dtype}); a label image holds integer labels: round or cast them to "
            "integers, or mesh a grey image with fepre.sdf.image(..., level=...) (fepre mesh: --level instead of --labels)")


@dataclass(frozen=True)
class LabelPlan:
    """The labels of an image: ``order`` (label values, index 0 the background, then the
    regions' labels in increasing order), ``named`` (label value -> region name), and
    ``background``, ``keep_background``."""

    order: np.ndarray
    named: dict
    background: int
    keep_background: bool

    def indices(self, values: np.ndarray) -> np.ndarray:
        """int16 label indices (positions in ``order``) of label values."""
        indices = np.searchsorted(np.sort(self.order), values).astype(np.int16)
        return np.argsort(self.order)[indices].astype(np.int16)  # sorted position -> index in order


#: most labels a segmentation may hold (more, or a negative one, is a grey image given as labels)
MAX_LABELS = 1000


def label_plan(data: Image, present: np.ndarray, names: Any, background: int, keep_background: bool) -> LabelPlan:
    """The regions of an image holding the label values ``present``: at least two, named
    (``names``: label value -> region name)."""
    present = np.asarray(present).astype(np.int64)
    kept = present if keep_background else present[present != background]
    if len(kept) > MAX_LABELS or (kept < 0).any():
        raise ImageInputError(
            f"{data.name} holds {len(present)} distinct values from {int(present.min())} to {int(present.max())}: it "
            f"looks like a grey image, not a segmentation (labels are a few non-negative integers, at most {MAX_LABELS}); "
            f"mesh it with fepre.sdf.image(..., level=...) (fepre mesh: --level instead of --labels)"
        )
    if len(kept) < 2:
        raise ImageInputError(
            f"{data.name} holds {len(kept)} label{'s' if len(kept) != 1 else ''} besides the background {background} "
            f"(values {shown(present.tolist())}); regions need at least two: give a segmentation of two or more "
            f"materials, or mesh a single one with fepre.sdf.image(..., level=0.5) (fepre mesh: --level 0.5 instead of "
            f"--labels)"
        )
    named = _names(kept, names, data, background)
    check_names(list(named.values()), "names")
    order = np.concatenate([[background], kept[kept != background]])  # index 0 is the background
    return LabelPlan(order, named, background, keep_background)


def label_regions(surface, data: Image, plan: LabelPlan, reaches: bool, values: np.ndarray | None = None) -> LabelRegions:
    """The regions' models of a label surface (``reaches``: a label reaches the image's border,
    so the surface closes beyond it and the voxels' box cuts the part). With the label
    ``values`` the surface was made from (an image in memory, its cracks filled or not), the
    labels inside the image are marked (``inside_image``) and those whose surface is rounded off
    their voxels' volume named."""
    order, named, background = plan.order, plan.named, plan.background
    regions = LabelRegions()
    regions.labels, regions.image = {}, data
    for index in range(1, len(order)):
        label = int(order[index])
        faces, other, plane = surface.region_planes(index)
        regions[named[label]] = LabelModel(surface.vertices, faces, data.name, data, label, other, plane)
        regions.labels[named[label]] = label
    faces, _, plane = surface.part(0)
    part = LabelModel(surface.vertices, faces, data.name, data, "part", np.zeros(len(faces), np.int64), plane)
    lower, upper = data.voxel_box()
    from ..solids import box

    whole = box(tuple(upper - lower), center=tuple(0.5 * (lower + upper)))
    if plan.keep_background:
        regions[named[background]] = whole & -part
        regions.labels[named[background]] = background
        regions.part = whole
    else:
        regions.part = part & whole if reaches else part
        for model in regions.values():  # (a region that reaches the border pokes out of the box)
            model.within = None if reaches else regions.part
    if values is None:  # read chunk by chunk: not counted
        return regions
    from .levelset import border_values

    border = np.unique(border_values(values))
    for name, label in regions.labels.items():
        if isinstance(regions[name], LabelModel):
            regions[name].inside_image = label not in border
    _warn_rounded(regions, data, values)
    return regions


#: a label region whose surface holds more than this share less (or more) than its voxels is named
LABEL_VOLUME_TOLERANCE = 0.02


def _warn_rounded(regions: LabelRegions, data: Image, values: np.ndarray) -> None:
    """A ResolutionWarning for the regions (away from the image's border) whose surface holds
    more than ``LABEL_VOLUME_TOLERANCE`` less or more than their voxels: a region a few voxels
    across, its surface rounded over about a voxel (a new user's ball inclusion: -5.2%, a post
    -4.1%, none said; the mesh then matched the surface, not the voxels)."""
    from ...errors import ResolutionWarning, warn_user

    voxel = float(np.prod(data.spacing))
    off = []
    for name, label in regions.labels.items():
        model = regions[name]
        if not getattr(model, "inside_image", False):
            continue
        voxels = int(np.count_nonzero(values == label))
        error = abs(float(model.volume)) / (voxels * voxel) - 1.0 if voxels else 0.0
        if abs(error) > LABEL_VOLUME_TOLERANCE:
            off.append(f"{name!r} (label {label}) {100 * abs(error):.1f}% {'less' if error < 0 else 'more'} than "
                       f"its {voxels} voxels ({voxels * voxel:.4g})")
    if off:
        warn_user(
            f"{data.name}: the surfaces of {', '.join(off)}: a region a few voxels across is rounded over "
            f"about a voxel where the labels are smoothed into surfaces; a finer image keeps its volume (a mesh "
            f"follows the surface)", ResolutionWarning)
