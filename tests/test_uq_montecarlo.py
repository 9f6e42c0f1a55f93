"""Monte Carlo reliability: agreement with closed forms inside its intervals, whole-cycle
property, failures, intervals."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import special

from mechrel.errors import StudyError
from mechrel.uq import (
    Allowable,
    Evaluations,
    FunctionModel,
    ModelFailure,
    Normal,
    UncertainInputs,
    binomial_interval,
    evaluate,
    linear_model,
    monte_carlo,
    monte_carlo_design,
    reliability_one_sided,
    reliability_two_sided,
)
from mechrel.uq import SampleFailuresError

# z = 4: a correct estimator falls outside its interval with probability 6e-5 per quantity, so
# the test is not flaky, yet the intervals (half-width ≈ 4·sqrt(R(1−R)/n)) stay narrow enough
# to reject the wrong event or the wrong allowable model (checked below).
Z4 = 1 - 2 * special.ndtr(-4.0)

INPUTS = UncertainInputs.from_specs({"x0": Normal(0.0, 1.0), "x1": Normal(1.0, 0.5)},
                                    correlation={("x0", "x1"): 0.4})
A0 = np.array([0.1, -0.5])
B = np.array([[0.5, 0.0], [0.2, 0.3]])
ALLOW = Allowable(1.0, 0.3)


def _exact():
    cov = INPUTS.covariance
    mu = A0 + B @ INPUTS.mean
    sd = np.sqrt(np.diag(B @ cov @ B.T))
    return mu, sd


def _model():
    return linear_model(A0, B, INPUTS.names)


@pytest.mark.parametrize("rule", ["random", "latin_hypercube", "sobol"])
def test_linear_normal_model_within_intervals(rule):
    """A linear model of normal inputs has a normal error, so the interference formulas are
    exact: MC must contain them in its z = 4 intervals; mean and std too."""
    n = 4096
    mu, sd = _exact()
    r1 = reliability_one_sided(mu, sd, ALLOW.mean, ALLOW.std)[1]
    r2 = reliability_two_sided(mu, sd, ALLOW.mean, ALLOW.std)[2]
    for event, exact, other in (("two-sided", r2, r1), ("one-sided", r1, r2)):
        res = monte_carlo(model=_model(), inputs=INPUTS, n=n, rule=rule, seed=2024, allowable=ALLOW,
                          event=event, confidence_level=Z4)
        t = res.table
        assert np.all((t["reliability_lo"] <= exact) & (exact <= t["reliability_hi"])), (t, exact)
        assert np.all((t["mean_lo"] <= mu) & (mu <= t["mean_hi"]))
        assert np.all((t["std_lo"] <= sd) & (sd <= t["std_hi"]))
        # discrimination: output 0 has μ_i ≈ 0, so the two forms differ by P(i < −I) ≈ 0.03,
        # more than the interval half-width (≈ 0.015): a wrong event would fail this test
        assert not (t["reliability_lo"].iloc[0] <= other[0] <= t["reliability_hi"].iloc[0])
        assert res.provenance["settings"]["rule"] == rule


def test_fixed_allowable_mode_is_an_allowable_with_zero_std():
    n = 2000
    a = monte_carlo(model=_model(), inputs=INPUTS, n=n, seed=5, allowable=ALLOW,
                    allowable_mode="fixed")
    b = monte_carlo(model=_model(), inputs=INPUTS, n=n, seed=5, allowable=Allowable(1.0, 0.0))
    pd.testing.assert_frame_equal(a.table.drop(columns="allowable_std"),
                                  b.table.drop(columns="allowable_std"))
    mu, sd = _exact()
    exact = reliability_two_sided(mu, sd, 1.0, 0.0)[2]
    t = monte_carlo(model=_model(), inputs=INPUTS, n=n, seed=5, allowable=ALLOW,
                    allowable_mode="fixed",
                    confidence_level=Z4).table
    assert np.all((t["reliability_lo"] <= exact) & (exact <= t["reliability_hi"]))


def test_precomputed_evaluations_reproduce_the_model_run():
    X = monte_carlo_design(INPUTS, n=500, rule="latin_hypercube", seed=9)
    ev = evaluate(_model(), X, progress=False)
    a = monte_carlo(model=_model(), inputs=INPUTS, n=500, rule="latin_hypercube", seed=9,
                    allowable=ALLOW)
    b = monte_carlo(evaluations=ev, seed=9, allowable=ALLOW)
    pd.testing.assert_frame_equal(a.table, b.table)
    pd.testing.assert_frame_equal(a.whole_cycle, b.whole_cycle)


@st.composite
def _data(draw):
    n = draw(st.integers(2, 40))
    n_ang = draw(st.integers(1, 4))
    quantities = draw(st.lists(st.sampled_from(["displacement", "velocity", "acceleration"]),
                               min_size=1,
                               max_size=3, unique=True))
    idx = pd.MultiIndex.from_product([quantities, np.arange(n_ang) * 90.0],
                                     names=["quantity", "crank_angle"])
    Y = draw(st.lists(st.lists(st.floats(-3, 3, allow_nan=False), min_size=len(idx),
                               max_size=len(idx)),
                      min_size=n, max_size=n))
    allow = {q: Allowable(draw(st.floats(0.05, 3.0)),
                          draw(st.sampled_from([0.0, 0.1, 1.0]))) for q in quantities}
    event = draw(st.sampled_from(["one-sided", "two-sided"]))
    mode = draw(st.sampled_from(["sampled", "fixed"]))
    seed = draw(st.integers(0, 2**32 - 1))
    return np.array(Y), idx, allow, event, mode, seed


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_data())
def test_whole_cycle_never_exceeds_the_smallest_point_reliability(data):
    Y, idx, allow, event, mode, seed = data
    ev = Evaluations.from_arrays(np.zeros((Y.shape[0], 1)), Y, output_index=idx)
    res = monte_carlo(evaluations=ev, allowable=allow, event=event, allowable_mode=mode, seed=seed)
    point = res.table["reliability"]
    wc = res.whole_cycle["reliability"]
    for q in idx.get_level_values("quantity").unique():
        assert wc[q] <= point.loc[q].min() + 1e-15
        assert wc["all"] <= wc[q] + 1e-15
    assert wc["all"] <= point.min() + 1e-15
    # two-sided is the stricter event, sample by sample (same allowable draws)
    if event == "one-sided":
        two = monte_carlo(evaluations=ev, allowable=allow, event="two-sided",
                          allowable_mode=mode, seed=seed)
        assert np.all(two.table["reliability"] <= point + 1e-15)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_data())
def test_allowable_draws_are_the_allowables_the_result_counted(data):
    Y, idx, allow, event, mode, seed = data
    ev = Evaluations.from_arrays(np.zeros((Y.shape[0], 1)), Y, output_index=idx)
    res = monte_carlo(evaluations=ev, allowable=allow, event=event, allowable_mode=mode, seed=seed)
    draws = res.allowable_draws()
    assert draws.shape == Y.shape
    inside = (np.abs(Y) <= draws) if event == "two-sided" else (Y <= draws)
    np.testing.assert_array_equal(inside.sum(axis=0), res.table["n_inside"].to_numpy())
    mu = res.table["allowable_mean"].to_numpy()
    sd = res.table["allowable_std"].to_numpy()
    if mode == "fixed":
        np.testing.assert_array_equal(draws, np.broadcast_to(mu, Y.shape))
    # one standard normal per sample and quantity: the outputs of a quantity move together
    for q in idx.get_level_values("quantity").unique():
        cols = np.flatnonzero((idx.get_level_values("quantity") == q) & (sd > 0))
        if mode == "sampled" and cols.size:
            z = (draws[:, cols] - mu[cols]) / sd[cols]
            np.testing.assert_allclose(z, z[:, :1].repeat(cols.size, axis=1), rtol=1e-12,
                                       atol=1e-12)


def _fails_in_a_region(x):
    if x[0] > 1.5:
        raise ModelFailure("assembly failed: links cannot close")
    if x[0] < -2.0:
        raise ModelFailure("integrator step size underflow")
    return np.array([0.2 * x[0] + 0.1 * x[1]])


def test_failing_region_is_counted_with_reasons_and_the_run_finishes():
    inputs = UncertainInputs.from_specs({"x0": Normal(0.0, 1.0), "x1": Normal(0.0, 1.0)})
    m = FunctionModel(_fails_in_a_region, inputs.names, ["y"])
    res = monte_carlo(model=m, inputs=inputs, n=2000, seed=1, allowable=Allowable(0.3, 0.0))
    ev = res.evaluations
    n_lock = int(np.sum(ev.X[:, 0] > 1.5))
    n_under = int(np.sum(ev.X[:, 0] < -2.0))
    assert n_lock > 0 and n_under > 0
    assert res.n_failed == n_lock + n_under == ev.n_failed
    assert res.failure_counts == {"assembly failed: links cannot close": n_lock,
                                  "integrator step size underflow": n_under}
    assert np.all(np.isnan(ev.Y[~ev.ok])) and np.all(np.isfinite(ev.Y[ev.ok]))
    assert res.table["n"].iloc[0] == 2000 - res.n_failed  # excluded, not silently counted
    assert list(ev.failures()["reason"].unique()) != []
    # conservative alternative: failures count as violations
    cons = monte_carlo(model=m, inputs=inputs, n=2000, seed=1, allowable=Allowable(0.3, 0.0),
                       failures="as_violation")
    assert cons.table["n"].iloc[0] == 2000
    assert cons.table["reliability"].iloc[0] < res.table["reliability"].iloc[0]
    # refuse above the threshold, with the reasons in the message and every sample in the error
    with pytest.raises(SampleFailuresError,
                       match=r"monte_carlo: \d+ of 2000 samples failed \(\d+× assembly failed"
                       ) as info:
        monte_carlo(model=m, inputs=inputs, n=2000, seed=1, allowable=Allowable(0.3, 0.0),
                    max_failure_fraction=0.01)
    assert isinstance(info.value, StudyError)
    assert np.array_equal(info.value.evaluations.X, ev.X)
    assert info.value.evaluations.failure_counts() == res.failure_counts


def _always_fails(x):
    raise ModelFailure("joint jams")


def test_too_few_successful_samples_is_a_refusal_that_keeps_the_samples():
    m = FunctionModel(_always_fails, INPUTS.names, ["y"])
    with pytest.raises(SampleFailuresError,
                       match=r"monte_carlo: need at least 2 successful samples, got 0 "
                       r"\(8 of 8 samples failed \(8× joint jams\)\)") as info:
        monte_carlo(model=m, inputs=INPUTS, n=8, seed=1, allowable=ALLOW, max_failure_fraction=1.0)
    assert info.value.evaluations.n_failed == 8


def test_binomial_intervals():
    # Clopper–Pearson with k = 0: upper = 1 − (α/2)^(1/n) exactly
    lo, hi = binomial_interval(0, 10, method="clopper-pearson")
    assert lo == 0 and hi == pytest.approx(1 - 0.025 ** (1 / 10), rel=1e-12)
    # Wilson: closed form for k = n: lower = n/(n + z²)
    z = 1.959963984540054
    lo, hi = binomial_interval(50, 50)
    assert hi == 1 and lo == pytest.approx(50 / (50 + z * z), rel=1e-12)
    with pytest.raises(StudyError, match=r"ci_method: got 'agresti'"):
        binomial_interval(1, 10, method="agresti")


def test_argument_validation_messages():
    m = _model()
    with pytest.raises(StudyError, match=r'allowable_mode = "random": unknown value; allowed: '
                                         r'one of sampled, fixed'):
        monte_carlo(model=m, inputs=INPUTS, n=10, allowable=ALLOW, allowable_mode="random")
    with pytest.raises(StudyError, match=r'rule = "lhs": unknown value; allowed: one of random, '
                                         r'latin_hypercube, sobol'):
        monte_carlo(model=m, inputs=INPUTS, n=10, rule="lhs", allowable=ALLOW)
    with pytest.raises(StudyError, match=r"confidence_level = 1\.5: must be < 1; allowed: a "
                                         r"finite number in \(0, 1\)"):
        monte_carlo(model=m, inputs=INPUTS, n=10, allowable=ALLOW, confidence_level=1.5)
    with pytest.raises(StudyError, match=r"n = None: expected an integer, got None; allowed: "
                                         r"an integer >= 2 \(a sample count\)"):
        monte_carlo(model=m, inputs=INPUTS, allowable=ALLOW)
    with pytest.raises(StudyError, match=r'failures = "ignore": unknown value; allowed: one of '
                                         r'exclude, as_violation'):
        monte_carlo(model=m, inputs=INPUTS, n=10, allowable=ALLOW, failures="ignore")
    bad = UncertainInputs.from_specs({"x0": Normal(0, 1), "zz": Normal(0, 1)})
    with pytest.raises(StudyError,
                       match=r"inputs: names must match the model's input_names; missing \['x1'\]"):
        monte_carlo(model=m, inputs=bad, n=10, allowable=ALLOW)


def test_seed_none_is_recorded_and_replayable():
    a = monte_carlo(model=_model(), inputs=INPUTS, n=300, allowable=ALLOW)
    entropy = a.provenance["seed"]["entropy"]
    b = monte_carlo(model=_model(), inputs=INPUTS, n=300, allowable=ALLOW, seed=entropy)
    pd.testing.assert_frame_equal(a.table, b.table)
    assert set(a.provenance) >= {"seed", "n_evaluations", "wall_time", "versions",
                                 "model_cache_key", "settings"}


def test_monte_carlo_on_a_limit_state_with_a_random_allowable():
    # y = x, x ~ N(0, 1), against a random allowable I ~ N(2, 0.5²): P(y > I) = Φ(−2/√1.25)
    # exactly; the estimate is within 4 binomial standard deviations of it, its Wilson interval
    # covers it, and the sample is the same for any number of workers.
    from mechrel.uq import FunctionModel, LimitState, MonteCarloResult

    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    model = FunctionModel(lambda X: X[:, 0], ["x"], ["y"], vectorized=True)
    ls = LimitState.exceedance(["y"], Normal(2.0, 0.5), kind="upper", name="y > I")
    n = 4000
    r = monte_carlo(model=model, inputs=inputs, limit_state=ls, n=n, seed=3, progress=False)
    exact = float(special.ndtr(-2.0 / np.sqrt(1.25)))
    assert isinstance(r, MonteCarloResult) and r.n_evaluations == n  # one result type
    assert r.table is None and r.whole_cycle is None and r.n_failed == 0
    assert abs(r.pf - exact) <= 4 * np.sqrt(exact * (1 - exact) / n)
    row = r.to_frame().iloc[0]
    assert row["pf_lo"] < exact < row["pf_hi"]
    assert r.provenance["limit_state"] == ls.describe()
    again = monte_carlo(model=model, inputs=inputs, limit_state=ls, n=n, seed=3, progress=False,
                        n_jobs=2)
    assert again.to_frame().equals(r.to_frame())


def test_monte_carlo_refuses_a_limit_state_with_allowables_or_evaluations():
    from mechrel.uq import LimitState, evaluate

    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    model = linear_model([0.0], [[1.0]], ["x"])

    with pytest.raises(StudyError, match=r"^monte_carlo: allowable= and limit_state= are both "
                                         r"given; allowed: one of them"):
        monte_carlo(model=model, inputs=inputs, n=8, limit_state=LimitState.margin(),
                    allowable=Allowable(1.0, 0.0), progress=False)
    ev = evaluate(model, np.zeros((4, 1)), progress=False)
    with pytest.raises(StudyError, match=r"^monte_carlo: limit_state= with evaluations=.*allowed: "
                                         r"model= and inputs= with limit_state="):
        monte_carlo(evaluations=ev, limit_state=LimitState.margin())
