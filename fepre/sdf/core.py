"""The SDF node type: evaluation, gradients, projection and the model tree.

Every model is a tree of :class:`SDF` nodes. A node implements :meth:`SDF._values` on
coordinate arrays (``x, y, z`` for 3D, ``x, y`` for 2D) that only need to be broadcastable
against each other. That one protocol serves both ways of evaluating a model:

* ``model(points)`` on an (N, 3) array: coordinates are column views, evaluated in cache-sized
  blocks on several threads (numpy releases the GIL);
* :meth:`SDF.values_on_axes` on three 1D axis arrays: a grid is sampled without ever
  materialising its coordinates ("direct function sampling" in Kelly's master's project); work that depends on
  one axis only is done once per axis value.

Nodes with an analytic gradient override :meth:`SDF._values_and_gradient`; the others get
central differences of their own values.
"""

from __future__ import annotations

import itertools
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from ..arguments import as_points, positive_int
from ..config import config
from .scratch import ScratchArenas, give_scratch, take_scratch, thread_pool  # noqa: F401  (re-exported)
from .touching import settle_grid_block

__all__ = ["SDF", "Bounds", "Coords", "ScratchArenas", "take_scratch", "give_scratch"]

Bounds = tuple[tuple[float, ...], tuple[float, ...]]
Coords = tuple[np.ndarray, ...]

#: z-slices per block when sampling a 3D grid: work that depends on x and y only is shared by
#: the slices of a block.
GRID_BLOCK_DEPTH = 16
#: Largest number of x-values per block when sampling a 3D grid. Blocks span whole rows of
#: usual grids: numpy's loops over a block then run along long contiguous rows (a 64-wide tile
#: costs ~0.3 ns per point and operation in loop overhead alone).
GRID_BLOCK_WIDTH = 512
#: Points per grid block, in units of ``config.chunk_points`` float64 values (262144 float32
#: points by default). Grid nodes write in place into the block and reuse scratch arrays, so a
#: block's few temporaries may exceed the cache-sized chunks of point evaluation; larger blocks
#: mean fewer numpy calls per point, which are also where threads wait for each other (the GIL).
GRID_BLOCK_CHUNKS = 4


#: The functions behind the operators and modifier methods of :class:`SDF` (``a | b``,
#: ``a.translate(v)``, ``a.shell(t)``), by name. They are defined by the modules that build on
#: this one (booleans, transforms, deform), which register them with :func:`operation` as they
#: load: core imports none of them. ``fepre/sdf/__init__.py`` loads them all, and Python runs it
#: before any submodule of ``fepre.sdf``, so every method finds its function.
_OPERATIONS: dict[str, Callable[..., "SDF"]] = {}


def operation(function: Callable[..., "SDF"]) -> Callable[..., "SDF"]:
    """Register ``function`` (unchanged) as the one behind the SDF method of its name."""
    _OPERATIONS[function.__name__] = function
    return function


def _operation(name: str) -> Callable[..., "SDF"]:
    try:
        return _OPERATIONS[name]
    except KeyError:  # pragma: no cover - fepre.sdf's __init__ registers them all
        raise RuntimeError(f"fepre.sdf.{name} is not registered: import fepre.sdf") from None


def _format_value(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (tuple, list)):
        return "(" + ", ".join(_format_value(v) for v in value) + ")"
    return repr(value)


def _far_for_single(axes) -> bool:
    """True when rounding the grid's coordinates to float32 moves them by more than 1e-4 of the
    smallest node spacing (the grid lies far from the origin for its spacing)."""
    largest, step = 0.0, np.inf
    for axis in axes:
        vector = np.asarray(axis, dtype=np.float64)
        largest = max(largest, float(np.abs(vector).max()))
        if vector.size > 1:
            step = min(step, float(np.abs(np.diff(vector)).min()))
    if not np.isfinite(step) or step == 0.0:
        return False
    return largest * float(np.finfo(np.float32).eps) > 1e-4 * step


