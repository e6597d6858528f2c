"""A seeded corpus of random CAD-style parts, and an independent check of their meshes.

:func:`fepre.corpus.parts` makes the parts (:mod:`fepre.corpus.generate`), by category: touching
and coplanar faces, acute angles, re-entrant corners, small holes, narrow gaps, thin plates,
lattices, tiny, huge and far-off parts, and random CSG. :func:`fepre.corpus.check_mesh`
(:mod:`fepre.corpus.validate`) checks a mesh without fepre's own quality code. ``fepre bench
corpus`` meshes the whole corpus with fepre and pytetwild and prints a table by category.
"""

from .generate import ALIGNED, CATEGORIES, CorpusPart, parts
from .validate import MeshCheck, cell_measures, check_mesh, monte_carlo_volume

__all__ = ["ALIGNED", "CATEGORIES", "CorpusPart", "parts", "MeshCheck", "check_mesh", "cell_measures", "monte_carlo_volume"]
