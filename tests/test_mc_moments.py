"""Monte Carlo's moments in one pass are the bits of the formulas it always used.

``sample_moments`` once centred each column itself for the standard deviation and the fourth
moment (``(c**4).mean``) and called ``scipy.stats.skew``/``kurtosis`` (bias-corrected), which
centre and raise to powers again. ``mechrel.uq.estimators._moments`` forms every sum from one
centred value per entry in the order NumPy sums, and ``pow(c, 4)`` without calling ``pow``
where it can tell the answer. Every test here compares bits (``==``, NaN with NaN, the sign of
zero), never a tolerance: the claim is identity.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import stats

from mechrel.uq.estimators._moments import column_moments, pow4_array
from mechrel.uq.estimators.monte_carlo import sample_moments


def _c_pow4(x):
    """``pow(x, 4.0)`` of the C library, entry by entry (Python's ``math.pow`` calls it):
    NumPy's ``x**4`` was this where the moments were written, and is not in every build (NumPy
    2.4.6 on an AVX-512 machine differs by one ulp at 2.7 % of the entries)."""
    def pow4(v):
        try:
            return math.pow(v, 4.0)
        except OverflowError:  # Python raises where C's pow returns +inf (x⁴ ≥ 0)
            return math.inf

    x = np.asarray(x, dtype=float)
    return np.frompyfunc(pow4, 1, 1)(x).astype(float).reshape(x.shape)


def _old_sample_moments(Y, *, confidence_level):
    """``sample_moments`` as it was before the one-pass moments (mechrel 1c9fbd5), verbatim
    but for the fourth power, the C library's ``pow`` (``_c_pow4``) as NumPy's ``power`` then
    was, whatever NumPy runs the tests."""
    n = Y.shape[0]
    z = stats.norm.ppf(0.5 + confidence_level / 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = Y.mean(axis=0)
        c = Y - mean
        s2 = (c**2).sum(axis=0) / (n - 1) if n > 1 else np.full(Y.shape[1], np.nan)
        s = np.sqrt(s2)
        m4 = _c_pow4(c).mean(axis=0)
        se_mean = s / np.sqrt(n)
        var_s2 = (m4 - s2**2 * (n - 3) / (n - 1)) / n
        se_s2 = np.sqrt(np.maximum(var_s2, 0.0))
        skew = stats.skew(Y, axis=0, bias=False) if n > 2 else np.full(Y.shape[1], np.nan)
        kurt = stats.kurtosis(Y, axis=0, fisher=True, bias=False) if n > 3 else np.full(Y.shape[1], np.nan)  # noqa: E501
    return pd.DataFrame(
        {"mean": mean, "mean_lo": mean - z * se_mean, "mean_hi": mean + z * se_mean,
         "std": s, "std_lo": np.sqrt(np.maximum(s2 - z * se_s2, 0.0)), "std_hi": np.sqrt(s2 + z * se_s2),  # noqa: E501
         "skewness": skew, "excess_kurtosis": kurt},
    )


def _same_bits(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return (a.shape == b.shape and np.array_equal(np.isnan(a), np.isnan(b))
            and np.array_equal(a[~np.isnan(a)].view(np.int64), b[~np.isnan(b)].view(np.int64)))


def _check(Y, rows=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # SciPy's note on nearly constant data
        old = _old_sample_moments(Y if rows is None else Y[rows], confidence_level=0.95)
    new = sample_moments(Y, rows=rows, confidence_level=0.95)
    assert list(new.columns) == list(old.columns)
    bad = [c for c in old.columns if not _same_bits(new[c].to_numpy(), old[c].to_numpy())]
    assert not bad, (Y.shape, bad, new[bad].to_numpy() - old[bad].to_numpy())


def _magnitudes(rng, n):
    """Values of every binade from 2⁻¹⁰⁷⁴ (subnormal) to 2¹⁰²³, both signs, random mantissas."""
    return rng.choice([-1.0, 1.0], n) * np.ldexp(rng.uniform(0.5, 1.0, n),
                                                 rng.integers(-1074, 1024, n))


def test_the_fourth_power_is_the_c_librarys_pow_entry_by_entry():
    rng = np.random.default_rng(20261128)
    x = np.concatenate([
        rng.standard_normal(4_000_000) * 1e-5,  # errors of a mechanism (m)
        rng.standard_normal(2_000_000),
        rng.uniform(-1.0, 1.0, 1_000_000) * 1e3,
        _magnitudes(rng, 2_000_000),
        # short mantissas: x⁴ exact, or a tie between two doubles
        rng.integers(-2**14, 2**14, 500_000) * 2.0 ** rng.integers(-60, 40, 500_000),
        np.ldexp(1.0, np.arange(-1074, 1024)),  # every power of two
        np.nextafter(np.ldexp(1.0, np.arange(-300, 300)), 0.0),  # just below them
        np.ldexp(1.0, np.arange(-201, -199)), np.ldexp(1.0, np.arange(199, 201)),  # the ends
        [0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324, 1.7976931348623157e308],
    ])
    with np.errstate(all="ignore"):
        want = _c_pow4(x)
    got = pow4_array(x)
    same = (got.view(np.int64) == want.view(np.int64)) | (np.isnan(got) & np.isnan(want))
    assert same.all(), (x[~same][:5], got[~same][:5], want[~same][:5])


@pytest.mark.parametrize("shape", [(200_000, 8), (5_000, 2), (3_001, 1), (997, 3),
                                   (257, 40), (4, 5), (5, 2), (3, 4), (2, 3), (1, 2)])
def test_moments_are_the_old_bits(shape):
    rng = np.random.default_rng(sum(shape))
    n, k = shape
    # columns of other scales and shapes: errors (m) around a mean, skewed, heavy-tailed
    Y = (rng.standard_normal(shape) * 10.0 ** rng.uniform(-7, 1, k)
         + rng.uniform(-1, 1, k) * 10.0 ** rng.uniform(-6, 2, k))
    if k > 2:
        Y[:, 1] = rng.lognormal(0.0, 1.0, n)
        Y[:, 2] = rng.standard_t(3, n) * 1e-4
    _check(Y)
    ok = rng.random(n) > 0.1
    _check(Y, ok)  # the rows of the successful samples, not copied out
    _check(np.asfortranarray(Y))  # another memory order: NumPy sums it otherwise


def test_degenerate_columns_and_non_finite_values_are_the_old_bits():
    rng = np.random.default_rng(7)
    Y = rng.standard_normal((1000, 6))
    Y[:, 0] = 0.25  # constant: skewness and kurtosis NaN
    Y[:, 1] = 0.0  # constant zero
    Y[:, 2] = 1e6 + rng.standard_normal(1000) * 1e-9  # cancellation in the centring
    Y[:, 3] = np.where(np.arange(1000) % 2, 1.0, -1.0)  # two values
    _check(Y)
    Z = Y.copy()
    Z[10, 4] = np.nan  # a NaN column: SciPy's per-column path for the others
    _check(Z)
    Z[11, 5] = np.inf
    _check(Z)


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 40), st.integers(1, 5)),
              elements=st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)))
def test_moments_are_the_old_bits_for_any_array(Y):
    _check(Y)


def test_column_moments_reads_only_the_given_rows():
    rng = np.random.default_rng(3)
    Y = rng.standard_normal((500, 4))
    rows = rng.random(500) > 0.3
    Y[~rows] = np.nan  # the failed samples' NaN rows are never read
    got = column_moments(Y, rows)
    want = column_moments(np.ascontiguousarray(Y[rows]))
    assert got[0] == rows.sum() and all(_same_bits(g, w) for g, w in zip(got[1:], want[1:]))


def test_normal_inputs_are_sampled_with_scipys_bits():
    # from_unit maps a normal marginal as from_z(ndtri(u)), not through norm.ppf: the same bits
    from mechrel.uq import LogNormal, Normal, UncertainInputs
    from mechrel.uq.problem import inputs as mod

    inputs = UncertainInputs.from_specs({"a": Normal(0.05, 2e-5), "b": Normal(-3.0, 0.7),
                                         "c": LogNormal(1.0, 0.1)})
    u = np.random.default_rng(5).random((100_000, 3))
    u[:3] = [[1e-300, 0.5, 1 - 1e-17]] * 3  # clipped to stay inside (0, 1)
    X = inputs.from_unit(u)
    uc = np.clip(u, mod._U_EPS, 1.0 - mod._U_EPS)
    want = np.column_stack([m.scipy().ppf(uc[:, j]) for j, m in enumerate(inputs.marginals)])
    assert _same_bits(X, want)
