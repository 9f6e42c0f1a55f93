"""FOSM (paper eqs. 25–28) against closed forms; interference formulas; allowables."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest
from scipy import integrate, special, stats

from mechrel.errors import StudyError
from mechrel.uq import (
    Allowable,
    Evaluations,
    FunctionModel,
    ModelFailure,
    Normal,
    UncertainInputs,
    evaluate,
    fd_steps,
    fosm,
    fosm_design,
    linear_model,
    reliability_one_sided,
    reliability_two_sided,
)

EPS = np.finfo(float).eps

# y = a + B x, three correlated normal inputs, two outputs
A0 = np.array([0.01, -0.02])
B = np.array([[0.5, -0.3, 0.2], [0.1, 0.4, -0.25]])
MU = np.array([1.0, 2.0, -0.5])
SD = np.array([0.1, 0.2, 0.05])
CORR = np.array([[1.0, 0.3, 0.0], [0.3, 1.0, -0.2], [0.0, -0.2, 1.0]])


def _linear():
    inputs = UncertainInputs.from_specs({f"x{j}": Normal(MU[j], SD[j]) for j in range(3)},
                                        correlation=CORR)
    model = linear_model(A0, B, inputs.names)
    cov = CORR * np.outer(SD, SD)
    mu = A0 + B @ MU
    sd = np.sqrt(np.diag(B @ cov @ B.T))
    return model, inputs, mu, sd


def test_linear_model_fosm_is_exact():
    """μ_i, σ_i and β equal the closed forms to 1e-10 relative.

    Central differences of an affine function have no truncation error; what remains is rounding
    in f(μ ± h e_j): |δf| ≲ ε·F with F = |a| + Σ|B_kj x_j| ≈ 1.2, so the slope error is
    ≲ ε·F/h_j with the default h_j = ε^(1/3)·max(|μ_j|, σ_j) ≥ 3·10⁻⁶: ≲ 1e-10 absolute on
    slopes of size 0.1–0.5. (A step of 1e-10 would make it ~1e-6: the step matters.)
    """
    model, inputs, mu, sd = _linear()
    res = fosm(model=model, inputs=inputs, allowable=Allowable(1.0, 0.2), event="one-sided")
    t = res.table
    np.testing.assert_allclose(t["mean"], mu, rtol=1e-12)
    np.testing.assert_allclose(t["std"], sd, rtol=1e-10)
    beta = (1.0 - mu) / np.sqrt(0.2**2 + sd**2)
    np.testing.assert_allclose(t["beta"], beta, rtol=1e-10)
    np.testing.assert_allclose(t["R_one_sided"], special.ndtr(beta), rtol=1e-10)
    np.testing.assert_allclose(res.gradient.to_numpy(), B, rtol=1e-9, atol=1e-10)
    # the paper's form: R = Φ(β) exactly and "reliability" follows the event
    assert np.array_equal(t["reliability"], t["R_one_sided"])
    assert res.evaluations.n == 2 * 3 + 1
    assert res.provenance["n_evaluations"] == 7
    assert res.provenance["model_cache_key"] == model.cache_key()
    np.testing.assert_allclose(res.steps, EPS ** (1 / 3) * np.maximum(np.abs(MU), SD))


def test_fd_step_choices():
    _, inputs, _, _ = _linear()
    np.testing.assert_allclose(fd_steps(inputs, 0.1), 0.1 * SD)
    np.testing.assert_allclose(fd_steps(inputs, "auto", noise=1e-8),
                               1e-8 ** (1 / 3) * np.maximum(np.abs(MU), SD))
    np.testing.assert_allclose(fd_steps(inputs, [1e-3, 2e-3, 3e-3]), [1e-3, 2e-3, 3e-3])
    with pytest.raises(StudyError, match=r"step: a fraction of the std must be > 0, got -1"):
        fd_steps(inputs, -1)
    with pytest.raises(StudyError, match=r"step: got 'big'; allowed: 'auto'"):
        fd_steps(inputs, "big")
    # a simulated model declares its output noise (integrator rtol); the automatic step uses it
    model, _, _, _ = _linear()
    model.output_noise = 1e-8
    res = fosm(model=model, inputs=inputs, allowable=Allowable(1.0, 0.2))
    np.testing.assert_allclose(res.steps, 1e-8 ** (1 / 3) * np.maximum(np.abs(MU), SD))
    assert res.provenance["settings"]["noise"] == 1e-8


def _quadratic(x):
    return np.array([x[0] ** 2 + 3.0 * x[1]])


def test_quadratic_gradient_is_exact_for_any_step():
    """F = x0² + 3 x1: central differences are exact for quadratics (truncation ∝ f‴ = 0), so
    even a step of half a standard deviation gives ∇f = (2μ0, 3)."""
    inputs = UncertainInputs.from_specs({"x0": Normal(2.0, 0.3), "x1": Normal(0.0, 0.1)})
    m = FunctionModel(_quadratic, inputs.names, ["y"])
    res = fosm(model=m, inputs=inputs, step=0.5, allowable=Allowable(10.0, 1.0))
    np.testing.assert_allclose(res.gradient.to_numpy(), [[4.0, 3.0]], rtol=1e-12)
    np.testing.assert_allclose(res.table["std"], math.hypot(4 * 0.3, 3 * 0.1), rtol=1e-12)
    imp = res.importance()
    np.testing.assert_allclose(imp.sum(axis=1), 1.0, rtol=1e-12)


def test_two_sided_formula_against_direct_integration():
    """R₂ = P(−I < i < I) = ∫_{t>0} φ_I(t)[Φ((t−μ_i)/σ_i) − Φ((−t−μ_i)/σ_i)] dt (independent
    1-D quadrature, error < 1e-10) equals the bivariate-normal orthant form."""
    for mu_i, s_i, mu_I, s_I in [(0.3, 0.5, 1.0, 0.4), (-0.2, 0.1, 0.3, 0.1),
                                 (0.0, 0.2, 0.012, 0.004),
                                 (5.0, 1.0, 18.0,
                                  6.0), (0.0, 1e-3, 1.0, 0.5), (0.9, 0.3, 1.0, 0.05)]:
        f = lambda t: stats.norm.pdf(t, mu_I, s_I) * (  # noqa: E731
            stats.norm.cdf((t - mu_i) / s_i) - stats.norm.cdf((-t - mu_i) / s_i))
        ref, _ = integrate.quad(f, 0, mu_I + 12 * s_I, epsabs=1e-13, epsrel=1e-12, points=[mu_I],
                                limit=200)
        r2 = reliability_two_sided(mu_i, s_i, mu_I, s_I)[2]
        assert r2 == pytest.approx(ref, abs=1e-10)
        # two-sided never exceeds one-sided (an intersection of events)
        assert r2 <= reliability_one_sided(mu_i, s_i, mu_I, s_I)[1] + 1e-15
    # limits: fixed allowable (σ_I = 0) and deterministic error (σ_i = 0)
    r = reliability_two_sided(0.3, 0.5, 1.0, 0.0)[2]
    assert r == pytest.approx(stats.norm.cdf(0.7 / 0.5) - stats.norm.cdf(-1.3 / 0.5), abs=1e-15)
    r = reliability_two_sided(-0.3, 0.0, 1.0, 0.4)[2]
    assert r == pytest.approx(stats.norm.cdf(0.7 / 0.4), abs=1e-15)


# (β, R) pairs printed in the paper's §5 (Chen, Wang, Gao 2022)
PAPER_PAIRS = [(2.021, 0.9784), (2.014, 0.9780), (1.614, 0.9464), (2.013, 0.9780),
               (-0.1706, 0.4325),
               (1.675,
                0.9530), (2.213, 0.9865), (2.214, 0.9866), (1.710, 0.9564), (0.08237, 0.5329),
               (-0.7213,
                0.2358), (2.043, 0.9795), (2.091, 0.9817), (2.263, 0.9882), (2.539, 0.9945),
               (2.051, 0.9798), (2.389, 0.9916), (2.187, 0.9859), (1.832, 0.9666), (2.736, 0.9969),
               (1.304, 0.9039), (2.437, 0.9927), (0.5269, 0.7009)]


def test_paper_pairs_are_one_sided_and_one_is_a_misprint():
    """Every printed pair satisfies R = Φ(β) within 5e-4 (the largest deviation, 4.4e-4 at
    β = −0.7213, is rounding of values read at slightly different precision), i.e. the paper's
    numbers are the one-sided form. (1.172, 0.8581) is off by 0.021, 40 times more:
    Φ(1.172) = 0.8794, while 0.8581 = Φ(1.072) — a misprinted digit."""
    for beta, R in PAPER_PAIRS:
        assert reliability_one_sided(-beta, 0.0, 0.0, 1.0)[1] == pytest.approx(R, abs=5e-4)
    assert special.ndtr(1.172) - 0.8581 > 0.02
    assert special.ndtr(1.072) == pytest.approx(0.8581, abs=1e-4)
    # every printed β ≤ μ_I/σ_I = 3, the largest β possible with a non-negative mean error
    assert max(b for b, _ in PAPER_PAIRS) <= 3.0


def _mechanism_like(x):
    """Outputs on a (quantity, crank_angle) grid like the mechanism model's."""
    ang = np.deg2rad(np.arange(0, 360, 90))
    d = 1e-3 * x[0] * np.sin(ang) + 2e-3
    v = 0.05 * x[0] * np.cos(ang) + 0.1 * x[1]
    a = 3.0 * x[1] * np.sin(ang) + 1.0
    return np.concatenate([d, v, a])


