"""Model files: Python files that define a part for the ``fepre`` command.

A model file defines ``model`` (an :class:`fepre.sdf.SDF`) and may define ``h`` (target edge
length), ``bounds`` (meshing box), ``boundaries`` (name -> SDF for named boundary sets),
``regions`` (name -> SDF: material regions that split the part, meshed conformally) and
``materials`` (region name -> ``(E, nu)``, written to ``.inp`` files; a part without ``regions``
is the one region ``volume``) and ``boundary_areas``
(boundary name -> the exact area the user knows, printed beside the set's by ``fepre mesh``)
and ``boundary_tolerance`` (how far a set's nodes may lie from its surface, in local edge
lengths: :func:`fepre.export`'s, for a model whose surface only comes near a set's).
Loading one runs it with ``runpy`` (``__name__`` is not ``"__main__"``, so a file can also be a
script) and turns every failure into a :class:`ModelFileError` naming the file and the reason.

Examples
--------
>>> import pathlib, tempfile
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> _ = (folder / "ball.py").write_text("from fepre import sdf\\nmodel = sdf.sphere(1.0)\\nh = 0.2\\n")
>>> part = load_model(folder / "ball.py")
>>> part.h, part.model.bounds[1]
(0.2, (1.0, 1.0, 1.0))
"""

from __future__ import annotations

import os
import runpy
import sys
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .arguments import as_bounds, positive_float
from .sdf import SDF

__all__ = ["ModelFile", "ModelFileError", "load_model", "MESH_SUFFIXES"]

#: Surface mesh files taken as models directly: ``fepre mesh part.stl`` meshes ``sdf.mesh("part.stl")``.
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off", ".vtp", ".vtk", ".vtu", ".mesh", ".msh", ".inp",
                 ".step", ".stp", ".brep", ".iges", ".igs")


#: CAD formats fepre does not read (ACIS, Parasolid): named in the error, with what to export
CAD_SUFFIXES = (".sat", ".x_t", ".x_b")


def _not_a_model_file(path: Path) -> str:
    """Why ``path`` is not a model file, with how to tessellate a CAD file."""
    message = (f"model file {path} must be a Python file ending in .py, a surface mesh ({', '.join(MESH_SUFFIXES)}) "
               f"or an image (.vti, .nii, .nii.gz, .tif, .zarr); got {path.suffix or 'no suffix'!r}")
    if path.suffix.lower() in CAD_SUFFIXES:
        message += ("; fepre reads CAD geometry from STEP and BREP files only: export a STEP (or an STL) "
                    "from the CAD program")
    return message


class ModelFileError(ValueError):
    """A model file is missing, does not run, or does not define a usable ``model``."""


@dataclass
class ModelFile:
    """What a model file defines.

    Attributes
    ----------
    path : Path
        The file that was run.
    model : SDF
        The part.
    h : float or None
        Target edge length, if the file sets ``h``.
    bounds : ((min...), (max...)) or None
        Meshing/sampling box, if the file sets ``bounds`` (else the model's own bounds).
    boundaries : dict
        Named boundary sets (name -> SDF or callable), possibly empty.
    regions : dict
        Material regions (name -> SDF) that split the part, possibly empty.
    materials : dict
        Elastic material of each region (name -> ``(E, nu)`` or ``{"E": ..., "nu": ...}``), possibly empty.
    boundary_areas : dict
        The exact area of named boundary sets (name -> float > 0), as the user knows it from the
        drawing; ``fepre mesh`` prints each set's area beside it. Possibly empty.
    boundary_tolerance : float or None
        :func:`fepre.export`'s ``boundary_tolerance`` for the sets, if the file sets it (a
        triangle-mesh model's facets lie only near an exact cylinder named as a set).
    namespace : dict
        Every global the file defined.
    """

    path: Path
    model: SDF
    h: float | None = None
    bounds: Any = None
    boundaries: dict[str, Any] = field(default_factory=dict)
    regions: dict[str, Any] = field(default_factory=dict)
    materials: dict[str, Any] = field(default_factory=dict)
    boundary_areas: dict[str, float] = field(default_factory=dict)
    boundary_tolerance: float | None = None
    namespace: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        """The file's stem, used to name outputs."""
        return self.path.stem

    def domain_bounds(self):
        """``bounds`` if the file set it, else the model's bounds; an error if neither exists."""
        if self.bounds is not None:
            return self.bounds
        if self.model.bounds is None:
            raise ModelFileError(
                f"{self.path}: the model is unbounded; set `bounds = ((xmin, ymin, zmin), "
                "(xmax, ymax, zmax))` in the model file"
            )
        return self.model.bounds


