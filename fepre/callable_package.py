"""Packages that are also functions: ``fepre.distmesh(...)``, ``fepre.export(...)``, ``fepre.features(...)``,
``fepre.compare(...)``.

A user reaches the function and its helpers by one name. ``inspect.signature``, IDEs and ``help()``
must still show the function: the package carries its signature, and its docstring starts with the
function's (``help(fepre.distmesh)`` opens on the parameters, then lists the package's contents).
"""

from __future__ import annotations

import inspect
import sys
import types
from typing import Any, Callable

__all__ = ["make_callable"]


class CallablePackage(types.ModuleType):
    """A package whose call is its function's (``__wrapped__``)."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.__wrapped__(*args, **kwargs)


def make_callable(package_name: str, function: Callable) -> None:
    """Make the loaded package ``package_name`` callable as ``function``, with its signature and doc.

    Examples
    --------
    >>> import fepre, inspect
    >>> list(inspect.signature(fepre.distmesh).parameters)[:2]
    ['model', 'h']
    >>> fepre.distmesh.__doc__.splitlines()[0].startswith("fepre.distmesh(model, h=None")
    True
    """
    package = sys.modules[package_name]
    own_doc = inspect.cleandoc(package.__doc__ or "")
    package.__class__ = CallablePackage
    package.__wrapped__ = function
    package.__signature__ = inspect.signature(function)
    plain = package.__signature__.replace(
        parameters=[p.replace(annotation=inspect.Parameter.empty) for p in package.__signature__.parameters.values()],
        return_annotation=inspect.Signature.empty,
    )
    package.__doc__ = (
        f"{package_name}{plain}\n\n{inspect.getdoc(function) or ''}\n\n"
        f"The package ``{package_name}``\n{'-' * (len(package_name) + 16)}\n{own_doc}\n"
    )
