"""A real MRI as three regions: the MNI ICBM152 brain template, segmented into white matter, grey
matter and ventricles, meshed conformally, exported to CalculiX with one section per region and
solved under its own weight.

The data: the ICBM 2009a symmetric templates (T1 and the grey- and white-matter probability maps,
1 mm, 197 x 233 x 189) that nilearn's wheel ships as package data
(``nilearn/datasets/data/mni_icbm152_*_tal_nlin_sym_09a_converted.nii.gz``; Fonov et al.,
NeuroImage 2011; McConnell Brain Imaging Centre, Montreal Neurological Institute). They are read
with nibabel from the installed package's folder; nilearn itself is not imported (its imports
pull pandas and scikit-learn), so ``pip install --no-deps nilearn`` is enough. The templates'
licence is the file ``COPYING`` of the MNI's template archive, permissive (quoted as nibabel's
``mni_basal_ganglia`` README quotes it):

    Copyright (C) 1993-2004 Louis Collins, McConnell Brain Imaging Centre, Montreal Neurological
    Institute, McGill University. Permission to use, copy, modify, and distribute this software
    and its documentation for any purpose and without fee is hereby granted, provided that the
    above copyright notice appear in all copies. The authors and McGill University make no
    representations about the suitability of this software for any purpose. It is provided "as
    is" without express or implied warranty. The authors are not responsible for any data loss,
    equipment damage, property loss, or injury to subjects or patients resulting from the use or
    misuse of this software package.

The segmentation (:func:`mni152_labels`): the probabilities averaged over 2 x 2 x 2 voxels (2 mm)
and blurred by one voxel; the brain is where the T1 template is above 0.2 of its maximum (as
nilearn's ``load_mni152_brain_mask``), holes filled, the largest piece; in it each voxel takes
the largest of white matter, grey matter and the rest (1 - both: cerebrospinal fluid). The fluid
in the sulci is a sheet a voxel thick that no mesh at a few millimetres resolves, so the fluid is
opened by one voxel (what is left are the ventricles) and the rest joins the grey matter; pieces
of a label under 200 voxels join the label around them.

The check (:func:`calculix`): the brain, its surface held in the lowest 40 mm (the skull base),
carries its own weight
(``*DLOAD ... GRAV``; each tissue's density is in its section's material, written by
``fepre.export(materials={name: (E, nu, density)})``). What the support carries, CalculiX's
reaction plus the weight lumped straight onto the held nodes, must equal the weight of the
voxels, the sum over labels of voxel count x voxel volume x density x g, within the mesh's
volume error (2%); and the largest displacement has the scale of a column of the brain's
height above the support sagging under its own weight, rho g H^2 / (2 E) with the mean E
(brain tissue is soft: tens of millimetres, where linear elasticity is only a check).

Run: ``python examples/brain_mri.py [output folder]`` (about 1-3 minutes: the mesh at h = 5 mm,
then CalculiX when ``ccx`` is on the PATH).
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

import fepre
from fepre import sdf

#: the three tissues: label, name, (E in MPa, nu), density in t/mm^3
TISSUES = {
    1: ("white_matter", (1.9e-3, 0.45), 1.041e-9),
    2: ("grey_matter", (1.4e-3, 0.45), 1.045e-9),
    3: ("deep_structures", (1.2e-3, 0.47), 1.030e-9),
}
GRAVITY = 9810.0  # mm/s^2
#: the surface nodes this low (mm above the lowest) are held
SUPPORT = 40.0
#: grey matter and fluid deeper than this (mm) in the brain are the deep structures
DEEP = 20.0
TEMPLATE = "mni_icbm152_{}_tal_nlin_sym_09a_converted.nii.gz"


def template_folder() -> Path | None:
    """nilearn's folder of packaged templates, found without importing nilearn; None if absent."""
    spec = importlib.util.find_spec("nilearn")
    if spec is None or spec.origin is None:
        return None
    folder = Path(spec.origin).parent / "datasets" / "data"
    return folder if (folder / TEMPLATE.format("t1")).exists() else None