def _error_line(exc: BaseException, path: Path) -> str:
    """' (line N)' for the deepest traceback frame inside ``path``, or ''."""
    line = None
    for frame in traceback.extract_tb(exc.__traceback__):
        if Path(frame.filename).resolve() == path:
            line = frame.lineno
    return f" (line {line})" if line is not None else ""


def _load_image(path: Path, image: dict | None) -> ModelFile:
    """An image file as a model: ``sdf.image`` at ``image["level"]`` (or, with
    ``image["labels"]``, ``sdf.labels`` and its regions)."""
    from .sdf import image as image_model
    from .sdf import labels

    options = dict(image or {})
    if options.pop("labels", False):
        try:
            regions = labels(path, **options)
        except ValueError as exc:
            raise ModelFileError(str(exc)) from None
        return ModelFile(path=path, model=regions.part, regions=dict(regions))
    level = options.pop("level", None)
    if level is None:
        raise ModelFileError(
            f"{path} is an image: pass --level, the grey value of the part's boundary (or, to fepre mesh, --labels for a "
            "label image)"
        )
    try:
        return ModelFile(path=path, model=image_model(path, level, **options))
    except ValueError as exc:
        raise ModelFileError(str(exc)) from None


def _load_mesh_file(path: Path, inside: str) -> ModelFile:
    """A surface, volume mesh or CAD file as one model (``sdf.mesh``)."""
    from .sdf import mesh

    try:
        return ModelFile(path=path, model=mesh(path, inside=inside))
    except ValueError as exc:
        raise ModelFileError(str(exc)) from None


def _load_solids(path: Path, names: dict, inside: str) -> ModelFile:
    """A CAD file's solids as regions (``--solids``)."""
    from .sdf import cad_solids
    from .sdf.meshmodel.cad_files import CAD_SUFFIXES as SOLID_SUFFIXES

    if path.suffix.lower() not in SOLID_SUFFIXES:
        raise ModelFileError(f"--solids takes a CAD file ({', '.join(SOLID_SUFFIXES)}), one region per solid; got {path}")
    if inside != "closed":
        raise ModelFileError(f"--inside {inside} applies to surface mesh files; {path} is a CAD file of solids")
    try:
        regions = cad_solids(path, names=names or None)
    except ValueError as exc:
        raise ModelFileError(str(exc)) from None
    return ModelFile(path=path, model=regions.part, regions=dict(regions))


#: the options of an image MODEL (``load_model(image=)``'s keys) and their flags
_IMAGE_FLAGS = {"smoothing": "--smoothing", "partial_volume": "--partial-volume", "spacing": "--voxel-size",
                "origin": "--origin", "labels": "--labels", "array": "--array"}


def _refuse_image_options(path: Path, image: dict | None) -> None:
    """A clear error for an image's option given with a model that is not an image."""
    given = [flag for key, flag in _IMAGE_FLAGS.items() if (image or {}).get(key) not in (None, False)]
    if given:
        raise ModelFileError(f"model file {path}: {', '.join(given)} applies to images (.vti, .nii, .nii.gz, .tif, "
                             f".zarr) only; {path.name} is not one")