def _grid_index():
    return pd.MultiIndex.from_product([["displacement", "velocity", "acceleration"],
                                       [0.0, 90.0, 180.0, 270.0]],
                                      names=["quantity", "crank_angle"])


def test_default_allowables_are_the_papers_per_quantity():
    inputs = UncertainInputs.from_specs({"c1": Normal(1.0, 0.2), "c2": Normal(0.5, 0.1)})
    m = FunctionModel(_mechanism_like, inputs.names, _grid_index())
    res = fosm(model=m, inputs=inputs)
    t = res.table
    for q, mean, std in (("displacement", 0.012, 0.004), ("velocity", 0.3, 0.1),
                         ("acceleration", 18.0, 6.0)):
        assert (t.loc[q, "allowable_mean"] == mean).all()
        assert (t.loc[q, "allowable_std"] == std).all()
    # custom mapping; missing quantity is an error naming it
    with pytest.raises(StudyError,
                       match=r"allowable: no allowable error for quantity \['acceleration'\]"):
        fosm(model=m, inputs=inputs,
             allowable={"displacement": Allowable(0.01, 0.0), "velocity": (0.2, 0.05)})
    # analytic outputs without a quantity level need an explicit allowable
    m2 = linear_model([0.0], [[1.0, 0.0]], inputs.names)
    with pytest.raises(StudyError, match=r"outputs have no 'quantity' level"):
        fosm(model=m2, inputs=inputs)