def mni152_labels(factor: int = 2, box: tuple | None = None) -> tuple[np.ndarray, tuple, tuple]:
    """The label image (1 white matter, 2 grey matter, 3 ventricles, 0 outside), its spacing and
    origin in mm (see the module); ``box`` ((x0, y0, z0), (x1, y1, z1)) in mm crops it."""
    import nibabel
    from scipy import ndimage

    folder = template_folder()
    if folder is None:
        raise FileNotFoundError("the MNI152 templates come with nilearn: pip install --no-deps nilearn")

    def load(name: str) -> tuple[np.ndarray, np.ndarray]:
        image = nibabel.load(folder / TEMPLATE.format(name))
        data = np.asarray(image.dataobj, dtype=np.float32)
        shape = (np.array(data.shape) // factor) * factor
        data = data[: shape[0], : shape[1], : shape[2]]
        blocks = data.reshape(shape[0] // factor, factor, shape[1] // factor, factor, shape[2] // factor, factor)
        return blocks.mean(axis=(1, 3, 5)) / 255.0, image.affine

    t1, affine = load("t1")
    grey, _ = load("gm")
    white, _ = load("wm")
    brain = ndimage.binary_fill_holes(ndimage.gaussian_filter(t1 / t1.max(), 1.0) > 0.2)
    pieces, _ = ndimage.label(brain)
    brain = pieces == np.argmax(np.bincount(pieces.ravel())[1:]) + 1
    grey, white = ndimage.gaussian_filter(grey, 1.0), ndimage.gaussian_filter(white, 1.0)
    share = np.stack([white, grey, np.clip(1.0 - grey - white, 0.0, 1.0)])
    labels = np.where(brain, np.argmax(share, axis=0) + 1, 0).astype(np.int16)
    # the fluid in the sulci is a sheet a voxel thick: it joins the grey matter, and what lies
    # deeper than DEEP mm in the brain (basal ganglia, thalamus, ventricles) is the third label
    depth = ndimage.distance_transform_edt(brain) * float(factor)
    labels[labels == 3] = 2
    labels[(labels == 2) & (depth > DEEP)] = 3
    for _ in range(3):  # small pieces join the label around them
        kept = labels == 0
        for label in (1, 2, 3):
            pieces, _ = ndimage.label(labels == label)
            sizes = np.bincount(pieces.ravel())
            kept |= (sizes >= 200)[pieces] & (pieces > 0)
        nearest = ndimage.distance_transform_edt(~kept, return_distances=False, return_indices=True)
        labels = labels[tuple(nearest)]
    spacing = np.abs(np.diag(affine)[:3]) * float(factor)
    origin = affine[:3, 3] + 0.5 * (factor - 1) * np.diag(affine)[:3]
    if box is not None:
        low = np.maximum(np.ceil((np.asarray(box[0]) - origin) / spacing), 0).astype(int)
        high = np.floor((np.asarray(box[1]) - origin) / spacing).astype(int) + 1
        labels = labels[low[0] : high[0], low[1] : high[1], low[2] : high[2]]
        origin = origin + low * spacing
    return labels, tuple(spacing.tolist()), tuple(origin.tolist())


def calculix(mesh, folder: Path, voxel_weight: float) -> dict | None:
    """Export with one section per tissue, hold the lowest 6 mm, load each region by its weight;
    the vertical reaction and displacements CalculiX finds (None without ``ccx``)."""
    materials = {name: (*elastic, density) for name, elastic, density in TISSUES.values()}
    written = fepre.export(mesh, folder / "brain.inp", materials=materials)
    points = np.asarray(written.points)
    # the skull base carries the brain: its surface nodes in the lowest SUPPORT mm are held
    surface = np.asarray(mesh.point_data["boundary"]) == 1
    base = np.flatnonzero(surface & (points[:, 2] <= points[:, 2].min() + SUPPORT)) + 1
    ccx = shutil.which("ccx")
    if ccx is None:
        return None
    rows = "\n".join(", ".join(str(n) for n in base[k : k + 16]) for k in range(0, len(base), 16))
    job = (
        f"*INCLUDE, INPUT=brain.inp\n*NSET, NSET=BASE\n{rows}\n*BOUNDARY\nBASE, 1, 3\n"
        f"*STEP\n*STATIC\n*DLOAD\nEALL, GRAV, {GRAVITY!r}, 0., 0., -1.\n*NODE PRINT, NSET=BASE, TOTALS=ONLY\nRF\n"
        "*NODE PRINT, NSET=NALL\nU\n*END STEP\n"
    )
    (folder / "job.inp").write_text(job)
    env = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1")
    done = subprocess.run([ccx, "-i", "job"], cwd=folder, capture_output=True, text=True, timeout=900, env=env)
    if done.returncode != 0 or "*ERROR" in done.stdout:
        raise RuntimeError(f"CalculiX failed: {done.stdout[-2000:]}")
    text = (folder / "job.dat").read_text()
    total = re.search(r"total force.*\n\s*\n?\s*([-+0-9.Ee]+)\s+([-+0-9.Ee]+)\s+([-+0-9.Ee]+)", text)
    block = text[text.index("displacements") :]
    numbers = re.findall(r"^\s*(\d+)\s+([-+0-9.Ee]+)\s+([-+0-9.Ee]+)\s+([-+0-9.Ee]+)\s*$", block, flags=re.M)
    displacement = np.array([[float(v) for v in row[1:]] for row in numbers])
    # CalculiX's reaction is K u at the held nodes: the weight lumped onto them (a quarter of
    # each tetrahedron's weight per node) goes straight into the support and is not in it
    cells = np.asarray(written.cells_dict[10])
    a, b, c, d = (points[cells[:, k]] for k in range(4))
    volume = np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))) / 6.0
    density = np.array([t[2] for t in TISSUES.values()])[np.asarray(written.cell_data["region_id"])]
    held = np.isin(cells + 1, base).sum(axis=1)
    direct = float((density * GRAVITY * volume / 4.0 * held).sum())
    # a column of the brain's height above the support, with the tissues' mean stiffness, sags
    # by rho g H^2 / (2 E) under its own weight: the scale the largest displacement should have
    young = np.array([t[1][0] for t in TISSUES.values()])[np.asarray(written.cell_data["region_id"])]
    height = points[:, 2].max() - points[:, 2].min() - SUPPORT
    column = float((density * volume).sum() / volume.sum() * GRAVITY * height**2 / (2.0 * (young * volume).sum() / volume.sum()))
    return {
        "column_sag": column,
        "reaction_z": float(total.group(3)),
        "support_z": float(total.group(3)) + direct,
        "weight_voxels": voxel_weight,
        "max_displacement": float(np.linalg.norm(displacement, axis=1).max()),
        "mean_displacement_z": float(displacement[:, 2].mean()),
        "base_nodes": len(base),
    }


