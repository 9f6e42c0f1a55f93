"""The inverse question (:func:`mechrel.uq.inverse_reliability`): the allowable for a target.

The model
---------
Two quantities of three standard-normal inputs, with their cycle extremes:
velocity e(θ) = A1 x1 cos θ + A2 x2 sin θ, whose largest |e| (and largest e) over the whole
cycle is V = √(A1² x1² + A2² x2²); acceleration 3 + x3 at every angle, extreme A = |3 + x3|.
Closed forms: P(A ≤ r) = Φ(r − 3) − Φ(−r − 3); P(V ≤ r) by one-dimensional quadrature,
∫ φ(x1) [2Φ(√(r² − A1² x1²)/A2) − 1] dx1 over |x1| ≤ r/A1 (checked against the Rayleigh law
at A1 = A2); the
whole cycle's factor k solves P(V ≤ k s_v) P(A ≤ k s_a) = R_t (V and A independent). Quantiles
by Brent's method to 1e-14.

Tolerances
----------
* Monte Carlo's order-statistic interval holds with probability ≥ its level whatever the law
  (module docstring of ``order_statistics``); the tests that must hold for three scalars at
  once ask 99.9 % intervals (a false alarm with probability ≤ 0.3 %; the seeds are fixed).
* Its coverage: 400 repetitions of the interval on normal samples, the frequency within
  3.3 binomial standard deviations of the exact coverage P(l ≤ K ≤ u − 1) of the ranks.
* Subset simulation: 95 % intervals (Au–Beck's upper bound, which covered 99–100 % over 100
  seeds, ``subset_levels`` docstring); a forward run with the same seed at the allowable found
  walks the same chains, so its P_f is 1 − R_t up to repeated chain states (ties: 2 in N).
* FORM (PMA) on a margin linear in normal inputs: exact up to the central difference's
  round-off (ε|g|/h ≈ 1e-11): 1e-8.
* The forward check at the allowable found: the independent forward estimate R̂ and the
  inverse's own sampling error add: |R̂ − R_t| ≤ 3.29 √(R_t (1 − R_t)(1/n_inv + 1/n_fwd)) (99.9 %).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, optimize, special, stats

from mechrel.errors import EstimateWarning, StudyError
from mechrel.uq import (INVERSE_METHODS, Allowable, FORMConvergenceError, FunctionModel,
                        LimitState, Normal, SampleFailuresError, UncertainInputs, evaluate, form,
                        inverse_reliability, linear_model, monte_carlo, subset_simulation)
from mechrel.uq.inverse import choose_method
from mechrel.uq.inverse.extremes import Extremes
from mechrel.uq.inverse.order_statistics import order_statistic_ranks, quantile_interval

A1, A2 = 0.02, 0.01      # m/s per unit of x1, x2
SV, SA = 0.05, 6.0       # the reference allowables (velocity m/s, acceleration m/s²)
REF = {"velocity": SV, "acceleration": SA}
ANGLES = np.arange(0.0, 360.0, 30.0)
LABELS = pd.MultiIndex.from_tuples(
    [(q, a) for q in ("velocity", "acceleration")
     for a in [*ANGLES.tolist(), "max", "min", "max_abs"]], names=["quantity", "crank_angle"])


def _errors(X):
    t = np.deg2rad(ANGLES)
    v = A1 * X[:, :1] * np.cos(t) + A2 * X[:, 1:2] * np.sin(t)
    r = np.sqrt((A1 * X[:, 0]) ** 2 + (A2 * X[:, 1]) ** 2)  # max over θ of |v| and of v
    a = 3.0 + X[:, 2]
    return np.column_stack([v, r, -r, r, np.repeat(a[:, None], len(t), axis=1), a, a, np.abs(a)])


MODEL = FunctionModel(_errors, ["x1", "x2", "x3"], LABELS, key="inverse-test", vectorized=True)
INPUTS = UncertainInputs.from_specs({k: Normal(0.0, 1.0) for k in ("x1", "x2", "x3")})


def cdf_v(r):
    """P(V ≤ r): x1 = (r/A1) sin φ removes the square root's singularity at the ends."""
    if r <= 0:
        return 0.0
    c = r / A1

    def f(phi):  # φ(x1) (2Φ(y) − 1) dx1, 2Φ(y) − 1 = erf(y/√2)
        x, y = c * math.sin(phi), r * math.cos(phi) / A2
        density = math.exp(-0.5 * x * x) / math.sqrt(2 * math.pi)
        return density * math.erf(y / math.sqrt(2)) * c * math.cos(phi)
    return integrate.quad(f, -math.pi / 2, math.pi / 2, epsabs=1e-14, epsrel=1e-12)[0]


