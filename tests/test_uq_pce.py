"""Polynomial chaos: exactness on linear models, orthonormal basis, Ishigami indices, failures."""

from __future__ import annotations

import math

import chaospy
import numpy as np
import pytest

from mechrel.errors import StudyError
from mechrel.uq import (
    Allowable,
    FunctionModel,
    LogNormal,
    ModelFailure,
    Normal,
    TruncNormal,
    UncertainInputs,
    Uniform,
    ishigami_indices,
    ishigami_inputs,
    ishigami_model,
    linear_model,
    monte_carlo,
    multi_indices,
    polynomial_chaos,
    reliability_one_sided,
)
from mechrel.uq import SampleFailuresError
from mechrel.uq.surrogates.pce import _basis, _recurrences

A0 = np.array([0.3, -1.0])
B = np.array([[0.5, -2.0, 0.1], [1.5, 0.25, -0.7]])
IND = UncertainInputs.from_specs({"x0": Normal(1.0, 0.2), "x1": Uniform(-1.0, 3.0),
                                  "x2": Normal(-2.0, 0.5)})


def _closed_form(inputs):
    mu = A0 + B @ inputs.mean
    sd = np.sqrt(np.diag(B @ inputs.covariance @ B.T))
    return mu, sd


@pytest.mark.parametrize("method, sparse",
                         [("regression", False), ("quadrature", False), ("quadrature", True)])
