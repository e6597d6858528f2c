"""Every script in examples/ runs to completion (examples are also tests)."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = sorted((Path(__file__).parent.parent / "examples").glob("*.py"))
# examples whose main() a test below runs and checks (not run twice)
CHECKED = {"adaptive_remeshing", "cube_with_hole", "simp_cantilever", "brain_mri"}
RUN_ONLY = [p for p in EXAMPLES if p.stem not in CHECKED]
# 7-11 s each in the default run on 2 cores: run with the long proofs
SLOW = {"regions", "chunked_surfaces", "periodic_cell", "compare_with_pytetwild"}


@pytest.mark.parametrize("script", [pytest.param(p, id=p.stem, marks=[pytest.mark.slow] if p.stem in SLOW else [])
                                    for p in RUN_ONLY])
def test_example_runs(script, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(script), str(tmp_path)])
    runpy.run_path(str(script), run_name="__main__")
    assert any(tmp_path.iterdir()), f"{script.name} wrote nothing into its output folder"


@pytest.mark.slow  # 3 s of the default run on 2 cores
def test_cube_with_hole_surface_is_closed_with_the_right_volume(tmp_path):
    namespace = runpy.run_path(str(EXAMPLES[[p.stem for p in EXAMPLES].index("cube_with_hole")]))
    check = namespace["main"](str(tmp_path))
    assert (tmp_path / "cube_with_hole.stl").stat().st_size > 10_000
    assert check.watertight and check.manifold and check.oriented
    assert check.genus == 1
    assert check.volume == pytest.approx(125 - 5 * 3.141592653589793, rel=5e-3)


@pytest.mark.slow
def test_adaptive_remeshing_beats_uniform_refinement_per_cell(tmp_path):
    """Issue 14: on the L-block's singular edge the energy error falls faster per cell when each
    mesh is the background size of the next (from a Zienkiewicz-Zhu estimate) than uniformly."""
    pytest.importorskip("skfem")
    namespace = runpy.run_path(str(EXAMPLES[[p.stem for p in EXAMPLES].index("adaptive_remeshing")]))
    uniform, adaptive = namespace["main"](str(tmp_path))
    assert (tmp_path / "adapted_l_block.vtu").stat().st_size > 10_000
    rate = namespace["rate"]
    # uniform refinement: the singularity's rate, (2/3) / 3 per cell in 3D
    assert rate(uniform) == pytest.approx(-2 / 9, abs=0.06)
    assert rate(adaptive) < rate(uniform) - 0.1
    # fewer cells, smaller error than the finest uniform mesh
    assert adaptive[-1][0] < 0.5 * uniform[-1][0] and adaptive[-1][1] < uniform[-1][1]


@pytest.mark.slow
def test_simp_density_to_a_calculix_solve(tmp_path):
    """Issue 35: a SIMP cantilever's density, thresholded by sdf.image, meshed and solved in
    CalculiX (about 30 s of CPU: the SIMP loop and the solves), its compliance within a few
    percent of the SIMP model's."""
    pytest.importorskip("skfem")
    import shutil

    namespace = runpy.run_path(str(EXAMPLES[[p.stem for p in EXAMPLES].index("simp_cantilever")]))
    figures = namespace["main"](str(tmp_path))
    assert figures["volume_fraction"] == pytest.approx(0.3, abs=1e-3)
    # the projection ends nearly black and white: thresholding changes little
    assert figures["compliance_thresholded_hex"] == pytest.approx(figures["compliance_simp"], rel=0.12)
    assert figures["volume_mesh"] == pytest.approx(figures["volume_thresholded_cells"], rel=0.03)
    assert figures["min_dihedral"] >= 25.0
    assert (tmp_path / "cantilever.inp").exists() and (tmp_path / "density.vti").exists()
    # the same design with triquadratic hexahedra on the SIMP grid: the trilinear ones lock in bending
    assert figures["compliance_thresholded_hex27"] == pytest.approx(1.449, rel=0.03)
    if shutil.which("ccx") is not None:
        # under the same total force the meshed part's compliance is the SIMP model's within a few
        # percent (measured 1.374 against 1.429) and the converged design's (1.449)
        assert figures["compliance_calculix"] == pytest.approx(figures["compliance_simp"], rel=0.05)
        assert figures["compliance_calculix"] == pytest.approx(figures["compliance_thresholded_hex27"], rel=0.06)


def _brain():
    namespace = runpy.run_path(str(EXAMPLES[[p.stem for p in EXAMPLES].index("brain_mri")]))
    if namespace["template_folder"]() is None:
        pytest.skip("the MNI152 templates come with nilearn: pip install --no-deps nilearn")
    return namespace


def test_brain_mri_labels_from_the_mni_templates():
    """Issue 35: the reader of the real scan: three labels that fill the brain mask nilearn
    defines (its T1 template above 0.2 of its maximum), counted at 1 mm independently."""
    pytest.importorskip("nibabel")
    namespace = _brain()
    import nibabel

    labels, spacing, origin = namespace["mni152_labels"]()
    assert labels.shape == (98, 116, 94) and spacing == (2.0, 2.0, 2.0)
    counts = np.bincount(labels.ravel(), minlength=4) * 8.0 / 1e3  # mL
    t1 = np.asarray(nibabel.load(namespace["template_folder"]() / namespace["TEMPLATE"].format("t1")).dataobj, float)
    mask = (t1 / t1.max() > 0.2).sum() / 1e3
    # measured 1944 mL against 1883 (+3.3%: the mask is blurred by 2 mm and its holes filled)
    assert counts[1:].sum() == pytest.approx(mask, rel=0.04)
    assert counts[1] > 500 and counts[2] > 800 and counts[3] > 200  # 598, 1047, 299 mL


@pytest.mark.slow
def test_brain_mri_meshed_and_solved_under_its_own_weight(tmp_path):
    """Issue 35: a real MRI as three regions, meshed conformally, exported with a section (and
    density) per tissue, solved in CalculiX (about 6-8 minutes on a loaded 2-core machine)."""
    import shutil

    namespace = _brain()
    figures = namespace["main"](str(tmp_path))
    for name, _, _ in namespace["TISSUES"].values():
        # measured -0.45%, +0.27%, -1.52%
        assert figures[f"volume_{name}_mesh"] == pytest.approx(figures[f"volume_{name}_voxels"], rel=0.02)
    text = (tmp_path / "brain.inp").read_text()
    assert text.count("*SOLID SECTION") == 3 and text.count("*DENSITY") == 3
    if shutil.which("ccx") is not None:
        # what the support carries is the voxels' weight, to the mesh's volume error
        assert figures["support_z"] == pytest.approx(figures["weight_voxels"], rel=0.02)
        assert figures["support_z"] == pytest.approx(figures["weight_mesh"], rel=1e-4)
        assert figures["mean_displacement_z"] < 0
        # the largest displacement against a column's sag under its own weight (held at its
        # lowest 6 mm only, the brain hung off the brainstem and moved 30 m)
        assert 0.3 < figures["max_displacement"] / figures["column_sag"] < 3.0