def cdf_a(r):
    return special.ndtr(r - 3.0) - special.ndtr(-r - 3.0)


def exact(target):
    """The allowables: velocity, acceleration, and the whole cycle's factor k."""
    v = optimize.brentq(lambda r: cdf_v(r) - target, 1e-9, 1.0, xtol=1e-14)
    a = optimize.brentq(lambda r: cdf_a(r) - target, 1e-9, 30.0, xtol=1e-14)
    k = optimize.brentq(lambda k: cdf_v(k * SV) * cdf_a(k * SA) - target, 1e-6, 10.0, xtol=1e-14)
    return {"velocity": v, "acceleration": a, "all": k}


def _run(target, method, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EstimateWarning)
        return inverse_reliability(model=MODEL, inputs=INPUTS, target=target, method=method,
                                   allowable=REF, progress=False, **kw)


def _inside(r, truth):
    """Per scalar: is the exact answer inside the result's interval?"""
    t = r.table
    out = {}
    for g in ("velocity", "acceleration"):
        row = t.loc[(g, g)]
        out[g] = row["allowable_lo"] <= truth[g] <= row["allowable_hi"]
    row = t.loc[("all", "velocity")]
    out["all"] = row["factor_lo"] <= truth["all"] <= row["factor_hi"]
    return out


def test_the_closed_forms_agree_with_the_rayleigh_law_and_monte_carlo():
    # at A1 = A2 = σ the velocity extreme is Rayleigh: P(V ≤ r) = 1 − exp(−r²/(2σ²))
    global A2
    keep, A2 = A2, A1
    try:
        for r in (0.01, 0.03, 0.07):
            assert cdf_v(r) == pytest.approx(1 - math.exp(-r * r / (2 * A1 * A1)), abs=1e-11)
    finally:
        A2 = keep
    # and the model's extreme is the largest |e| over a fine grid of angles
    X = np.random.default_rng(0).standard_normal((50, 3))
    t = np.deg2rad(np.linspace(0, 360, 20001))
    fine = np.abs(A1 * X[:, :1] * np.cos(t) + A2 * X[:, 1:2] * np.sin(t)).max(axis=1)
    np.testing.assert_allclose(_errors(X)[:, 14], fine, rtol=1e-7)


def test_the_scalars_per_quantity_and_the_whole_cycle():
    e = Extremes.of(LABELS, allowable=REF)
    assert e.names == ("velocity", "acceleration", "all") and e.basis == ("cycle extreme",) * 2
    Y = MODEL.evaluate_batch(np.array([[1.0, -2.0, 0.5], [0.0, 0.0, -9.0]]))
    V = e.values(Y)
    np.testing.assert_allclose(V[:, 0], [math.hypot(A1, 2 * A2), 0.0])
    np.testing.assert_allclose(V[:, 1], [3.5, 6.0])
    np.testing.assert_allclose(V[:, 2], np.maximum(V[:, 0] / SV, V[:, 1] / SA))
    # without cycle extremes: the largest over the analysis angles
    angles_only = LABELS[[not isinstance(a, str) for a in LABELS.get_level_values(1)]]
    e2 = Extremes.of(angles_only, allowable=REF)
    assert e2.basis == ("analysis angles",) * 2
    Ya = Y[:, [i for i, lbl in enumerate(LABELS) if not isinstance(lbl[1], str)]]
    assert e2.values(Ya)[0, 0] == pytest.approx(np.abs(Ya[0, :12]).max())
    # one-sided: the largest signed error (the acceleration's is 3 + x3, not |3 + x3|)
    assert Extremes.of(LABELS, event="one-sided", allowable=REF).values(Y)[1, 1] == -6.0


