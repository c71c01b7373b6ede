"""§2.4 SNET/CNET (the net codes, §2.4.1 step by step), §2.9 pinned corners and
curve ends, §2.10 joined sides, of docs/format.md."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .container import Arrays, ReadError, Take
from .tables import Spline

if TYPE_CHECKING:
    from .reader import Model

SURFACE_METHODS = {0, 1, 2, 5, 7, 8, 10, *range(12, 23)}
#: §2.4 (2.14): the orders of extrapolation (along u, along v) of methods 14-22
ORDERS = {14 + 3 * (a - 1) + (b - 1): (a, b) for a in (1, 2, 3) for b in (1, 2, 3)}
CURVE_METHODS = {3, 4, 6, 9, 11}
SLOPES = (0.0, 1.0)


# ---------------------------------------------------------------- the DCT


def dct_matrix(n: int) -> np.ndarray:
    """The orthonormal DCT-II matrix, as §2.4.1 evaluates it."""
    k = np.arange(n)[:, None]
    c = np.cos(np.pi * k * (2 * np.arange(n)[None, :] + 1) / (2 * n)) * np.sqrt(2.0 / n)
    c[0] /= np.sqrt(2.0)
    return c


#: Lengths up to this use the matrix; longer ones scipy.fft (§2.4.1, the DCT).
MATRIX_MAX = 64


def idct(x: np.ndarray, axis: int = 0) -> np.ndarray:
    """Inverse DCT along ``axis``: the matrix product M.T @ x (x's other axes
    flattened) up to 64 values, scipy.fft's orthonormal DCT-III above."""
    if x.shape[axis] > MATRIX_MAX:
        from scipy import fft

        return np.asarray(fft.idct(x, type=2, norm="ortho", axis=axis))
    m = dct_matrix(x.shape[axis])
    y = np.moveaxis(x, axis, 0)
    r = (m.T @ y.reshape(y.shape[0], -1)).reshape(y.shape)
    return np.moveaxis(r, 0, axis)


def idct2(x: np.ndarray) -> np.ndarray:
    """Along axis 0 (one product, the other axes flattened), then axis 1 row
    by row (a product per row r of the first result, as §2.4.1 writes it:
    numpy's stacked matmul; one product over all rows at once sums in
    another order on some CPUs' BLAS kernels); scipy.fft over both when
    either side is over 64."""
    if max(x.shape[:2]) > MATRIX_MAX:
        from scipy import fft

        return np.asarray(fft.idctn(x, type=2, norm="ortho", axes=(0, 1)))
    n, m = x.shape[:2]
    rows = idct(x, 0).reshape(n, m, -1)
    return (dct_matrix(m).T @ rows).reshape(x.shape)


# ---------------------------------------------------------------- abscissae


def flat_knots(
    knots: np.ndarray, mults: np.ndarray, degree: int, periodic: bool, n: int
) -> list[float]:
    flat = [float(k) for k, m in zip(knots.tolist(), mults.tolist(), strict=True) for _ in range(m)]
    if periodic:
        period = float(knots[-1]) - float(knots[0])
        while len(flat) < n + degree:  # u_{k+n} = u_k + period
            flat.append(flat[len(flat) - n] + period)
    return flat


def abscissae(
    knots: np.ndarray, mults: np.ndarray, degree: int, periodic: bool, n: int
) -> np.ndarray:
    """§2.4.1 Abscissae: normalised Greville abscissae (eq. 17)."""
    u = flat_knots(knots, mults, degree, periodic, n)
    if degree == 0:
        g = [u[i] for i in range(n)]
    else:
        c = [0.0]
        for x in u:
            c.append(c[-1] + x)
        g = [(c[i + degree + 1] - c[i + 1]) / degree for i in range(n)]
    span = g[n - 1] - g[0]
    if span > 0:
        s = np.array([(gi - g[0]) / span for gi in g])
    else:
        s = np.arange(n) * (1.0 / (n - 1))
        s[-1] = 1.0
    return s


# ---------------------------------------------------------------- one net


class Code:
    """A net's integers (``take``) and the table's DC floats (``take_dc``)."""

    def __init__(self, ints: np.ndarray, dcs: Take) -> None:
        self.ints = Take(np.asarray(ints, np.int64), "net integers")
        self.dcs = dcs

    def take(self, k: int) -> np.ndarray:
        return self.ints(k)


