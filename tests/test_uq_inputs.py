"""Uncertain inputs: specs, validation messages, seeded sampling, Nataf correlation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from mechrel.errors import MechrelError, StudyError
from mechrel.uq import LogNormal, Normal, TruncNormal, UncertainInputs, Uniform


def test_specs_from_dicts_and_objects_are_the_same():
    a = UncertainInputs.from_specs({"c": {"distribution": "normal", "mean": 1.0, "std": 0.1},
                                    "u": {"distribution": "uniform", "lower": 0, "upper": 2}})
    b = UncertainInputs.from_specs({"c": Normal(1.0, 0.1), "u": Uniform(0.0, 2.0)})
    assert a.marginals == b.marginals and a.names == ("c", "u")


def test_lognormal_by_mean_and_std_of_the_variable():
    # E[X] and Std[X] of the lognormal must be the given ones exactly (closed-form conversion).
    inp = UncertainInputs.from_specs({"k": LogNormal(2.0, 0.5)})
    assert inp.mean[0] == pytest.approx(2.0, rel=1e-12)
    assert inp.std[0] == pytest.approx(0.5, rel=1e-12)
    mu, s = inp.marginals[0].log_params
    assert s**2 == pytest.approx(math.log(1 + 0.0625), rel=1e-14)
    # chaospy's marginal agrees with scipy's (same parametrisation)
    assert float(inp.joint.mom(1)) == pytest.approx(2.0, rel=1e-10)


def test_truncnormal_moments_are_those_of_the_truncated_variable():
    m = TruncNormal(0.0, 1.0, -1.0, 2.0)
    inp = UncertainInputs.from_specs({"t": m})
    ref = stats.truncnorm(-1, 2)
    assert inp.mean[0] == pytest.approx(ref.mean(), rel=1e-12)
    assert inp.std[0] == pytest.approx(ref.std(), rel=1e-12)
    x = inp.sample(4096, "sobol", seed=1)
    assert x.min() >= -1 and x.max() <= 2


@pytest.mark.parametrize("rule", ["random", "latin_hypercube", "sobol"])
def test_sampling_is_seeded_and_leaves_global_state_alone(rule):
    inp = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Uniform(-1, 1),
                                      "c": LogNormal(1, 0.2)})
    np.random.seed(123)  # noqa: NPY002 (the legacy global state must stay untouched)
    before = np.random.get_state()[1].copy()  # noqa: NPY002
    x1 = inp.sample(256, rule, seed=7)
    x2 = inp.sample(256, rule, seed=7)
    x3 = inp.sample(256, rule, seed=8)
    assert np.array_equal(x1, x2) and not np.array_equal(x1, x3)
    assert np.array_equal(np.random.get_state()[1], before)  # noqa: NPY002
    assert np.all(np.isfinite(x1))


def test_latin_hypercube_stratifies_every_margin():
    inp = UncertainInputs.from_specs({"a": Uniform(0, 1), "b": Uniform(0, 1)})
    x = inp.sample(50, "latin_hypercube", seed=3)
    for j in range(2):  # exactly one point per stratum [k/50, (k+1)/50)
        assert np.array_equal(np.sort(np.floor(x[:, j] * 50)), np.arange(50))


def test_correlated_sample_matches_the_requested_pearson_correlation():
    rho = {("a", "b"): 0.6, ("b", "c"): -0.4, ("a", "d"): 0.3}
    inp = UncertainInputs.from_specs(
        {"a": Normal(1, 0.1), "b": Uniform(0, 2), "c": LogNormal(2, 0.6),
         "d": TruncNormal(0, 1, -1, 2)},
        correlation=rho,
    )
    # Nataf adjusts the Gaussian-copula correlation for non-normal margins
    assert inp.gaussian_correlation[0, 1] != pytest.approx(0.6, abs=1e-3)
    n = 2**16
    x = inp.sample(n, "random", seed=11)
    r = np.corrcoef(x.T)
    target = inp.pearson_correlation
    # se(r) ≈ (1 − ρ²)/√n for near-normal pairs (≤ 0.004 here); lognormal tails inflate it, so
    # allow 5 standard errors of the worst case: 5/√n = 0.0195.
    assert np.abs(r - target).max() < 5 / math.sqrt(n)
    # marginals are untouched by the copula
    assert x[:, 0].mean() == pytest.approx(1.0, abs=4 * 0.1 / math.sqrt(n))
    assert x[:, 1].min() >= 0 and x[:, 1].max() <= 2
    # the chaospy joint (Nataf) gives the same dependence
    y = np.asarray(inp.joint.sample(20000, seed=5)).T
    assert np.abs(np.corrcoef(y.T) - target).max() < 5 / math.sqrt(20000)
    # round trip through the germ
    z = inp.to_standard_normal(x[:100])
    assert np.allclose(inp.from_standard_normal(z), x[:100], rtol=1e-10, atol=1e-12)


def test_two_normals_keep_their_correlation_exactly():
    inp = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(5, 2)},
                                     correlation=[[1, 0.7], [0.7, 1]])
    assert inp.gaussian_correlation[0, 1] == 0.7
    assert inp.covariance[0, 1] == pytest.approx(0.7 * 2)


@pytest.mark.parametrize(
    "specs, correlation, match",
    [
        ({"a": {"distribution": "normal", "mean": 1.0, "std": -0.1}}, None,
         r"inputs\.a\.std: must be > 0, got -0\.1"),
        ({"a": {"distribution": "gauss", "mean": 1.0, "std": 0.1}}, None,
         r"inputs\.a\.distribution: got 'gauss'; allowed: \['beta', 'gamma', 'gumbel', "
         r"'lognormal', 'normal', 'truncnormal', 'uniform', 'weibull'\], or 'scipy\.NAME'"),
        ({"a": {"distribution": "uniform", "lower": 2, "upper": 1}}, None,
         r"inputs\.a\.lower/upper: need lower < upper, got lower=2\.0, upper=1\.0"),
        ({"a": {"distribution": "normal", "mean": 1.0}}, None,
         r"inputs\.a: distribution 'normal' takes fields \['mean', 'std'\]; missing \['std'\]"),
        ({"a": {"distribution": "lognormal", "mean": -1.0, "std": 0.1}}, None,
         r"inputs\.a\.mean: must be > 0, got -1\.0"),
        ({"a": {"distribution": "normal", "mean": "x", "std": 0.1}}, None,
         r"inputs\.a\.mean: must be a number, got 'x'"),
        ({"a": {"distribution": "truncnormal", "mean": 0, "std": 1, "lower": 50, "upper": 60}},
         None,
         r"inputs\.a: \[lower, upper\] = \[50\.0, 60\.0\] holds probability"),
        ({"a": Normal(0, 1), "b": Normal(0, 1)}, [[1, 1.2], [1.2, 1]],
         r"inputs\.correlation\['a', 'b'\]: got 1\.2; allowed: -1 < rho < 1"),
        ({"a": Normal(0, 1), "b": Normal(0, 1)}, {("a", "z"): 0.2},
         r"inputs\.correlation: unknown input 'z'; allowed: \['a', 'b'\]"),
        ({"a": Normal(0, 1), "b": Normal(0, 1)}, [[1, 0.2]], r"inputs\.correlation: must be 2x2"),
        ({"a": Uniform(0, 1), "b": LogNormal(1, 2.0)}, {("a", "b"): -0.95},
         r"inputs\.correlation\['a', 'b'\]: got -0\.95; these marginals "
         r"\(uniform, lognormal\) can only reach"),
    ],
)
def test_validation_messages_name_field_value_and_what_is_allowed(specs, correlation, match):
    with pytest.raises(StudyError, match=match) as exc:
        UncertainInputs.from_specs(specs, correlation=correlation)
    assert isinstance(exc.value, MechrelError)


def test_sampling_argument_errors():
    inp = UncertainInputs.from_specs({"a": Normal(0, 1)})
    with pytest.raises(StudyError, match=r'rule = "halton": unknown value; allowed: one of '
                                         r'random, latin_hypercube, sobol'):
        inp.sample(8, "halton", seed=1)
    with pytest.raises(StudyError, match=r"n = 0: must be >= 1; allowed: an integer >= 1 "
                                         r"\(a number of draws\)"):
        inp.sample(0, seed=1)
    with pytest.raises(StudyError,
                       match=r"seed = -3: must be >= 0; allowed: an integer >= 0 \(a seed\)"):
        inp.sample(4, seed=-3)


def test_reordering_to_model_names():
    inp = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Uniform(0, 1)},
                                     correlation={("a", "b"): 0.3})
    r = inp.reordered(("b", "a"))
    assert r.names == ("b", "a") and r.marginals[0] == Uniform(0.0, 1.0)
    assert r.correlation[0, 1] == 0.3
    with pytest.raises(StudyError, match=r"missing \['c'\], not inputs of the model \['b'\]"):
        inp.reordered(("a", "c"))
