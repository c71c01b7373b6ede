"""Discrete cosine transforms and quantizers of the paper (eq. 8-10, 26-27).

The paper writes the DCT of a length-N sequence with ``n-2`` where N = n-1 is
meant (a typo, docs/design.md §4); we use scipy's orthonormal DCT-II, which is
eq. 8-9 with that correction, and its inverse (DCT-III).  All functions work
on numpy arrays and transform along the leading axes, so xyz sits in the last.
"""

from __future__ import annotations

import functools

import numpy as np

#: Lengths up to this are transformed by a cached matrix product: on the
#: small nets of real files (most have 2-16 poles a side) a call into
#: scipy.fft costs far more than the arithmetic.  Longer ones use scipy.fft.
MATRIX_MAX = 64


@functools.lru_cache(maxsize=MATRIX_MAX + 1)
def _matrix(n: int) -> np.ndarray:
    """The orthonormal DCT-II matrix C (n, n): dct(v) = C @ v, idct(d) = C.T @ d."""
    k = np.arange(n)[:, None]
    c = np.cos(np.pi * k * (2 * np.arange(n)[None, :] + 1) / (2 * n)) * np.sqrt(2.0 / n)
    c[0] /= np.sqrt(2.0)
    c.setflags(write=False)
    return c


def dct1(v: np.ndarray) -> np.ndarray:
    """Orthonormal DCT-II along axis 0 (eq. 8-9, N = n-1).

    Parameters
    ----------
    v : ndarray, shape (N, ...)
    """
    if v.ndim == 2 and len(v) <= MATRIX_MAX:
        return _matrix(len(v)) @ v
    from scipy import fft  # on first use: ~0.2 s that info and --help skip

    return fft.dct(v, type=2, norm="ortho", axis=0)


def idct1(d: np.ndarray) -> np.ndarray:
    """Inverse of :func:`dct1`."""
    if d.ndim == 2 and len(d) <= MATRIX_MAX:
        return _matrix(len(d)).T @ d
    from scipy import fft  # on first use: ~0.2 s that info and --help skip

    return fft.idct(d, type=2, norm="ortho", axis=0)


def dct1_rows(v: np.ndarray) -> np.ndarray:
    """:func:`dct1` of each v[r] of ``v`` (R, N, c), N ≤ ``MATRIX_MAX``: the
    same matrix product, item by item (numpy's stacked matmul)."""
    return _matrix(v.shape[1]) @ v


def idct1_rows(d: np.ndarray) -> np.ndarray:
    """:func:`idct1` of each d[r] of ``d`` (R, N, c), N ≤ ``MATRIX_MAX``."""
    return _matrix(d.shape[1]).T @ d


def dct2(v: np.ndarray) -> np.ndarray:
    """Orthonormal 2-D DCT-II over axes 0 and 1 (eq. 26).

    Parameters
    ----------
    v : ndarray, shape (N, M, ...)
    """
    if v.ndim == 3 and max(v.shape[:2]) <= MATRIX_MAX:
        n, m, c = v.shape
        rows = _matrix(n) @ v.reshape(n, m * c)  # along axis 0
        return (_matrix(m) @ rows.reshape(n, m, c)).reshape(n, m, c)  # along axis 1
    from scipy import fft  # on first use: ~0.2 s that info and --help skip

    return fft.dctn(v, type=2, norm="ortho", axes=(0, 1))


def idct2(d: np.ndarray) -> np.ndarray:
    """Inverse of :func:`dct2`."""
    if d.ndim == 3 and max(d.shape[:2]) <= MATRIX_MAX:
        n, m, c = d.shape
        rows = _matrix(n).T @ d.reshape(n, m * c)
        return (_matrix(m).T @ rows.reshape(n, m, c)).reshape(n, m, c)
    from scipy import fft  # on first use: ~0.2 s that info and --help skip

    return fft.idctn(d, type=2, norm="ortho", axes=(0, 1))


def dct2_rows(v: np.ndarray) -> np.ndarray:
    """:func:`dct2` of each v[r] of ``v`` (R, N, M, c), N, M ≤ ``MATRIX_MAX``:
    the same matrix products, item by item."""
    r, n, m, c = v.shape
    rows = _matrix(n) @ v.reshape(r, n, m * c)  # along axis 1
    return (_matrix(m) @ rows.reshape(r, n, m, c)).reshape(r, n, m, c)  # along axis 2


def idct2_rows(d: np.ndarray) -> np.ndarray:
    """:func:`idct2` of each d[r] of ``d`` (R, N, M, c), N, M ≤ ``MATRIX_MAX``."""
    r, n, m, c = d.shape
    rows = _matrix(n).T @ d.reshape(r, n, m * c)
    return (_matrix(m).T @ rows.reshape(r, n, m, c)).reshape(r, n, m, c)


def paper_steps(shape: tuple[int, ...], dc: np.ndarray, a: int) -> np.ndarray:
    """The paper's quantizer steps, Q_k = (1+k)·D0/2^a (eq. 10), Q_kl = (1+k+l)·D00/2^a (eq. 27).

    Parameters
    ----------
    shape : tuple
        ``(N,)`` for a curve, ``(N, M)`` for a map.
    dc : ndarray, shape (c,)
        The DC coefficient of each channel (x, y, z or d).  It must be sent,
        since round(D00/Q00) is always 2^a.  Where it is 0 the step collapses;
        the caller then has to use :func:`tol_steps`.
    a : int
        Bits of the quantizer.

    Returns
    -------
    ndarray, shape (*shape, c)
    """
    idx = np.indices(shape).sum(axis=0)
    return (1.0 + idx)[..., None] * np.abs(dc) / 2.0**a


def tol_steps(shape: tuple[int, ...], delta: float, slope: float) -> np.ndarray:
    """Tolerance-driven steps, Q = (1 + slope·(k+l))·Δ, shape ``shape + (1,)``.

    Δ is chosen by the tolerance search; ``slope`` > 0 quantizes high
    frequencies more coarsely, as the paper's (1+k+l) does.
    """
    idx = np.indices(shape).sum(axis=0)
    return ((1.0 + slope * idx) * delta)[..., None]


def quantize(d: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Round(D/Q) as int64 (eq. 10, 27).  Zero steps give zero."""
    safe = np.where(steps > 0, steps, 1.0)
    return np.where(steps > 0, np.rint(d / safe), 0).astype(np.int64)


def dequantize(q: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """The decoder's D' = q·Q."""
    return q * steps