class SDF:
    """A signed distance function node: negative inside, zero on the boundary, positive outside.

    Parameters
    ----------
    bounds : ((min...), (max...)) or None
        Axis-aligned box containing the solid (the negative region), or None if unbounded.
    exact : bool
        True only where the value is the true Euclidean distance everywhere; otherwise the value
        is a 1-Lipschitz lower bound of the distance.
    children : sequence of SDF
        The node's operands, for tree walks and ``repr``.

    Examples
    --------
    >>> from fepre import sdf
    >>> ball = sdf.sphere(1.0)
    >>> float(ball([0.0, 0.0, 2.0]))
    1.0
    >>> ball([[0, 0, 0], [1, 0, 0]]).tolist()
    [-1.0, 0.0]
    """

    dim: int = 3
    #: True where the node overrides ``_values_and_gradient`` with an analytic gradient.
    analytic_gradient: bool = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # A subclass that redefines _values but inherits an in-place _values_into (written for
        # its parent's formula) would be sampled with the parent's values: fall back to _values.
        if "_values" in cls.__dict__ and "_values_into" not in cls.__dict__:
            cls._values_into = SDF._values_into

    def __init__(self, *, bounds: Bounds | None, exact: bool, children: Sequence["SDF"] = ()) -> None:
        if bounds is not None:
            lo, hi = bounds
            bounds = (tuple(float(v) for v in lo), tuple(float(v) for v in hi))
        self._bounds = bounds
        self._exact = bool(exact)
        self._children = tuple(children)

    # ------------------------------------------------------------------ properties
    @property
    def bounds(self) -> Bounds | None:
        """Axis-aligned box ``((xmin, ymin, zmin), (xmax, ymax, zmax))`` of the solid, or None."""
        return self._bounds

    @property
    def exact(self) -> bool:
        """True when the value is the exact Euclidean signed distance everywhere."""
        return self._exact

    @property
    def children(self) -> tuple["SDF", ...]:
        """The operands of this node."""
        return self._children

    def walk(self) -> Iterator["SDF"]:
        """Yield this node and all its descendants, depth first."""
        yield self
        for child in self._children:
            yield from child.walk()

    # ------------------------------------------------------------------ the protocol
    def _values(self, *coords: np.ndarray) -> np.ndarray:
        """Values at broadcastable coordinate arrays; dtype follows the coordinates."""
        raise NotImplementedError(f"{type(self).__name__} does not implement _values")

    def _values_into(self, target: np.ndarray, *coords: np.ndarray) -> None:
        """Write the values into ``target`` (a block of a sampled grid, of the full shape).

        Nodes whose last operation can write in place (booleans) override this to save a pass
        over the block.
        """
        target[...] = self._values(*coords)

    def _values_and_gradient(self, *coords: np.ndarray) -> tuple[np.ndarray, Coords]:
        """Values and gradient components; central differences unless overridden."""
        values = self._values(*coords)
        step = self.difference_step
        gradient = []
        for axis in range(self.dim):
            plus = list(coords)
            minus = list(coords)
            plus[axis] = coords[axis] + step
            minus[axis] = coords[axis] - step
            gradient.append((self._values(*plus) - self._values(*minus)) / (2.0 * step))
        return values, tuple(gradient)

    @property
    def difference_step(self) -> float:
        """Step of central differences: cbrt(machine epsilon) times the model's size."""
        return 6e-6 * self.length_scale

    @property
    def length_scale(self) -> float:
        """A characteristic length: the largest extent of ``bounds`` (1 if unbounded)."""
        if self._bounds is None:
            return 1.0
        lo, hi = np.asarray(self._bounds[0]), np.asarray(self._bounds[1])
        extent = float(np.max(hi - lo))
        return extent if np.isfinite(extent) and extent > 0 else 1.0

    # ------------------------------------------------------------------ evaluation
    def __call__(self, points: Any) -> np.ndarray | float:
        """Evaluate at an (N, dim) array (returns (N,) float64) or one point (returns float)."""
        array, single = as_points(points, self.dim)
        values = self._evaluate_rows(array, self._values_block)
        return float(values[0]) if single else values

    def _values_block(self, block: np.ndarray) -> np.ndarray:
        return self._values(*(block[:, axis] for axis in range(self.dim)))

    def _evaluate_rows(self, array: np.ndarray, kernel, width: int = 0, workers: int | None = None):
        """Apply ``kernel`` to row blocks of ``array`` (threaded when there are many)."""
        count = array.shape[0]
        shape = (count,) if width == 0 else (count, width)
        out = np.empty(shape, dtype=np.float64)
        if count == 0:  # kernels reduce over their block (a box's sign test): nothing to evaluate
            return out
        chunk = max(1024, int(config.chunk_points))
        if count <= chunk:
            out[...] = kernel(array)
            return out
        starts = range(0, count, chunk)
        arenas = ScratchArenas()

        def run(start: int) -> None:
            out[start : start + chunk] = arenas.run(kernel, array[start : start + chunk])

        workers = config.resolve_workers(workers)
        if workers == 1:
            for start in starts:
                run(start)
        else:
            list(thread_pool(workers).map(run, starts))
        return out

    def value_and_gradient(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        """Values (N,) and gradients (N, dim) at an (N, dim) array of points."""
        array, _ = as_points(points, self.dim)

        def kernel(block: np.ndarray) -> np.ndarray:
            values, gradient = self._values_and_gradient(*(block[:, axis] for axis in range(self.dim)))
            result = np.empty((block.shape[0], self.dim + 1))
            result[:, 0] = values
            for axis in range(self.dim):
                result[:, axis + 1] = gradient[axis]
            return result

        both = self._evaluate_rows(array, kernel, width=self.dim + 1)
        return both[:, 0], both[:, 1:]

    def gradient(self, points: Any) -> np.ndarray:
        """Gradient at an (N, dim) array of points, shape (N, dim); a single point gives (dim,).

        Analytic where the node has one (``analytic_gradient``), central differences otherwise.

        Examples
        --------
        >>> from fepre import sdf
        >>> sdf.sphere(1.0).gradient([2.0, 0.0, 0.0]).tolist()
        [1.0, 0.0, 0.0]
        """
        array, single = as_points(points, self.dim)
        _, gradient = self.value_and_gradient(array)
        return gradient[0] if single else gradient

    # ------------------------------------------------------------------ smooth surface patches
    @property
    def patch_count(self) -> int:
        """Number of smooth pieces ("patches") of the node's surface, labelled 0..count-1.

        Sharp features lie where two patches meet at an angle: a box has six patches (its
        faces), a capped cylinder three, a sharp boolean the patches of its operands. Nodes with
        a smooth surface have one.
        """
        return 1

    def patch_labels(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        """Values (N,) and the label (N,) of the patch that decides the value at each point.

        Examples
        --------
        >>> from fepre import sdf
        >>> cube = sdf.box(2.0)
        >>> values, labels = cube.patch_labels([[0.9, 0.0, 0.0], [0.0, 0.0, -0.95]])
        >>> labels.tolist()   # faces: 2 * axis + (1 on the + side)
        [1, 4]
        """
        array, _ = as_points(points, self.dim)
        return self._patch_labels(array)

    def patch_values(self, labels: Any, points: Any) -> np.ndarray:
        """Values (N,) of each point's patch ``labels[i]`` as a smooth function: its zero set holds
        the patch and it is negative on the solid's side (a face's plane, a hole's cylinder).

        Examples
        --------
        >>> from fepre import sdf
        >>> float(sdf.box(2.0).patch_values([1], [[3.0, 5.0, 0.0]])[0])   # the x = 1 plane
        2.0
        """
        array, _ = as_points(points, self.dim)
        labels = np.asarray(labels)
        if labels.shape != (array.shape[0],) or labels.dtype.kind not in "iu":
            raise ValueError(f"labels must be an integer array of shape ({array.shape[0]},); got {labels.shape} {labels.dtype}")
        if labels.size and (labels.min() < 0 or labels.max() >= self.patch_count):
            raise ValueError(f"labels must lie in 0..{self.patch_count - 1} (patch_count); got {labels.min()}..{labels.max()}")
        return np.asarray(self._patch_values(labels.astype(np.int64), array), dtype=np.float64)

    def singular_points(self) -> np.ndarray:
        """Isolated points where the surface is not smooth within one patch (a cone's apex), (M, dim).

        Only candidates: a point counts when it lies on the model's zero set.
        """
        return np.zeros((0, self.dim))

    def _patch_labels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self._values(*points.T), np.zeros(points.shape[0], dtype=np.int64)

    def _patch_values(self, labels: np.ndarray, points: np.ndarray) -> np.ndarray:
        return self._values(*points.T)

    def values_on_axes(
        self,
        *axes: Any,
        out: np.ndarray | None = None,
        dtype: Any = np.float32,
        workers: int | None = None,
    ) -> np.ndarray:
        """Sample on the tensor grid of 1D ``axes`` (x, y[, z]) without building coordinates.

        Returns an array of shape ``(nz, ny, nx)`` (``(ny, nx)`` in 2D), C-contiguous, so that
        ``result.ravel()`` is in VTK point order (x fastest). Blocks of rows are evaluated on
        ``workers`` threads; each block's temporaries stay cache-sized.

        Examples
        --------
        >>> import numpy as np
        >>> from fepre import sdf
        >>> t = np.linspace(-1, 1, 5)
        >>> sdf.sphere(0.5).values_on_axes(t, t, t).shape
        (5, 5, 5)
        """
        if len(axes) != self.dim:
            raise ValueError(f"values_on_axes needs {self.dim} axis arrays; got {len(axes)}")
        dtype = np.dtype(dtype)
        if dtype.kind != "f":
            raise TypeError(f"dtype must be a floating type such as 'float32'; got {dtype}")
        vectors = []
        for name, axis in zip("xyz", axes):
            vector = np.asarray(axis, dtype=dtype)
            if vector.ndim != 1 or vector.size == 0:
                raise ValueError(f"axis {name} must be a non-empty 1D array; got shape {vector.shape}")
            if not np.isfinite(vector).all():
                raise ValueError(f"axis {name} must be finite")
            vectors.append(vector)
        far = dtype.itemsize < 8 and _far_for_single(axes)
        if far:
            # float32 coordinates far from the origin (a part placed at 1e4) keep three decimals:
            # evaluate in float64, store in ``dtype``
            vectors = [np.asarray(axis, dtype=np.float64) for axis in axes]
        shape = tuple(v.size for v in reversed(vectors))
        if out is None:
            out = np.empty(shape, dtype=dtype)
        elif out.shape != shape:
            raise ValueError(f"out must have shape {shape}; got {out.shape}")

        # In 3D a block is a tile of at most ``GRID_BLOCK_WIDTH`` x-values, a few y-rows and
        # ``GRID_BLOCK_DEPTH`` z-slices: work that depends on x and y only (radii, box
        # cross-sections) is done once per block and shared by its slices, and booleans can
        # skip operands whose bounds are far from a tile. ``chunk_points`` is sized for
        # float64 temporaries; float32 blocks hold twice as many points.
        block_points = max(1, int(config.chunk_points) * GRID_BLOCK_CHUNKS * 8 // dtype.itemsize)
        if self.dim == 3:
            nz, ny, nx = shape
            kx = max(1, min(nx, GRID_BLOCK_WIDTH))
            rows_per_block = max(1, block_points // kx)
            depth = max(1, min(nz, GRID_BLOCK_DEPTH, rows_per_block))
            ky = max(1, min(ny, rows_per_block // depth))
            kz = max(1, min(nz, rows_per_block // ky))
            blocks = [
                (z, min(z + kz, nz), y, min(y + ky, ny), x, min(x + kx, nx))
                for z, y, x in itertools.product(range(0, nz, kz), range(0, ny, ky), range(0, nx, kx))
            ]

            def evaluate(block: tuple[int, int, int, int, int, int]) -> None:
                z0, z1, y0, y1, x0, x1 = block
                x = vectors[0][None, None, x0:x1]
                y = vectors[1][None, y0:y1, None]
                z = vectors[2][z0:z1, None, None]
                self._values_into(out[z0:z1, y0:y1, x0:x1], x, y, z)
                settle_grid_block(self, out[z0:z1, y0:y1, x0:x1], (x, y, z))

        else:
            ny = shape[0]
            rows_per_block = max(1, block_points // shape[-1])
            blocks = [(y, min(y + rows_per_block, ny)) for y in range(0, ny, rows_per_block)]
            x = vectors[0][None, :]

            def evaluate(block: tuple[int, int]) -> None:
                y0, y1 = block
                self._values_into(out[y0:y1, :], x, vectors[1][y0:y1, None])
                settle_grid_block(self, out[y0:y1, :], (x, vectors[1][y0:y1, None]))

        arenas = ScratchArenas()

        def run(block: tuple[int, ...]) -> None:
            arenas.run(evaluate, block)

        workers = config.resolve_workers(workers)
        if workers == 1 or len(blocks) == 1:
            for block in blocks:
                run(block)
        else:
            list(thread_pool(workers).map(run, blocks))
        if far:
            # a node on a face far from the origin reads the rounding of its coordinates (3e-14 at
            # 248.5), not 0: one sign or the other at random, so a grid edge along a crease
            # "crosses" it and the dual methods put four vertices on one line (zero-area
            # triangles). Values below that rounding are 0, as they are near the origin.
            noise = 16.0 * float(np.finfo(np.float64).eps) * max(float(np.abs(v).max()) for v in vectors)
            out[np.abs(out) <= noise] = 0.0
        return out

    def project(
        self, points: Any, iterations: int = 10, tol: float | None = None, warn: bool = True
    ) -> np.ndarray:
        """Move points onto the zero level set by Newton steps ``p -= d * g / |g|^2``.

        Near the sharp edges of booleans the gradient switches between operands and the steps
        can stall off the surface (sphere minus box: 5% of random points stay 0.3 away): such
        points are returned where they stopped, with a warning.

        Parameters
        ----------
        points : (N, dim) or (dim,) array
        iterations : int
            Largest number of Newton steps.
        tol : float, optional
            Stop once every ``|d|`` is below this (default ``1e-12`` times the model's size).
        warn : bool
            Warn (:class:`fepre.ConvergenceWarning`) naming how many points are still farther
            than ``tol`` from the zero set after ``iterations`` steps (fepre's own callers check
            the values themselves and pass False).

        Examples
        --------
        >>> from fepre import sdf
        >>> sdf.sphere(1.0).project([3.0, 0.0, 0.0]).tolist()
        [1.0, 0.0, 0.0]
        """
        array, single = as_points(points, self.dim)
        iterations = positive_int(iterations, "iterations")
        tol = 1e-12 * self.length_scale if tol is None else float(tol)
        current = array.copy()
        active = np.arange(current.shape[0])
        values = np.zeros(0)
        for _ in range(iterations):
            values, gradient = self.value_and_gradient(current[active])
            moving = np.abs(values) > tol
            if not moving.any():
                active = active[:0]
                break
            active, values, gradient = active[moving], values[moving], gradient[moving]
            norm2 = np.einsum("ij,ij->i", gradient, gradient)
            norm2 = np.where(norm2 > 1e-300, norm2, 1.0)
            current[active] -= (values / norm2)[:, None] * gradient
        if warn and active.size:
            remaining = np.abs(self(current[active])) if active.size else np.zeros(0)
            off = remaining > tol
            if off.any():
                from ..errors import ConvergenceWarning, warn_user

                warn_user(
                    f"project: {int(off.sum())} of {len(current)} points are still off the zero set after "
                    f"iterations={iterations} (largest |value| {float(remaining.max()):.3g} > tol={tol:.3g}); "
                    f"pass more iterations or check the points",
                    ConvergenceWarning,
                )
        return current[0] if single else current

    # ------------------------------------------------------------------ operators and modifiers
    def __or__(self, other: "SDF") -> "SDF":
        return _operation("union")(self, other)

    def __and__(self, other: "SDF") -> "SDF":
        return _operation("intersection")(self, other)

    def __sub__(self, other: "SDF") -> "SDF":
        return _operation("difference")(self, other)

    def __neg__(self) -> "SDF":
        return _operation("complement")(self)

    def __ror__(self, other: Any) -> "SDF":
        return _operation("union")(other, self)

    def __rand__(self, other: Any) -> "SDF":
        return _operation("intersection")(other, self)

    def __rsub__(self, other: Any) -> "SDF":
        return _operation("difference")(other, self)

    def translate(self, offset: Any) -> "SDF":
        """Moved by ``offset`` (see :func:`fepre.sdf.translate`)."""
        return _operation("translate")(self, offset)

    def rotate(self, angle: float, axis: Any = None, center: Any = None) -> "SDF":
        """Rotated by ``angle`` degrees about ``axis`` through ``center`` (see :func:`fepre.sdf.rotate`)."""
        return _operation("rotate")(self, angle, axis, center)

    def scale(self, factor: Any) -> "SDF":
        """Scaled about the origin (see :func:`fepre.sdf.scale`)."""
        return _operation("scale")(self, factor)

    def mirror(self, normal: Any, point: Any = None) -> "SDF":
        """Reflected across a plane (see :func:`fepre.sdf.mirror`)."""
        return _operation("mirror")(self, normal, point)

    def transform(self, matrix: Any) -> "SDF":
        """Mapped by a general affine matrix (see :func:`fepre.sdf.transform`)."""
        return _operation("transform")(self, matrix)

    def offset(self, distance: float) -> "SDF":
        """Grown by ``distance`` (see :func:`fepre.sdf.offset`)."""
        return _operation("offset")(self, distance)

    def shell(self, thickness: float) -> "SDF":
        """Hollowed inwards to a wall of ``thickness`` (see :func:`fepre.sdf.shell`)."""
        return _operation("shell")(self, thickness)

    def elongate(self, h: Any, center: Any = None) -> "SDF":
        """Stretched by ``2 h`` per axis (see :func:`fepre.sdf.elongate`)."""
        return _operation("elongate")(self, h, center)

    def twist(self, rate: float) -> "SDF":
        """Twisted about z by ``rate`` degrees per unit length (see :func:`fepre.sdf.twist`)."""
        return _operation("twist")(self, rate)

    def bend(self, rate: float) -> "SDF":
        """Bent in the xy-plane by ``rate`` degrees per unit length (see :func:`fepre.sdf.bend`)."""
        return _operation("bend")(self, rate)

    # ------------------------------------------------------------------ tree display
    def _parameters(self) -> dict[str, Any]:
        """Parameters shown by ``repr`` (override in nodes)."""
        return {}

    def _label(self) -> str:
        return type(self).__name__.lower()

    def describe(self) -> str:
        """One line naming the node and its parameters."""
        parameters = ", ".join(f"{k}={_format_value(v)}" for k, v in self._parameters().items())
        return f"{self._label()}({parameters})"

    def __repr__(self) -> str:
        lines: list[str] = []

        def visit(node: SDF, prefix: str, last: bool, root: bool) -> None:
            lines.append(node.describe() if root else f"{prefix}{'└─ ' if last else '├─ '}{node.describe()}")
            child_prefix = "" if root else prefix + ("   " if last else "│  ")
            for index, child in enumerate(node.children):
                visit(child, child_prefix, index == len(node.children) - 1, False)

        visit(self, "", True, True)
        return "\n".join(lines)


def require_solid_model(model: Any, name: str = "model") -> None:
    """TypeError unless ``model`` is a 3D :class:`SDF`; a file name is told to read the file first.

    Examples
    --------
    >>> require_solid_model("part.stl")
    Traceback (most recent call last):
    ...
    TypeError: model must be a 3D fepre.sdf.SDF; got the str 'part.stl': read a file first with fepre.sdf.mesh('part.stl') (triangle meshes, STEP) or fepre.sdf.image (images)
    """
    if isinstance(model, SDF) and model.dim == 3:
        return
    import os

    if isinstance(model, (str, os.PathLike)):
        path = os.fspath(model)
        raise TypeError(f"{name} must be a 3D fepre.sdf.SDF; got the {type(model).__name__} {path!r}: read a file first "
                        f"with fepre.sdf.mesh({path!r}) (triangle meshes, STEP) or fepre.sdf.image (images)")
    got = f"a {model.dim}D SDF" if isinstance(model, SDF) else type(model).__name__
    raise TypeError(f"{name} must be a 3D fepre.sdf.SDF; got {got}")