class Net:
    def __init__(self, code: Code, method: int, quant: int, level: int, slope: int, tol: float):
        self.code, self.method, self.quant, self.level = code, method, quant, level
        if quant != 0:  # §2.4: quantizer 1 is reserved
            raise ReadError(f"quantizer {quant} is reserved")
        self.h = tol * 2.0 ** (level / 4)
        if slope not in (0, 1):
            raise ReadError(f"slope {slope}")
        self.S = SLOPES[slope]

    def snap(self, x: np.ndarray) -> np.ndarray:
        return np.rint(np.asarray(x) / self.h).astype(np.int64)

    def grid(self, k: int, o: np.ndarray, dim: int = 3) -> np.ndarray:
        d = self.code.take(k * dim).reshape(k, dim)
        r = o.shape[0]
        q = d.copy()
        q[:r] = d[:r] + self.snap(o)
        q[r:] = d[r:] + q[0]
        return q * self.h

    def coeffs(self, shape: tuple[int, ...], c: int) -> np.ndarray:
        if len(shape) == 1:
            steps = (1 + self.S * np.arange(shape[0])) * self.h
        else:
            kk, ll = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
            steps = (1 + self.S * (kk + ll)) * self.h
        v = self.code.take(int(np.prod(shape)) * c).reshape(*shape, c)
        return v * steps[..., None]

    def curve(self, count: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        n = count - 1
        if n < 2:
            return np.stack([a, b])
        f = (np.arange(n - 1) + 1) / n
        g = 1 - f
        r = g[:, None] * a + f[:, None] * b
        v = self.coeffs((n - 1,), a.shape[0])
        return np.concatenate([a[None], r + idct(v, 0), b[None]])


def coons_bilinear(u0, u1, v0, v1, s, t) -> np.ndarray:
    c0, c1, c2, c3 = u0[0], u0[-1], u1[0], u1[-1]
    S, T = s[:, None, None], t[None, :, None]
    return (
        ((1 - S) * u0[None, :] + S * u1[None, :])
        + ((1 - T) * v0[:, None] + T * v1[:, None])
        - ((1 - S) * (1 - T) * c0 + (1 - S) * T * c1 + S * (1 - T) * c2 + S * T * c3)
    )


def _h(x: np.ndarray) -> tuple[np.ndarray, ...]:
    x2 = x * x
    x3 = x * x * x
    return 2 * x3 - 3 * x2 + 1, -2 * x3 + 3 * x2, x3 - 2 * x2 + x, x3 - x2


def _slope(b: np.ndarray, x: np.ndarray, end: bool) -> np.ndarray:
    dx = (x[-1] - x[-2]) if end else (x[1] - x[0])
    if not dx > 0:
        return np.zeros_like(b[0])
    return ((b[-1] - b[-2]) if end else (b[1] - b[0])) / dx


def coons_bicubic(u0, u1, v0, v1, s, t) -> np.ndarray:
    c0, c1, c2, c3 = u0[0], u0[-1], u1[0], u1[-1]
    a00, a01 = _slope(u0, t, False), _slope(u0, t, True)
    a10, a11 = _slope(u1, t, False), _slope(u1, t, True)
    b00, b10 = _slope(v0, s, False), _slope(v0, s, True)
    b01, b11 = _slope(v1, s, False), _slope(v1, s, True)
    w = c0 - c1 - c2 + c3
    hs = [h[:, None] for h in _h(s)]
    ht = [h[:, None] for h in _h(t)]
    dv0 = hs[0] * a00 + hs[1] * a10 + (hs[2] + hs[3]) * w
    dv1 = hs[0] * a01 + hs[1] * a11 + (hs[2] + hs[3]) * w
    du0 = ht[0] * b00 + ht[1] * b01 + (ht[2] + ht[3]) * w
    du1 = ht[0] * b10 + ht[1] * b11 + (ht[2] + ht[3]) * w
    g0 = hs[0] * c0 + hs[1] * c2 + hs[2] * b00 + hs[3] * b10
    g1 = hs[0] * c1 + hs[1] * c3 + hs[2] * b01 + hs[3] * b11
    T0, T1, T2, T3 = (h[None, :, None] for h in _h(t))
    S0, S1, S2, S3 = (h[:, None, None] for h in _h(s))

    def tt(A, B, dA, dB):
        return T0 * A[:, None] + T1 * B[:, None] + T2 * dA[:, None] + T3 * dB[:, None]

    s2 = S0 * u0[None] + S1 * u1[None] + S2 * du0[None] + S3 * du1[None]
    return tt(v0, v1, dv0, dv1) + s2 - tt(g0, g1, dv0, dv1)


def dmap_flat(g: Spline, axis: int, n: int) -> tuple[np.ndarray, int]:
    """§2.4.1 D-map, step 1: the flat knot vector and degree along ``axis``."""
    if g.bezier:
        return np.array([0.0] * n + [1.0] * n), n - 1
    flat = np.repeat(np.asarray(g.knots[axis], float), np.asarray(g.mults[axis], int))
    return flat, g.degrees[axis]


def dmap_basis(flat: np.ndarray, p: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """§2.4.1 D-map, steps 2-3: B-spline basis values and first derivatives at the
    Greville abscissae, (n, n) each: row k is abscissa k, column i basis i."""
    if p == 0:
        x = flat[:n].copy()
    else:
        c = np.concatenate([[0.0], np.cumsum(flat)])
        i = np.arange(n)
        x = (c[i + p + 1] - c[i + 1]) / p
    x = np.clip(x, flat[p], flat[n])
    from scipy.interpolate import BSpline

    spline = BSpline(flat, np.eye(n), p, extrapolate=True)
    der = spline.derivative()(x) if p > 0 else np.zeros((n, n))
    return spline(x), der


def dmap_normals(net: np.ndarray, g: Spline) -> np.ndarray:
    """§2.4.1 D-map, steps 4-5: unit normals (nu, nv, 3) of the surface of
    ``net`` (with the row's knots, degrees and weights) at its Greville points."""
    nu, nv = net.shape[:2]
    fu, pu = dmap_flat(g, 0, nu)
    fv, pv = dmap_flat(g, 1, nv)
    bu, du = dmap_basis(fu, pu, nu)
    bv, dv = dmap_basis(fv, pv, nv)
    w = np.ones((nu, nv)) if g.weights is None else np.asarray(g.weights).reshape(nu, nv)
    hw = net * w[..., None]
    S = np.einsum("ki,ijc,lj->klc", bu, hw, bv)
    Su = np.einsum("ki,ijc,lj->klc", du, hw, bv)
    Sv = np.einsum("ki,ijc,lj->klc", bu, hw, dv)
    W = np.einsum("ki,ij,lj->kl", bu, w, bv)[..., None]
    Wu = np.einsum("ki,ij,lj->kl", du, w, bv)[..., None]
    Wv = np.einsum("ki,ij,lj->kl", bu, w, dv)[..., None]
    P = S / W
    xu = (Su - Wu * P) / W
    xv = (Sv - Wv * P) / W
    n = np.cross(xu, xv)
    length = np.sqrt((n**2).sum(-1, keepdims=True))
    return np.divide(n, length, out=np.zeros_like(n), where=length > 1e-300)


def _cumsum2(r: np.ndarray) -> np.ndarray:
    return np.cumsum(np.cumsum(r, axis=0), axis=1)


def _unextrapolate(r: np.ndarray) -> np.ndarray:
    for axis in (1, 0):
        w = np.moveaxis(r, axis, 0).copy()
        for k in range(2, w.shape[0]):
            w[k] = w[k] + w[k - 1]
        r = np.moveaxis(np.cumsum(w, axis=0), 0, axis)
    return r


def _node_weights(g, o: int) -> list[list[float]]:
    """§2.4 (2.14): per k, the weights of x[k-1], x[k-2], x[k-3]."""
    from math import comb, isfinite, ldexp

    out = [[0.0, 0.0, 0.0]]
    for k in range(1, len(g)):
        a = min(k, o)
        lag = []
        for m in range(1, a + 1):
            num, den = 1.0, 1.0
            for j in range(1, a + 1):
                if j != m:
                    num *= float(g[k]) - float(g[k - j])
                    den *= float(g[k - m]) - float(g[k - j])
            lag.append(num / den if den != 0.0 else float("nan"))
        if all(isfinite(x) and abs(x) <= 1024.0 for x in lag):
            w = [0.0, 0.0, 0.0]
            for m in range(2, a + 1):
                w[m - 1] = ldexp(round(ldexp(lag[m - 1], 20)), -20)
            w[0] = (1.0 - w[1]) - w[2]
        else:
            w = [float((-1) ** (m + 1) * comb(a, m)) for m in range(1, a + 1)] + [0.0] * (3 - a)
        out.append(w)
    return out


def _undo_lift(y: np.ndarray, w: list[list[float]]) -> np.ndarray:
    """Along axis 0: x[k] = y[k] + rint((w1*x[k-1] + w2*x[k-2]) + w3*x[k-3])."""
    x = np.zeros_like(y)
    for k in range(y.shape[0]):
        back = [x[k - m].astype(np.float64) if k >= m else np.zeros(y.shape[1:]) for m in (1, 2, 3)]
        with np.errstate(over="ignore", invalid="ignore"):
            p = (w[k][0] * back[0] + w[k][1] * back[1]) + w[k][2] * back[2]
            ok = np.abs(p) < 2.0**62
        pred = np.where(ok, np.rint(np.where(ok, p, 0.0)), 0.0).astype(np.int64)
        with np.errstate(over="ignore"):
            x[k] = y[k] + pred
    return x


def _lifted(r: np.ndarray, s, t, orders: tuple[int, int]) -> np.ndarray:
    """§2.4 (2.14): the rows' errors along u, then the poles along v."""
    z = _undo_lift(r, _node_weights(s, orders[0]))
    return _undo_lift(z.transpose(1, 0, 2), _node_weights(t, orders[1])).transpose(1, 0, 2)


def _next_arc_pole(row: list[np.ndarray], j: int) -> np.ndarray:
    """§2.4 (2.14): pole j of one row from the poles before it."""
    if j == 0:
        return np.zeros(3, np.int64)
    if j == 1:
        return row[0]
    if j == 2 or j % 2 == 1:
        return 2 * row[j - 1] - row[j - 2]
    a = [float(x) for x in row[j - 3] - row[j - 4]]
    b = [float(x) for x in row[j - 2] - row[j - 3]]
    aa = (a[0] * a[0] + a[1] * a[1]) + a[2] * a[2]
    ab = (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]
    if not aa > 0:
        return row[j - 1]
    f = (2 * ab) / aa
    p = [(float(row[j - 1][c]) + f * b[c]) - a[c] for c in range(3)]
    if not all(abs(x) < 2.0**62 for x in p):
        return row[j - 1]
    return np.array([round(x) for x in p], np.int64)  # Python's round: half to even


def _arcs(r: np.ndarray, along_u: bool) -> np.ndarray:
    """§2.4 (2.14): the grid integers of rows of arcs."""
    x = r.transpose(1, 0, 2) if along_u else r
    out = np.zeros_like(x)
    err = np.zeros((x.shape[1], 3), np.int64)
    with np.errstate(over="ignore"):
        for i in range(x.shape[0]):
            err = err + x[i]
            row: list[np.ndarray] = []
            for j in range(x.shape[1]):
                row.append(err[j] + _next_arc_pole(row, j))
            out[i] = np.array(row)
    return out.transpose(1, 0, 2) if along_u else out


def _with_corners(r: np.ndarray, integrate, corners: dict[int, np.ndarray]) -> np.ndarray:
    """§2.4.1 (2.10): each anchored corner, in order P0m, Pn0, Pnm, gets the
    residual that makes its integrated value snap(vertex) + what was stored."""
    nu, nv = r.shape[:2]
    at = {1: (0, nv - 1), 2: (nu - 1, 0), 3: (nu - 1, nv - 1)}
    for k in (1, 2, 3):
        if k in corners:
            i, j = at[k]
            stored = r[i, j].copy()
            r[i, j] = 0
            r[i, j] = corners[k] + stored - integrate(r)[i, j]
    return r


def decode_surface(
    net: Net,
    shape: tuple[int, int],
    o: np.ndarray,
    s,
    t,
    g: Spline | None = None,
    corners: dict[int, np.ndarray] | None = None,
) -> np.ndarray:
    """``corners`` (2.10): corner k (1-3) -> its vertex's point."""
    nu, nv = shape
    m = net.method
    snapped = {k: net.snap(v) for k, v in (corners or {}).items()}
    if m == 0:
        r = net.code.take(nu * nv * 3).reshape(nu, nv, 3).copy()
        r[0, 0] += net.snap(o[0])
        return _cumsum2(_with_corners(r, _cumsum2, snapped)) * net.h
    if m == 10:
        if net.quant != 0 or net.S != 0.0:
            raise ReadError("method 10 with quant or slope other than 0")
        r = net.code.take(nu * nv * 3).reshape(nu, nv, 3).copy()
        r[0, 0] += net.snap(o[0])
        return _unextrapolate(_with_corners(r, _unextrapolate, snapped)) * net.h
    if m in ORDERS:
        if net.quant != 0 or net.S != 0.0:
            raise ReadError(f"method {m} with quant or slope other than 0")
        r = net.code.take(nu * nv * 3).reshape(nu, nv, 3).copy()
        r[0, 0] += net.snap(o[0])

        def undo(x: np.ndarray) -> np.ndarray:
            return _lifted(x, s, t, ORDERS[m])

        return undo(_with_corners(r, undo, snapped)) * net.h
    if m in (12, 13):
        r = net.code.take(nu * nv * 3).reshape(nu, nv, 3).copy()
        r[0, 0] += net.snap(o[0])

        def rows(x: np.ndarray) -> np.ndarray:
            return _arcs(x, m == 13)

        return rows(_with_corners(r, rows, snapped)) * net.h
    if m in (1, 2, 5, 7, 8):
        d = net.code.take(12).reshape(4, 3)
        q = d.copy()
        q[0] = d[0] + net.snap(o[0])
        q[1:] = d[1:] + q[0]
        for k, v in snapped.items():
            q[k] = d[k] + v
        c = q * net.h
        u0 = net.curve(nv, c[0], c[1])
        u1 = net.curve(nv, c[2], c[3])
        v0 = net.curve(nu, c[0], c[2])
        v1 = net.curve(nu, c[1], c[3])
        coons = coons_bicubic if m in (7, 8) else coons_bilinear
        p = coons(u0, u1, v0, v1, s, t)
        if m in (2, 8) and nu > 2 and nv > 2:
            w = net.coeffs((nu - 2, nv - 2), 3)
            p[1:-1, 1:-1] = p[1:-1, 1:-1] + idct2(w)
        if m == 5:
            if g is None or not clamped(g) or nu < 3 or nv < 3:
                raise ReadError("D-map (method 5): not a clamped net with an interior")
            w = net.coeffs((nu - 2, nv - 2), 1)
            d = idct2(w)[..., 0]
            n = dmap_normals(p, g)
            p[1:-1, 1:-1] = p[1:-1, 1:-1] + d[..., None] * n[1:-1, 1:-1]
        return p
    raise ReadError(f"SNET method {m}")


def decode_curve(net: Net, n: int, o: np.ndarray) -> np.ndarray:
    m = net.method
    if m == 3:
        r = net.code.take(n * 3).reshape(n, 3).copy()
        r[0] += net.snap(o[0])
        return np.cumsum(np.cumsum(r, axis=0), axis=0) * net.h
    if m == 4:
        ends = net.grid(2, o)
        return net.curve(n, ends[0], ends[1])
    if m == 11:  # (2.10) the ends are the two anchors themselves
        if len(o) != 2:
            raise ReadError("CNET: method 11 on a row without two anchors")
        return net.curve(n, o[0], o[1])
    raise ReadError(f"CNET method {m}")


# ---------------------------------------------------------------- tables of codes


class Table:
    def __init__(self, raw: bytes, tag: str, revision: int) -> None:
        a = Arrays(raw, tag)
        self.method, self.quant, self.level, self.slope = (a.ints().tolist() for _ in range(4))
        self.n = len(self.method)
        self.revision = revision
        self.anchor = [0] * self.n
        self.corners = [[0, 0, 0] for _ in range(self.n)]
        self.counts: list[int] | None = None
        if revision < 4 or self.n == 0:
            self.counts = a.ints().tolist()
            self.ints = Take(a.ints(), f"{tag} ints")
        else:
            if tag == "SNET":
                self.anchor = a.ints().tolist()
                if revision >= 13:  # (2.10) corners P0m, Pn0, Pnm against vertices
                    flat = a.ints().tolist()
                    if len(flat) != 3 * self.n:
                        raise ReadError("SNET corners: not three per net")
                    self.corners = [flat[3 * k : 3 * k + 3] for k in range(self.n)]
            self.streams = [Take(a.ints(), f"{tag} stream {k}") for k in range(5)]
        self.dcs = Take(a.floats(), f"{tag} dcs")
        a.end()
        self.last_iso = 0
        allowed = SURFACE_METHODS if tag == "SNET" else CURVE_METHODS
        for k in range(self.n):
            if self.method[k] not in allowed:
                raise ReadError(f"{tag}: method {self.method[k]}")
            if self.quant[k] != 0:
                raise ReadError(f"{tag}: quantizer {self.quant[k]} is reserved")
            if tag == "SNET" and self.method[k] == 10 and revision < 3:
                raise ReadError("SNET: method 10 before 2.0")
            if tag == "CNET" and self.method[k] == 11 and revision < 13:
                raise ReadError("CNET: method 11 before 2.10")
            if tag == "SNET" and self.method[k] >= 12 and revision < 17:
                raise ReadError("SNET: methods 12 to 22 before 2.14")

    def code(self, k: int, shape: tuple[int, ...]) -> Code:
        """The k-th code's integers, for a row of poles of ``shape`` (n, 3) or (nu, nv, 3)."""
        if self.counts is not None:
            return Code(self.ints(self.counts[k]), self.dcs)
        pts, res, cco, mco, refs = self.streams
        m = self.method[k]
        size = int(np.prod(shape))
        c = 3
        parts: list[np.ndarray] = []
        if m in (0, 10, 3) or 12 <= m <= 22:
            parts += [pts(min(c, size)), res(size - min(c, size))]
        elif m in (4, 11):
            n = shape[0]
            if m == 4:
                parts.append(pts(2 * c))
            if n > 2:
                parts.append(cco((n - 2) * c))
        elif m in (1, 2, 5, 7, 8):
            nu, nv = shape[0], shape[1]
            parts.append(pts(12))
            for kk in (nv, nv, nu, nu):
                if kk > 2:
                    parts.append(cco((kk - 2) * 3))
            if m in (2, 8) and nu > 2 and nv > 2:
                parts.append(mco((nu - 2) * (nv - 2) * 3))
            if m == 5:
                parts.append(mco((nu - 2) * (nv - 2)))
        elif m == 6:
            r = refs(3).copy()
            r[0] += self.last_iso
            self.last_iso = int(r[0])
            parts.append(r)
        elif m == 9:
            parts.append(refs(2))
        return Code(np.concatenate(parts) if parts else np.zeros(0, np.int64), self.dcs)

    def end(self) -> None:
        if self.counts is not None:
            self.ints.end()
        else:
            for s in self.streams:
                s.end()
        self.dcs.end()


# ---------------------------------------------------------------- topology helpers


def vertex_set(m: Model, shape: int) -> list[int]:
    """VERT rows of the vertices reached from ``shape`` through references of
    location 0, each shape visited once, sorted by row."""
    sh = m.shapes
    seen = {shape}
    stack = [shape]
    out = set()
    while stack:
        s = stack.pop()
        if sh.type[s] == 7:
            out.add(sh.row_of[s])
        for c, _, loc in sh.children[s]:
            if loc == 0 and c not in seen:
                seen.add(c)
                stack.append(c)
    return sorted(out)


def face_vertex_sets(m: Model) -> list[list[int]]:
    faces = m.shapes.of(4)
    return [vertex_set(m, faces[f]) if int(m.faces.loc[f]) == 0 else [] for f in range(len(faces))]


def dist(a: np.ndarray, b: np.ndarray) -> float:
    d = a - b
    return math.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])


