"""``fepre.distmesh``, ``fepre.export`` and ``fepre.features`` are packages and functions at once:
calling, ``inspect.signature`` and ``help()`` all show the function."""

from __future__ import annotations

import inspect
import pydoc

import pytest

import fepre
from fepre import sdf


@pytest.mark.parametrize("package, first", [(fepre.distmesh, "model"), (fepre.export, "mesh"), (fepre.features, "model"),
                                            (fepre.compare, "model")])
def test_help_opens_on_the_function_and_its_parameters(package, first):
    text = pydoc.render_doc(package, renderer=pydoc.plaintext)
    head = "\n".join(text.splitlines()[:40])
    # before: help() printed the package (contents, classes) and the parameters ~370 lines in
    assert f"{package.__name__}({first}" in head
    assert "Parameters" in head
    parameters = list(inspect.signature(package).parameters)
    assert parameters[0] == first
    described = text[: text.index("PACKAGE CONTENTS")] if "PACKAGE CONTENTS" in text else text
    for name in parameters:
        if name not in ("args", "kwargs", "overrides"):
            assert f"{name} :" in described or f"{name}," in described or f"{name}:" in described, name


def test_the_package_is_still_the_package_and_calls_the_function():
    assert fepre.distmesh.DistMeshOptions is fepre.DistMeshOptions
    mesh = fepre.distmesh(sdf.sphere(1.0), h=0.5)
    assert mesh.n_cells > 0 and fepre.distmesh.__wrapped__ is fepre.distmesh.mesher.distmesh


def test_no_public_function_is_shadowed_by_a_submodule_of_its_name():
    """Importing a submodule sets the package's attribute of its name: fepre.homogenize was the
    module fepre/homogenize.py (not callable) once something had imported it."""
    import importlib
    import pkgutil

    for info in pkgutil.walk_packages(fepre.__path__, "fepre."):
        if info.name.split(".")[-1] not in ("__main__",):
            importlib.import_module(info.name)
    for name in fepre.__all__:
        value = getattr(fepre, name)
        if name in ("sdf", "config", "__version__", "quality", "sampling", "surface", "bench", "cli", "corpus", "sizing", "chunked"):
            continue
        assert callable(value), f"fepre.{name} is {value!r}"