def test_monte_carlo_intervals_contain_the_closed_form():
    truth = exact(0.99)
    r = _run(0.99, "mc", n=20000, seed=1, confidence_level=0.999)
    assert all(_inside(r, truth).values()), (r.table, truth)
    assert r.method == "mc" and r.n_evaluations == 20000 and r.warnings == ()
    t = r.table
    # every quantity's whole-cycle allowable is at least its own (Z ≥ Y_q/s_q in every sample)
    for q, s in REF.items():
        assert t.loc[("all", q), "allowable"] >= t.loc[(q, q), "allowable"]
        assert t.loc[("all", q), "allowable"] == pytest.approx(t.loc[("all", q), "factor"] * s)
    assert set(t["unit"]) == {"m/s", "m/s²"}
    # the estimate is the k-th order statistic of the samples, k = ⌈n R_t⌉
    Z = r.extremes.values(r.evaluations.Y)
    assert t.loc[("acceleration", "acceleration"), "allowable"] == np.sort(Z[:, 1])[19800 - 1]


def test_monte_carlo_reuses_a_forward_runs_evaluations_and_cache(tmp_path):
    fwd = monte_carlo(model=MODEL, inputs=INPUTS, n=500, seed=4, progress=False,
                      allowable={q: Allowable(s) for q, s in REF.items()})
    a = _run(0.95, "mc", n=500, seed=4)
    b = _run(0.95, "mc", evaluations=fwd.evaluations)
    pd.testing.assert_frame_equal(a.table, b.table)  # the same design: monte_carlo's
    c = _run(0.95, "mc", n=500, seed=4, cache=tmp_path)
    d = _run(0.95, "mc", n=500, seed=4, cache=tmp_path)
    assert d.provenance["n_computed"] == 0 and d.provenance["n_cached"] == 500
    pd.testing.assert_frame_equal(c.table, d.table)
    with pytest.raises(StudyError, match="evaluations: of another model"):
        _run(0.95, "mc", evaluations=evaluate(linear_model([0.0], [[1.0]], ["x1"]),
                                              np.zeros((3, 1)), progress=False))


def test_the_order_statistic_interval_covers_at_its_level():
    n, target, level, reps = 500, 0.95, 0.9, 400
    k, l, u = order_statistic_ranks(n, target, level)
    exact_cover = stats.binom.cdf(u - 1, n, target) - stats.binom.cdf(l - 1, n, target)
    assert exact_cover >= level
    xi = stats.norm.ppf(target)
    rng = np.random.default_rng(11)
    hits = sum(lo <= xi <= hi for lo, hi in
               (quantile_interval(rng.standard_normal(n), target, level)[1:] for _ in range(reps)))
    assert abs(hits / reps - exact_cover) <= 3.3 * math.sqrt(exact_cover * (1 - exact_cover) / reps)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=2, max_size=300),
       st.floats(0.01, 0.99), st.floats(0.01, 0.99), st.floats(1e-3, 1e3))
def test_order_statistic_properties(values, t1, t2, c):
    y = np.array(values)
    lo, hi = sorted((t1, t2))
    v1, l1, h1 = quantile_interval(y, lo, 0.95)
    v2, l2, h2 = quantile_interval(y, hi, 0.95)
    assert l1 <= v1 <= h1 and l2 <= v2 <= h2            # the estimate inside its interval
    assert v1 <= v2 and l1 <= l2 and h1 <= h2          # monotone in the target
    vs, ls, hs = quantile_interval(c * y, hi, 0.95)     # equivariant to a change of unit
    assert (vs, ls, hs) == pytest.approx((c * v2, c * l2, c * h2), rel=1e-12, abs=0)
    # the empirical reliability at the estimate reaches the target
    assert np.mean(y <= v2) >= hi - 1e-12


def test_monte_carlo_warns_when_the_target_is_beyond_its_samples():
    with pytest.warns(EstimateWarning) as caught:
        r = inverse_reliability(model=MODEL, inputs=INPUTS, target=0.999, method="mc", n=256,
                                seed=2, allowable=REF, progress=False)
    text = " ".join(str(w.message) for w in caught)
    assert "n (1 − R_t) = 0.256 < 10" in text and "use n ≥ 10000" in text
    assert "no upper end" in text and "needs n ≥ 3688" in text
    assert r.warnings and np.isinf(r.table["allowable_hi"]).all()
    # the estimate is the largest sample: nothing above it is seen
    largest = r.extremes.values(r.evaluations.Y)[:, 0].max()
    assert r.table.loc[("velocity", "velocity"), "allowable"] == largest