def clamped(g: Spline) -> bool:
    if g.bezier:
        return True
    return all(
        not p and int(mu[0]) == d + 1 and int(mu[-1]) == d + 1
        for p, mu, d in zip(g.periodic, g.mults, g.degrees, strict=True)
    )


def boundary(p: np.ndarray, side: int) -> np.ndarray:
    return [p[0, :], p[-1, :], p[:, 0], p[:, -1]][side]


# ---------------------------------------------------------------- decoding


def decode(m: Model) -> None:
    snet = Table(m.snet, "SNET", m.revision)
    cnet = Table(m.cnet, "CNET", m.revision)
    srows = [
        i
        for i, g in enumerate(m.surfaces)
        if not m.surf_copies[i] and isinstance(g, Spline) and g.coded
    ]
    crows = [
        i
        for i, g in enumerate(m.curves3d)
        if not m.crv3_copies[i] and isinstance(g, Spline) and g.coded
    ]
    if snet.n != len(srows) or cnet.n != len(crows):
        raise ReadError("net counts")
    if m.tol is None:
        if srows or crows:
            raise ReadError("coded rows in lossless mode")
        return
    tol = m.tol
    vsets = face_vertex_sets(m)
    points = m.vertices.point
    # ---- SNET
    origin = np.zeros((1, 3))
    for k, row in enumerate(srows):
        g = m.surfaces[row]
        assert isinstance(g, Spline)
        nu, nv = g.shape
        o = origin
        cand = next((vsets[f] for f in range(len(vsets)) if int(m.faces.surface[f]) == row), [])
        if snet.anchor[k] > 0:
            if snet.anchor[k] > len(cand):
                raise ReadError("SNET anchor past the candidates")
            o = points[cand[snet.anchor[k] - 1]][None]
        elif snet.anchor[k] < 0:
            raise ReadError("SNET anchor below 0")
        s = abscissae(g.knots[0], g.mults[0], g.degrees[0], g.periodic[0], nu)
        t = abscissae(g.knots[1], g.mults[1], g.degrees[1], g.periodic[1], nv)
        net = Net(snet.code(k, (nu, nv, 3)), snet.method[k], snet.quant[k], snet.level[k],
                  snet.slope[k], tol)  # fmt: skip
        corners = {}
        for c, a in enumerate(snet.corners[k], 1):  # (2.10)
            if a:
                if not 0 < a <= len(cand):
                    raise ReadError("SNET corner pick past the candidates")
                corners[c] = points[cand[a - 1]]
        p = decode_surface(net, (nu, nv), o, s, t, g, corners)
        net.code.ints.end()
        g.poles = p
        origin = p[0, 0][None].copy()
    snet.end()
    # ---- corner pins (§2.9)
    level = dict(zip(srows, zip(snet.quant, snet.level, strict=True), strict=True))
    coded = set(srows)
    pinned: set[int] = set()
    pins: list[tuple[int, int, int]] = []
    for f in range(len(vsets)):
        r = int(m.faces.surface[f])
        g = m.surfaces[r]
        if (
            r not in coded
            or r in pinned
            or not vsets[f]
            or not isinstance(g, Spline)
            or not clamped(g)
        ):
            continue
        _, e = level[r]
        if m.revision < 2:
            rho = tol
        else:
            rho = min(tol, tol * 2.0 ** (e / 4))
        assert g.poles is not None
        nu, nv = g.shape
        got = []
        for ci, (i, j) in enumerate(((0, 0), (0, nv - 1), (nu - 1, 0), (nu - 1, nv - 1))):
            best = min(vsets[f], key=lambda v: (dist(g.poles[i, j], points[v]), v))
            if dist(g.poles[i, j], points[best]) <= rho:
                got.append((r, ci, best))
        if got:
            pinned.add(r)
            pins += got
    for r, ci, v in pins:
        g = m.surfaces[r]
        assert isinstance(g, Spline) and g.poles is not None
        nu, nv = g.shape
        i, j = ((0, 0), (0, nv - 1), (nu - 1, 0), (nu - 1, nv - 1))[ci]
        g.poles[i, j] = points[v]
    # ---- joins (§2.10)
    for r, side, lead, lside, rev in m.sides:
        g, h = m.surfaces[r], m.surfaces[lead]
        assert isinstance(g, Spline) and isinstance(h, Spline)
        assert g.poles is not None and h.poles is not None
        src = boundary(h.poles, lside).copy()
        if rev:
            src = src[::-1]
        dst = boundary(g.poles, side)
        if dst.shape != src.shape:
            raise ReadError("SIDE: sides of different lengths")
        dst[...] = src
    # ---- CNET
    anchors = curve_anchors(m, set(crows))
    origin = np.zeros((1, 3))
    copies: list[tuple[int, int, int]] = []
    for k, row in enumerate(crows):
        g = m.curves3d[row]
        assert isinstance(g, Spline)
        n = g.shape[0]
        method = cnet.method[k]
        code = cnet.code(k, (n, 3))
        if method == 9:
            back, rev = (int(x) for x in code.take(2))
            copies.append((row, back, rev))
            code.ints.end()
            continue
        if method == 6:
            srow, side, rev = (int(x) for x in code.take(3))
            code.ints.end()
            h = m.surfaces[srow]
            if not isinstance(h, Spline) or h.poles is None:
                raise ReadError("CNET: iso-boundary of a surface without a net")
            p = boundary(h.poles, side).copy()
            if rev:
                p = p[::-1].copy()
            g.poles = p
            origin = p[0][None].copy()
            continue
        net = Net(code, method, cnet.quant[k], cnet.level[k], cnet.slope[k], tol)
        o = anchors.get(row, origin)
        p = decode_curve(net, n, o)
        code.ints.end()
        g.poles = p
        origin = p[0][None].copy()
    cnet.end()
    # ---- curve ends (§2.9)
    cpins: list[tuple[int, int, int]] = []
    for row, ends in curve_end_candidates(m, set(crows) - {c for c, _, _ in copies}).items():
        g = m.curves3d[row]
        assert isinstance(g, Spline) and g.poles is not None
        got = [(row, end, v) for end, v in ends if dist(g.poles[end], points[v]) <= tol]
        cpins += got
    for row, end, v in cpins:
        g = m.curves3d[row]
        assert isinstance(g, Spline) and g.poles is not None
        g.poles[end] = points[v]
    # ---- copies (§2.4, method 9: moved by inv(P_row)·P_leader where placed apart)
    where = curve_placements(m) if copies else {}
    m.copies = [(row, row - back) for row, back, _ in copies]
    eye = np.eye(4)
    for row, back, rev in copies:
        g, lead = m.curves3d[row], m.curves3d[row - back]
        assert isinstance(g, Spline)
        if not isinstance(lead, Spline) or lead.poles is None:
            raise ReadError("CNET: copy of a row without poles")
        p = lead.poles.copy()
        p = p[::-1].copy() if rev else p
        a, b = where.get(row, eye), where.get(row - back, eye)
        if not np.array_equal(a, b):
            t = np.linalg.inv(a) @ b
            p = p @ t[:3, :3].T + t[:3, 3]
        g.poles = p