def test_order_one_is_exact_for_a_linear_model(method, sparse):
    """Y = a + Bx is in the span of the order-1 basis: the fit is exact up to rounding.

    Orthonormal degree-1 polynomials are (x − mean)/std for normal and uniform marginals, so the
    coefficients are c₀ = a + Bμ and c_j = B_j·σ_j (to 1e-10: least squares on 8 well-spread
    points / 2-point Gauss rules have condition numbers O(1)).
    """
    model = linear_model(A0, B, IND.names)
    res = polynomial_chaos(model=model, inputs=IND, order=1, method=method, sparse=sparse, seed=0,
                           n_validation=0)
    mu, sd = _closed_form(IND)
    alphas = res.multi_indices
    coef = res.coefficients
    assert np.array_equal(alphas[0], [0, 0, 0])
    np.testing.assert_allclose(coef[0], mu, rtol=1e-10)
    for j in range(3):
        k = int(np.flatnonzero((alphas[:, j] == 1) & (alphas.sum(axis=1) == 1))[0])
        np.testing.assert_allclose(coef[k], B[:, j] * IND.std[j], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(res.mean, mu, rtol=1e-10)
    np.testing.assert_allclose(res.std, sd, rtol=1e-10)
    # β from the PCE moments equals the closed form
    beta = (2.0 - mu) / np.sqrt(0.5**2 + sd**2)
    np.testing.assert_allclose(reliability_one_sided(res.mean, res.std, 2.0, 0.5)[0], beta,
                               rtol=1e-10)
    # Sobol' indices of a linear model: (B_j σ_j)² / Σ (B_k σ_k)², first = total
    v = (B * IND.std[None, :]) ** 2
    np.testing.assert_allclose(res.sobol_first.to_numpy(), v / v.sum(axis=1, keepdims=True),
                               rtol=1e-9)
    np.testing.assert_allclose(res.sobol_total.to_numpy(), res.sobol_first.to_numpy(), rtol=1e-12)
    if method == "regression":
        assert res.loo_error.max() < 1e-20
    # predictions reproduce the model
    X = IND.sample(50, seed=1)
    np.testing.assert_allclose(res.predict(X), X @ B.T + A0, rtol=1e-10, atol=1e-12)


def test_correlated_inputs_use_a_normal_germ():
    inputs = UncertainInputs.from_specs({"x0": Normal(1.0, 0.2), "x1": Normal(0.0, 1.0),
                                         "x2": Normal(-2.0, 0.5)},
                                        correlation={("x0", "x1"): 0.5, ("x1", "x2"): -0.3})
    res = polynomial_chaos(model=linear_model(A0, B, inputs.names), inputs=inputs, order=1, seed=3)
    mu, sd = _closed_form(inputs)
    np.testing.assert_allclose(res.mean, mu, rtol=1e-10)
    np.testing.assert_allclose(res.std, sd, rtol=1e-10)
    assert res.germ == "standard_normal" and res.sobol_first is None


def test_basis_is_orthonormal_for_every_marginal():
    """E[Ψ_a Ψ_b] = δ_ab under the input distribution, checked with a chaospy Gauss rule of
    order 8 (exact for products of degree ≤ 17 > 2·4)."""
    inputs = UncertainInputs.from_specs({"n": Normal(1.0, 2.0), "u": Uniform(0.0, 1.0),
                                         "t": TruncNormal(0.5, 1.0, -1.0,
                                                          2.0), "l": LogNormal(1.0, 0.3)})
    order = 4
    alphas = multi_indices(4, order)
    rec = _recurrences(inputs, order)
    nodes, w = chaospy.generate_quadrature(8, inputs.joint, rule="gaussian")
    Psi = _basis(np.asarray(nodes).T, alphas, rec, order)
    gram = (Psi * w[:, None]).T @ Psi
    np.testing.assert_allclose(gram, np.eye(len(alphas)), atol=1e-8)


def test_multi_indices():
    assert len(multi_indices(3, 4)) == math.comb(7, 4)
    assert len(multi_indices(5, 3, q_norm=0.5)) < math.comb(8, 3)
    A = multi_indices(2, 2)
    assert A.tolist()[0] == [0, 0] and sorted(A.sum(axis=1)) == list(A.sum(axis=1))


def test_ishigami_indices_from_quadrature_coefficients():
    """Gauss–Legendre order 10 (11³ nodes): the Ishigami terms are smooth (sin, x⁴), spectral
    convergence gives |S − S_exact| ≈ 2e-5 at order 10; we require the brief's 0.02."""
    ref = ishigami_indices()
    res = polynomial_chaos(model=ishigami_model(), inputs=ishigami_inputs(), order=10,
                           method="quadrature",
                           n_validation=64, seed=1)
    np.testing.assert_allclose(res.sobol_first.to_numpy()[0], ref["first"], atol=0.02)
    np.testing.assert_allclose(res.sobol_total.to_numpy()[0], ref["total"], atol=0.02)
    assert res.mean.iloc[0] == pytest.approx(ref["mean"], abs=1e-3)
    assert res.std.iloc[0] ** 2 == pytest.approx(ref["variance"], rel=1e-3)
    assert res.validation_error.iloc[0] < 1e-3


def test_ishigami_indices_from_regression_with_loo():
    """Least squares at order 8 (165 terms) on 512 Sobol' points: indices within 0.02 and a
    small leave-one-out error (it measures the truncation of the series, ~1e-3)."""
    ref = ishigami_indices()
    res = polynomial_chaos(model=ishigami_model(), inputs=ishigami_inputs(), order=8,
                           oversampling=3.0,
                           rule="sobol", seed=1)
    assert res.evaluations.n == 512
    np.testing.assert_allclose(res.sobol_first.to_numpy()[0], ref["first"], atol=0.02)
    np.testing.assert_allclose(res.sobol_total.to_numpy()[0], ref["total"], atol=0.02)
    assert res.loo_error.iloc[0] < 0.01
    frame = res.to_frame()
    assert {"mean", "std", "loo_error", "S1_x1", "ST_x3"} <= set(frame.columns)


def test_surrogate_reliability_matches_monte_carlo_on_an_exact_surrogate():
    model = linear_model(A0[:1], B[:1], IND.names, output_index=["y"])
    res = polynomial_chaos(model=model, inputs=IND, order=1, seed=0)
    allow = Allowable(1.5, 0.2)
    sur = res.reliability(n=4000, seed=12, allowable=allow)
    mc = monte_carlo(model=model, inputs=IND, n=4000, seed=12, allowable=allow)
    # same seed → same input sample and allowable draws; the surrogate equals the model to
    # ~1e-15, so the indicator agrees sample by sample
    assert sur.table["reliability"].iloc[0] == mc.table["reliability"].iloc[0]
    assert sur.provenance["surrogate"]["order"] == 1


def _fails_high(x):
    if x[0] > 1.3:
        raise ModelFailure("contact solver failed")
    return np.array([x[0] + x[1]])


def test_failures_regression_drops_and_quadrature_refuses():
    inputs = UncertainInputs.from_specs({"x0": Normal(1.0, 0.2), "x1": Normal(0.0, 1.0)})
    model = FunctionModel(_fails_high, inputs.names, ["y"])
    res = polynomial_chaos(model=model, inputs=inputs, order=2, oversampling=4.0, seed=0)
    assert res.evaluations.n_failed > 0
    assert res.provenance["settings"]["failed_samples_dropped"] == res.evaluations.n_failed
    assert res.mean.iloc[0] == pytest.approx(1.0, abs=1e-10)  # linear: exact from the rest
    with pytest.raises(SampleFailuresError,
                       match=r"quadrature needs every node; 3 of 9 samples failed "
                             r"\(3× contact solver failed\)") as info:
        polynomial_chaos(model=model, inputs=inputs, order=2, method="quadrature")
    assert info.value.evaluations.n_failed == 3
    # regression above the threshold: refused, every sample (and its reason) in the error
    share = res.evaluations.n_failed / res.evaluations.n
    with pytest.raises(SampleFailuresError,
                       match=rf"polynomial_chaos: {res.evaluations.n_failed} of "
                       rf"{res.evaluations.n} samples failed .*max_failure_fraction"
                       ) as info:
        polynomial_chaos(evaluations=res.evaluations, inputs=inputs, order=2,
                         max_failure_fraction=share / 2)
    assert info.value.evaluations is res.evaluations


def test_argument_errors():
    model = linear_model(A0, B, IND.names)
    with pytest.raises(StudyError, match=r"order = 1\.5: expected an integer, got a number; "
                                         r"allowed: an integer >= 0"):
        polynomial_chaos(model=model, inputs=IND, order=1.5)
    with pytest.raises(StudyError, match=r'method = "galerkin": unknown value; allowed: one of '
                                         r'regression, quadrature'):
        polynomial_chaos(model=model, inputs=IND, order=1, method="galerkin")
    with pytest.raises(StudyError, match=r"oversampling: samples per basis term must be >= 1"):
        polynomial_chaos(model=model, inputs=IND, order=1, oversampling=0.5)
