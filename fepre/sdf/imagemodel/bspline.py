"""The cubic B-spline interpolant of an image: its coefficients and its values between samples.

The interpolant is ``f(x) = sum_j c_j b(x - j)`` with ``b`` the cubic B-spline and ``c`` the
coefficients that make ``f`` pass through the samples (``scipy.ndimage.spline_filter`` on the
samples padded by 12 copies of their border, exactly as ``scipy.ndimage.zoom(mode="nearest")``
prefilters them). The prefilter is an IIR filter: a sample's influence on a coefficient ``n``
samples away decays as ``0.268^n`` (``2 - sqrt(3)``), so the coefficients of a block read with
``SPLINE_HALO`` samples beyond it on every side are those of the whole image, bit for bit (the
recursions' states meet exactly well before the block). The refined values are evaluated one axis
at a time (four coefficients per node), so a block's nodes are the whole image's nodes, bit for
bit, whether the image is held whole or read in chunks.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SPLINE_HALO", "PAD", "spline_coefficients", "refined_nodes", "refine_samples", "refined_count", "certainly_one_side"]

#: samples read beyond a block so that its coefficients are the whole image's (0.268^40 = 1e-23)
SPLINE_HALO = 40
#: border copies added before the prefilter (as scipy.ndimage.zoom does for mode="nearest")
PAD = 12
#: sum of the negative taps of the 3D prefilter: the 1D taps sum to 1 and their magnitudes to 3,
#: so the 3D ones to 1 and 27, the negative ones to -(27 - 1) / 2
NEGATIVE_TAPS = 13.0


def refined_count(samples: int, refine: int) -> int:
    """Nodes of the refined grid along an axis of ``samples`` samples."""
    return (samples - 1) * refine + 1


def spline_coefficients(samples: np.ndarray) -> np.ndarray:
    """The B-spline coefficients (float64) of ``samples`` padded by ``PAD`` border copies on
    every side: coefficient ``j`` of the samples is element ``j + PAD``.

    Examples
    --------
    >>> c = spline_coefficients(np.full((4, 4, 4), 2.0, dtype=np.float32))
    >>> c.shape, bool(np.allclose(c, 2.0))
    ((28, 28, 28), True)
    """
    from scipy import ndimage

    padded = np.pad(np.asarray(samples, dtype=np.float32), PAD, mode="edge")
    return ndimage.spline_filter(padded, 3, output=np.float64, mode="nearest")


def _weights(refine: int) -> np.ndarray:
    """(refine, 4) cubic B-spline weights of coefficients j-1 .. j+2 at x = j + t / refine."""
    u = np.arange(refine, dtype=np.float64) / refine
    return np.stack([
        (1.0 - u) ** 3 / 6.0,
        (3.0 * u**3 - 6.0 * u**2 + 4.0) / 6.0,
        (-3.0 * u**3 + 3.0 * u**2 + 3.0 * u + 1.0) / 6.0,
        u**3 / 6.0,
    ], axis=1)


def _along(coefficients: np.ndarray, axis: int, first: int, lo: int, hi: int, refine: int, dtype=np.float64) -> np.ndarray:
    """The interpolant along ``axis`` at refined nodes ``[lo, hi)``; element 0 of
    ``coefficients`` along that axis is coefficient ``first`` (in sample indices)."""
    from ._bspline_kernel import refine_axis

    nodes = np.arange(lo, hi)
    base, phase = np.divmod(nodes, refine)
    shape = list(coefficients.shape)
    shape[axis] = nodes.size
    out = np.empty(shape, dtype=dtype)
    refine_axis(coefficients, out, axis, (base - 1 - first).astype(np.int64), _weights(refine)[phase])
    return out


def refined_nodes(coefficients: np.ndarray, first, lo, hi, refine: int) -> np.ndarray:
    """The interpolant (float32) at refined nodes ``[lo, hi)`` along x, y, z (node ``q`` is at
    sample position ``q / refine``), from coefficients whose element (0, 0, 0) is coefficient
    ``first`` (sample indices, ``-PAD`` for :func:`spline_coefficients` of a whole image).

    Examples
    --------
    >>> x = np.arange(5.0)
    >>> samples = np.broadcast_to(x[:, None, None] ** 2, (5, 5, 5)).astype(np.float32)
    >>> fine = refined_nodes(spline_coefficients(samples), (-PAD,) * 3, (0, 0, 0), (9, 9, 9), 2)
    >>> np.round(fine[::2, 0, 0], 5).tolist()     # through the samples
    [0.0, 1.0, 4.0, 9.0, 16.0]
    """
    first, lo, hi = (np.asarray(a, dtype=np.int64) for a in (first, lo, hi))
    low, high = lo // refine - 1, (hi - 1) // refine + 3  # the coefficients these nodes use
    coefficients = coefficients[tuple(slice(int(a - f), int(b - f)) for a, b, f in zip(low, high, first))]
    values = _along(coefficients, 0, int(low[0]), int(lo[0]), int(hi[0]), refine)
    values = _along(values, 1, int(low[1]), int(lo[1]), int(hi[1]), refine)
    return _along(values, 2, int(low[2]), int(lo[2]), int(hi[2]), refine, np.float32)


def refine_samples(samples: np.ndarray, first, lo, hi, refine: int) -> np.ndarray:
    """The interpolant (float32) at refined nodes ``[lo, hi)`` of the samples ``samples`` whose
    element (0, 0, 0) is sample ``first`` of the image: :func:`refined_nodes` of their
    :func:`spline_coefficients`, each array let go as soon as the next pass has it.

    Examples
    --------
    >>> samples = np.random.default_rng(0).random((6, 6, 6)).astype(np.float32)
    >>> fine = refine_samples(samples, (0, 0, 0), (0, 0, 0), (11, 11, 11), 2)
    >>> bool(np.allclose(fine[::2, ::2, ::2], samples, atol=1e-6))
    True
    """
    first, lo, hi = (np.asarray(a, dtype=np.int64) for a in (first, lo, hi))
    coefficients = spline_coefficients(samples)
    low, high = lo // refine - 1, (hi - 1) // refine + 3
    crop = tuple(slice(int(a - f + PAD), int(b - f + PAD)) for a, b, f in zip(low, high, first))
    values = _along(coefficients[crop], 0, int(low[0]), int(lo[0]), int(hi[0]), refine)
    del coefficients
    values = _along(values, 1, int(low[1]), int(lo[1]), int(hi[1]), refine)
    return _along(values, 2, int(low[2]), int(lo[2]), int(hi[2]), refine, np.float32)


def certainly_one_side(field_low: float, field_high: float, tolerance: float) -> int:
    """+1 when every value of the interpolant of samples whose field (negative inside) lies in
    ``[field_low, field_high]`` is positive, -1 when every one is negative, else 0.

    A coefficient is the samples filtered by taps summing to 1 whose negative ones sum to
    ``-NEGATIVE_TAPS``; so it is at least ``low - 13 (high - low)`` (and at most the mirror
    bound), and the interpolant, a convex combination of coefficients, too. ``tolerance``
    covers rounding and the samples beyond ``SPLINE_HALO`` (their weight is below 1e-22).

    Examples
    --------
    >>> certainly_one_side(0.5, 0.5, 1e-6), certainly_one_side(-1.0, -0.95, 1e-6), certainly_one_side(0.1, 0.5, 1e-6)
    (1, -1, 0)
    """
    spread = NEGATIVE_TAPS * (field_high - field_low)
    if field_low - spread > tolerance:
        return 1
    if -field_high - spread > tolerance:
        return -1
    return 0
