"""TIFF stacks and the voxel size their metadata carries.

A stack of slices has no standard voxel size; the two common records are read:

- OME-TIFF (microscopes, Bio-Formats): the ``PhysicalSizeX``, ``PhysicalSizeY`` and
  ``PhysicalSizeZ`` attributes of the OME-XML ``Pixels`` element;
- ImageJ/Fiji (and the tools that write its hyperstacks, such as tifffile's ``imagej=True``): the
  slice step ``spacing`` in the ImageJ description and the x/y ``XResolution``/``YResolution``
  tags, in pixels per ``unit``.

A plain TIFF's resolution tags are a print density (72 dpi) and are not a voxel size. A stack
without either record has none: the caller uses 1 and says so.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np

__all__ = ["read_tiff_stack"]


def _ome_spacing(description: str) -> np.ndarray | None:
    try:
        root = ElementTree.fromstring(description)
    except ElementTree.ParseError:
        return None
    pixels = next((element for element in root.iter() if element.tag.rsplit("}", 1)[-1] == "Pixels"), None)
    if pixels is None:
        return None
    sizes = [pixels.get(f"PhysicalSize{axis}") for axis in "XYZ"]
    if sizes[0] is None or sizes[1] is None:
        return None
    return np.array([float(sizes[0]), float(sizes[1]), float(sizes[2] or sizes[0])])


def _per_pixel(page, tag: str) -> float | None:
    found = page.tags.get(tag)
    if found is None:
        return None
    value = found.value
    numerator, denominator = value if isinstance(value, tuple) else (value, 1)
    return float(denominator) / float(numerator) if numerator else None


def _imagej_spacing(tif) -> np.ndarray | None:
    metadata = tif.imagej_metadata or {}
    page = tif.pages[0]
    x, y = _per_pixel(page, "XResolution"), _per_pixel(page, "YResolution")
    z = metadata.get("spacing")
    if x is None and z is None:
        return None
    x = 1.0 if x is None else x
    return np.array([x, x if y is None else y, float(z) if z is not None else x])


def read_tiff_stack(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """The values of a TIFF stack, (nx, ny, nz) with index ``i`` along x, and the voxel size its
    OME or ImageJ metadata gives (None when it gives none).

    Examples
    --------
    >>> import tempfile, numpy as np, tifffile
    >>> path = tempfile.mkdtemp() + "/stack.tif"
    >>> tifffile.imwrite(path, np.zeros((3, 4, 5), np.uint8), imagej=True, resolution=(10.0, 10.0),
    ...                  metadata={"spacing": 0.25, "unit": "mm"})
    >>> values, spacing = read_tiff_stack(path)
    >>> values.shape, spacing.tolist()
    ((5, 4, 3), [0.1, 0.1, 0.25])
    """
    import tifffile

    with tifffile.TiffFile(str(path)) as tif:
        values = np.asarray(tif.asarray())
        spacing = None
        if tif.is_ome and tif.ome_metadata:
            spacing = _ome_spacing(tif.ome_metadata)
        if spacing is None and tif.is_imagej:
            spacing = _imagej_spacing(tif)
    if values.ndim == 3:  # a stack is (slices, rows, columns): z, y, x
        values = np.transpose(values, (2, 1, 0))
    if spacing is not None and (not np.isfinite(spacing).all() or (spacing <= 0).any()):
        spacing = None
    return values, spacing