def test_a_wide_interval_is_warned_about():
    # the median of |3 + x3| from 40 samples: known to about ±20 % only
    with pytest.warns(EstimateWarning, match="interval too wide, more than 20%") as caught:
        inverse_reliability(model=MODEL, inputs=INPUTS, target=0.5, method="mc", n=40, seed=2,
                            allowable=REF, progress=False)
    message = str(caught[0].message)
    assert "acceleration [" in message


def test_subset_levels_contain_the_closed_form_and_replay_forward():
    target = 0.9999
    truth = exact(target)
    r = _run(target, "subset", n_per_level=500, seed=3)
    assert all(_inside(r, truth).values()), (r.table, truth)
    lv = r.details["levels"]
    assert list(lv.index.get_level_values("scalar").unique()) == ["velocity", "acceleration", "all"]
    # four levels each: P = 0.1, 0.01, 0.001, then the quantile at 1e-4 (q = 0.1)
    assert lv.loc["velocity", "P"].tolist() == pytest.approx([0.1, 0.01, 1e-3, 1e-4])
    # level 0 is shared: 500 + 3 scalars × 3 levels × 450 chain states
    assert r.n_evaluations == 500 + 3 * 3 * 450
    # a forward subset simulation with the same seed at the allowable found walks the same
    # chains: its thresholds are a − z_i and its P_f is 1 − R_t (to tied chain states)
    for g in ("velocity", "acceleration", "all"):
        fwd = subset_simulation(model=MODEL, inputs=INPUTS, limit_state=r.limit_state(g),
                                seed=3, n_per_level=500)
        assert fwd.pf == pytest.approx(1 - target, abs=2 * 1e-3 * 1e-3 / 0.5)
        z = lv.loc[g, "threshold"].to_numpy()
        # the system's margin is k − Z (in units of the reference allowables)
        a = (r.table.loc[(g, g), "allowable"] if g != "all"
             else r.table.loc[("all", "velocity"), "factor"])
        np.testing.assert_allclose(fwd.levels["threshold"].to_numpy()[:-1], a - z[:-1],
                                   rtol=1e-12, atol=1e-15)


def test_subset_interval_covers_over_seeds():
    # the interval is the Au–Beck upper bound: it must cover at least its level
    target, truth, reps = 0.999, exact(0.999)["acceleration"], 30
    one = LABELS[LABELS.get_level_values(0) == "acceleration"]
    model = FunctionModel(lambda X: _errors(np.column_stack([X, X, X]))[:, 15:], ["x3"], one,
                          vectorized=True)
    inputs = UncertainInputs.from_specs({"x3": Normal(0.0, 1.0)})
    hits = 0
    for seed in range(reps):
        with warnings.catch_warnings():  # N = 200 is meant to give wide intervals
            warnings.simplefilter("ignore", EstimateWarning)
            r = inverse_reliability(model=model, inputs=inputs, target=target, method="subset",
                                    n_per_level=200, seed=seed, progress=False)
        row = r.table.loc[("acceleration", "acceleration")]
        hits += row["allowable_lo"] <= truth <= row["allowable_hi"]
    # at 95 %, fewer than 25 of 30 has probability 0.016
    assert hits >= 25


