"""Images as models: grey-value images (CT scans, densities) and label images.

Examples
--------
>>> import numpy as np
>>> from fepre import sdf
>>> x, y, z = np.mgrid[-1:1:21j, -1:1:21j, -1:1:21j]
>>> ball = sdf.image(1.0 - np.sqrt(x**2 + y**2 + z**2), level=0.5, spacing=0.1, origin=-1.0)
>>> ball.bounds[1][0] > 0.49, round(float(ball([0.0, 0.0, 0.0])), 2)
(True, -0.5)
"""

from .labelmodel import LabelModel, LabelRegions, labels
from .model import ImageModel, image
from .read import IMAGE_SUFFIXES, Image, ImageInputError, read_image

__all__ = ["image", "labels", "ImageModel", "LabelRegions", "LabelModel", "ImageInputError", "Image", "read_image", "IMAGE_SUFFIXES"]
