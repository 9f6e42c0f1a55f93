"""The mechanism as a model for the estimators, at small scale: FOSM against Monte Carlo on the
lubricated nine-bar, pickling and determinism, input validation, failures counted by reason.

Cost: ~140 two-cycle simulations of the lubricated nine-bar (≈0.4 s each) on 2 workers.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy import optimize

from mechrel.errors import StudyError
from mechrel.uq import (
    Allowable,
    LogNormal,
    ModelFailure,
    Normal,
    TruncNormal,
    UncertainInputs,
    fosm,
    monte_carlo,
    monte_carlo_design,
    normality_check,
    reliability_two_sided,
)
from mechrel.uq.problem.mechanism import MechanismModel
from mechrel.uq.problem.allowables import per_angle_mask

CLEARANCE = ["joints.C1.clearance", "joints.C2.clearance"]
VISCOSITY = ["joints.C1.lubricant.viscosity", "joints.C2.lubricant.viscosity"]
SEED = 20221014
N_MC = 128
LEVEL = 0.99          # Monte Carlo interval used for the agreement check
RTOL = 1e-7           # the lubricated scenes' solver tolerance: FOSM's output-noise level


@pytest.fixture(scope="module")
def model():
    return MechanismModel("nine-bar-lubricated", {"clearance": CLEARANCE, "viscosity": VISCOSITY},
                          cycles=2)


@pytest.fixture(scope="module")
def inputs():
    # the default study's clearance and viscosity distributions (docs/studies.md)
    return UncertainInputs.from_specs({"clearance": TruncNormal(0.5e-3, 0.05e-3, 0.35e-3, 0.65e-3),
                                       "viscosity": LogNormal(0.1, 0.015)})


def probe_allowables(table, target=0.5):
    """Fixed allowable per quantity (σ_I = 0) at which FOSM's smallest two-sided reliability
    over the cycle is ``target``.

    Why: the paper's allowables (0.012 ± 0.004 m, ...) are 4–30 times the error's own spread
    on this mechanism, so P(|i| < I) ≈ Φ((μ_I − |μ_i|)/σ_I) whatever the error's distribution,
    and failure probabilities are ~0.3 %: a few hundred samples could neither resolve them nor
    tell a right σ_i from a wrong one. A fixed allowable at the error's own scale puts several
    angles at 5–95 % failure probability, where 128 samples resolve R to about ±0.1 (99 %)
    and R depends on the error's whole distribution — the thing FOSM models."""
    out = {}
    for q in ("displacement", "velocity", "acceleration"):
        t = table[per_angle_mask(table.index)].xs(q, level="quantity")  # the angles only
        mu, sd = t["mean"].to_numpy(), t["std"].to_numpy()
        hi = float(np.max(np.abs(mu) + 10 * sd))
        I = optimize.brentq(lambda v: reliability_two_sided(mu, sd, v, 0.0)[2].min() - target,
                            1e-12, hi, xtol=1e-14 * hi)
        out[q] = Allowable(I, 0.0)
    return out


@pytest.fixture(scope="module")
def runs(model, inputs):
    f0 = fosm(model=model, inputs=inputs, noise=RTOL, n_jobs=2)
    allow = probe_allowables(f0.table)
    f = fosm(evaluations=f0.evaluations, inputs=inputs, noise=RTOL, allowable=allow)
    mc = monte_carlo(model=model, inputs=inputs, n=N_MC, rule="sobol", seed=SEED, n_jobs=2,
                     allowable=allow, confidence_level=LEVEL)
    return f, mc, normality_check(fosm=f, monte_carlo=mc), allow


def test_fosm_agrees_with_monte_carlo_where_the_error_is_normal(runs):
    f, mc, nc, allow = runs
    t = nc.to_frame()
    t = t[per_angle_mask(t.index)]                                 # the analysis angles,
    t = t[t.index.get_level_values("crank_angle").astype(float) < 360]  # 360° repeats 0°
    assert mc.n_failed == 0
    # where the error is close to normal (AD does not reject at 1 %, |skewness| < 0.5) and the
    # failure probability is resolvable, FOSM's R lies inside the Monte Carlo interval
    normal = (t["ad_pvalue"] > 0.01) & (t["skewness"].abs() < 0.5)
    informative = (t["R_mc"] > 0.05) & (t["R_mc"] < 0.95)
    checked = t[normal & informative]
    assert len(checked) >= 3, f"too few informative near-normal angles to test:\n{t}"
    inside = (checked["R_fosm"] >= checked["R_mc_lo"]) & (checked["R_fosm"] <= checked["R_mc_hi"])
    assert inside.all(), f"FOSM outside the {LEVEL:.0%} MC interval:\n{checked[~inside]}"
    # first-order moments agree with the sample moments there, too
    rel = (checked["fosm_std"] / checked["mc_std"]).to_numpy()
    assert np.all((rel > 0.7) & (rel < 1.4)), rel

    # the check has power: FOSM with σ_i doubled (or halved) falls outside the interval
    for factor in (2.0, 0.5):
        I = np.array([allow[q].mean for q in checked.index.get_level_values("quantity")])
        wrong = reliability_two_sided(checked["fosm_mean"], factor * checked["fosm_std"], I,
                                      0.0)[2]
        out = (wrong < checked["R_mc_lo"]) | (wrong > checked["R_mc_hi"])
        assert out.any(), f"σ_i × {factor} would pass too: the test has no power"


