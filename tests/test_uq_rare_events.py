"""Rare events: limit states, vectorised models, FORM, SORM, importance sampling, subset
simulation and the registry of methods.

Tolerances
----------
* FORM on limit states that are linear in the standard normal space: β is exact up to the
  finite-difference round-off (ε·|g|/h ≈ 1e-12 with h = 1e-4): asserted to 1e-10.
* SORM on a parabolic limit state: the curvature is exact for a quadratic (central second
  differences have no truncation error on it); Tvedt's formula is exact for the paraboloid to
  its three-term expansion, checked against the quadrature of the exact probability to 1 %.
* Sampling estimators, fixed seeds: |P̂ − P_ref| ≤ 3·δ·P̂ (δ the estimator's own c.o.v.; 3σ
  of the normal approximation), plus the rounding of a published reference value where it
  applies (references with 3 significant digits: 0.5 %).
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, special, stats

from mechrel.errors import StudyError
from mechrel.uq import (
    FunctionModel,
    LogNormal,
    ModelFailure,
    Normal,
    SampleFailuresError,
    UncertainInputs,
    evaluate,
)
from mechrel.uq import (
    METHODS,
    FORMConvergenceError,
    FORMResult,
    ImportanceSamplingResult,
    LimitState,
    SORMResult,
    SubsetSimulationResult,
    form,
    importance_sampling,
    sorm,
    subset_simulation,
)
from mechrel.uq.estimators import get_method
from mechrel.uq.estimators.sorm import sorm_probabilities

SQ2 = math.sqrt(2.0)
STD2 = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
STD3 = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0),
                                   "x3": Normal(0.0, 1.0)})


# ---------------------------------------------------------------- models (module level: picklable)
def _r_minus_s(X):
    return X[:, 0] - X[:, 1]


def _log_r_minus_s(X):
    return np.log(X[:, 0]) - np.log(X[:, 1])


def _parabola(X, beta=4.5, kappa=0.2):
    """Margin g = β − u₂ + ½κu₁²: design point (0, β), curvature κ."""
    return beta - X[:, 1] + 0.5 * kappa * X[:, 0] ** 2


def _parabola_1e5(X):
    return _parabola(X, beta=4.2, kappa=0.1)


def _exact_parabola(beta, kappa):
    f = lambda v: stats.norm.pdf(v) * stats.norm.sf(beta + 0.5 * kappa * v * v)  # noqa: E731
    return integrate.quad(f, -np.inf, np.inf, epsabs=0, epsrel=1e-12)[0]


def _rp22(X):
    return 2.5 - (X[:, 0] + X[:, 1]) / SQ2 + 0.1 * (X[:, 0] - X[:, 1]) ** 2


def _rp24(X):
    return 2.5 - 0.2357 * (X[:, 0] - X[:, 1]) + 0.00463 * (X[:, 0] + X[:, 1] - 20.0) ** 4


def _rp25_branches(X):
    return np.column_stack([X[:, 0] ** 2 - 8 * X[:, 1] + 16, -16 * X[:, 0] + X[:, 1] + 32])


def _rp33_branches(X):
    return np.column_stack([-X[:, 0] - X[:, 1] - X[:, 2] + 3 * math.sqrt(3), -X[:, 2] + 3])


def _rp57(X):
    x1, x2 = X[:, 0], X[:, 1]
    g1 = -x1**2 + x2**3 + 3
    g2 = 2 - x1 - 8 * x2
    g3 = (x1 + 3) ** 2 + (x2 + 3) ** 2 - 4
    return np.minimum(np.maximum(g1, g2), g3)


def _four_branch(X, k=7.0):
    a, b = X[:, 0], X[:, 1]
    q = 3 + 0.1 * (a - b) ** 2
    return np.column_stack([q - (a + b) / SQ2, q + (a + b) / SQ2, a - b + k / SQ2, b - a + k / SQ2])


def _vec(func, inputs, outputs=("g",), key="t"):
    return FunctionModel(func, inputs.names, list(outputs), key=key, vectorized=True)


# ---------------------------------------------------------------- limit states
ANGLES = [0.0, 90.0, 180.0, 270.0]
CYCLE_INDEX = pd.MultiIndex.from_product([["displacement", "velocity"], ANGLES],
                                         names=["quantity", "crank_angle"])


def _cycle(X):
    """A made-up mechanism: signed errors at 4 angles of 2 quantities, and their cycle extremes."""
    t = np.deg2rad(ANGLES)
    d = X[:, :1] * np.sin(t)[None, :] + 0.2 * X[:, 1:2]
    v = X[:, 1:2] * np.cos(t)[None, :]
    return np.hstack([d, v])


def test_limit_state_values_match_hand_computation():
    Y = np.array([[0.5, -1.2, 0.1, 0.0, 2.0, -0.1, 0.3, 0.4]])
    lab = lambda a: ("displacement", a)  # noqa: E731
    disp = [lab(a) for a in ANGLES]
    cases = [
        (LimitState.exceedance(disp, 1.0, kind="abs"), 1.0 - 1.2),
        (LimitState.exceedance(disp, 1.0, kind="upper"), 1.0 - 0.5),
        (LimitState.exceedance(disp, -1.0, kind="lower"), -1.2 + 1.0),
        (LimitState.exceedance(("velocity", 0.0), 1.5, kind="abs"), 1.5 - 2.0),
        (LimitState.margin(("velocity", 270.0)), 0.4),
        (LimitState.series(LimitState.exceedance(disp, 1.0, name="d"),
                           LimitState.exceedance(("velocity", 0.0), 3.0,
                                                 name="v")), min(1.0 - 1.2, 3.0 - 2.0)),
        (LimitState.parallel(LimitState.exceedance(disp, 1.0, name="d"),
                             LimitState.exceedance(("velocity", 0.0), 3.0,
                                                   name="v")), max(1.0 - 1.2, 3.0 - 2.0)),
        (LimitState.from_function(lambda Y: Y[:, 0] * Y[:, 4]), 1.0),
    ]
    for ls, want in cases:
        g = ls.bind(CYCLE_INDEX)(Y)
        assert g.shape == (1,) and g[0] == pytest.approx(want, abs=1e-15), ls
    # a quantity label alone selects every crank angle of it (the whole cycle)
    whole = LimitState.exceedance(["displacement"], 1.0).bind(CYCLE_INDEX)
    assert whole(Y)[0] == pytest.approx(1.0 - 1.2)


def test_limit_state_errors_name_field_value_and_allowed():
    with pytest.raises(StudyError,
                       match=r"kind = 'both': unknown; allowed: \['abs', 'upper', 'lower'\]"):
        LimitState.exceedance("g", 1.0, kind="both")
    with pytest.raises(StudyError, match=r"allowable\[g\] = 'x': not a number or a marginal"):
        LimitState.exceedance("g", "x")
    with pytest.raises(StudyError, match=r"allowable\[g\] = inf: not finite"):
        LimitState.exceedance("g", math.inf)
    with pytest.raises(StudyError,
                       match=r"output = \('speed', 0.0\) \(component 's'\): not a label"):
        LimitState.exceedance(("speed", 0.0), 1.0, name="s").bind(CYCLE_INDEX)
    with pytest.raises(StudyError,
                       match="output = None for component 'g', but the model has 8 outputs"):
        LimitState.margin().bind(CYCLE_INDEX)
    par = LimitState.parallel(LimitState.margin("a"), LimitState.margin("b"))
    with pytest.raises(StudyError, match="cannot be nested in a series system"):
        LimitState.series(par, LimitState.margin("c"))
    with pytest.raises(StudyError, match=r"component names = \['a', 'a'\]: duplicated"):
        LimitState.series(LimitState.margin("a"), LimitState.margin("a"))
    with pytest.raises(StudyError, match="system = 'mixed': unknown"):
        LimitState((LimitState.margin("a").components[0],), "mixed")


def test_whole_cycle_limit_state_against_numpy_and_first_passage_bound():
    """Series over every crank angle of a quantity = the whole-cycle event; its P_f is at least
    the worst single-angle P_f (an intersection of safe events), computed here by subset
    simulation and checked against crude MC on the same function."""
    inputs = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
    model = _vec(_cycle, inputs, CYCLE_INDEX.tolist())
    ls = LimitState.exceedance(["displacement"], 2.5, kind="abs", name="disp_cycle")
    res = subset_simulation(model=model, inputs=inputs, limit_state=ls, n_per_level=2000, seed=5)
    X = np.random.default_rng(0).standard_normal((2_000_000, 2))
    Y = _cycle(X)
    p_mc = float(np.mean(np.abs(Y[:, :4]).max(axis=1) >= 2.5))
    p_point = float(np.max(np.mean(np.abs(Y[:, :4]) >= 2.5, axis=0)))
    se_mc = math.sqrt(p_mc * (1 - p_mc) / len(X))
    assert p_mc > p_point  # the cycle is worse than its worst angle
    assert abs(res.pf - p_mc) <= 3 * math.hypot(res.cov * res.pf, se_mc)


def test_random_allowable_is_an_extra_independent_input():
    """Output y ~ N(10, 1) against I ~ N(14, 0.8) (upper): β = 4/√(1 + 0.64) exactly (linear,
    normal)."""
    inputs = UncertainInputs.from_specs({"R": Normal(10.0, 1.0)})
    model = _vec(lambda X: X[:, 0], inputs, ["y"])
    res = form(model=model, inputs=inputs,
               limit_state=LimitState.exceedance("y", Normal(14.0, 0.8), kind="upper"))
    assert res.beta == pytest.approx(4.0 / math.hypot(1.0, 0.8), abs=1e-10)
    assert list(res.design_point.index) == ["R", "allowable[y]"]
    assert res.importance.to_numpy() == pytest.approx([1 / 1.64, 0.64 / 1.64], abs=1e-10)
    # at the design point the output meets the allowable: x_R = x_I
    assert res.x_star.iloc[0] == pytest.approx(res.x_star.iloc[1], abs=1e-9)
    # the allowable never reaches the model: every model row has one column
    assert res.evaluations.X.shape[1] == 1


# ---------------------------------------------------------------- vectorised model path
def _vec_with_failures(X):
    Y = np.column_stack([X[:, 0] + X[:, 1], X[:, 0] * X[:, 1]])
    Y[X[:, 0] > 1.5, 1] = np.nan
    return Y


def _vec_raises(X):
    if np.any(X[:, 0] < -1.0):
        raise ModelFailure("x0 below -1")
    return np.column_stack([X[:, 0] + X[:, 1], X[:, 0] * X[:, 1]])


def _row(x):
    if x[0] < -1.0:
        raise ModelFailure("x0 below -1")
    y = np.array([x[0] + x[1], x[0] * x[1]])
    if x[0] > 1.5:
        y[1] = np.nan
    return y


def test_vectorized_function_model_same_rows_failures_and_cache(tmp_path):
    X = np.random.default_rng(3).normal(0.0, 1.2, (400, 2))
    ref = evaluate(FunctionModel(_row, ["a", "b"], ["s", "p"], key="v"), X, progress=False,
                   chunk_size=50)
    nan_rows = X[:, 0] > 1.5
    raise_rows = X[:, 0] < -1.0
    assert nan_rows.any() and raise_rows.any()
    vm = FunctionModel(_vec_with_failures, ["a", "b"], ["s", "p"], key="v", vectorized=True)
    ev = evaluate(vm, X, progress=False, chunk_size=50)
    assert np.array_equal(ev.ok, ~nan_rows)
    assert set(r for r in ev.reasons if r) == {"non-finite output (1 of 2 entries)"}
    ok = ~nan_rows
    assert np.array_equal(ev.Y[ok], ref.Y[ok]) or np.array_equal(ev.Y[ok & ~raise_rows],
                                                                 ref.Y[ok & ~raise_rows])
    # a raising batch falls back to rows: only the raising rows fail, with their reason
    vr = FunctionModel(_vec_raises, ["a", "b"], ["s", "p"], key="v", vectorized=True)
    ev2 = evaluate(vr, X, progress=False, chunk_size=50, cache=tmp_path)
    assert np.array_equal(~ev2.ok, raise_rows)
    assert {r for r in ev2.reasons if r} == {"x0 below -1"}
    assert np.array_equal(ev2.Y[~raise_rows],
                          np.column_stack([X[:, 0] + X[:, 1], X[:, 0] * X[:, 1]])[~raise_rows])
    assert ev2.n_model_calls == 400
    again = evaluate(vr, X, progress=False, chunk_size=50, cache=tmp_path)
    assert again.n_model_calls == 0 and np.array_equal(again.Y, ev2.Y, equal_nan=True)
    with pytest.raises(StudyError,
                       match=r"returned shape \(50, 3\) for 50 rows; allowed: \(50, 2\)"):
        evaluate(FunctionModel(lambda X: np.zeros((len(X), 3)), ["a", "b"], ["s", "p"],
                               vectorized=True), X[:50],
                 progress=False, chunk_size=50)
    with pytest.raises(StudyError, match="vectorized: got 'yes'; allowed: True or False"):
        FunctionModel(_row, ["a", "b"], ["s", "p"], vectorized="yes")


# ---------------------------------------------------------------- FORM
@settings(max_examples=25, deadline=None)
@given(st.floats(0.5, 5.0), st.floats(0.1, 3.0), st.floats(0.1, 3.0), st.floats(-0.8, 0.8))
def test_form_exact_on_linear_normal(mu_diff, s_r, s_s, rho):
    """Margin g = R − S, (R, S) correlated normals: β = (μ_R − μ_S)/√(σ_R² + σ_S² − 2ρσ_Rσ_S).

    The converged β is off by |G(u*)|/‖∇G‖ ≤ tol·|G(0)|/‖∇G‖ (the surface criterion): tol = 1e-12
    bounds it below 1e-10 here; the gradient of a linear g has no truncation error, its round-off
    (ε|x|/(hσ) ≈ 1e-11) limits the direction criterion, which enters β only squared: 1e-8."""
    inputs = UncertainInputs.from_specs({"R": Normal(10.0 + mu_diff, s_r), "S": Normal(10.0, s_s)},
                                        correlation={("R", "S"): rho})
    res = form(model=_vec(_r_minus_s, inputs), inputs=inputs, tol=1e-12, tol_direction=1e-8)
    want = mu_diff / math.sqrt(s_r**2 + s_s**2 - 2 * rho * s_r * s_s)
    assert res.beta == pytest.approx(want, abs=1e-10)
    assert res.pf == special.ndtr(-res.beta)
    assert res.importance.sum() == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("func", [_log_r_minus_s, _r_minus_s])
def test_form_exact_on_lognormal_r_minus_s(func):
    """The margin ln R − ln S with lognormal R, S is linear in u:
    β = (μ_lnR − μ_lnS)/√(σ_lnR² + σ_lnS²). R − S has the same failure surface (nonlinear g,
    same design point). P_f ≈ 1e-6 here."""
    inputs = UncertainInputs.from_specs({"R": LogNormal(10.0, 1.5), "S": LogNormal(3.0, 0.6)})
    (mr, sr), (ms, ss) = inputs.marginals[0].log_params, inputs.marginals[1].log_params
    want = (mr - ms) / math.hypot(sr, ss)
    res = form(model=_vec(func, inputs), inputs=inputs, tol=1e-10)
    assert 1e-7 < special.ndtr(-want) < 1e-5
    assert res.beta == pytest.approx(want, abs=1e-10)
    # design point in physical units: R* = S* on the surface, u* = β α
    assert res.x_star["R"] == pytest.approx(res.x_star["S"], rel=1e-10)
    assert res.design_point["u"].to_numpy() == pytest.approx(res.beta * res.alpha.to_numpy(),
                                                             abs=1e-9)
    assert res.importance.to_numpy() == pytest.approx([sr**2, ss**2] / np.float64(sr**2 + ss**2),
                                                      abs=1e-9)
    assert res.n_evaluations <= 200


def test_form_history_and_convergence_errors():
    inputs = STD2
    res = form(model=_vec(_parabola, inputs), inputs=inputs)
    assert list(res.history.columns)[:3] == ["beta", "g", "merit_c"]
    assert res.history["beta"].iloc[-1] == pytest.approx(4.5, abs=1e-10)
    assert (res.provenance["method"] == "form"
            and res.provenance["n_evaluations"] == res.n_evaluations)
    with pytest.raises(FORMConvergenceError,
                       match="did not converge in max_iter = 1 iterations") as e:
        form(model=_vec(_r_minus_s, UncertainInputs.from_specs({"R": LogNormal(10, 1.5),
                                                                "S": LogNormal(3, .6)})),
             inputs=UncertainInputs.from_specs({"R": LogNormal(10, 1.5),
                                                "S": LogNormal(3, .6)}), max_iter=1)
    assert len(e.value.history) == 2
    # g = 1 + u1² + u2²: flat at the origin, never violated
    flat = _vec(lambda X: 1.0 + X[:, 0] ** 2 + X[:, 1] ** 2, inputs)
    with pytest.raises(FORMConvergenceError, match="gradient of g is zero at iteration 0") as e:
        form(model=flat, inputs=inputs)
    assert e.value.history.shape[0] == 1
    with pytest.raises(StudyError, match=r"step: got -1; allowed: a number > 0"):
        form(model=flat, inputs=inputs, step=-1)
    with pytest.raises(StudyError, match=r'scheme = "backward": unknown value; allowed: one of '
                                         r'central, forward'):
        form(model=flat, inputs=inputs, scheme="backward")
    with pytest.raises(StudyError, match="limit_state = 'g': not a LimitState"):
        form(model=flat, inputs=inputs, limit_state="g")


# ---------------------------------------------------------------- SORM
def test_sorm_parabolic_at_beta_4_5():
    """β = 4.5, κ = 0.2: curvature exact; Hohenbichler–Rackwitz (default) and Tvedt within 1 % of
    the quadrature, Breitung within 10 %, in a few dozen evaluations; FORM alone is 40 % off."""
    exact = _exact_parabola(4.5, 0.2)
    res = sorm(model=_vec(_parabola, STD2), inputs=STD2)
    assert isinstance(res, SORMResult)
    assert res.curvatures == pytest.approx([0.2], abs=1e-6)
    assert res.table["beta_form"].iloc[0] == pytest.approx(4.5, abs=1e-10)
    assert res.pf == pytest.approx(exact, rel=0.01)
    assert res.table["pf_tvedt"].iloc[0] == pytest.approx(exact, rel=0.001)
    for col in ("pf_breitung", "pf_hohenbichler", "pf_tvedt"):
        assert res.table[col].iloc[0] == pytest.approx(exact, rel=0.10)
    assert res.table["pf_form"].iloc[0] / exact - 1 > 0.3
    assert res.n_evaluations <= 2000


def test_sorm_formulas_closed_forms_and_error():
    b, k = 3.0, np.array([0.1, -0.2])
    p = sorm_probabilities(b, k)
    assert p["breitung"] == pytest.approx(
        special.ndtr(-b) / math.sqrt((1 + b * 0.1) * (1 - b * 0.2)), rel=1e-14)
    psi = stats.norm.pdf(b) / special.ndtr(-b)
    assert p["hohenbichler"] == pytest.approx(
        special.ndtr(-b) / math.sqrt((1 + psi * 0.1) * (1 - psi * 0.2)), rel=1e-14)
    assert sorm_probabilities(b, [0.0, 0.0]) == pytest.approx({n: special.ndtr(-b) for n in p},
                                                              rel=1e-15)
    # κ = −0.32 at β = 3: Breitung defined (1 + βκ = 0.04), Hohenbichler (ψ = 3.283: 1 + ψκ < 0)
    # and Tvedt (1 + 4κ < 0) are not: None, never NaN
    q = sorm_probabilities(3.0, [-0.32])
    assert q["breitung"] == pytest.approx(special.ndtr(-3.0) / math.sqrt(0.04), rel=1e-13)
    assert q["hohenbichler"] is None and q["tvedt"] is None
    with pytest.raises(StudyError, match=r"curvature κ = \[-0.5\] at β = 3: 1 \+ βκ ≤ 0"):
        sorm_probabilities(b, [0.1, -0.5])


# ---------------------------------------------------------------- importance sampling
def test_importance_sampling_parabolic_within_its_interval():
    """The classic estimator (one design point, no defensive component: ``defensive=0`` draws
    the samples of the earlier single-centre version, sample for sample)."""
    exact = _exact_parabola(4.5, 0.2)
    res = importance_sampling(model=_vec(_parabola, STD2), inputs=STD2, n=1000, seed=11,
                              progress=False, defensive=0.0)
    assert isinstance(res, ImportanceSamplingResult)
    assert res.n_evaluations <= 2000
    assert res.cov <= 0.1
    assert abs(res.pf - exact) <= 3 * res.cov * res.pf
    assert abs(res.pf - exact) / exact <= 0.10
    assert (res.table["pf_lo"].iloc[0] <= exact <= res.table["pf_hi"].iloc[0]
            or abs(res.pf - exact) <= 3 * res.cov * res.pf)


@pytest.mark.parametrize("func, inputs, reference", [
    # Rozsas & Slobbe (2019), RP22 and RP24; values as tabulated in OpenTURNS' otbenchmark
    (_rp22, STD2, 4.16e-3),
    (_rp24, UncertainInputs.from_specs({"x1": Normal(10.0, 3.0), "x2": Normal(10.0, 3.0)}),
     2.86e-3),
])
def test_importance_sampling_rp_single_design_point(func, inputs, reference):
    res = importance_sampling(model=_vec(func, inputs), inputs=inputs, n=2000, seed=2,
                              progress=False)
    assert abs(res.pf - reference) <= 3 * res.cov * res.pf + 0.005 * reference


# ---------------------------------------------------------------- subset simulation
def test_subset_simulation_at_1e_5():
    """P_f ≈ 1e-5 (β = 4.2, κ = 0.1): c.o.v. ≤ 0.3 within 2·10⁴ evaluations."""
    exact = _exact_parabola(4.2, 0.1)
    assert 5e-6 < exact < 2e-5
    res = subset_simulation(model=_vec(_parabola_1e5, STD2), inputs=STD2, n_per_level=3000, seed=4)
    assert isinstance(res, SubsetSimulationResult)
    assert res.n_evaluations <= 20_000
    assert res.cov <= 0.3
    assert abs(res.pf - exact) <= 3 * res.cov * res.pf
    lv = res.levels
    assert np.all(np.diff(lv["threshold"].to_numpy()[:-1]) < 0) and lv["threshold"].iloc[-1] == 0.0
    assert lv["n_evaluations"].sum() == res.n_evaluations


def test_subset_simulation_agrees_with_crude_mc_at_1e_3():
    """Four-branch series system (k = 7, P_f = 2.22e-3): subset simulation against crude MC of
    10⁶ samples on the same function, within the combined 3σ interval."""
    model = _vec(_four_branch, STD2, ["b1", "b2", "b3", "b4"])
    ls = LimitState.series(*(LimitState.margin(b) for b in ["b1", "b2", "b3", "b4"]))
    res = subset_simulation(model=model, inputs=STD2, limit_state=ls, n_per_level=2000, seed=8)
    X = np.random.default_rng(1).standard_normal((1_000_000, 2))
    p_mc = float(np.mean(_four_branch(X).min(axis=1) <= 0))
    se_mc = math.sqrt(p_mc * (1 - p_mc) / len(X))
    assert abs(res.pf - p_mc) <= 3 * math.hypot(res.cov * res.pf, se_mc)


@pytest.mark.parametrize("name, model, inputs, ls, reference", [
    # Reference P_f: Rozsas, Á. & Slobbe, A. (2019), "Repository and black-box reliability
    # challenge 2019", TNO; the four-branch system: Waarts (2000), k = 7. Values as tabulated in
    # OpenTURNS' otbenchmark (ReliabilityProblem22/24/25/33/57, FourBranchSerialSystemReliability).
    ("RP22", _vec(_rp22, STD2), STD2, None, 4.16e-3),
    ("RP24",
     _vec(_rp24, UncertainInputs.from_specs({"x1": Normal(10.0, 3.0), "x2": Normal(10.0, 3.0)})),
     UncertainInputs.from_specs({"x1": Normal(10.0, 3.0), "x2": Normal(10.0, 3.0)}), None, 2.86e-3),
    ("RP25", _vec(_rp25_branches, STD2, ["g1", "g2"]), STD2,
     LimitState.parallel(LimitState.margin("g1"), LimitState.margin("g2")), 4.148566293759747e-05),
    ("RP33", _vec(_rp33_branches, STD3, ["g1", "g2"]), STD3,
     LimitState.series(LimitState.margin("g1"), LimitState.margin("g2")), 2.57e-3),
    ("RP57", _vec(_rp57, STD2), STD2, None, 2.84e-2),
    ("four-branch", _vec(_four_branch, STD2, ["b1", "b2", "b3", "b4"]), STD2,
     LimitState.series(*(LimitState.margin(b) for b in ["b1", "b2", "b3", "b4"])), 2.2228e-3),
])
def test_subset_simulation_benchmark_problems(name, model, inputs, ls, reference):
    res = subset_simulation(model=model, inputs=inputs, limit_state=ls, n_per_level=2000, seed=21)
    assert abs(res.pf - reference) <= 3 * res.cov * res.pf + 0.005 * reference, (name, res.pf,
                                                                                 res.cov)


def _fails_left(X):
    Y = X[:, 1] * 0 + (3.0 - X[:, 0])
    Y[X[:, 1] < -2.5] = np.nan  # about 0.6 % of the standard normal mass
    return Y


def test_subset_failures_counted_and_refused():
    model = _vec(_fails_left, STD2)
    res = subset_simulation(model=model, inputs=STD2, n_per_level=1000, seed=3)
    assert res.table["n_failed_model"].iloc[0] > 0
    assert res.evaluations.n_failed == res.table["n_failed_model"].iloc[0]
    assert abs(res.pf - special.ndtr(-3.0)) <= 3 * res.cov * res.pf
    with pytest.raises(SampleFailuresError, match="more than max_failure_fraction=0.001"):
        subset_simulation(model=model, inputs=STD2, n_per_level=1000, seed=3,
                          max_failure_fraction=0.001)
    # importance sampling: excluded failures leave the estimate alone (they lie far from the
    # design point (3, 0)); counted as failures they add their weighted share
    kw = dict(model=model, inputs=STD2, n=2000, seed=5, progress=False)
    ex = importance_sampling(**kw)
    asf = importance_sampling(**kw, failures="as_failure")
    assert ex.table["n_failed_model"].iloc[0] == asf.table["n_failed_model"].iloc[0] > 0
    assert abs(ex.pf - special.ndtr(-3.0)) <= 3 * ex.cov * ex.pf
    assert asf.pf > ex.pf
    assert sum(ex.failure_counts.values()) == ex.table["n_failed_model"].iloc[0]


def test_subset_on_a_frequent_event_warns_and_is_crude_mc():
    always = _vec(lambda X: 0.5 - X[:, 0], STD2)  # P_f = Φ(−0.5) = 0.31
    with pytest.warns(UserWarning, match="not a rare event, the result is crude Monte Carlo"):
        res = subset_simulation(model=always, inputs=STD2, n_per_level=1000, seed=0)
    assert res.n_evaluations == 1000 and res.table["n_levels"].iloc[0] == 1
    p = special.ndtr(-0.5)
    assert abs(res.pf - p) <= 3 * math.sqrt(p * (1 - p) / 1000)  # binomial 3σ


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=3, max_size=3), st.floats(0.1, 5))
def test_series_below_components_below_parallel(y, a):
    idx = pd.Index(["y0", "y1", "y2"])
    parts = [LimitState.exceedance("y0", a, name="c0"), LimitState.margin("y1"),
             LimitState.exceedance("y2", a, kind="upper", name="c2")]
    Y = np.array([y])
    comp = LimitState.series(*parts).bind(idx).components(Y)[0]
    assert comp.tolist() == [a - abs(y[0]), y[1], a - y[2]]
    ser = LimitState.series(*parts).bind(idx)(Y)[0]
    par = LimitState.parallel(*parts).bind(idx)(Y)[0]
    assert ser == comp.min() and par == comp.max() and ser <= par


def test_subset_errors():
    never = _vec(lambda X: np.full(len(X), 1.0), STD2)
    with pytest.raises(StudyError, match="threshold stopped decreasing|max_levels"):
        subset_simulation(model=never, inputs=STD2, n_per_level=100, seed=0)
    with pytest.raises(StudyError, match=r"p0: got 0.3 with n_per_level = 100; allowed: "
                                         r"1/p0 and n_per_level·p0"):
        subset_simulation(model=never, inputs=STD2, n_per_level=100, p0=0.3)
    with pytest.raises(StudyError,
                       match=r'proposal = "gibbs": unknown value; allowed: one of conditional, '
                       r"modified_metropolis"):
        subset_simulation(model=never, inputs=STD2, proposal="gibbs")


# ---------------------------------------------------------------- reproducibility, cache, registry
def test_same_seed_same_result_any_n_jobs_and_resume_from_cache(tmp_path):
    model = _vec(_rp22, STD2)
    kw = dict(model=model, inputs=STD2, n_per_level=500, seed=9, chunk_size=25)
    a = subset_simulation(**kw, n_jobs=1)
    b = subset_simulation(**kw, n_jobs=2, backend="loky", cache=tmp_path)
    pd.testing.assert_frame_equal(a.table, b.table, check_exact=True)
    c = subset_simulation(**kw, n_jobs=1, cache=tmp_path)
    pd.testing.assert_frame_equal(a.table, c.table, check_exact=True)
    assert c.provenance["n_computed"] == 0 and c.provenance["n_cached"] == c.n_evaluations
    # FORM's stencils and line-search points are cached rows too
    f1 = form(model=model, inputs=STD2, cache=tmp_path / "form")
    f2 = form(model=model, inputs=STD2, cache=tmp_path / "form")
    assert f2.beta == f1.beta and f2.provenance["n_computed"] == 0
    assert f1.provenance["limit_state"]["components"][0]["kind"] == "margin"


def test_registry_lists_every_method_and_validates_settings():
    assert METHODS["monte_carlo"].settings["n"].default is None  # read from the signature
    # the failure definition (allowable=, event=, limit_state=) is a common argument, no setting
    from mechrel.uq.estimators import COMMON_ARGUMENTS

    assert {"allowable", "event", "limit_state"} <= set(COMMON_ARGUMENTS)
    for meth in METHODS.values():
        assert not set(meth.settings) & set(COMMON_ARGUMENTS), meth.name
    m = get_method("sorm")
    res = m(model=_vec(_parabola, STD2), inputs=STD2, formula="breitung")
    assert isinstance(res, m.result_type) and res.formula == "breitung"
    assert isinstance(get_method("form")(model=_vec(_parabola, STD2), inputs=STD2), FORMResult)
    with pytest.raises(StudyError, match=r"sorm: settings \['formla'\]: unknown; allowed: \["):
        m.validate({"formla": "tvedt"})
    with pytest.raises(StudyError,
                       match=r"subset_simulation.n_per_level: got 5; allowed: an integer > 9"):
        get_method("subset_simulation").validate({"n_per_level": 5})
    with pytest.raises(StudyError, match=re.escape(f"method: got 'mcmc'; allowed: "
                                                   f"{sorted(METHODS)}")):
        get_method("mcmc")
    for name, meth in METHODS.items():
        assert callable(meth.function) and isinstance(meth.result_type, type), name
        # every setting's default passes its own check (or the estimator checks it)
        defaults = {k: s.default for k, s in meth.settings.items()}
        assert meth.validate({}) == defaults, name
        for k, s in meth.settings.items():
            if s.check is not None and s.default is not None:
                assert s.check(f"{name}.{k}", s.default) == s.default, (name, k)


# ---------------------------------------------------------------- the mechanism model
@pytest.mark.slow
def test_form_sorm_on_the_lubricated_nine_bar_against_monte_carlo():
    """FORM/SORM through the mechanism model (clearance, viscosity; 2 cycles): the point-in-time
    probability that the acceleration error at its most uncertain angle exceeds μ + 1.28σ
    (≈ 0.1 under normality), against 256 Monte Carlo samples of an independent seed, within
    3 binomial standard deviations. The whole-cycle limit state binds to the model's labels.
    Cost: about 300 two-cycle simulations (≈ 1–2 min on 2 workers)."""
    from mechrel.uq import TruncNormal, fosm
    from mechrel.uq.problem.mechanism import MechanismModel

    model = MechanismModel("nine-bar-lubricated",
                           {"clearance": ["joints.C1.clearance", "joints.C2.clearance"],
                            "viscosity": ["joints.C1.lubricant.viscosity",
                                          "joints.C2.lubricant.viscosity"]}, cycles=2)
    inputs = UncertainInputs.from_specs({"clearance": TruncNormal(0.5e-3, 0.05e-3, 0.35e-3,
                                                                  0.65e-3),
                                         "viscosity": LogNormal(0.1, 0.015)})
    whole = LimitState.exceedance(["acceleration"], 1.0).bind(model.output_index)
    n_angles = int((model.output_index.get_level_values("quantity") == "acceleration").sum())
    assert whole.positions[0].size == n_angles > 1
    f = fosm(model=model, inputs=inputs, progress=False)
    acc = f.table.loc["acceleration"]
    angle = acc["std"].idxmax()
    a = float(acc.loc[angle, "mean"] + 1.2816 * acc.loc[angle, "std"])
    ls = LimitState.exceedance(("acceleration", angle), a, kind="upper")
    # an ODE-integrated output is noisy at the 1e-5..1e-4 level relative to the error (a small
    # difference of two large responses): the defaults made for smooth functions (step 1e-4,
    # tol 1e-6) stall in the line search with the direction criterion jumping 1e-3..1e-1; a step
    # of 0.05 standard deviations and tol = 1e-3 converge in 3 iterations (docs/uq.md)
    so = sorm(model=model, inputs=inputs, limit_state=ls, n_jobs=2, step=0.05, tol=1e-3,
              curvature_step=0.25)
    assert so.form.n_evaluations <= 60
    X = inputs.sample(256, seed=SEED_MC)
    ev = evaluate(model, X, n_jobs=2, progress=False)
    assert ev.n_failed == 0
    y = ev.Y[:, model.output_index.get_loc(("acceleration", angle))]
    p_mc = float(np.mean(y >= a))
    assert abs(so.pf - p_mc) <= 3 * math.sqrt(p_mc * (1 - p_mc) / 256)
    assert abs(so.form.pf - p_mc) <= 3 * math.sqrt(p_mc * (1 - p_mc) / 256)


SEED_MC = 20261125
