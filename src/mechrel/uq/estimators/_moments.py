"""Column moments of a sample in one pass over the centred values, bitwise those of the
formulas Monte Carlo has always used.

:func:`column_moments` returns, per column of ``Y`` (rows: samples), the mean, the unbiased
variance, the fourth central moment ``mean((y − ȳ)**4)`` (the power being the C library's
``pow``, which NumPy's ``power`` was where these formulas were written; see below), and the
bias-corrected skewness and excess kurtosis of ``scipy.stats.skew(Y, bias=False)`` and
``scipy.stats.kurtosis(Y, bias=False)``. The numbers are those bits, not approximations of them: SciPy computes each moment on its own (it centres
the array four times and raises it to powers again, a second per 10⁶×8 array); here the
centred value of each entry is formed once and every sum taken from it, in the order NumPy
and SciPy sum (see below), and the closing formulas are SciPy's, operation by operation
(``scipy/stats/_stats_py.py``: ``_moment``, ``skew``, ``kurtosis``; SciPy 1.17).

How the sums are ordered
------------------------
NumPy reduces axis 0 of a C-ordered array with two or more columns row after row (a plain
running sum per column); SciPy's ``nan_policy`` wrapper moves that axis last as a view, so
its reductions run over the same memory in the same order. The compiled pass
(:func:`_central_sums`) keeps those running sums. A single column, or an array that is not
C-ordered, is summed by NumPy pairwise instead: those arrays go through the same formulas on
whole arrays with NumPy (:func:`_numpy_moments`), which then sums as it always did. An array
with a NaN or an infinity goes to SciPy itself (its ``nan_policy="propagate"`` path treats
each column on its own), as do fewer than 4 rows.

The fourth power
----------------
``(y − ȳ)**4`` is the C library's ``pow``, some 25 ns an entry and most of the cost of the
moments. The compiled pass forms x⁴ exactly as a double-double (Dekker's products: x² = p + e
and p² = q + f, all exact) and rounds it once; where the exact value lies within 1/16 ulp of
a rounding boundary (one entry in eight) it calls ``pow`` itself. Elsewhere the two agree:
glibc's ``pow`` (since 2.28) errs by at most 0.54 ulp (its source's bound, "ulperr_exp +
1024 Ln2 relerr_log 2^53"), so it rounds to the nearest double whenever the exact value is
more than 0.04 ulp from a boundary. ``tests/test_mc_moments.py`` checks the pass against
``pow`` (Python's ``math.pow``) entry by entry on ~10⁷ values of every magnitude, and the whole
against SciPy, bitwise.

NumPy's own ``x**4`` of a float64 array is no longer ``pow`` in every build: NumPy 2.4.6 from
PyPI, on an AVX-512 machine, differs from it by one ulp at 2.7 % of the entries, at every
magnitude (2026-11-29). The moments keep ``pow``, so that they do not depend on NumPy's build,
and the tests' "formulas Monte Carlo always used" take ``pow`` too.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy import stats

__all__ = ["column_moments"]

_SPLIT = 134217729.0  # 2**27 + 1: Veltkamp's splitting constant for binary64
_GUARD = 0.5 - 1.0 / 16.0  # |x⁴ − r| below this many ulps of r: r is pow's answer
_LO, _HI = 2.0**-200, 2.0**200  # |x| outside: x⁴ near the ends of the range, pow itself


@numba.njit(cache=True, inline="always")
def _two_prod_err(a, b, p):
    """a·b − p exactly, for p = fl(a·b) (Dekker 1971: no fused multiply-add needed)."""
    t = _SPLIT * a
    ah = t - (t - a)
    al = a - ah
    t = _SPLIT * b
    bh = t - (t - b)
    bl = b - bh
    return ((ah * bh - p) + ah * bl + al * bh) + al * bl


@numba.njit(cache=True)
def _pow4_into(x, out):
    """``out[i] = pow(x[i], 4.0)`` of the C library, bitwise (see the module's docstring): the
    rounded double-double first (a loop without calls, which the compiler vectorises), then
    ``pow`` itself for the entries within the guard band and outside the safe range."""
    m = x.shape[0]
    bits = np.empty(1)
    ibits = bits.view(np.int64)  # to read a double's exponent field without a call
    hard = np.empty(m, dtype=np.bool_)
    for i in range(m):
        ax = abs(x[i])
        p = ax * ax
        e = _two_prod_err(ax, ax, p)  # x² = p + e
        q = p * p
        f = _two_prod_err(p, p, q)  # p² = q + f
        t = f + 2.0 * p * e + e * e
        r = q + t
        d = (q - r) + t  # x⁴ − r, to about 2⁻¹⁰⁰ r (q − r is exact: Sterbenz)
        bits[0] = r
        b = ibits[0]
        ibits[0] = ((b >> 52) - 52) << 52
        u = bits[0]  # the spacing of doubles above r (r > 2⁻⁸⁰⁰ is normal)
        if (b & 0xFFFFFFFFFFFFF) == 0 and d < 0.0:
            u *= 0.5  # and below r, when r is a power of two
        out[i] = r
        hard[i] = not (_LO < ax < _HI and abs(d) < _GUARD * u)  # also 0, NaN and inf
    for i in range(m):
        if hard[i]:
            out[i] = math.pow(x[i], 4.0)


@numba.njit(cache=True)
def pow4_array(x):
    """``pow(x, 4.0)`` of each entry of a 1-D array, as :func:`_central_sums` forms it (for
    the tests)."""
    out = np.empty_like(x)
    _pow4_into(x, out)
    return out


@numba.njit(cache=True)
def _central_sums(Y, rows):
    """Per column of ``Y[rows]`` (C-ordered, the rows in order): the running sums of y, then of
    c², c²·c, c²·c² and pow(c, 4) for c = y − ȳ, ȳ = Σy / n; returns ``(mean, S2, S3, S4, P4,
    finite)``, ``finite`` False when a sum of y is not finite (the caller then leaves the
    work to SciPy). Rows are taken in blocks, each block's fourth powers formed at once."""
    n_rows, k = Y.shape
    n = 0
    s1 = np.zeros(k)
    for i in range(n_rows):
        if rows[i]:
            n += 1
            for j in range(k):
                s1[j] += Y[i, j]
    mean = s1 / n
    for j in range(k):
        if not math.isfinite(s1[j]):
            return mean, s1, s1, s1, s1, False
    s2 = np.zeros(k)
    s3 = np.zeros(k)
    s4 = np.zeros(k)
    p4 = np.zeros(k)
    block = max(1, 4096 // k)
    c = np.empty(block * k)
    c4 = np.empty(block * k)
    i = 0
    while i < n_rows:
        m = 0  # rows of this block
        while i < n_rows and m < block:
            if rows[i]:
                for j in range(k):
                    c[m * k + j] = Y[i, j] - mean[j]
                m += 1
            i += 1
        _pow4_into(c[:m * k], c4[:m * k])
        for r in range(m):
            for j in range(k):
                cj = c[r * k + j]
                c2 = cj * cj
                s2[j] += c2
                s3[j] += c2 * cj
                s4[j] += c2 * c2
                p4[j] += c4[r * k + j]
    return mean, s2, s3, s4, p4, True


def _closing(n, mean, m2, m3, m4s):
    """SciPy's skewness and kurtosis (bias=False, Fisher) from its moments, operation by
    operation (``n`` a Python int, as SciPy's ``_length_nonmasked`` gives it)."""
    with np.errstate(all="ignore"):
        eps = np.finfo(m2.dtype).eps
        zero = m2 <= (eps * mean) ** 2
        skew = np.where(zero, np.nan, m3 / m2**1.5)
        can_correct = ~zero & (n > 2)
        if np.any(can_correct):
            nval = ((n - 1.0) * n) ** 0.5 / (n - 2.0) * m3 / m2**1.5
            skew = np.where(can_correct, nval, skew)
        zero = m2 <= (np.finfo(m2.dtype).eps * mean) ** 2
        kurt = np.where(zero, np.nan, m4s / m2**2.0)
        can_correct = ~zero & (n > 3)
        if np.any(can_correct):
            nval = 1.0 / (n - 2) / (n - 3) * ((n**2 - 1.0) * m4s / m2**2.0 - 3 * (n - 1) ** 2.0)
            kurt = np.where(can_correct, nval + 3.0, kurt)
        kurt = kurt - 3
    return skew, kurt


def _pow4(c):
    """``pow(c, 4.0)`` of the C library entry by entry (:func:`_pow4_into`), in ``c``'s memory
    layout (NumPy then sums it as it sums ``c**4``)."""
    out = np.empty_like(c)  # contiguous in c's order: its K-order ravel is a view of it
    _pow4_into(np.ascontiguousarray(c.ravel(order="K")), out.ravel(order="K"))
    return out


def _numpy_moments(Y):
    """The formulas on whole arrays with NumPy (its own summation order for the layout)."""
    n = Y.shape[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = Y.mean(axis=0)
        c = Y - mean
        c2 = c**2
        ss = c2.sum(axis=0)
        p4 = _pow4(c).mean(axis=0)
        skew, kurt = _closing(n, mean, ss / n, (c2 * c).mean(axis=0), (c2 * c2).mean(axis=0))
    return mean, ss, p4, skew, kurt


def _scipy_moments(Y):
    """The formulas as they were written before, SciPy computing skewness and kurtosis."""
    n = Y.shape[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = Y.mean(axis=0)
        c = Y - mean
        ss = (c**2).sum(axis=0)
        p4 = _pow4(c).mean(axis=0)
        skew = stats.skew(Y, axis=0, bias=False) if n > 2 else np.full(Y.shape[1], np.nan)
        kurt = (stats.kurtosis(Y, axis=0, fisher=True, bias=False) if n > 3
                else np.full(Y.shape[1], np.nan))
    return mean, ss, p4, skew, kurt


def column_moments(Y: np.ndarray, rows: np.ndarray | None = None):
    """Moments of each column of ``Y[rows]`` (all rows when ``rows`` is None).

    Parameters
    ----------
    Y : ndarray, shape (m, k)
        The sample, one row per draw.
    rows : ndarray of bool, shape (m,), optional
        The rows to use (the successful samples); the others are not read.

    Returns
    -------
    n : int
        The number of rows used.
    mean, sum_sq, m4, skewness, excess_kurtosis : ndarray, shape (k,)
        ȳ; Σ(y − ȳ)²; mean of pow(y − ȳ, 4); SciPy's bias-corrected skewness and excess
        kurtosis (NaN for fewer than 3 and 4 rows, and for a constant column).
    """
    Y = np.asarray(Y, dtype=float)
    n = int(Y.shape[0] if rows is None else np.count_nonzero(rows))
    if Y.ndim == 2 and Y.shape[1] >= 2 and n >= 4 and Y.flags.c_contiguous:
        sel = np.ones(Y.shape[0], dtype=np.bool_) if rows is None else np.asarray(rows, bool)
        mean, s2, s3, s4, p4, finite = _central_sums(Y, sel)
        if finite:
            with np.errstate(invalid="ignore", divide="ignore"):
                skew, kurt = _closing(n, mean, s2 / n, s3 / n, s4 / n)
                return n, mean, s2, p4 / n, skew, kurt
    Ys = Y if rows is None else Y[rows]
    if n >= 4 and np.isfinite(Ys).all():
        return (n, *_numpy_moments(Ys))
    return (n, *_scipy_moments(Ys))