def main(folder: str = ".", h: float = 5.0) -> dict:
    folder = Path(folder)
    labels, spacing, origin = mni152_labels()
    voxel = float(np.prod(spacing))
    counts = np.bincount(labels.ravel(), minlength=4)
    regions = sdf.labels(labels, spacing=spacing, origin=origin, names={k: v[0] for k, v in TISSUES.items()})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        mesh = fepre.distmesh(regions.part, h, regions=regions, progress=False, features=False)
    ids = np.asarray(mesh["region_id"])
    volumes = np.bincount(ids, mesh["volume"], minlength=3)
    figures = {"cells": mesh.n_cells, "shape": labels.shape}
    for k, (label, (name, _, density)) in enumerate(TISSUES.items()):
        figures[f"volume_{name}_voxels"] = float(counts[label] * voxel)
        figures[f"volume_{name}_model"] = float(regions[name].volume)
        figures[f"volume_{name}_mesh"] = float(volumes[k])
        figures[f"min_dihedral_{name}"] = float(mesh["min_dihedral_angle"][ids == k].min())
    weight = sum(counts[label] * voxel * density * GRAVITY for label, (_, _, density) in TISSUES.items())
    figures["weight_mesh"] = float(sum(volumes[k] * d * GRAVITY for k, (_, _, d) in enumerate(TISSUES.values())))
    solved = calculix(mesh, folder, float(weight))
    figures.update(solved or {"reaction_z": None})
    for name, value in figures.items():
        print(f"{name:28s} {value if value is not None else 'ccx not installed'}")
    return figures


if __name__ == "__main__":
    if template_folder() is None:
        print("the MNI152 templates come with nilearn: pip install --no-deps nilearn")
        sys.exit(0)
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