def test_sampling_methods_on_a_single_linear_output():
    # y = 0.5 + 2 x: P(|y| ≤ a) = Φ((a − 0.5)/2) − Φ((−a − 0.5)/2), solved for a
    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    model = linear_model([0.5], [[2.0]], ["x"])

    def exact_two_sided(target):
        return optimize.brentq(lambda a: special.ndtr((a - 0.5) / 2) - special.ndtr((-a - 0.5) / 2)
                               - target, 1e-9, 50.0, xtol=1e-14)

    mc = inverse_reliability(model=model, inputs=inputs, target=0.99, method="mc", n=20000,
                             seed=4, confidence_level=0.999, progress=False)
    row = mc.table.loc[("all", "all")]
    assert row["allowable_lo"] <= exact_two_sided(0.99) <= row["allowable_hi"]
    # the one-sided event: the R_t-quantile of y itself, 0.5 + 2 Φ⁻¹(R_t)
    one = inverse_reliability(model=model, inputs=inputs, target=0.99, method="mc", n=20000,
                              seed=4, event="one-sided", confidence_level=0.999, progress=False)
    row = one.table.loc[("all", "all")]
    assert row["allowable_lo"] <= 0.5 + 2 * special.ndtri(0.99) <= row["allowable_hi"]
    sub = inverse_reliability(model=model, inputs=inputs, target=0.9999, method="subset",
                              n_per_level=1000, seed=4, progress=False)
    row = sub.table.loc[("all", "all")]
    assert row["allowable_lo"] <= exact_two_sided(0.9999) <= row["allowable_hi"]
    # its relative error had a standard deviation of 1.5–2.4 % over 100 seeds at N = 500
    # (subset_levels docstring): 5 % is about 3σ at N = 1000
    assert row["allowable"] == pytest.approx(exact_two_sided(0.9999), rel=0.05)


def test_form_is_exact_on_a_linear_extreme_and_on_a_dominant_sign():
    inputs = UncertainInputs.from_specs({"x1": Normal(1.0, 2.0), "x2": Normal(-1.0, 0.5)})
    model = linear_model([0.3], [[0.5, -2.0]], ["x1", "x2"])  # y = 0.3 + 0.5 x1 − 2 x2
    mu, sd = 0.3 + 0.5 - 2 * -1.0, math.hypot(0.5 * 2.0, 2 * 0.5)
    for target in (0.9, 0.999, 1 - 1e-6):
        r = inverse_reliability(model=model, inputs=inputs, target=target, method="form",
                                event="one-sided", allowable=1.0, progress=False)
        a = r.table.loc[("all", "all"), "allowable"]
        assert a == pytest.approx(mu + sd * special.ndtri(target), abs=1e-8)
        # FORM's forward P_f at it is 1 − R_t (the round trip)
        f = form(model=model, inputs=inputs, limit_state=r.limit_state())
        assert f.pf == pytest.approx(1 - target, rel=1e-6)
        assert np.isnan(r.table["allowable_lo"]).all()
    dp = r.details["design_points"].loc["all"]
    assert dp["importance"].sum() == pytest.approx(1.0)
    # two-sided with the mean far from zero: the other sign adds Φ(−β − 2μ/σ), negligible
    r2 = inverse_reliability(model=model, inputs=inputs, target=0.999, method="form",
                             allowable=1.0, progress=False)
    a2 = r2.table.loc[("all", "all"), "allowable"]
    assert a2 == pytest.approx(mu + sd * special.ndtri(0.999), abs=1e-8)
    two_sided = stats.norm.cdf((a2 - mu) / sd) - stats.norm.cdf((-a2 - mu) / sd)
    assert two_sided == pytest.approx(0.999, abs=1e-9) and r2.warnings == ()
    s = r2.details["searches"]
    assert s.loc[("all", "opposite"), "first_order_pf"] < 1e-9