def test_allowable_validation():
    with pytest.raises(StudyError, match=r"Allowable\.mean: must be finite and > 0, got -1"):
        Allowable(-1, 0.1)
    with pytest.raises(StudyError, match=r"Allowable\.std: must be finite and >= 0, got -0\.1"):
        Allowable(1.0, -0.1)


def test_precomputed_evaluations_give_the_same_result():
    model, inputs, _, _ = _linear()
    X = fosm_design(inputs)
    ev = evaluate(model, X, progress=False)
    a = fosm(model=model, inputs=inputs, allowable=Allowable(1.0, 0.2))
    b = fosm(evaluations=ev, inputs=inputs, allowable=Allowable(1.0, 0.2))
    pd.testing.assert_frame_equal(a.to_frame(), b.to_frame())
    with pytest.raises(StudyError, match=r"evaluations\.X is not fosm_design"):
        fosm(evaluations=ev, inputs=inputs, allowable=Allowable(1.0, 0.2), step=0.1)
    with pytest.raises(StudyError,
                       match=r"pass exactly one of model= .* or evaluations= .*, got both"):
        fosm(model=model, evaluations=ev, inputs=inputs)
    with pytest.raises(StudyError,
                       match=r"event: got 'both'; allowed: \['one-sided', 'two-sided'\]"):
        fosm(model=model, inputs=inputs, event="both")


