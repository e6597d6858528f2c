"""The solids of a STEP or BREP assembly as regions: one model per solid, meshed conformally.

An assembly file holds several bodies: a pin in a plate's bore, a block bolted to a base, an
insert moulded into a housing. :func:`cad_solids` imports it with OpenCASCADE (through gmsh, in
a separate interpreter as :mod:`.cad_files` does), fragments the solids so that faces they share
are one face, tessellates the faces once and returns one :class:`~fepre.sdf.MeshModel` per
solid, whose surfaces coincide triangle for triangle where two solids touch, and the part they
make together. ``fepre.distmesh(solids.part, h, regions=solids)`` gives one conformal mesh with
one element set per solid, which a solver can give each its own material or bond.

Where two solids overlap (an interference of the assembly, or an insert modelled whole inside
its housing), the overlap goes to the smaller of them, which stays whole, with a warning naming
both and the overlap's volume.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ...child_runs import run_child
from .cad_files import CAD_SUFFIXES, TIMEOUT, import_shapes, mesh_faces

__all__ = ["cad_solids", "SolidRegions"]


class SolidRegions(dict):
    """Solid name -> model of an assembly's solid (a dict, for ``regions=``), with the part.

    Attributes
    ----------
    part : fepre.sdf.MeshModel
        The union of the solids: the model to mesh.
    volumes : dict
        Solid name -> its volume as OpenCASCADE computes it (exact for the CAD geometry).
    path : pathlib.Path
        The file read.
    """

    part: Any
    volumes: dict
    path: Path


def cad_solids(path: str | os.PathLike, names: dict | None = None, *, timeout: float = TIMEOUT) -> SolidRegions:
    """The solids of a STEP or BREP file as regions of one part.

    Parameters
    ----------
    path : str or path-like
        A ``.step``, ``.stp`` or ``.brep`` file holding one or more solids.
    names : dict, optional
        Solid number (1, 2, ... in the file's order) -> region name. The default is the
        solid's name in the file where it has one (letters, digits, ``_`` and ``-`` kept),
        else ``solid_<number>``.
    timeout : float
        Seconds the import and tessellation may take.

    Returns
    -------
    SolidRegions
        Region name -> :class:`~fepre.sdf.MeshModel`, in the file's order, with ``part``.

    Raises
    ------
    fepre.sdf.MeshInputError
        The file is not a CAD file, holds no solid, OpenCASCADE could not read it, or
        ``names`` gives a number the file has no solid for.

    Warns
    -----
    fepre.ResolutionWarning
        Two solids overlap: the overlap's volume and which solid gets it (the smaller, which
        stays whole: the housing round an insert modelled whole in it gets the cavity).

    Examples
    --------
    >>> import fepre
    >>> from fepre import sdf
    >>> solids = sdf.cad_solids("pin_in_plate.step", names={1: "plate", 2: "pin"})  # doctest: +SKIP
    >>> mesh = fepre.distmesh(solids.part, 1.0, regions=solids)                     # doctest: +SKIP
    """
    from .model import MeshInputError

    path = Path(path)
    if path.suffix.lower() not in CAD_SUFFIXES:
        raise MeshInputError(f"cad_solids reads {', '.join(CAD_SUFFIXES)} files; got {path}")
    if not path.exists():
        raise MeshInputError(f"{path} does not exist")
    if names is not None and not isinstance(names, dict):
        raise TypeError(f"names must be a dict of solid number -> region name (e.g. {{1: 'plate'}}); got {type(names).__name__}")
    with tempfile.TemporaryDirectory(prefix="fepre-cad-") as scratch:
        out = os.path.join(scratch, "solids.npz")
        command = [sys.executable, "-m", "fepre.sdf.meshmodel.cad_solids", str(path.resolve()), out]
        try:
            run_child(command, out, timeout=timeout, cwd=scratch, tool="OpenCASCADE", doing=f"reading {path}",
                      error=ValueError)
        except ValueError as exc:
            raise MeshInputError(str(exc)) from None
        with np.load(out) as result:
            found = {key: result[key] for key in result.files}
    return _regions(path, found, names)


def _region_names(path: Path, file_names: list[str], names: dict | None) -> list[str]:
    from .model import MeshInputError

    chosen = []
    for number, name in enumerate(file_names, start=1):
        name = re.sub(r"[^A-Za-z0-9_-]+", "_", name.rsplit("/", 1)[-1]).strip("_")
        chosen.append(name if name and "translator" not in name else f"solid_{number}")
    if len(set(chosen)) < len(chosen):  # a name given to several solids: each numbered
        chosen = [f"{name}_{number}" if chosen.count(name) > 1 else name for number, name in enumerate(chosen, start=1)]
    unknown = [k for k in (names or {}) if not isinstance(k, (int, np.integer)) or not 1 <= k <= len(chosen)]
    if unknown:
        raise MeshInputError(f"{path}: names (fepre mesh --solid NUMBER=NAME) gives solids {unknown}; the file "
                             f"holds solids 1 to {len(chosen)}")
    for number, name in (names or {}).items():
        chosen[number - 1] = str(name)
    if len(set(chosen)) < len(chosen):
        raise MeshInputError(f"{path}: two solids would share a region name ({', '.join(chosen)}); give each its own")
    return chosen


def _overlaps_message(path: Path, overlaps: np.ndarray, names: list[str]) -> str:
    """One line per pair of solids that overlap: the volume, in how many pieces, who gets it
    (the first named)."""
    pairs, inverse = np.unique(overlaps[:, :2].astype(np.int64), axis=0, return_inverse=True)
    volumes = np.bincount(inverse.ravel(), overlaps[:, 2], minlength=len(pairs))
    pieces = np.bincount(inverse.ravel(), minlength=len(pairs))
    listed = "; ".join(
        f"{names[a]} and {names[b]} by a volume of {v:.6g}" + (f" in {n} pieces" if n > 1 else "")
        for (a, b), v, n in zip(pairs, volumes, pieces))
    return (f"{path}: {len(pairs)} pair(s) of solids overlap (interference): {listed}; each overlap is meshed as part "
            "of the first solid named, the smaller of the two, which stays whole (an insert or a pin modelled whole "
            "in its housing)")


def _regions(path: Path, found: dict, names: dict | None) -> SolidRegions:
    """The region models from the child's arrays: each solid's faces once (a face between two of
    its own pieces, an overlap it took, is inside it), turned to face out of it."""
    import pyvista as pv

    from ...errors import ResolutionWarning
    from .model import MeshInputError, mesh
    from .repair import _orient as orient

    points, triangles, surface = found["points"], found["triangles"], found["triangle_surface"]
    owner = found["piece_owner"]  # (P,) the solid each fragment piece goes to
    piece, face = found["boundary_piece"], found["boundary_surface"]
    solid_names = _region_names(path, [str(n) for n in found["names"]], names)
    if len(found["overlaps"]):
        warnings.warn(_overlaps_message(path, found["overlaps"], solid_names), ResolutionWarning, stacklevel=3)
    order = np.argsort(surface, kind="stable")
    starts = np.searchsorted(surface[order], np.arange(int(surface.max()) + 2)) if len(surface) else np.zeros(1, int)

    def closed_surface(faces: np.ndarray) -> pv.PolyData:
        keys, counts = np.unique(faces, return_counts=True)
        once = set(keys[counts == 1].tolist())
        chosen = [triangles[order[starts[f]:starts[f + 1]]] for f in faces if int(f) in once]
        # gmsh's triangles of a face shared by two solids face one way: each solid's turned out of it
        closed, _ = orient(points, np.concatenate(chosen))
        return pv.PolyData.from_regular_faces(points, closed)

    regions = SolidRegions()
    regions.path, regions.volumes = path, {}
    for number, name in enumerate(solid_names):
        if not (owner == number).any():  # every piece of it went to another solid: a copy of it
            twin = solid_names[int(owner[np.flatnonzero(found["piece_holders"][:, number])[0]])]
            raise MeshInputError(f"{path}: solid {number + 1} ({name}) is the same body as {twin}: the file holds it twice; "
                                 "remove the copy")
        mine = np.isin(piece, np.flatnonzero(owner == number))
        regions[name] = mesh(closed_surface(face[mine]))
        regions.volumes[name] = float(found["piece_volume"][owner == number].sum())
    regions.part = mesh(closed_surface(face)) if len(solid_names) > 1 else next(iter(regions.values()))
    for model in regions.values():  # each lies in the part: its own part for its sizes and interfaces
        model.within = regions.part
    return regions


def _tessellate_solids(path: str) -> dict:
    """In the child: import ``path``, fragment its solids, mesh the faces once; the arrays
    :func:`_regions` reads."""
    import gmsh

    from ...child_runs import gmsh_cells

    gmsh.initialize(interruptible=False)
    try:
        import_shapes(path)
        inputs = gmsh.model.getEntities(3)
        if not inputs:
            raise ValueError("the file holds no solid")
        file_names = [gmsh.model.getEntityName(3, tag) for _, tag in inputs]
        solid_volumes = [gmsh.model.occ.getMass(3, tag) for _, tag in inputs]
        mapping = [[entity] for entity in inputs]
        if len(inputs) > 1:
            try:
                _, mapping = gmsh.model.occ.fragment(inputs[:1], inputs[1:])
            except Exception as exc:  # noqa: BLE001
                raise ValueError(f"OpenCASCADE could not fragment its solids ({str(exc).strip()[:200]})") from None
            gmsh.model.occ.synchronize()
        pieces = sorted({tag for found in mapping for dim, tag in found if dim == 3})
        # a piece held by several solids (an overlap) goes to the smallest of them, which stays
        # whole: an insert, pin or bushing modelled whole in its housing (first in the file on a tie)
        holders = {tag: sorted((i for i, found in enumerate(mapping) if (3, tag) in found), key=lambda i: solid_volumes[i])
                   for tag in pieces}
        volumes = np.array([gmsh.model.occ.getMass(3, tag) for tag in pieces])
        overlaps = [(holders[tag][0], other, volume) for tag, volume in zip(pieces, volumes) for other in holders[tag][1:]]
        mesh_faces()
        points, _ = gmsh_cells(2, 2, 3) or (None, None)
        if points is None:
            raise ValueError("tessellating its faces gave no triangles")
        tags, _, _ = gmsh.model.mesh.getNodes()
        node_order = np.argsort(tags)
        triangles, triangle_surface = [], []
        for _, surface in gmsh.model.getEntities(2):
            types, _, nodes = gmsh.model.mesh.getElements(2, surface)
            if 2 in list(types):
                cells = np.asarray(nodes[list(types).index(2)], dtype=np.int64).reshape(-1, 3)
                triangles.append(np.searchsorted(tags[node_order], cells))
                triangle_surface.append(np.full(len(cells), surface))
        boundary = [(k, abs(tag)) for k, piece in enumerate(pieces) for _, tag in gmsh.model.getBoundary([(3, piece)])]
        return {
            "points": points, "triangles": np.concatenate(triangles), "triangle_surface": np.concatenate(triangle_surface),
            "piece_owner": np.array([holders[tag][0] for tag in pieces]), "piece_volume": volumes,
            "piece_holders": np.array([[i in holders[tag] for i in range(len(inputs))] for tag in pieces]).reshape(-1, len(inputs)),
            "boundary_piece": np.array([b[0] for b in boundary]), "boundary_surface": np.array([b[1] for b in boundary]),
            "names": np.array(file_names, dtype=str),
            "overlaps": np.array(overlaps, dtype=np.float64).reshape(-1, 3),
        }
    finally:
        gmsh.finalize()


def main(arguments: list[str]) -> int:
    """``python -m fepre.sdf.meshmodel.cad_solids CAD OUT.npz``: the solids' faces into OUT.npz."""
    path, out = arguments
    try:
        found = _tessellate_solids(path)
    except ValueError as exc:
        Path(out + ".error").write_text(str(exc), encoding="utf-8")
        return 1
    np.savez(out, **found)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