def test_form_warns_about_a_second_design_point_and_another_quantity():
    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    # |0.1 + x|: the two signs have nearly the same β; FORM sees one of them
    model = linear_model([0.1], [[1.0]], ["x"])
    with pytest.warns(EstimateWarning, match="second design point"):
        r = inverse_reliability(model=model, inputs=inputs, target=0.99, method="form",
                                allowable=1.0, progress=False)
    a = r.table.loc[("all", "all"), "allowable"]
    assert a == pytest.approx(0.1 + special.ndtri(0.99), abs=1e-8)
    true = optimize.brentq(lambda x: special.ndtr(x - 0.1) - special.ndtr(-x - 0.1) - 0.99, 0, 9)
    assert a < true  # unconservative, as warned
    # the whole cycle of two quantities with the same weight: the factor is set by one, the
    # other adds as much
    idx = pd.MultiIndex.from_tuples([("velocity", "max_abs"), ("acceleration", "max_abs")],
                                    names=["quantity", "crank_angle"])
    two = FunctionModel(lambda X: np.column_stack([1.0 + 0.02 * X[:, 0], 100.0 + 2.0 * X[:, 1]]),
                        ["a", "b"], idx, vectorized=True)
    inputs2 = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
    ref = {"velocity": 1.0, "acceleration": 100.0}
    with pytest.warns(EstimateWarning, match="factor .* is set by"):
        inverse_reliability(model=two, inputs=inputs2, target=0.99, method="form",
                            allowable=ref, progress=False)
    # a dominated second quantity: no warning, the factor the first quantity's
    with warnings.catch_warnings():
        warnings.simplefilter("error", EstimateWarning)
        r = inverse_reliability(model=two, inputs=inputs2, target=0.99, method="form",
                                allowable={"velocity": 1.0, "acceleration": 200.0}, progress=False)
    k = r.table.loc[("all", "velocity"), "factor"]
    assert k == pytest.approx(1 + 0.02 * special.ndtri(0.99), abs=1e-8)


def test_form_refuses_a_kink_at_the_mean():
    # V = √(A1² x1² + A2² x2²) has no gradient at the mean: FORM cannot start
    with pytest.raises(FORMConvergenceError, match="gradient of the extreme is zero"):
        _run(0.99, "form")


def test_the_forward_run_at_the_allowable_found_meets_the_target():
    target, n_inv, n_fwd = 0.98, 20000, 20000
    r = _run(target, "mc", n=n_inv, seed=7)
    fwd = monte_carlo(model=MODEL, inputs=INPUTS, n=n_fwd, seed=8, allowable=r.allowables("all"),
                      progress=False)
    R = fwd.whole_cycle.loc["all", "reliability"]
    bound = 3.29 * math.sqrt(target * (1 - target) * (1 / n_inv + 1 / n_fwd))
    assert abs(R - target) <= bound
    for q in REF:  # each quantity alone at its own allowable (the other's out of reach)
        allow = {**{o: Allowable(1e9) for o in REF}, **r.allowables(q)}
        fq = monte_carlo(model=MODEL, inputs=INPUTS, n=n_fwd, seed=8, allowable=allow,
                         progress=False)
        assert abs(fq.whole_cycle.loc[q, "reliability"] - target) <= bound
    # and the true reliability at the allowables found (the closed form)
    k = r.table.loc[("all", "velocity"), "factor"]
    true = cdf_v(k * SV) * cdf_a(k * SA)
    assert abs(true - target) <= 3.29 * math.sqrt(target * (1 - target) / n_inv)
    # the rare target: subset simulation, checked by an independent subset run
    t2 = 0.9999
    r2 = _run(t2, "subset", n_per_level=1000, seed=1)
    f2 = subset_simulation(model=MODEL, inputs=INPUTS, limit_state=r2.limit_state("all"), seed=99,
                           n_per_level=1000)
    cov_inv = r2.details["levels"].loc["all", "cov_total"].iloc[-1]
    assert abs(f2.pf / (1 - t2) - 1) <= 1.96 * math.hypot(cov_inv, f2.cov)


def test_a_model_without_quantities_and_a_single_quantity():
    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    r = inverse_reliability(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
                            target=0.95, method="mc", n=4000, seed=1, progress=False)
    assert r.table.index.tolist() == [("all", "all")]
    assert np.isnan(r.table["reference"].iloc[0])  # no allowable given: no factor
    one = MODEL.output_index[MODEL.output_index.get_level_values(0) == "velocity"]
    m1 = FunctionModel(lambda X: _errors(X)[:, :15], ["x1", "x2", "x3"], one, vectorized=True)
    r1 = inverse_reliability(model=m1, inputs=INPUTS, target=0.95, method="mc", n=2000, seed=1,
                             progress=False)  # the default velocity allowable, 0.3 m/s
    t = r1.table
    assert t.index.tolist() == [("velocity", "velocity"), ("all", "velocity")]
    assert t.loc[("all", "velocity"), "allowable"] == t.loc[("velocity", "velocity"), "allowable"]
    row = t.loc[("all", "velocity")]
    assert row["factor"] == pytest.approx(row["allowable"] / 0.3)