def _is_image(path: Path) -> bool:
    from .sdf.imagemodel import IMAGE_SUFFIXES

    name = path.name.lower()
    return any(name.endswith(suffix) for suffix in IMAGE_SUFFIXES)


def load_model(path: str | os.PathLike, image: dict | None = None, *, inside: str = "closed",
               solids: dict | None = None) -> ModelFile:
    """Run a model file and return what it defines.

    Parameters
    ----------
    path : str or path-like
        A Python file defining ``model`` and optionally ``h``, ``bounds``, ``boundaries``; a
        surface mesh file (``MESH_SUFFIXES``: STL, OBJ, PLY, OFF, VTP, VTK) or a volume mesh file
        (VTU, Medit MESH, gmsh MSH, Abaqus/CalculiX INP: its boundary) or a CAD file (STEP,
        BREP: its solids tessellated), whose model is :func:`fepre.sdf.mesh` of it; or an image
        (``.vti``, ``.nii``, ``.nii.gz``, ``.tif``; a ``.zarr`` store is read chunk by chunk),
        whose model is :func:`fepre.sdf.image` of it with the options ``image``.
    image : dict, optional
        For an image file: ``level`` (required) and the keywords of :func:`fepre.sdf.image`
        (``inside``, ``smoothing``); or ``labels=True`` and the keywords of
        :func:`fepre.sdf.labels` (``names``, ``smoothing``): a label image, its regions.
    inside : {"closed", "winding"}
        For a surface mesh file, ``inside=`` of :func:`fepre.sdf.mesh` (``"winding"``: the solid
        where the generalised winding number exceeds 1/2, for open surfaces).
    solids : dict, optional
        For a CAD file, each solid a region: ``names`` of :func:`fepre.sdf.cad_solids` ({} for its defaults).

    Returns
    -------
    ModelFile

    Raises
    ------
    ModelFileError
        The file is missing, is not a ``.py`` file, has a syntax error, raises while running,
        defines no ``model``, or defines values of the wrong kind. The message names the file,
        the line where known, and the reason.

    Examples
    --------
    >>> load_model("no/such/file.py")
    Traceback (most recent call last):
    ...
    fepre.modelfile.ModelFileError: model file no/such/file.py does not exist
    """
    path = Path(path)
    if not path.exists():
        raise ModelFileError(f"model file {path} does not exist")
    if path.is_dir() and not _is_image(path):
        raise ModelFileError(f"model file {path} is a directory; give a .py file that defines `model`")
    if solids is not None:
        return _load_solids(path, solids, inside)
    image_inside = (image or {}).get("inside")
    if _is_image(path):
        if inside != "closed" or image_inside in ("closed", "winding"):
            raise ModelFileError(f"{path} is an image: --inside takes 'above' or 'below' for an image (the part is "
                                 f"where the image is above or below --level); got {image_inside or inside!r}")
        return _load_image(path, image)
    if image_inside in ("above", "below"):
        raise ModelFileError(f"model file {path}: --inside {image_inside} applies to images only; a surface mesh file "
                             "takes --inside closed or winding")
    _refuse_image_options(path, image)
    if path.suffix.lower() in MESH_SUFFIXES:
        return _load_mesh_file(path, inside)
    if inside != "closed":
        raise ModelFileError(f"model file {path}: --inside {inside} applies to surface mesh files "
                             f"({', '.join(MESH_SUFFIXES)}) only; a Python model file defines its solid itself")
    if path.suffix != ".py":
        raise ModelFileError(_not_a_model_file(path))
    resolved = path.resolve()
    folder = str(resolved.parent)
    sys.path.insert(0, folder)  # lets a model file import its neighbours
    try:
        namespace = runpy.run_path(str(resolved), run_name="__fepre_model__")
    except SyntaxError as exc:
        raise ModelFileError(f"{path}:{exc.lineno}: syntax error: {exc.msg}") from None
    except SystemExit as exc:
        raise ModelFileError(f"{path}: exited while loading (SystemExit {exc.code!r})") from None
    except Exception as exc:  # the user's code may raise anything
        raise ModelFileError(
            f"{path}: failed to run{_error_line(exc, resolved)}: {type(exc).__name__}: {exc}"
        ) from None
    finally:
        try:
            sys.path.remove(folder)
        except ValueError:  # pragma: no cover - the file removed it itself
            pass

    if "model" not in namespace:
        raise ModelFileError(f"{path} defines no `model`; add a line such as `model = sdf.sphere(1.0)`")
    model = namespace["model"]
    if not isinstance(model, SDF):
        raise ModelFileError(
            f"{path}: `model` must be an fepre SDF (built with fepre.sdf); got {type(model).__name__}"
        )
    if model.dim != 3:
        raise ModelFileError(f"{path}: `model` must be a 3D solid; got a {model.dim}D shape (extrude or revolve it)")

    try:
        h = namespace.get("h")
        h = None if h is None else positive_float(h, "h")
        bounds = namespace.get("bounds")
        bounds = None if bounds is None else as_bounds(bounds, 3, "bounds")
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: {exc}") from None

    boundaries = namespace.get("boundaries") or {}
    if not isinstance(boundaries, dict) or not all(isinstance(k, str) and callable(v) for k, v in boundaries.items()):
        raise ModelFileError(f"{path}: `boundaries` must be a dict of name -> SDF (or callable); got {boundaries!r:.80}")
    regions = namespace.get("regions") or {}
    if not isinstance(regions, dict) or not all(isinstance(k, str) and isinstance(v, SDF) for k, v in regions.items()):
        raise ModelFileError(f"{path}: `regions` must be a dict of name -> fepre SDF; got {regions!r:.80}")
    materials = namespace.get("materials") or {}
    if not isinstance(materials, dict):
        raise ModelFileError(f"{path}: `materials` must be a dict of region name -> (E, nu); got {materials!r:.80}")
    unknown = [name for name in materials if name not in regions]
    if unknown and regions:
        raise ModelFileError(f"{path}: `materials` names {unknown}, which are not in `regions` {list(regions)}")
    areas = _boundary_areas(path, namespace.get("boundary_areas") or {}, boundaries)
    tolerance = _boundary_tolerance(path, namespace.get("boundary_tolerance"))
    return ModelFile(path=path, model=model, h=h, bounds=bounds, boundaries=dict(boundaries), regions=dict(regions),
                     materials=dict(materials), boundary_areas=areas, boundary_tolerance=tolerance, namespace=namespace)


