"""The HTML report: one self-contained file with the table, histograms and mesh pictures."""

from __future__ import annotations

import base64
import io
import math
import re

import numpy as np
import pytest
from PIL import Image

import fepre
from fepre import sdf
from fepre.report import write_report

SPHERE_VOLUME = 4.0 * math.pi / 3.0


@pytest.fixture(scope="module")
def comparison():
    return fepre.compare(sdf.sphere(1.0), 0.5, references=("gmsh",), exact_volume=SPHERE_VOLUME, surface_spacing=0.125)


@pytest.fixture(scope="module")
def report_text(comparison, tmp_path_factory):
    path = tmp_path_factory.mktemp("report") / "report.html"
    assert comparison.to_html(path) == path
    return path.read_text(encoding="utf-8")


def _images(text: str) -> list[np.ndarray]:
    uris = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', text)
    return [np.asarray(Image.open(io.BytesIO(base64.b64decode(uri))).convert("RGB")) for uri in uris]


def test_report_embeds_its_images_and_links_nothing_outside(report_text):
    images = _images(report_text)
    # one histogram figure + one picture per mesh (fepre, gmsh)
    assert len(images) == 3
    for image in images:
        assert image.shape[0] > 300 and image.shape[1] > 500
        not_white = np.any(image < 235, axis=2).mean()
        assert not_white > 0.05, "an image is blank"
        assert len(np.unique(image.reshape(-1, 3), axis=0)) > 50, "an image has almost no content"
    assert "http://" not in report_text and "https://" not in report_text
    assert "<script" not in report_text


def test_report_table_holds_the_comparison_figures(comparison, report_text):
    fepre_metrics = comparison["fepre"].metrics
    gmsh_metrics = comparison["gmsh"].metrics
    row = re.search(r"<tr><th>tetrahedra</th>(.*?)</tr>", report_text).group(1)
    cells = re.findall(r">(\d+)</td>", row)
    assert cells == [str(fepre_metrics["elements"]), str(gmsh_metrics["elements"])]
    row = re.search(r"<tr><th>min dihedral \[deg\]</th>(.*?)</tr>", report_text).group(1)
    assert f"{fepre_metrics['min_dihedral_angle_min']:.2f}" in row
    assert f"{gmsh_metrics['min_dihedral_angle_min']:.2f}" in row
    for label in ("volume error", "Hausdorff to fine surface", "cells below 10 deg", "mean radius ratio"):
        assert f"<th>{label}</th>" in report_text


def test_report_shows_surface_check_settings_and_versions(comparison, report_text):
    assert "Surface check of the extracted surface" in report_text
    assert re.search(r"<th>watertight</th><td>True</td>", report_text)
    assert f"<th>surface_spacing</th><td>{comparison.settings['surface_spacing']}</td>" in report_text
    assert f"<th>pyvista</th><td>{comparison.settings['versions']['pyvista']}</td>" in report_text
    assert "sphere(radius=1" in report_text  # the model tree


def test_bad_destinations_fail_before_any_work(comparison, tmp_path):
    # (reports of several parts are exercised by tests/test_demo.py)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        write_report([comparison], tmp_path / "missing" / "r.html")
    with pytest.raises(ValueError, match="at least one Comparison"):
        write_report({}, tmp_path / "empty.html")
    assert not list(tmp_path.glob(".*.tmp")), "a temporary file was left behind"
