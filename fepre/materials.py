"""Isotropic linear-elastic materials as users give them: ``(E, nu)`` or ``{"E": ..., "nu": ...}``,
optionally with a density: ``(E, nu, density)`` or a ``"density"`` key."""

from __future__ import annotations

from typing import Any

from .arguments import finite_float, positive_float

__all__ = ["elastic_material", "material_density"]


def elastic_material(material: Any, parameter: str = "material") -> tuple[float, float]:
    """``(E, nu)`` of an isotropic elastic material, checked.

    ``material`` is a pair ``(E, nu)`` or a dict with keys ``E`` and ``nu`` (any case, or
    ``youngs_modulus`` and ``poissons_ratio``); ``E > 0`` and ``-1 < nu < 0.5``.

    Examples
    --------
    >>> elastic_material({"E": 210e3, "nu": 0.3})
    (210000.0, 0.3)
    """
    if isinstance(material, dict):
        keys = {str(k).lower(): v for k, v in material.items()}
        young = keys.get("e", keys.get("youngs_modulus"))
        poisson = keys.get("nu", keys.get("poissons_ratio"))
        if young is None or poisson is None:
            raise ValueError(f"{parameter} must give E and nu (keys 'E' and 'nu'); got keys {sorted(material)}")
    else:
        try:
            young, poisson, *rest = material
            if len(rest) > 1:
                raise ValueError
        except (TypeError, ValueError):
            raise TypeError(f"{parameter} must be (E, nu), (E, nu, density) or {{'E': ..., 'nu': ...}}; got {material!r}") from None
    young = positive_float(young, f"{parameter} E")
    poisson = finite_float(poisson, f"{parameter} nu")
    if not -1.0 < poisson < 0.5:
        raise ValueError(f"{parameter} nu must lie in (-1, 0.5) for an isotropic solid; got {poisson!r}")
    return young, poisson


def material_density(material: Any, parameter: str = "material") -> float | None:
    """The density of a material given as ``(E, nu, density)`` or with a ``"density"`` key, else
    None; positive when given.

    Examples
    --------
    >>> material_density((1.9e-3, 0.45, 1.04e-9)), material_density({"E": 210e3, "nu": 0.3})
    (1.04e-09, None)
    """
    if isinstance(material, dict):
        value = {str(k).lower(): v for k, v in material.items()}.get("density")
    else:
        value = material[2] if len(material) == 3 else None
    return None if value is None else positive_float(value, f"{parameter} density")
