"""``fepre.SizeField``: wanted edge lengths on a regular grid, interpolated anywhere.

A size field is a grid of sizes (world units) with trilinear interpolation between nodes and
the nearest node's value outside the grid. It is what :func:`fepre.size_field` returns, what a
background mesh or an image of sizes becomes, and what :func:`fepre.distmesh` meshes with.
Fields combine by taking the smaller size (:meth:`SizeField.minimum`), with each other and with
plain callables ``(N, 3) -> (N,)``.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..arguments import as_points, evaluate_size, shown

__all__ = ["SizeField"]


class SizeField:
    """Edge lengths wanted at every point: a grid of sizes with trilinear interpolation.

    Parameters
    ----------
    origin : (3,) floats
        Position of node (0, 0, 0).
    spacing : (3,) floats
        Node spacing along x, y, z (positive).
    values : (nz, ny, nx) array
        Sizes at the nodes (finite, positive), in world units.

    Examples
    --------
    >>> import numpy as np
    >>> field = SizeField((0, 0, 0), (1, 1, 1), np.array([[[1.0, 3.0]]]))   # 2 nodes along x
    >>> field([[0.5, 0.0, 0.0], [9.0, 0.0, 0.0]]).tolist()
    [2.0, 3.0]
    >>> field.minimum(lambda p: np.full(len(p), 1.5))([[1.0, 0.0, 0.0]]).tolist()
    [1.5]
    """

    #: Its values are edge lengths in world units, not relative sizes. Code below fepre.sizing
    #: (fepre.features) tells a SizeField from a relative size function by this, without
    #: importing the class.
    world_units = True

    def __init__(self, origin: Any, spacing: Any, values: Any):
        origin = np.asarray(origin, dtype=np.float64).reshape(-1)
        spacing = np.asarray(spacing, dtype=np.float64).reshape(-1)
        values = np.asarray(values, dtype=np.float64)
        if origin.shape != (3,) or not np.isfinite(origin).all():
            raise ValueError(f"origin must be 3 finite numbers; got {origin.tolist()}")
        if spacing.shape != (3,) or not (np.isfinite(spacing).all() and (spacing > 0).all()):
            raise ValueError(f"spacing must be 3 positive numbers; got {spacing.tolist()}")
        if values.ndim != 3 or values.size == 0:
            raise ValueError(f"values must be a non-empty (nz, ny, nx) array; got shape {values.shape}")
        bad = ~(np.isfinite(values) & (values > 0))
        if bad.any():
            raise ValueError(f"sizes must be finite and > 0; got {shown(values[bad].ravel()[0])}")
        self.origin, self.spacing, self.values = origin, spacing, values
        #: seconds :func:`fepre.size_field` took to build the field (None for other fields)
        self.seconds: float | None = None
        #: for a field from a background mesh, which points that mesh covers
        self.coverage: _Coverage | None = None
        #: the crease search :func:`fepre.size_field` made (``Features.creases``): the mesher's
        #: feature search on the same grid takes it instead of searching again (not carried
        #: over to moved, clipped or combined fields)
        self.creases = None
        #: the places :func:`fepre.size_field` names as needing sizes below its hmin, in the
        #: user's frame: ``(size wanted, point, thickness or width, kind)`` with kind one of
        #: "wall", "gap", "edges", "knife", "touching" (the last two without a size: 0)
        self.unresolved: list[tuple] = []

    # ------------------------------------------------------------------ the field
    @property
    def shape(self) -> tuple[int, int, int]:
        """Node counts ``(nx, ny, nz)``."""
        nz, ny, nx = self.values.shape
        return nx, ny, nz

    @property
    def bounds(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The grid's box ``((xmin, ymin, zmin), (xmax, ymax, zmax))``."""
        upper = self.origin + self.spacing * (np.array(self.shape) - 1)
        return tuple(self.origin.tolist()), tuple(upper.tolist())

    @property
    def hmin(self) -> float:
        """The smallest size in the field."""
        return float(self.values.min())

    @property
    def hmax(self) -> float:
        """The largest size in the field."""
        return float(self.values.max())

    def __call__(self, points: Any) -> np.ndarray:
        """Sizes at ``points`` (N, 3): trilinear between nodes, the nearest node's outside."""
        from scipy.ndimage import map_coordinates

        array, single = as_points(points, 3)
        index = ((array - self.origin) / self.spacing).T[::-1]  # (z, y, x) fractional indices
        out = map_coordinates(self.values, index, order=1, mode="nearest")
        return out[0] if single else out

    def __repr__(self) -> str:
        nx, ny, nz = self.shape
        return (f"SizeField({nx} x {ny} x {nz} nodes, spacing {float(self.spacing.max()):.4g}, "
                f"sizes {self.hmin:.4g} to {self.hmax:.4g})")

    def nodes(self) -> np.ndarray:
        """(nx * ny * nz, 3) node positions, x fastest (VTK's order)."""
        axes = [self.origin[k] + self.spacing[k] * np.arange(n) for k, n in enumerate(self.shape)]
        z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
        return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)

    # ------------------------------------------------------------------ combining
    def minimum(self, *others: "SizeField | Callable[[np.ndarray], np.ndarray] | float") -> "SizeField":
        """The smaller size of this field and each of ``others`` (fields, callables or numbers),
        on this field's grid.

        A callable is evaluated at this field's nodes, so detail finer than its spacing is
        smoothed over; put the finer field first to keep it.
        """
        values = self.values.copy()
        nodes = None
        for other in others:
            if isinstance(other, (int, float)) and not isinstance(other, bool):
                if not (np.isfinite(other) and other > 0):
                    raise ValueError(f"a size must be finite and > 0; got {shown(other)}")
                np.minimum(values, float(other), out=values)
                continue
            if not callable(other):
                raise TypeError(f"minimum() takes size fields, callables (N, 3) -> (N,) or numbers; got {type(other).__name__}")
            if nodes is None:
                nodes = self.nodes()
            np.minimum(values, evaluate_size(other, nodes).reshape(values.shape), out=values)
        combined = SizeField(self.origin, self.spacing, values)
        combined.unresolved = self.unresolved + [place for other in others for place in getattr(other, "unresolved", [])]
        return combined

    def translated(self, offset: Any) -> "SizeField":
        """The same sizes moved by ``offset`` (the grid's origin moved; a background mesh's
        coverage with it).

        Examples
        --------
        >>> field = SizeField((0, 0, 0), (1, 1, 1), np.array([[[1.0, 3.0]]]))
        >>> field.translated((10, 0, 0))([[10.5, 0.0, 0.0]]).tolist()
        [2.0]
        """
        offset = np.asarray(offset, dtype=np.float64).reshape(3)
        moved = SizeField(self.origin + offset, self.spacing, self.values)
        moved.seconds = self.seconds
        moved.unresolved = self.unresolved  # named in the user's frame already
        if self.coverage is not None:
            moved.coverage = _Coverage(self.coverage.mesh.translate(tuple(offset), inplace=False))
        return moved

    def clip(self, hmin: float, hmax: float) -> "SizeField":
        """The field with its sizes clamped to ``[hmin, hmax]``."""
        if not (0 < hmin <= hmax):
            raise ValueError(f"clip needs 0 < hmin <= hmax; got hmin={shown(hmin)}, hmax={shown(hmax)}")
        clipped = SizeField(self.origin, self.spacing, np.clip(self.values, hmin, hmax))
        clipped.unresolved = [place for place in self.unresolved if place[0] < hmin or place[0] == 0]
        return clipped

    # ------------------------------------------------------------------ images and meshes
    def to_image(self, name: str = "size"):
        """The field as a :class:`pyvista.ImageData` with point array ``name``."""
        import pyvista as pv

        image = pv.ImageData(dimensions=self.shape, spacing=tuple(self.spacing), origin=tuple(self.origin))
        image.point_data[name] = self.values.reshape(-1)
        return image

    @classmethod
    def from_image(cls, image, name: str | None = None) -> "SizeField":
        """A field from a :class:`pyvista.ImageData` with a point array of sizes (``name``, or
        its only point array)."""
        import pyvista as pv

        if not isinstance(image, pv.ImageData):
            raise TypeError(f"image must be a pyvista.ImageData; got {type(image).__name__}")
        name = _array_name(image.point_data.keys(), name, "point")
        nx, ny, nz = image.dimensions
        values = np.asarray(image.point_data[name], dtype=np.float64).reshape(nz, ny, nx)
        return cls(image.origin, image.spacing, values)

    @classmethod
    def from_mesh(cls, mesh, name: str | None = None, *, spacing: float | None = None, bounds: Any = None) -> "SizeField":
        """A field from a background mesh carrying a point or cell array of sizes.

        The mesh (any :class:`pyvista.DataSet`, e.g. a solver's mesh with an error-driven size
        per cell) is probed on a grid over ``bounds`` (default the mesh's) at ``spacing``
        (default a third of its smallest size, or coarser to keep the grid under
        ``BACKGROUND_NODES`` nodes). Grid nodes outside the mesh take the nearest
        covered node's size; :func:`fepre.distmesh` checks that the mesh covers the part.
        """
        import pyvista as pv

        if not isinstance(mesh, pv.DataSet):
            raise TypeError(f"a background mesh must be a pyvista dataset; got {type(mesh).__name__}")
        if mesh.n_points == 0 or mesh.n_cells == 0:
            raise ValueError("the background mesh is empty")
        keys = list(mesh.point_data.keys()) + list(mesh.cell_data.keys())
        name = _array_name(keys, name, "point or cell")
        sizes = np.asarray(mesh.point_data[name] if name in mesh.point_data else mesh.cell_data[name], dtype=np.float64)
        if sizes.ndim != 1:
            raise ValueError(f"the background mesh's array {name!r} must hold one size per point or cell; got shape {sizes.shape}")
        bad = ~(np.isfinite(sizes) & (sizes > 0))
        if bad.any():
            raise ValueError(f"the background mesh's sizes ({name!r}) must be finite and > 0; got {shown(sizes[bad][0])}")
        if bounds is None:
            b = np.asarray(mesh.bounds, dtype=np.float64).reshape(3, 2)
            lower, upper = b[:, 0], b[:, 1]
        else:
            from ..arguments import as_bounds

            lower, upper = (np.asarray(v, dtype=np.float64) for v in as_bounds(bounds, 3, "bounds"))
        if spacing is None:
            step = max(float(sizes.min()) / 3.0, float(np.cbrt(np.prod(upper - lower) / BACKGROUND_NODES)))
        else:
            step = float(spacing)
        if not step > 0:
            raise ValueError(f"spacing must be > 0; got {shown(spacing)}")
        counts = np.maximum(np.ceil((upper - lower) / step - 1e-9).astype(np.int64) + 1, 2)
        if int(np.prod(counts)) > MAX_NODES:
            step = float(np.cbrt(np.prod(upper - lower) / MAX_NODES))
            counts = np.maximum(np.ceil((upper - lower) / step - 1e-9).astype(np.int64) + 1, 2)
        steps = np.where(counts > 1, (upper - lower) / np.maximum(counts - 1, 1), step)
        steps = np.where(steps > 0, steps, step)
        image = pv.ImageData(dimensions=tuple(int(c) for c in counts), spacing=tuple(steps), origin=tuple(lower))
        carrier = mesh.copy(deep=False)
        carrier.clear_data()
        if name in mesh.point_data:
            carrier.point_data["size"] = sizes
        else:
            carrier.cell_data["size"] = sizes
        from ..surface.flying_edges import sequential_smp

        with sequential_smp():  # threads made nodes on a face between cells take either cell's size
            probed = image.sample(carrier)
        values = np.asarray(probed.point_data["size"], dtype=np.float64)
        covered = np.asarray(probed.point_data["vtkValidPointMask"]).astype(bool)
        if not covered.any():
            raise ValueError("the background mesh covers no node of its own grid: is it a volume mesh?")
        if not covered.all():
            from scipy.ndimage import distance_transform_edt

            shape = tuple(int(c) for c in counts[::-1])
            _, nearest = distance_transform_edt(~covered.reshape(shape), return_indices=True)
            values = values.reshape(shape)[tuple(nearest)].reshape(-1)
        field = cls(lower, steps, values.reshape(tuple(int(c) for c in counts[::-1])))
        field.coverage = _Coverage(carrier)
        return field


#: largest grid a size field is built on (a field this size holds 128 MB of float64)
MAX_NODES = 16_000_000
#: nodes of the grid a background mesh is probed on by default
BACKGROUND_NODES = 2_000_000


class _Coverage:
    """Which points a background mesh covers (for the check that it covers the part)."""

    def __init__(self, mesh):
        self.mesh = mesh

    def uncovered(self, points: np.ndarray) -> np.ndarray:
        import pyvista as pv

        probed = pv.PolyData(np.asarray(points, dtype=np.float64)).sample(self.mesh)
        return ~np.asarray(probed.point_data["vtkValidPointMask"]).astype(bool)


def _array_name(keys, name: str | None, kind: str) -> str:
    keys = list(keys)
    if name is not None:
        if name not in keys:
            raise ValueError(f"no {kind} array named {name!r}; the arrays are {keys}")
        return name
    candidates = [k for k in keys if k not in ("vtkValidPointMask", "vtkGhostType")]
    if len(candidates) != 1:
        raise ValueError(f"name the {kind} array of sizes (name=...): found {candidates or 'none'}")
    return candidates[0]
