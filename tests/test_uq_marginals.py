"""Marginals beyond the normal family: Gumbel (max), Weibull, gamma, beta, and any frozen
continuous scipy.stats distribution (ScipyMarginal), everywhere a marginal is used.

Tolerances
----------
* Moments and quantiles against the closed forms: 1e-12 relative (a few roundings of the
  special functions involved).
* Sample moments and frequencies: 4.5 standard errors (two-sided 7e-6 per assertion at fixed
  seeds). The standard error of a mean is σ/√n; of a variance √((μ₄ − σ⁴)/n) (μ₄ the fourth
  central moment, closed form); of a frequency √(p(1 − p)/n). Latin hypercube and Sobol' points
  stratify each margin, so their errors are smaller than the iid ones the bound is built for.
* Sample Pearson correlation: 4.5 standard errors from the delta method (the influence function
  of r, x̃ỹ − r(x̃² + ỹ²)/2 of the standardised pair, valid for non-normal pairs).
* The Nataf matrix against an independent quadrature (composite Gauss–Legendre on the plane,
  scipy's own ppf): 1e-7, the size the 48-point Gauss–Hermite rule reaches on these pairs.
* Round trips x → z → x and z → x → z: the rounding of x (a few ε·(|x| + scale)) propagated by
  dz/dx = f(x)/φ(z).
* FORM in one dimension is exact for a monotone map: β to 1e-10 (the surface criterion).
  Sampling estimators: 3 of their own c.o.v. (normal approximation, 3σ).
* PCE: exact (1e-11) where the basis holds the model (polynomials of gamma and beta inputs);
  for the standard-normal image of Gumbel, Weibull and scipy inputs, spectral convergence
  measured at Gauss–Hermite order 16 (largest error 2.8e-7, the std of Student's t with 7
  degrees of freedom): 1e-6.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, special, stats

from mechrel.errors import StudyError
from mechrel.uq import (
    Allowable,
    Beta,
    FunctionModel,
    Gamma,
    Gumbel,
    LimitState,
    ScipyMarginal,
    UncertainInputs,
    Weibull,
    form,
    fosm,
    importance_sampling,
    monte_carlo,
    polynomial_chaos,
    sorm,
)

EULER = 0.5772156649015329

GEV = ScipyMarginal(stats.genextreme(c=-0.1, loc=1.0, scale=2.0))
T7 = ScipyMarginal(stats.t(df=7.0, loc=1.0, scale=0.5))
MARGINALS = {
    "gumbel": Gumbel(100.0, 15.0),
    "weibull": Weibull(1.5, 2.0, 1.0),
    "weibull_k0.8": Weibull(0.8, 2.0),
    "gamma": Gamma(2.0, 0.5),
    "gamma_skewed": Gamma(1.0, 2.0),
    "beta": Beta(2.0, 5.0, 1.0, 3.0),
    "beta_u": Beta(0.5, 0.7, -1.0, 1.0),
    "gev": GEV,
    "t7": T7,
}


def _closed_forms(m):
    """(mean, variance, fourth central moment, quantile function) by hand, not from scipy.stats."""
    if isinstance(m, Gumbel):
        b = m.std * math.sqrt(6) / math.pi
        mu = m.mean - EULER * b
        return m.mean, m.std**2, 5.4 * m.std**4, lambda p: mu - b * np.log(-np.log(p))
    if isinstance(m, Weibull):
        k, lam = m.shape, m.scale
        g = [math.gamma(1 + i / k) for i in range(5)]
        mean = lam * g[1]
        var = lam**2 * (g[2] - g[1] ** 2)
        mu4 = lam**4 * (g[4] - 4 * g[3] * g[1] + 6 * g[2] * g[1] ** 2 - 3 * g[1] ** 4)
        return m.lower + mean, var, mu4, lambda p: m.lower + lam * (-np.log1p(-p)) ** (1 / k)
    if isinstance(m, Gamma):
        k, th = (m.mean / m.std) ** 2, m.std**2 / m.mean
        return m.mean, m.std**2, 3 * k * (k + 2) * th**4, lambda p: th * special.gammaincinv(k, p)
    if isinstance(m, Beta):
        a, b, w = m.alpha, m.beta, m.upper - m.lower
        s = a + b
        var = a * b / (s**2 * (s + 1))
        ex_kurt = 6 * ((a - b) ** 2 * (s + 1) - a * b * (s + 2)) / (a * b * (s + 2) * (s + 3))
        return (m.lower + w * a / s, w**2 * var, w**4 * var**2 * (ex_kurt + 3),
                lambda p: m.lower + w * special.betaincinv(a, b, p))
    d = m.distribution
    mean, var, kurt = (float(v) for v in d.stats("mvk"))
    return mean, var, (kurt + 3) * var**2, d.ppf


# ---------------------------------------------------------------- moments and quantiles
@pytest.mark.parametrize("key", list(MARGINALS))
def test_moments_and_quantiles_against_closed_forms(key):
    m = MARGINALS[key]
    mean, var, _, quantile = _closed_forms(m)
    inputs = UncertainInputs.from_specs({"x": m})
    assert inputs.mean[0] == pytest.approx(mean, rel=1e-12)
    assert inputs.std[0] == pytest.approx(math.sqrt(var), rel=1e-12)
    p = np.array([1e-9, 1e-4, 0.01, 0.3, 0.5, 0.7, 0.99, 1 - 1e-4])
    q = quantile(p)
    assert m.from_z(special.ndtri(p)) == pytest.approx(q, rel=1e-12, abs=1e-13)
    assert m.scipy().ppf(p) == pytest.approx(q, rel=1e-12, abs=1e-13)
    # the chaospy distribution is the same law
    assert float(m.chaospy().mom(1)) == pytest.approx(mean, rel=1e-9)
    assert np.asarray(m.chaospy().fwd(q[2:-1])) == pytest.approx(p[2:-1], rel=1e-9)


def test_upper_tail_keeps_its_relative_accuracy():
    """Φ(z) rounds to 1 beyond z ≈ 8.3; the maps go through the upper tail's probability, so
    that P(X > x(z)) = Φ(−z) holds to 1e-12 relative out to z = 10 (Φ(−10) = 7.6e-24)."""
    z = np.array([6.0, 8.0, 9.0, 10.0])
    for key in ("gumbel", "weibull", "gamma", "gev"):
        m = MARGINALS[key]
        x = m.from_z(z)
        assert m.scipy().sf(x) == pytest.approx(special.ndtr(-z), rel=1e-11)
        assert m.to_z(x) == pytest.approx(z, rel=1e-12)
    # closed-form maps (Gumbel, Weibull) stay exact far beyond: z = 30, P = 4.9e-198
    for m in (MARGINALS["gumbel"], MARGINALS["weibull"]):
        assert float(m.scipy().sf(m.from_z(np.array([30.0])))[0]) == pytest.approx(
            special.ndtr(-30.0), rel=1e-10)


# ---------------------------------------------------------------- sampling
@pytest.mark.parametrize("rule", ["random", "latin_hypercube", "sobol"])
def test_sample_moments_and_frequencies_within_their_confidence_intervals(rule):
    keys = list(MARGINALS)
    inputs = UncertainInputs.from_specs({k: MARGINALS[k] for k in keys})
    n = 2**15
    X = inputs.sample(n, rule, seed=5)
    assert np.all(np.isfinite(X))
    for j, k in enumerate(keys):
        mean, var, mu4, quantile = _closed_forms(MARGINALS[k])
        x = X[:, j]
        assert abs(x.mean() - mean) <= 4.5 * math.sqrt(var / n), k
        assert abs(x.var(ddof=1) - var) <= 4.5 * math.sqrt((mu4 - var**2) / n), k
        for p in (0.01, 0.1, 0.5, 0.9, 0.99):
            assert abs(np.mean(x <= quantile(p)) - p) <= 4.5 * math.sqrt(p * (1 - p) / n), (k, p)
    lo, hi = keys.index("beta"), keys.index("weibull")
    assert X[:, lo].min() >= 1.0 and X[:, lo].max() <= 3.0 and X[:, hi].min() >= 1.0


# ---------------------------------------------------------------- Nataf
def _pearson_se(x, y):
    """Delta-method standard error of the sample Pearson correlation (any distribution)."""
    a = (x - x.mean()) / x.std()
    b = (y - y.mean()) / y.std()
    r = np.mean(a * b)
    return float(np.std(a * b - 0.5 * r * (a * a + b * b)) / math.sqrt(len(x)))


PAIRS = [
    ("gumbel", "weibull", 0.6),
    ("gumbel", "gumbel", -0.8),        # attainable down to −0.886
    ("weibull_k0.8", "gamma_skewed", 0.8),
    ("gamma", "beta", -0.4),
    ("beta_u", "gev", 0.5),
    ("t7", "gamma", 0.7),
    ("gev", "t7", -0.6),
]


@pytest.mark.parametrize("a, b, rho", PAIRS)
def test_correlated_sample_has_the_requested_pearson_correlation(a, b, rho):
    inputs = UncertainInputs.from_specs({"a": MARGINALS[a], "b": MARGINALS[b]},
                                        correlation={("a", "b"): rho})
    n = 2**17
    X = inputs.sample(n, "random", seed=3)
    r = np.corrcoef(X.T)[0, 1]
    assert abs(r - rho) <= 4.5 * _pearson_se(X[:, 0], X[:, 1])
    # the copula leaves the marginals alone
    for j, key in enumerate((a, b)):
        mean, var, *_ = _closed_forms(MARGINALS[key])
        assert abs(X[:, j].mean() - mean) <= 4.5 * math.sqrt(var / n)
    # round trip through the independent standard normal space
    Z = inputs.to_standard_normal(X[:200])
    assert inputs.from_standard_normal(Z) == pytest.approx(X[:200], rel=1e-9, abs=1e-12)


def _pearson_by_plane_quadrature(d1, d2, r, half_width=13.0, n=800):
    """ρ_x = E[g1(Z1) g2(Z2)] for Corr(Z1, Z2) = r, g = standardised F⁻¹∘Φ, by composite
    40-point Gauss–Legendre (20 panels) on [−13, 13]² (the Gaussian weight beyond is < 1e-37), using
    scipy's ppf/isf directly (not mechrel's maps)."""
    x, w = np.polynomial.legendre.leggauss(40)
    edges = np.linspace(-half_width, half_width, n // 40 + 1)
    z = np.concatenate([(lo + hi) / 2 + (hi - lo) / 2 * x for lo, hi in zip(edges[:-1], edges[1:])])
    wz = np.concatenate([(hi - lo) / 2 * w for lo, hi in zip(edges[:-1], edges[1:])])
    wz = wz * np.exp(-z * z / 2) / math.sqrt(2 * math.pi)

    def g(d, zz):
        p = special.ndtr(-np.abs(zz))
        out = np.where(zz <= 0, d.ppf(p), d.isf(p))
        return (out - d.mean()) / d.std()

    zb = r * z[:, None] + math.sqrt(1 - r * r) * z[None, :]
    return float(np.sum(wz[:, None] * wz[None, :] * g(d1, z)[:, None] * g(d2, zb)))


@pytest.mark.parametrize("a, b, rho", PAIRS[:5])
def test_nataf_matrix_against_an_independent_quadrature(a, b, rho):
    ma, mb = MARGINALS[a], MARGINALS[b]
    inputs = UncertainInputs.from_specs({"a": ma, "b": mb}, correlation={("a", "b"): rho})
    rz = inputs.gaussian_correlation[0, 1]
    assert rz != pytest.approx(rho, abs=1e-3)  # non-normal marginals: R_z differs from R_x
    assert _pearson_by_plane_quadrature(ma.scipy(), mb.scipy(), rz) == pytest.approx(rho, abs=1e-7)


def _frechet_bounds(d1, d2):
    """The Pearson correlations of the counter- and comonotonic couplings (1-D quadrature)."""
    m1, s1, m2, s2 = d1.mean(), d1.std(), d2.mean(), d2.std()
    co = integrate.quad(lambda u: d1.ppf(u) * d2.ppf(u), 0, 1, limit=500)[0]
    counter = integrate.quad(lambda u: d1.ppf(u) * d2.ppf(1 - u), 0, 1, limit=500)[0]
    return (counter - m1 * m2) / (s1 * s2), (co - m1 * m2) / (s1 * s2)


@pytest.mark.parametrize("a, b, rho, closed_form_low", [
    (Gamma(1.0, 1.0), Gamma(3.0, 3.0), -0.7, 1 - math.pi**2 / 6),  # two exponentials (Moran)
    (Gumbel(0.0, 1.0), Gumbel(5.0, 2.0), -0.9, None),
    (Weibull(1.5, 1.0), Weibull(1.5, 2.0, 3.0), -0.9, None),
    (Weibull(0.5, 1.0), Gamma(1.0, 2.0), 0.99, None),
])
def test_unattainable_correlation_is_refused_with_the_attainable_range(a, b, rho, closed_form_low):
    with pytest.raises(StudyError, match=r"inputs\.correlation\['a', 'b'\]: got ") as exc:
        UncertainInputs.from_specs({"a": a, "b": b}, correlation={("a", "b"): rho})
    lo, hi = (float(v) for v in re.search(r"in \[(\S+), (\S+)\]", str(exc.value)).groups())
    ref_lo, ref_hi = _frechet_bounds(a.scipy(), b.scipy())
    # printed to 4 decimals; the search stops at R_z = ±0.999999
    assert (lo, hi) == pytest.approx((ref_lo, ref_hi), abs=1e-4)
    if closed_form_low is not None:
        assert lo == pytest.approx(closed_form_low, abs=1e-4)
    # just inside the range is accepted
    inside = float(np.clip(rho, lo + 1e-3, hi - 1e-3))
    UncertainInputs.from_specs({"a": a, "b": b}, correlation={("a", "b"): inside})


# ---------------------------------------------------------------- round trips (hypothesis)
_MAKERS = {
    "gumbel": st.builds(Gumbel, st.floats(-1e3, 1e3), st.floats(1e-3, 1e2)),
    "weibull": st.builds(Weibull, st.floats(0.3, 20.0), st.floats(1e-3, 1e3), st.floats(-10, 10)),
    "gamma": st.builds(Gamma, st.floats(1e-2, 1e2), st.floats(1e-2, 1e2)),
    "beta": st.builds(lambda a, b, lo, w: Beta(a, b, lo, lo + w), st.floats(0.3, 20.0),
                      st.floats(0.3, 20.0), st.floats(-10, 10), st.floats(0.1, 10)),
    # shapes normal floats: SciPy's own genextreme is inconsistent at a subnormal shape
    # (c = 5e-324: ppf(p) = 0 for every p while cdf(0) = e^-1), which no wrapper can round-trip
    "scipy": st.builds(lambda c, loc, sc: ScipyMarginal(stats.genextreme(c, loc, sc)),
                       st.floats(-0.3, 0.3, allow_subnormal=False), st.floats(-10, 10),
                       st.floats(0.1, 10)),
}


@settings(max_examples=60, deadline=None)
@given(st.one_of(*_MAKERS.values()), st.floats(-7.0, 7.0))
def test_round_trip_between_the_marginal_and_the_standard_normal(m, z):
    m = m.validated("x")
    d = m.scipy()
    x = m.from_z(np.array([z]))[0]
    assert np.isfinite(x)
    # x is the Φ(z)-quantile (scipy's cdf/sf, an independent evaluation), to rounding
    p = special.ndtr(-abs(z))
    tail = d.cdf(x) if z <= 0 else d.sf(x)
    scale = float(d.std())
    with np.errstate(divide="ignore"):  # a Weibull of modulus < 1 at its lower end
        dens = float(d.pdf(x))
    rounding = 64 * np.finfo(float).eps * (abs(x) + scale)
    assert abs(tail - p) <= 1e-10 * p + dens * rounding
    # z -> x -> z: the rounding of x propagated by dz/dx = f(x)/φ(z)
    z2 = m.to_z(np.array([x]))[0]
    assert abs(z2 - z) <= 1e-9 + dens / stats.norm.pdf(z) * rounding
    # x -> z -> x: exact up to that rounding
    assert m.from_z(np.array([z2]))[0] == pytest.approx(x, abs=rounding + 1e-9 * scale)


# ---------------------------------------------------------------- FORM, SORM, IS
def _vec(func, inputs, outputs=("g",)):
    return FunctionModel(func, inputs.names, list(outputs), key="marginals", vectorized=True)


def _demand_minus_load(X):
    return 200.0 - X[:, 0]


def _strength_minus_load(X):
    return X[:, 0] - X[:, 1]


def _load(X):
    return X[:, 0]


def test_form_exact_in_one_dimension_for_gumbel_and_weibull():
    """Margins a − X (Gumbel load) and X − a (Weibull strength): a monotone map to z makes the
    limit state a point, so P_f = Φ(−β) exactly: P(X > a) = 1 − exp(−exp(−(a − μ)/β_G)) and
    P(X < a) = 1 − exp(−((a − lower)/λ)^k)."""
    load = Gumbel(100.0, 15.0)
    inputs = UncertainInputs.from_specs({"S": load})
    res = form(model=_vec(_demand_minus_load, inputs), inputs=inputs, tol=1e-12)
    mu, b = load.params
    pf = -math.expm1(-math.exp(-(200.0 - mu) / b))
    assert res.beta == pytest.approx(-special.ndtri(pf), abs=1e-10)
    assert 1e-5 < pf < 1e-3
    assert res.x_star["S"] == pytest.approx(200.0, rel=1e-9)

    strength = Weibull(8.0, 250.0, 20.0)
    inputs = UncertainInputs.from_specs({"R": strength})
    model = FunctionModel(lambda X: X[:, 0] - 120.0, ["R"], ["g"], key="w", vectorized=True)
    res = form(model=model, inputs=inputs, tol=1e-12)
    pf = -math.expm1(-(((120.0 - 20.0) / 250.0) ** 8))
    assert res.beta == pytest.approx(-special.ndtri(pf), abs=1e-10)
    assert res.x_star["R"] == pytest.approx(120.0, rel=1e-9)


def _stress_strength_reference(strength, load, rz=0.0):
    """P(R < S) for R, S coupled by a Gaussian copula of correlation rz: a 1-D quadrature over
    the load's germ z_S of P(z_R < Φ⁻¹(F_R(s)) | z_S), with s = F_S⁻¹(Φ(z_S)) (scipy's maps)."""
    dR, dS = strength.scipy(), load.scipy()

    def integrand(zs):
        s = dS.isf(special.ndtr(-zs))
        zr = special.ndtri(dR.cdf(s)) if dR.cdf(s) < 0.5 else -special.ndtri(dR.sf(s))
        return special.ndtr((zr - rz * zs) / math.sqrt(1 - rz * rz)) * stats.norm.pdf(zs)

    return integrate.quad(integrand, -12, 12, epsabs=0, epsrel=1e-11, limit=400,
                          points=[0, 2, 4])[0]


def _design_point_by_optimisation(inputs, g):
    """The minimum of ‖u‖ subject to g(x(u)) = 0, by SLSQP from several starts (a search
    independent of FORM's)."""
    from scipy.optimize import minimize

    best = None
    for start in ([1.0, 1.0], [-2.0, 2.0], [-3.0, 1.0]):
        on_surface = {"type": "eq", "fun": lambda u: g(inputs.from_standard_normal(u[None, :]))[0]}
        r = minimize(lambda u: u @ u, start, method="SLSQP", tol=1e-14, constraints=on_surface)
        if r.success and (best is None or r.fun < best.fun):
            best = r
    return math.sqrt(best.fun)


@pytest.mark.parametrize("rho", [0.0, 0.4])
def test_stress_strength_weibull_against_gumbel(rho):
    """Weibull strength R (modulus 8) against a Gumbel load S (P_f ≈ 1.4e-3 independent):
    FORM's β is that of an independent search for the design point; FORM itself is 21 % low
    here (the surface is curved in u), SORM within 2 %, importance sampling within its own
    interval of the 1-D quadrature."""
    strength, load = Weibull(8.0, 250.0), Gumbel(100.0, 15.0)
    inputs = UncertainInputs.from_specs({"R": strength, "S": load},
                                        correlation=None if rho == 0 else {("R", "S"): rho})
    model = _vec(_strength_minus_load, inputs)
    rz = 0.0 if rho == 0 else inputs.gaussian_correlation[0, 1]
    ref = _stress_strength_reference(strength, load, rz)
    assert 1e-4 < ref < 1e-2
    f = form(model=model, inputs=inputs, tol=1e-10)
    assert f.beta == pytest.approx(_design_point_by_optimisation(inputs, _strength_minus_load),
                                   abs=1e-6)
    assert f.x_star["R"] == pytest.approx(f.x_star["S"], rel=1e-8)  # on the surface R = S
    assert 0.6 < f.pf / ref < 1.0
    s = sorm(model=model, inputs=inputs)
    assert s.pf == pytest.approx(ref, rel=0.05)
    res = importance_sampling(model=model, inputs=inputs, n=4000, seed=3, progress=False)
    assert abs(res.pf - ref) <= 3 * res.cov * res.pf


def test_random_allowable_of_any_marginal():
    """The same stress–strength problem with the Weibull strength as the limit state's random
    allowable of the load output: the same design point, the same P_f, and the allowable never
    reaches the model."""
    strength, load = Weibull(8.0, 250.0), Gumbel(100.0, 15.0)
    both = UncertainInputs.from_specs({"R": strength, "S": load})
    ref = form(model=_vec(_strength_minus_load, both), inputs=both, tol=1e-10)
    inputs = UncertainInputs.from_specs({"S": load})
    ls = LimitState.exceedance("y", strength, kind="upper")
    res = form(model=_vec(_load, inputs, ["y"]), inputs=inputs, limit_state=ls, tol=1e-10)
    assert res.beta == pytest.approx(ref.beta, abs=1e-8)
    assert list(res.design_point.index) == ["S", "allowable[y]"]
    assert res.evaluations.X.shape[1] == 1
    assert ls.random_allowables == {"allowable[y]": strength}
    assert "Weibull(shape=8.0, scale=250.0, lower=0.0)" in str(res.provenance["inputs"])
    gev = LimitState.exceedance("y", GEV, kind="upper")
    assert gev.components[0].random


def test_limit_state_refuses_a_non_marginal_allowable_naming_the_marginals():
    with pytest.raises(StudyError, match=r"allowable\[y\] = 'x': not a number or a marginal; "
                                         r"allowed: .*Gumbel/Weibull/Gamma/Beta/ScipyMarginal"):
        LimitState.exceedance("y", "x")
    with pytest.raises(StudyError, match=r"inputs\.allowable\[y\]\.shape: must be > 0, got -1"):
        LimitState.exceedance("y", Weibull(-1.0, 2.0))


# ---------------------------------------------------------------- FOSM, Monte Carlo
def _linear(X):
    return np.column_stack([2.0 * X[:, 0] - 3.0 * X[:, 1], X[:, 2]])


def test_fosm_and_monte_carlo_use_the_true_moments_and_the_pearson_correlation():
    """FOSM is exact on a linear model: mean 2μ_a − 3μ_b, variance 4σ_a² + 9σ_b² − 12ρσ_aσ_b
    (central differences of an affine function: rounding only, 1e-9)."""
    specs = {"a": Weibull(1.5, 2.0, 1.0), "b": Gumbel(10.0, 2.0), "c": GEV}
    inputs = UncertainInputs.from_specs(specs, correlation={("a", "b"): 0.5})
    model = FunctionModel(_linear, list(specs), ["y", "c"], key="lin", vectorized=True)
    res = fosm(model=model, inputs=inputs, allowable=Allowable(1.0, 0.2))
    (ma, va, *_), (mb, vb, *_) = _closed_forms(specs["a"]), _closed_forms(specs["b"])
    sd = math.sqrt(4 * va + 9 * vb - 12 * 0.5 * math.sqrt(va * vb))
    assert res.table["mean"].to_numpy() == pytest.approx([2 * ma - 3 * mb, GEV.scipy().mean()],
                                                         rel=1e-9)
    assert res.table["std"].to_numpy() == pytest.approx([sd, GEV.scipy().std()], rel=1e-9)
    n = 2**14
    mc = monte_carlo(model=model, inputs=inputs, n=n, rule="random", seed=2,
                     allowable=Allowable(1.0, 0.2), progress=False)
    assert abs(mc.table["mean"].iloc[0] - (2 * ma - 3 * mb)) <= 4.5 * sd / math.sqrt(n)


# ---------------------------------------------------------------- polynomial chaos
def _square_and_cube(X):
    return np.column_stack([X[:, 0] ** 2, X[:, 0] ** 3])


@pytest.mark.parametrize("m", [Gamma(2.0, 1.5), Beta(0.5, 0.7, 1.0, 3.0)], ids=["gamma", "beta"])
@pytest.mark.parametrize("method", ["regression", "quadrature"])
def test_pce_in_the_own_polynomials_of_gamma_and_beta_is_exact_on_polynomials(m, method):
    """Laguerre and Jacobi polynomials (chaospy's closed-form recurrences): order 3 holds x²
    and x³ exactly, so the mean and std are the closed-form moments."""
    inputs = UncertainInputs.from_specs({"x": m})
    res = polynomial_chaos(model=FunctionModel(_square_and_cube, ["x"], ["x2", "x3"], key="p",
                                               vectorized=True),
                           inputs=inputs, order=3, method=method, seed=1, progress=False)
    d = m.scipy()
    for k, name in ((2, "x2"), (3, "x3")):
        assert res.mean[name] == pytest.approx(d.moment(k), rel=1e-11)
        sd = math.sqrt(d.moment(2 * k) - d.moment(k) ** 2)
        assert res.std[name] == pytest.approx(sd, rel=1e-10)


@pytest.mark.parametrize("key", ["gumbel", "weibull_k0.8", "gev", "t7"])
def test_pce_in_the_standard_normal_image_converges_to_the_moments(key):
    """x² in Hermite polynomials of z = Φ⁻¹(F(x)), Gauss–Hermite quadrature of order 16:
    measured errors at most 3e-7 (the std of t7, whose tails are the heaviest), a validation
    error (relative mean square on 256 random points) at most 9e-9. chaospy's own recurrence for
    the Weibull of modulus 0.8 (the basis before) was 7.5e-2 from orthonormal: 6.5 % off in
    the mean of x²."""
    m = MARGINALS[key]
    inputs = UncertainInputs.from_specs({"x": m})
    model = FunctionModel(_square_and_cube, ["x"], ["x2", "x3"], key="p", vectorized=True)
    res = polynomial_chaos(model=model, inputs=inputs, order=16, method="quadrature",
                           n_validation=256, seed=1, progress=False)
    d = m.scipy()
    assert res.germ == "inputs"
    assert res.mean["x2"] == pytest.approx(d.moment(2), rel=1e-6)
    assert res.std["x2"] == pytest.approx(math.sqrt(d.moment(4) - d.moment(2) ** 2), rel=1e-6)
    assert res.validation_error["x2"] < 1e-7
    # and between the nodes, in x (through the image), within a few √(validation error) σ
    x = m.from_z(np.linspace(-2.5, 2.5, 11))[:, None]
    assert np.abs(res.predict(x)[:, 0] - x[:, 0] ** 2).max() <= 1e-3 * res.std["x2"]


@pytest.mark.parametrize("key", ["gumbel", "weibull_k0.8", "gamma_skewed", "beta_u", "gev"])
def test_pce_basis_is_orthonormal_on_each_germ(key):
    """E[p_a p_b] = δ_ab under the germ of the input (its own law for gamma and beta, the
    standard normal for the image of a Gumbel, a Weibull and a scipy law), by the Gauss rule of
    order 10 on that germ (exact for degree <= 21 > 2·8); a product basis of such polynomials
    is then orthonormal too."""
    import chaospy

    from mechrel.uq.surrogates.pce import _basis, _germ_joint, _recurrences, multi_indices

    inputs = UncertainInputs.from_specs({"x": MARGINALS[key]})
    order = 8
    nodes, w = chaospy.generate_quadrature(10, _germ_joint(inputs), rule="gaussian")
    Psi = _basis(np.asarray(nodes).T, multi_indices(1, order), _recurrences(inputs, order), order)
    assert (Psi * w[:, None]).T @ Psi == pytest.approx(np.eye(order + 1), abs=1e-9)


def _additive(X):
    return (X[:, 0] + 2.0 * X[:, 1] + X[:, 2])[:, None]


def test_pce_sobol_indices_with_mixed_germs():
    """Y = a + 2b + c, independent: S_j = c_j² Var_j / Var y exactly; a Gumbel and a Weibull
    (normal images, regression of order 8 on 2^10 Sobol' points) beside a gamma (Laguerre)."""
    specs = {"a": Gumbel(0.0, 1.0), "b": Weibull(1.5, 1.0), "c": Gamma(2.0, 1.0)}
    inputs = UncertainInputs.from_specs(specs)
    var = np.array([1.0, 4.0 * specs["b"].scipy().var(), 1.0])
    res = polynomial_chaos(model=FunctionModel(_additive, list(specs), ["y"], key="add",
                                               vectorized=True),
                           inputs=inputs, order=8, q_norm=0.5, oversampling=3.0, seed=4,
                           progress=False)
    assert res.sobol_first.to_numpy()[0] == pytest.approx(var / var.sum(), abs=1e-4)
    assert res.sobol_total.to_numpy()[0] == pytest.approx(var / var.sum(), abs=1e-4)
    # the mean's error is the expansion's truncation error (measured 1.6e-5 relative)
    assert res.mean.iloc[0] == pytest.approx(0.0 + 2 * specs["b"].scipy().mean() + 2.0, rel=1e-4)


def test_pce_with_correlated_new_marginals_uses_the_standard_normal_germ():
    specs = {"a": Gumbel(1.0, 0.3), "b": Beta(2.0, 3.0, 0.0, 1.0)}
    inputs = UncertainInputs.from_specs(specs, correlation={("a", "b"): 0.5})
    model = FunctionModel(lambda X: (X[:, 0] + X[:, 1])[:, None], ["a", "b"], ["y"], key="s",
                          vectorized=True)
    res = polynomial_chaos(model=model, inputs=inputs, order=10, method="quadrature",
                           n_validation=0, progress=False)
    sd = math.sqrt(0.09 + 0.04 + 2 * 0.5 * 0.3 * 0.2)
    assert res.germ == "standard_normal"
    assert res.mean.iloc[0] == pytest.approx(1.0 + 0.4, rel=1e-6)
    assert res.std.iloc[0] == pytest.approx(sd, rel=1e-4)


# ---------------------------------------------------------------- specs, errors, description
def test_dict_specs_and_objects_are_the_same_marginals():
    a = UncertainInputs.from_specs({
        "g": {"distribution": "gumbel", "mean": 1.0, "std": 0.1},
        "w": {"distribution": "weibull", "shape": 2, "scale": 3},
        "w3": {"distribution": "Weibull", "shape": 2, "scale": 3, "lower": 1},
        "ga": {"distribution": "gamma", "mean": 2, "std": 1},
        "b": {"distribution": "beta", "alpha": 2, "beta": 3, "lower": 0, "upper": 1},
        "s": {"distribution": "scipy.genextreme", "c": -0.1, "loc": 1, "scale": 2},
        "s2": {"distribution": "scipy.logistic"},
    })
    b = UncertainInputs.from_specs({
        "g": Gumbel(1.0, 0.1), "w": Weibull(2.0, 3.0), "w3": Weibull(2.0, 3.0, 1.0),
        "ga": Gamma(2.0, 1.0), "b": Beta(2.0, 3.0, 0.0, 1.0), "s": GEV,
        "s2": ScipyMarginal(stats.logistic()),
    })
    assert a.marginals == b.marginals
    assert hash(a.marginals[5]) == hash(GEV)


def test_describe_to_frame_and_provenance_name_every_distribution():
    inputs = UncertainInputs.from_specs({"g": Gumbel(1.0, 0.1), "s": GEV})
    assert inputs.describe()["marginals"] == [
        "Gumbel(mean=1.0, std=0.1)",
        "ScipyMarginal(scipy.stats.genextreme(c=-0.1, loc=1.0, scale=2.0))"]
    frame = inputs.to_frame()
    assert frame["distribution"].tolist() == ["gumbel", "scipy.genextreme"]
    assert frame["std"].tolist() == pytest.approx([0.1, GEV.scipy().std()], rel=1e-12)
    model = FunctionModel(lambda X: X[:, :1], ["g", "s"], ["y"], key="d", vectorized=True)
    res = monte_carlo(model=model, inputs=inputs, n=16, seed=1, allowable=Allowable(1.0, 0.2),
                      progress=False)
    assert res.provenance["inputs"] == inputs.describe()
    # a user-defined distribution is named by its class, never by a memory address
    class Tri(stats.rv_continuous):
        def _pdf(self, x):
            return 2.0 * x

        def _cdf(self, x):
            return x * x

        def _ppf(self, q):
            return np.sqrt(q)

    m = ScipyMarginal(Tri(a=0.0, b=1.0, name="tri")())
    assert repr(m.validated("x")) == (
        f"ScipyMarginal({__name__}.test_describe_to_frame_and_provenance_name_every_"
        "distribution.<locals>.Tri(loc=0.0, scale=1.0))")
    assert UncertainInputs.from_specs({"x": m}).mean[0] == pytest.approx(2 / 3, rel=1e-9)


@pytest.mark.parametrize("spec, match", [
    ({"distribution": "gumbel", "mean": 1.0, "std": 0.0},
     r"inputs\.x\.std: must be > 0, got 0\.0"),
    ({"distribution": "gumbel", "mean": float("inf"), "std": 1.0},
     r"inputs\.x\.mean: must be finite, got inf"),
    ({"distribution": "weibull", "shape": -1.0, "scale": 1.0},
     r"inputs\.x\.shape: must be > 0, got -1\.0"),
    ({"distribution": "weibull", "shape": 2.0, "scale": "big"},
     r"inputs\.x\.scale: must be a number, got 'big'"),
    ({"distribution": "weibull", "shape": 2.0},
     r"inputs\.x: distribution 'weibull' takes fields \['shape', 'scale', 'lower'\] \(lower "
     r"optional\); missing \['scale'\], unknown \[\]"),
    ({"distribution": "weibull", "shape": 2.0, "scale": 1.0, "loc": 1.0},
     r"unknown \['loc'\]"),
    ({"distribution": "gamma", "mean": -2.0, "std": 1.0},
     r"inputs\.x\.mean: must be > 0, got -2\.0"),
    ({"distribution": "beta", "alpha": 0.0, "beta": 1.0, "lower": 0, "upper": 1},
     r"inputs\.x\.alpha: must be > 0, got 0"),
    ({"distribution": "beta", "alpha": 2.0, "beta": 1.0, "lower": 1, "upper": 1},
     r"inputs\.x\.lower/upper: need lower < upper, got lower=1\.0, upper=1\.0"),
    ({"distribution": "scipy.nosuch"},
     r"inputs\.x\.distribution: got 'scipy\.nosuch': not a scipy\.stats distribution; allowed: "
     r"\[.*\], or 'scipy\.NAME' with NAME a continuous scipy\.stats distribution"),
    ({"distribution": "scipy.poisson", "mu": 3.0},
     r"inputs\.x\.distribution: got 'scipy\.poisson': a discrete distribution; allowed:"),
    ({"distribution": "scipy.genextreme", "loc": 1.0},
     r"inputs\.x: distribution 'scipy\.genextreme' takes fields \['c', 'loc', 'scale'\] \(loc "
     r"and scale optional, default 0 and 1\); missing \['c'\], unknown \[\]"),
    ({"distribution": "scipy.genextreme", "c": 0.1, "k": 1.0}, r"unknown \['k'\]"),
    ({"distribution": "scipy.genextreme", "c": "x"}, r"inputs\.x\.c: must be a number, got 'x'"),
    ({"distribution": "scipy.gamma", "a": 2.0, "scale": -1.0},
     r"inputs\.x: scipy\.stats\.gamma\(a=2\.0, loc=0\.0, scale=-1\.0\): parameters outside the "
     r"distribution's domain; allowed: scale > 0 and shape parameters \['a'\] that "
     r"scipy\.stats\.gamma accepts"),
    ({"distribution": "scipy.t", "df": 2.0},
     r"inputs\.x: scipy\.stats\.t\(df=2\.0, loc=0\.0, scale=1\.0\) has no finite variance "
     r"\(variance inf\); allowed: a distribution with a finite mean and variance"),
    ({"distribution": "scipy.cauchy"},
     r"inputs\.x: scipy\.stats\.cauchy\(loc=0\.0, scale=1\.0\) has no finite mean \(mean nan\)"),
])
def test_bad_parameters_name_the_field_the_value_and_what_is_allowed(spec, match):
    with pytest.raises(StudyError, match=match):
        UncertainInputs.from_specs({"x": spec})


def test_bad_objects_name_the_input_and_what_is_allowed():
    with pytest.raises(StudyError, match=r"inputs\.x: got <scipy\.stats.*gamma_gen.*>; allowed: "
                                         r"a frozen continuous scipy\.stats distribution"):
        UncertainInputs.from_specs({"x": ScipyMarginal(stats.gamma)})
    with pytest.raises(StudyError, match=r"inputs\.x: got .*; allowed: a frozen continuous"):
        UncertainInputs.from_specs({"x": ScipyMarginal(stats.poisson(3.0))})
    with pytest.raises(StudyError, match=r"inputs\.x: expected a mapping .* or a marginal "
                                         r"\(Normal/.*/ScipyMarginal\), got float"):
        UncertainInputs.from_specs({"x": 1.0})
    with pytest.raises(StudyError, match=r"inputs\.x\.scale: must be > 0, got 0"):
        UncertainInputs.from_specs({"x": Weibull(1.0, 0)})


# ---------------------------------------------------------------- study files
STUDY = """\
scene = "slider-crank"
quantities = ["displacement"]
angle_step = 90.0

[inputs.crank]
paths = ["bodies.crank.length(O,A)"]
distribution = "beta"
alpha = 2.0
beta = 2.0
lower = 0.04998
upper = 0.05002

[inputs.rod]
paths = ["bodies.rod.length(A,B)"]
distribution = "weibull"
shape = 12.0
scale = 2e-5
lower = 0.11998

[inputs.pivot]
paths = ["ground.points.O[1]"]
distribution = "scipy.logistic"
loc = 0.0
scale = 5e-6

[correlation]
"crank,rod" = 0.3

[allowable.displacement]
mean = 1e-4
std = 0.0

[reliability]
methods = ["fosm", "mc"]
n = 16
seed = 3
"""


def test_study_file_with_new_marginals_loads_runs_and_reports_them(tmp_path):
    from mechrel.study.runner import run_reliability
    from mechrel.study.study import load_study

    path = tmp_path / "tolerances.toml"
    path.write_text(STUDY, encoding="utf-8")
    study = load_study(path)
    inputs = study.uncertain_inputs()
    assert inputs.marginals == (Beta(2.0, 2.0, 0.04998, 0.05002), Weibull(12.0, 2e-5, 0.11998),
                                ScipyMarginal(stats.logistic(0.0, 5e-6)))
    assert inputs.pearson_correlation[0, 1] == 0.3
    lines, results = run_reliability(study, out=tmp_path / "out", progress=False)
    text = "\n".join(lines)
    assert "rod: Weibull(shape=12.0, scale=2e-05, lower=0.11998)" in text
    assert "pivot: ScipyMarginal(scipy.stats.logistic(loc=0.0, scale=5e-06))" in text
    assert "correlation (Pearson): crank,rod 0.3" in text


@pytest.mark.parametrize("old, new, match", [
    ("shape = 12.0", "shape = -12.0",
     r"tolerances\.toml: inputs\.rod\.shape: must be > 0, got -12\.0"),
    ('distribution = "weibull"', 'distribution = "frechet"',
     r"tolerances\.toml: inputs\.rod\.distribution: got 'frechet'; allowed: \['beta', 'gamma', "
     r"'gumbel', 'lognormal', 'normal', 'truncnormal', 'uniform', 'weibull'\], or 'scipy\.NAME'"),
    ("loc = 0.0\n", "c = 0.0\n",
     r"tolerances\.toml: inputs\.pivot: distribution 'scipy\.logistic' takes fields \['loc', "
     r"'scale'\] \(loc and scale optional, default 0 and 1\); missing \[\], unknown \['c'\]"),
])
def test_study_file_errors_name_file_field_value(tmp_path, old, new, match):
    from mechrel.study.study import load_study

    assert old in STUDY
    path = tmp_path / "tolerances.toml"
    path.write_text(STUDY.replace(old, new), encoding="utf-8")
    with pytest.raises(StudyError, match=match):
        load_study(path)


def test_study_file_correlation_out_of_reach_is_refused(tmp_path):
    from mechrel.study.study import load_study

    path = tmp_path / "tolerances.toml"
    path.write_text(STUDY.replace('"crank,rod" = 0.3', '"rod,pivot" = -0.99'), encoding="utf-8")
    with pytest.raises(StudyError, match=r"tolerances\.toml: inputs\.correlation\['rod', "
                                         r"'pivot'\]: got -0\.99; these marginals \(weibull, "
                                         r"scipy\.logistic\) can only reach Pearson "
                                         r"correlations in \[-0\.9838, 0\.9838\]"):
        load_study(path)