def _boundary_tolerance(path: Path, value: Any) -> float | None:
    """A model file's ``boundary_tolerance`` (None when unset), in (0, ``MAX_TOLERANCE``]."""
    if value is None:
        return None
    from .export.boundaries import MAX_TOLERANCE

    try:
        tolerance = positive_float(value, "boundary_tolerance")
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: {exc}") from None
    if tolerance > MAX_TOLERANCE:
        raise ModelFileError(f"{path}: `boundary_tolerance` must be in (0, {MAX_TOLERANCE:g}] (local edge lengths); got {tolerance:g}")
    return tolerance


def _boundary_areas(path: Path, areas: Any, boundaries: dict) -> dict[str, float]:
    """A model file's ``boundary_areas``: name (one of ``boundaries``) -> exact area > 0."""
    if not isinstance(areas, dict):
        raise ModelFileError(f"{path}: `boundary_areas` must be a dict of boundary name -> exact area; got {areas!r:.80}")
    unknown = [name for name in areas if name not in boundaries]
    if unknown:
        raise ModelFileError(f"{path}: `boundary_areas` names {unknown}, which are not in `boundaries` {list(boundaries)}")
    try:
        return {name: positive_float(value, f"boundary_areas[{name!r}]") for name, value in areas.items()}
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: {exc}") from None