def matrix_power(t: np.ndarray, p: int) -> np.ndarray:
    """§2.4 placements: T^p (p ≠ 0), the inverse first for p < 0; p ≥ 4 by
    binary powering from the lowest bit."""
    if p < 0:
        t, p = np.linalg.inv(t), -p
    if p == 1:
        return t
    if p == 2:
        return t @ t
    if p == 3:
        return (t @ t) @ t
    z = out = None
    while p > 0:
        z = t if z is None else z @ z
        p, bit = divmod(p, 2)
        if bit:
            out = z if out is None else out @ z
    assert out is not None
    return out


def location_matrix(m: Model, loc: int) -> np.ndarray:
    """§2.4 placements: a location's 4 x 4 matrix, its factors multiplied first first."""
    out = np.eye(4)
    datums, powers = m.locations[loc]
    for d, p in zip(datums, powers, strict=True):
        t = np.eye(4)
        t[:3] = m.datums[d]
        out = out @ matrix_power(t, p)
    return out


def curve_placements(m: Model) -> dict[int, np.ndarray]:
    """§2.4 placements: per CRV3 row, the one matrix every kind-0 representation
    reached from the root gives it; rows placed two ways, or not reached, have none."""
    sh = m.shapes
    mats = [location_matrix(m, k) for k in range(len(m.locations))]
    n = len(sh.type)
    place: list[np.ndarray | None] = [None] * n
    many = [False] * n
    reached = [False] * n
    root, _, root_loc = sh.root
    place[root], reached[root] = mats[root_loc], True
    edge_at: dict[int, np.ndarray | None] = {}
    for s in range(n - 1, -1, -1):
        if not reached[s]:
            continue
        t = None if many[s] else place[s]
        if sh.type[s] == 6:
            edge_at[sh.row_of[s]] = t
            continue
        for c, _, loc in sh.children[s]:
            if sh.type[c] == 7:
                continue
            tc = None if t is None else t @ mats[loc]
            if not reached[c]:
                reached[c], place[c], many[c] = True, tc, tc is None
            elif not many[c] and (tc is None or not np.array_equal(place[c], tc)):
                many[c] = True
    at: dict[int, list[np.ndarray | None]] = {}
    reps = m.edges.reps
    for q in range(len(reps)):
        if int(reps[q, 1]) != 0:
            continue
        c, e = int(reps[q, 2]), int(reps[q, 0])
        if e in edge_at:
            t = edge_at[e]
            at.setdefault(c, []).append(None if t is None else t @ mats[int(reps[q, 6])])
    out = {}
    for c, ts in at.items():
        first = ts[0]
        if first is not None and all(x is not None and np.array_equal(x, first) for x in ts):
            out[c] = first
    return out