def test_model_is_picklable_and_deterministic(model, runs):
    _, mc, _, _ = runs
    clone = pickle.loads(pickle.dumps(model))
    assert clone.cache_key() == model.cache_key()
    assert clone.input_names == model.input_names and clone.output_index.equals(model.output_index)
    # the Monte Carlo rows were computed in worker processes from a pickled model
    ev = mc.evaluations
    for i in (0, 1):
        y = model.evaluate(ev.X[i])
        assert y.tobytes() == clone.evaluate(ev.X[i]).tobytes() == ev.Y[i].tobytes()
        assert y.tobytes() == model.evaluate(ev.X[i].copy()).tobytes()


@pytest.mark.parametrize("kwargs, match", [
    ({"inputs": ["joints.C9.clearance"]}, r"joints\.C9\.clearance.*not a value of the scene"),
    ({"inputs": ["joints.C1.model"]}, r"joints\.C1\.model.*must be a number"),
    ({"inputs": ["ground.points.H"]}, r"ground\.points\.H.*must be a number"),
    ({"inputs": "joints.C1.clearance"}, r"sequence of dotted scene paths"),
    ({"inputs": []}, r"non-empty"),
    ({"inputs": {"c": []}}, r"inputs\.c: names no scene path"),
    ({"inputs": {"c": ["joints.C1.clearance", "joints.C2.bogus"]}}, r"joints\.C2\.bogus"),
    ({"angle_step": 25.0}, r"angle_step.*divide 360"),
    ({"quantities": ["jerk"]}, r"quantities.*subset"),
    ({"output": "crank"}, r"output: 'crank' is not an output.*slider"),
    ({"cycles": 0.5}, r"cycles: 0\.5 must be a whole number"),
    ({"cycles": 1.5}, r"cycles: 1\.5 must be a whole number"),
    ({"scene": "nine-bar"}, r"no clearance joints"),
])
def test_input_validation_errors(kwargs, match):
    kw = {"scene": "nine-bar-lubricated", "inputs": CLEARANCE, **kwargs}
    with pytest.raises(StudyError, match=match):
        MechanismModel(kw.pop("scene"), kw.pop("inputs"), **kw)


def test_wrong_x_and_mismatched_inputs_are_study_errors(model, inputs):
    with pytest.raises(StudyError, match=r"x: expected 2 values \(clearance, viscosity\), got 1"):
        model.evaluate([0.5e-3])
    other = UncertainInputs.from_specs({"clearance": Normal(0.5e-3, 5e-5),
                                        "speed": Normal(9.4, 0.1)})
    with pytest.raises(StudyError):
        fosm(model=model, inputs=other)


def test_failures_are_recorded_with_a_reason_and_counted():
    """A clearance ≤ 0 drawn by Monte Carlo is a failed sample with a stable reason, counted."""
    m = MechanismModel("nine-bar-lubricated", {"clearance": CLEARANCE}, cycles=2)
    inp = UncertainInputs.from_specs({"clearance": Normal(0.35e-3, 0.3e-3)})
    seed, n = 37, 16
    X = monte_carlo_design(inp, n=n, rule="random", seed=seed)[:, 0]
    bad = X <= 0
    # precondition of this test (not of the code): some samples fail, and no positive clearance
    # is so small that the film needs minutes to integrate (or fails for another reason)
    assert 2 <= bad.sum() <= n // 2 and X[~bad].min() > 0.05e-3, X
    mc = monte_carlo(model=m, inputs=inp, n=n, rule="random", seed=seed,
                     max_failure_fraction=0.5)
    assert mc.n_failed == int(bad.sum())
    assert np.array_equal(~mc.evaluations.ok, bad)
    fails = mc.evaluations.failures()
    assert list(fails.index) == list(np.flatnonzero(bad))
    assert all("joints.C1.clearance" in r and "SceneError" in r for r in fails["reason"])
    # counted by cause: the reason carries no sample value, so equal causes share one entry
    assert sum(mc.failure_counts.values()) == mc.n_failed
    assert len(mc.failure_counts) == 1, mc.failure_counts
    assert int(mc.table["n"].iloc[0]) == n - mc.n_failed
    # counting failures as violations can only lower the reliability
    worst = monte_carlo(evaluations=mc.evaluations, seed=seed, failures="as_violation",
                        max_failure_fraction=0.5)
    assert np.all(worst.table["reliability"] <= mc.table["reliability"] + 1e-12)
    # a single evaluation raises ModelFailure with the same reason
    with pytest.raises(ModelFailure, match=r"clearance = #: must be >= #"):
        m.evaluate([-1e-4])
