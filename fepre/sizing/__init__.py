"""Size fields: the edge length a mesh should have at every point.

:func:`size_field` builds one from the model itself (wall thickness, gap widths, curvature,
close sharp edges, a gradation limit); :class:`SizeField` also comes from a background mesh
with sizes (:meth:`SizeField.from_mesh`) or an image (:meth:`SizeField.from_image`), combines
with others by the smaller size and turns into a :class:`pyvista.ImageData`.
:func:`fepre.distmesh` meshes with one (``h=(hmin, hmax)`` or ``size=field``).

Examples
--------
>>> import fepre
>>> from fepre import sdf
>>> plate = sdf.box((20.0, 20.0, 2.0)) - sdf.cylinder(0.5, 3.0)
>>> field = fepre.size_field(plate, 0.05, 4.0)
>>> [round(float(s), 2) for s in field([[0.5, 0.0, 0.0], [8.0, 8.0, 1.0]])]   # at the hole (chord), on a face (2/3, less a level)
[0.14, 0.65]
"""

from .build import size_field
from .field import MAX_NODES, SizeField

__all__ = ["size_field", "SizeField", "MAX_NODES"]