def _fails_above(x):
    if x[0] > 1.0:
        raise ModelFailure("mechanism locks")
    return np.array([x[0]])


def test_failed_stencil_point_is_an_error_naming_it():
    inputs = UncertainInputs.from_specs({"x0": Normal(1.0, 0.1)})
    m = FunctionModel(_fails_above, inputs.names, ["y"])
    with pytest.raises(StudyError, match=r"Failed points: \['x0 \+ h: mechanism locks'\]"):
        fosm(model=m, inputs=inputs, allowable=Allowable(1.0))


def test_results_are_frozen():
    model, inputs, _, _ = _linear()
    res = fosm(model=model, inputs=inputs, allowable=Allowable(1.0, 0.2))
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.event = "one-sided"
    with pytest.raises(ValueError):
        res.evaluations.Y[0, 0] = 1.0
    assert isinstance(res.evaluations, Evaluations)


def test_fosm_on_a_limit_state_is_exact_for_a_linear_margin_of_normals():
    # the exceedance y > I of y = a·x + c, x correlated normal, I ~ N(μ_I, σ_I²) a random
    # allowable (an input of g too): g = I − y, so β = (μ_I − c − a·μ)/sqrt(aᵀΣa + σ_I²)
    # exactly; central differences of a linear g are exact to round-off (asserted to 1e-9).
    from mechrel.uq import FOSMResult, LimitState

    inputs = UncertainInputs.from_specs({"x1": Normal(1.0, 0.3), "x2": Normal(-0.5, 0.2)},
                                        correlation={("x1", "x2"): 0.4})
    a, c = np.array([2.0, -1.0]), 0.25
    model = FunctionModel(lambda X: X @ a + c, ["x1", "x2"], ["y"], vectorized=True)
    ls = LimitState.exceedance(["y"], Normal(4.0, 0.5), kind="upper", name="y > I")
    r = fosm(model=model, inputs=inputs, limit_state=ls, progress=False)
    var = a @ inputs.covariance @ a + 0.5**2
    beta = (4.0 - c - a @ inputs.mean) / math.sqrt(var)
    assert isinstance(r, FOSMResult) and r.table is None and r.event is None  # one type
    assert r.beta == pytest.approx(beta, rel=1e-9)
    assert r.pf == pytest.approx(special.ndtr(-beta), rel=1e-8)
    assert r.n_evaluations == 2 * 3 + 1  # the allowable is a point of the stencil too
    assert r.gradient.to_numpy()[0] == pytest.approx([-2.0, 1.0, 1.0], rel=1e-9)
    assert r.gradient.index.tolist() == ["y > I"] and r.pf_table.index.name == "limit_state"
    assert r.to_frame()["std"].iloc[0] == pytest.approx(math.sqrt(var), rel=1e-9)


def test_fosm_refuses_a_limit_state_with_allowables_or_evaluations():
    from mechrel.uq import LimitState

    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    model = linear_model([0.0], [[1.0]], ["x"])
    with pytest.raises(StudyError, match=r"^fosm: allowable= and limit_state= are both given; "
                                         r"allowed: one of them"):
        fosm(model=model, inputs=inputs, limit_state=LimitState.margin(),
             allowable=Allowable(1.0, 0.0), progress=False)
    ev = evaluate(model, fosm_design(inputs), progress=False)
    with pytest.raises(StudyError, match=r"^fosm: limit_state= with evaluations=.*allowed: "
                                         r"model= and inputs= with limit_state="):
        fosm(evaluations=ev, inputs=inputs, limit_state=LimitState.margin())