def test_failed_samples_are_counted_left_out_or_beyond_every_allowable():
    def jam(X):
        Y = _errors(X)
        Y[X[:, 0] > 2.0] = np.nan   # about 2.3 % of the samples fail
        return Y
    model = FunctionModel(jam, ["x1", "x2", "x3"], LABELS, key="jam", vectorized=True)
    kw = dict(model=model, inputs=INPUTS, target=0.95, method="mc", n=2000, seed=5,
              allowable=REF, progress=False)
    ex = inverse_reliability(**kw)
    worst = inverse_reliability(**kw, failures="as_failure")
    assert ex.evaluations.n_failed == worst.evaluations.n_failed > 0
    assert (worst.table["allowable"] >= ex.table["allowable"]).all()
    with pytest.raises(SampleFailuresError, match="more than max_failure_fraction=0.01") as info:
        inverse_reliability(**kw, max_failure_fraction=0.01)
    assert info.value.evaluations.n_failed == ex.evaluations.n_failed
    with pytest.raises(SampleFailuresError, match="max_failure_fraction"):
        kw.pop("n")
        inverse_reliability(**{**kw, "method": "subset"}, n_per_level=200, max_failure_fraction=0.0)


def test_auto_takes_monte_carlo_where_it_resolves_the_target_else_subset():
    assert choose_method(0.99, 1000) == "mc" and choose_method(0.991, 1000) == "subset"
    assert _run(0.9, "auto", n=200, seed=1).method == "mc"
    with pytest.raises(StudyError, match="settings \\['n'\\]: unknown"):
        _run(0.999, "auto", n=200, seed=1)  # n = 200 does not resolve 0.999: subset, no n
    assert _run(0.999, "auto", seed=1, n_per_level=200).method == "subset"
    assert set(INVERSE_METHODS) >= {"mc", "subset", "form"}


@pytest.mark.parametrize("kwargs, message", [
    ({"target": 1.0}, "target = 1.0: must be < 1"),
    ({"target": 0.0}, "target = 0.0: must be > 0"),
    ({"target": 0.9, "method": "ml"},
     'method = "ml": unknown value; allowed: one of mc, subset, form, auto'),
    ({"target": 0.9, "method": "mc", "n_per_level": 10}, "settings \\['n_per_level'\\]: unknown"),
    ({"target": 0.9, "method": "mc", "n": 1}, "n = 1"),
    ({"target": 0.9, "event": "both"}, "event: got 'both'"),
    ({"target": 0.9, "failures": "drop"}, 'failures = "drop".*exclude, as_failure'),
    ({"target": 0.9, "allowable": {"velocity": 0.3}},
     "no reference allowable for quantity \\['acceleration'\\]"),
    ({"target": 0.9, "method": "subset", "p0": 0.3}, "1/p0 and n_per_level·p0 integers"),
    ({"target": 0.99, "method": "subset", "p0": 0.5, "n_per_level": 10, "max_levels": 2},
     "needs more than max_levels = 2 levels of p0 = 0.5"),
])
def test_bad_arguments_name_the_argument(kwargs, message):
    kw = {"allowable": REF, **kwargs}
    with pytest.raises(StudyError, match=message):
        inverse_reliability(model=MODEL, inputs=INPUTS, seed=1, progress=False, **kw)


def test_the_result_gives_forward_allowables_and_limit_states():
    r = _run(0.9, "mc", n=1000, seed=2)
    allow = r.allowables()
    assert set(allow) == {"velocity", "acceleration"} and all(a.std == 0 for a in allow.values())
    own = r.table.loc[("velocity", "velocity"), "allowable"]
    assert r.allowables("velocity")["velocity"].mean == own
    ls = r.limit_state()
    assert isinstance(ls, LimitState)
    assert [c.name for c in ls.components] == ["velocity", "acceleration"]
    with pytest.raises(StudyError, match="group: got 'speed'"):
        r.allowables("speed")
    p = r.provenance
    assert p["settings"]["target"] == 0.9 and p["settings"]["method"] == "mc"
    assert p["settings"]["allowable_std"].startswith("not used")
    assert p["n_evaluations"] == 1000
    assert r.to_frame() is not r.table and r.to_frame().equals(r.table)