def _rep_candidates(m: Model, rows: set[int]):
    """§2.9 curve ends, step 1: per coded curve row, the representations that
    may pin it, in row order, with their (pole end, vertex row) pairs."""
    e, sh = m.edges, m.shapes
    for r in range(len(e.reps)):
        if int(e.reps[r, 1]) != 0:
            continue
        c = int(e.reps[r, 2])
        if c not in rows or int(e.reps[r, 6]) != 0:
            continue
        g = m.curves3d[c]
        if not isinstance(g, Spline) or not clamped(g):
            continue
        first, last = (0.0, 1.0) if g.bezier else (float(g.knots[0][0]), float(g.knots[0][-1]))
        if not (float(e.range[r, 0]) == first and float(e.range[r, 1]) == last):
            continue
        es = sh.of(6)[int(e.reps[r, 0])]
        ends = []
        for ch, o, loc in sh.children[es]:
            if sh.type[ch] == 7 and loc == 0 and o in (0, 1):
                ends.append((0 if o == 0 else g.shape[0] - 1, sh.row_of[ch]))
        yield c, ends


def curve_end_candidates(m: Model, rows: set[int]) -> dict[int, list[tuple[int, int]]]:
    """Rows pinned by their first representation with a pin within tol: the
    distance test needs the poles, so this returns every candidate list in
    order; the caller keeps the first that pins."""
    out: dict[int, list[tuple[int, int]]] = {}
    tol = m.tol
    assert tol is not None
    for c, ends in _rep_candidates(m, rows):
        if c in out:
            continue
        g = m.curves3d[c]
        assert isinstance(g, Spline) and g.poles is not None
        if any(dist(g.poles[end], m.vertices.point[v]) <= tol for end, v in ends):
            out[c] = ends
    return out


def curve_anchors(m: Model, rows: set[int]) -> dict[int, np.ndarray]:
    """§2.4 anchored CNET rows: the vertices the first and last poles would be pinned to."""
    out: dict[int, np.ndarray] = {}
    done: set[int] = set()
    for c, ends in _rep_candidates(m, rows):
        if c in done or not ends:
            continue
        done.add(c)
        first = last = None
        for end, v in ends:
            if end == 0:
                first = v
            else:
                last = v
        if first is None:
            continue
        pts = [first] if last is None else [first, last]
        out[c] = m.vertices.point[pts]
    return out
