"""Holes the mesh makes or closes: the genus of its surface against the model's.

A wall thinner than ``h`` can come out punched through, and a hole narrower than ``h`` bridged,
with little volume: a 2.5 mm rib meshed at h = 4.8 got a hole of about 170 mm^3 (1.5 h^3), under
the lost-material check's floor of ``2 h^3``, and nothing was said. The floor is right for what
it is for (the few elements' worth that chords fill or cut at an acute corner); a change of
topology is not a matter of volume. Where the check found regions under its floor, the genus of
the mesh's boundary is compared with the model's: a closed triangle-mesh model's own triangles,
else the zero set on the check's grid at ``h / 4`` (flying edges; only where that grid covers
the whole box, not a graded mesh's zones). Where they differ, those regions are named.
"""

from __future__ import annotations

import numpy as np

from ..surface.check import surface_genus

__all__ = ["surface_genus", "model_genus", "genus_change"]


def model_genus(model, grid) -> int | None:
    """The genus of the model's surface: a closed triangle-mesh model's own (through the moves
    of a part far from the origin), else its zero set on ``grid`` (the lost-material check's
    sampling, ``values``/``origin``/``step``), or None."""
    from .lost_material import mesh_model_of

    given, _ = mesh_model_of(model)
    if given is not None and given.inside == "closed" and given.repaired.closed:
        return surface_genus(given.faces)
    if grid is None:
        return None
    import pyvista as pv

    from ..surface import isosurface

    nz, ny, nx = grid.values.shape
    image = pv.ImageData(dimensions=(nx, ny, nz), spacing=tuple(grid.step), origin=tuple(grid.origin))
    image.point_data["sdf"] = grid.values.ravel()
    return surface_genus(isosurface(image).regular_faces)


def genus_change(faces: np.ndarray, model, grid, lost: list, added: list) -> str | None:
    """"the mesh's surface has genus 3 where the model's has 2 (...)" when the mesh's boundary
    ``faces`` have another genus than the model and the regions ``lost`` or ``added`` account
    for it, else None."""
    meshed = surface_genus(faces)
    expected = model_genus(model, grid) if meshed is not None else None
    if expected is None or meshed == expected:
        return None
    # the regions found are the evidence: material lost for a hole punched, added for one
    # bridged. The zero set on a grid of h / 4 is perforated where the model is a sheet about
    # that thin: camelhead.off's grid had genus 9, its mesh 0, and only a lost region (a wall
    # 0.016 thick) was found; "a hole bridged" was not what happened
    if (meshed > expected and not lost) or (meshed < expected and not added):
        return None
    how = ("a wall thinner than the mesh resolves punched through, or a hole's rim cut" if meshed > expected
           else "a hole or a gap narrower than the mesh resolves bridged")
    return f"the mesh's surface has genus {meshed} where the model's has {expected} ({how})"
