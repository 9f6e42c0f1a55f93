"""Design for reliability (issue 31 §2): design_for_reliability against closed-form optima, the
whole-cycle against the per-angle constraint on the slider-crank, the warnings, the study
file's [design] section and ``mechrel design``.

Tolerances: the closed-form optima are exact; the methods estimate the constraint on one
sample (common random numbers), so the optimum carries that sample's error. At R_t = 0.99 with
n = 20 000 (200 points beyond the target), P̂_f has a c.o.v. of 7 %; for a normal error of std
s, P_f = 2 Φ(−1/s) and d ln P_f / d ln s = z φ(z)/Φ(−z) = 7.4 at z = 2.576, so the optimum's s
(and a cost ∝ 1/s) moves by 7 %/7.4 ≈ 1 % per standard error: the issue's 2 % is two of them
(the seeds are fixed; the verification's independent run checks the constraint with its own
interval).
"""

from __future__ import annotations

import json
import math
import tomllib
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import special, stats

from mechrel.cli.main import main
from mechrel.errors import EstimateWarning, StudyError
from mechrel.study.design import run_design
from mechrel.study.study import load_study
from mechrel.uq import (DESIGN_METHODS, FunctionModel, Normal, UncertainInputs,
                        design_for_reliability)
from mechrel.uq.design.expression import CostExpression
from mechrel.uq.design.space import DesignSpace, DesignVariable
from mechrel.uq.problem.analytic import slider_crank_tolerance_model


def _linear(coefs, names, label="error"):
    B = np.asarray(coefs, dtype=float)
    return FunctionModel(lambda X: X @ B[:, None], list(names), [label], vectorized=True,
                         key=f"test-linear:{tuple(coefs)}")


Z99 = float(special.ndtri(0.995))  # two-sided 99 %: |N(0, s)| <= 1 iff s <= 1/Z99


# ----------------------------------------------------------------------------- closed forms
def _two_tolerances(method, **kw):
    """2 x1 + x2, cost 1/t1 + 1/t2, P(|e| <= 1) >= 0.99: 4 t1² + t2² = 1/Z99² and
    t_i ∝ s_i^(-2/3) (Lagrange), so t2 = (1/Z99)/sqrt(4^(1/3) + 1), t1 = 4^(-1/3) t2."""
    inputs = UncertainInputs.from_specs({"x1": Normal(0, 0.1), "x2": Normal(0, 0.1)})
    return design_for_reliability(
        model=_linear([2.0, 1.0], ["x1", "x2"]), inputs=inputs,
        variables={"t1": {"kind": "std", "input": "x1", "lower": 0.01, "upper": 1.0},
                   "t2": {"kind": "std", "input": "x2", "lower": 0.01, "upper": 1.0}},
        cost="1/t1 + 1/t2", constraints=0.99, allowable=1.0, method=method, seed=11,
        progress=False, **kw)


def _exact_two():
    t2 = (1 / Z99) / math.sqrt(4 ** (1 / 3) + 1)
    t1 = 4 ** (-1 / 3) * t2
    return t1, t2, 1 / t1 + 1 / t2


@pytest.mark.parametrize("method,kw", [("mc", {"n": 20_000}),
                                       ("ak", {"n_population": 40_000})])
def test_a_tolerance_allocation_with_a_known_optimum(method, kw):
    t1, t2, cost = _exact_two()
    assert cost == pytest.approx(10.720, abs=5e-4)
    r = _two_tolerances(method, tradeoff=3, verify={"n": 40_000}, **kw)
    assert r.cost == pytest.approx(cost, rel=0.02)
    # the tolerances one by one are less well determined: the cost is stationary along the
    # constraint at the optimum, so a sample's error that tilts the estimated constraint moves
    # the ratio t1/t2 at first order but the cost only at second order (6 % in the ratio,
    # 4^(−1/3) exactly, is 0.1 % in the cost)
    assert r.design["t1"] / r.design["t2"] == pytest.approx(t1 / t2, rel=0.06)
    assert r.design["t1"] == pytest.approx(t1, rel=0.06)
    assert r.design["t2"] == pytest.approx(t2, rel=0.06)
    row = r.constraints.iloc[0]
    # the constraint is met: the independent run's interval reaches the target
    assert row["verify_pf_lo"] <= 0.01 and row["verified"]
    # and it is the active one (the cost would fall further without it)
    assert r.active == ["all (whole-cycle) R >= 0.99"]
    # the exact P_f at the optimum, from the closed form: the target, within two of the
    # method's sampling c.o.v. (7 % on 200 points beyond the target); and the verification's
    # estimate (40 000 samples, c.o.v. 5 %) within four of its standard errors of it
    s = math.hypot(2 * r.design["t1"], r.design["t2"])
    exact_pf = 2 * stats.norm.sf(1 / s)
    assert exact_pf == pytest.approx(0.01, rel=0.14)
    assert row["verify_pf"] == pytest.approx(exact_pf, abs=4 * math.sqrt(exact_pf / 40_000))
    # the trade-off curve: cost falls as the target P_f grows (a looser target), through the
    # optimum at f = 1
    t = r.tradeoff
    assert t["f"].tolist()[1] == 1.0 and len(t) == 3
    assert np.all(np.diff(t["cost"]) < 0)
    assert t.loc[t["f"] == 1.0, "cost"].iloc[0] == pytest.approx(r.cost)
    # the counts: every model run, the method's and the verification's
    prov = r.provenance
    assert prov["n_evaluations"] == (prov["counts"]["design"]["n_evaluations"]
                                           + prov["counts"]["verification"]["n_evaluations"])
    assert prov["counts"]["verification"]["n_evaluations"] == 40_000
    if method == "ak":  # the surrogate needs few runs of the model, and never one twice
        assert r.converged and prov["counts"]["design"]["n_evaluations"] <= 40
        X = np.asarray(r.evaluations.X)[: prov["counts"]["design"]["n_evaluations"]]
        assert len(np.unique(X, axis=0)) == X.shape[0]


@pytest.mark.parametrize("method,kw", [("mc", {"n": 1000}), ("ak", {"n_population": 20_000})])
def test_every_model_run_is_counted(method, kw):
    # the provenance counts the rows the model computed: every design the method tried (for
    # "mc", n rows each, the trade-off curve's re-optimisations on the same sample included),
    # and the verification's; nothing is cached here, so every row is computed
    seen = []

    def error(X):
        seen.append(len(X))
        return X[:, :1]

    model = FunctionModel(error, ["x"], ["e"], vectorized=True, key=f"test-counted-{method}")
    r = design_for_reliability(
        model=model, inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
        variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
        cost="1/t", constraints=0.9, allowable=1.0, method=method, seed=5, tradeoff=3,
        verify={"method": "mc", "n": 500}, progress=False, **kw)
    prov = r.provenance
    assert prov["n_evaluations"] == prov["n_computed"] == sum(seen)
    assert prov["n_cached"] == 0
    assert prov["counts"]["verification"]["n_evaluations"] == 500
    assert prov["counts"]["design"]["n_evaluations"] == sum(seen) - 500
    if method == "mc":  # one sample per design: more designs than the method's own search
        assert prov["counts"]["design"]["n_evaluations"] % 1000 == 0
        assert prov["counts"]["design"]["n_evaluations"] > 1000 * prov["settings"]["n_designs"]
    else:  # the surrogate's trade-off curve runs nothing
        assert prov["counts"]["design"]["n_evaluations"] == len(r.evaluations.Y)


def _one_tolerance(**kw):
    """The error x ~ N(0, t): P(|x| <= 1) >= R_t for t <= 1/Φ⁻¹((1 + R_t)/2)."""
    return design_for_reliability(
        model=_linear([1.0], ["x"]), inputs=UncertainInputs.from_specs({"x": Normal(0, 0.1)}),
        variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
        cost="1/t", allowable=1.0, seed=4, tradeoff=0, progress=False, **kw)


def test_a_surrogate_starts_from_an_earlier_results_runs():
    # the second target's surrogate learns from the first run's rows too (initial=): they are
    # kept in its evaluations but not counted as its runs. The optimum's tolerance: the
    # population's quantile of |x| (N = 20 000) has a relative s.e. of 0.7 % (R = 0.95) and
    # 0.9 % (R = 0.99), sqrt(p (1 − p)/N) / (2 φ(z) z); 3 % is over three of them
    first = _one_tolerance(constraints=0.99, method="ak", n_population=20_000, verify="none")
    second = _one_tolerance(constraints=0.95, method="ak", n_population=20_000, verify="none",
                            initial=first)
    for r, target in ((first, 0.99), (second, 0.95)):
        assert r.converged
        assert r.design["t"] == pytest.approx(1 / special.ndtri((1 + target) / 2), rel=0.03)
    n_first = len(first.evaluations.Y)
    assert second.provenance["settings"]["n_reused"] == n_first
    assert len(second.evaluations.Y) == n_first + second.provenance["n_evaluations"]
    with pytest.raises(StudyError, match=r"design \(ak\): initial = DesignResult: not a "
                                         r"DesignResult of method 'ak' on this model"):
        _one_tolerance(constraints=0.95, method="ak", initial=_one_tolerance(
            constraints=0.95, method="mc", n=400, verify="none"), verify="none")


def test_a_verification_by_subset_simulation():
    # at R = 0.999 a Monte Carlo verification of a few thousand runs sees a few failures;
    # subset simulation resolves P_f with as many. Its 95 % interval holds the exact P_f at the
    # optimum found, 2 Φ(−1/t)
    r = _one_tolerance(constraints=0.999, method="mc", n=20_000,
                       verify={"method": "subset", "n_per_level": 1000})
    c = r.constraints.iloc[0]
    exact = 2 * stats.norm.sf(1 / r.design["t"])
    assert c["verify_method"] == "subset" and c["verify_n"] >= 2000
    assert c["verify_pf_lo"] <= exact <= c["verify_pf_hi"]
    assert c["whole_cycle_pf"] == c["verify_pf"]  # one event: the whole cycle's
    assert r.provenance["counts"]["verification"]["n_evaluations"] == c["verify_n"]


def test_the_largest_mean_for_a_one_sided_target():
    # e = x, x ~ N(m, 0.1): P(e <= 1) >= 0.99 for m <= 1 − 0.1 Φ⁻¹(0.99)
    inputs = UncertainInputs.from_specs({"x": Normal(0.5, 0.1)})
    r = design_for_reliability(
        model=_linear([1.0], ["x"]), inputs=inputs,
        variables={"m": {"kind": "mean", "input": "x", "lower": 0.0, "upper": 2.0}},
        cost="m", sense="maximize", constraints=0.99, allowable=1.0, event="one-sided",
        method="mc", n=20_000, seed=2, tradeoff=0, verify={"n": 20_000}, progress=False)
    exact = 1 - 0.1 * special.ndtri(0.99)
    # the sample's 0.99-quantile of a normal: its standard error is
    # sqrt(0.99 · 0.01 / n)/φ(z) σ = 0.0026 σ; 5 of them
    assert r.design["m"] == pytest.approx(exact, abs=5 * 0.0026 * 0.1)
    assert r.table.loc["m", "on_bound"] == ""


def test_a_half_width_and_a_scene_value():
    # x ~ U(−h, h) times a scene gain g: P(|g x| <= 1) = 1/(g h) >= 0.95; cost 1/h − g
    # (wide tolerance, high gain): on the constraint g h = 1/0.95 the cost is −0.0526/h, which
    # a smaller h lowers, so g goes to its upper bound 5, and then h = 1/(0.95 · 5)
    from mechrel.uq import Uniform

    inputs = UncertainInputs.from_specs({"x": Uniform(-0.5, 0.5)})
    model = FunctionModel(lambda X: X[:, :1] * X[:, 1:2], ["x", "g"], ["e"], vectorized=True,
                          key="test-gain")
    with pytest.warns(EstimateWarning, match="upper bound of g"):
        r = design_for_reliability(
            model=model, inputs=inputs,
            variables={"h": {"kind": "half_width", "input": "x", "lower": 0.1, "upper": 2.0},
                       "g": {"kind": "scene", "input": "g", "lower": 0.1, "upper": 5.0,
                             "start": 1.0}},
            cost="1/h - g", constraints=0.95, allowable=1.0, method="mc", n=4000, seed=4,
            tradeoff=0, verify="none", progress=False)
    assert r.design["g"] == pytest.approx(5.0)
    # the 0.95-quantile of |x| on 4000 uniform draws: its s.e. is sqrt(0.95 · 0.05/4000)
    # = 0.0034 of the half-width; 1 % is three of them
    assert r.design["h"] == pytest.approx(1 / (0.95 * 5.0), rel=0.01)
    assert r.table.loc["g", "on_bound"] == "upper" and r.table.loc["h", "on_bound"] == ""


# ----------------------------------------------------------------------------- whole cycle
@pytest.fixture(scope="module")
def slider_crank():
    """A coarse slider-crank (the analytic model, equal to the simulator to 1e-13): the slider's
    displacement error, 30° analysis angles, cycle extremes on a 8-per-sector grid; crank and
    rod tolerances (std) 20 µm at the base design."""
    model = slider_crank_tolerance_model(quantities=["displacement"], angle_step=30.0,
                                         points_per_sector=8, sectors=False)
    inputs = UncertainInputs.from_specs({"crank": Normal(0.05, 20e-6),
                                         "rod": Normal(0.12, 20e-6),
                                         "offset": Normal(0.0, 1e-9)})
    variables = {"t_crank": {"kind": "std", "input": "crank", "lower": 2e-6, "upper": 2e-4},
                 "t_rod": {"kind": "std", "input": "rod", "lower": 2e-6, "upper": 2e-4}}
    return model, inputs, variables


@pytest.mark.parametrize("n", [8000])
def test_the_per_angle_optimum_lets_the_whole_cycle_fail_more_often(slider_crank, n):
    model, inputs, variables = slider_crank
    common = dict(model=model, inputs=inputs, variables=variables,
                  cost="1/t_crank + 1/t_rod", allowable={"displacement": 1e-4}, method="mc",
                  n=n, seed=7, tradeoff=0, verify={"n": 20_000}, progress=False)
    whole = design_for_reliability(constraints=0.99, **common)
    per = design_for_reliability(constraints={"reliability": 0.99, "basis": "per-angle"},
                                 **common)
    w, p = whole.constraints.iloc[0], per.constraints.iloc[0]
    # the per-angle constraint is the weaker one: its optimum is cheaper ...
    assert per.cost < whole.cost
    # ... and it meets its own constraint (the worst angle's P_f within its target) ...
    assert p["verify_pf_lo"] <= 0.01
    # ... but over the whole cycle it fails about twice as often as the target, beyond the
    # interval, and beyond the whole-cycle optimum's independent estimate (n = 8000 puts 80
    # samples beyond the target: the whole-cycle optimum's own P_f carries an 11 % c.o.v.,
    # which benchmarks/bench_design_slider_crank.py resolves with more samples)
    assert p["whole_cycle_pf_lo"] > 0.015
    assert p["whole_cycle_pf_lo"] > w["verify_pf_hi"]
    assert w["pf"] == pytest.approx(0.01, abs=2 / n)  # the method's estimate: on the target
    # the whole cycle asks for tighter tolerances of both links
    assert whole.design["t_rod"] < per.design["t_rod"]
    assert whole.design["t_crank"] < per.design["t_crank"]


# ----------------------------------------------------------------------------- warnings
def test_an_infeasible_target_warns_and_returns_the_closest_design():
    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    with pytest.warns(EstimateWarning) as rec:
        r = design_for_reliability(
            model=_linear([1.0], ["x"]), inputs=inputs,
            variables={"t": {"kind": "std", "input": "x", "lower": 0.6, "upper": 1.0}},
            cost="1/t", constraints=0.99, allowable=1.0, method="mc", n=4000, seed=1,
            tradeoff=0, verify={"n": 4000}, progress=False)
    text = " | ".join(str(w.message) for w in rec)
    assert "infeasible: no design within the bounds meets" in text
    assert "lower bound of t" in text
    assert "constraint not verified" in text  # P_f(t = 0.6) = 0.096 >> 0.01
    assert not r.feasible and r.design["t"] == pytest.approx(0.6)
    assert r.constraints.iloc[0]["factor"] == pytest.approx(0.6 * Z99, rel=0.03)


def test_a_surrogate_that_runs_out_of_budget_says_so():
    t1, t2, cost = _exact_two()
    with pytest.warns(EstimateWarning, match="surrogate not converged within max_evaluations"):
        r = _two_tolerances("ak", n_population=20_000, n_initial=6, max_evaluations=6,
                            tradeoff=0, verify="none")
    assert r.converged is False


# ----------------------------------------------------------------------------- bad input
def test_bad_arguments_name_the_field():
    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    model = _linear([1.0], ["x"])
    ok = {"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}}
    cases = [
        (dict(variables=ok, cost="1/t + os.system", constraints=0.99),
         r"cost = '1/t \+ os.system': Attribute"),
        (dict(variables=ok, cost="1/u", constraints=0.99), r"unknown name 'u'"),
        (dict(variables={"t": {"kind": "std", "input": "y", "lower": 0.01, "upper": 1.0}},
              cost="1/t", constraints=0.99), r"variables.t.input = 'y': not an uncertain input"),
        (dict(variables={"t": {"kind": "width", "input": "x", "lower": 0.01, "upper": 1.0}},
              cost="1/t", constraints=0.99), r"variables.t.kind"),
        (dict(variables=ok, cost="1/t", constraints=1.5), r"constraints\[0\].reliability"),
        (dict(variables=ok, cost="1/t", constraints={"reliability": 0.9,
                                                     "quantity": "velocity"}),
         r"constraints\[0\].quantity = 'velocity': not a quantity of the model"),
        (dict(variables=ok, cost="1/t", constraints=0.9, method="sora"), r"method"),
        (dict(variables=ok, cost="1/t", constraints={"reliability": 0.9, "basis": "per-angle"},
              method="ak"), r"per-angle constraint .* allowed: basis 'whole-cycle', or method "
                            r"'mc'"),
    ]
    for kw, message in cases:
        with pytest.raises(StudyError, match=message):
            design_for_reliability(model=model, inputs=inputs, allowable=1.0, progress=False,
                                   tradeoff=0, verify="none", **kw)


@pytest.mark.parametrize("kw,message", [
    (dict(variables={"t": {"kind": "width", "input": "x", "lower": 0.01, "upper": 1.0}}),
     r"^variables\.t\.kind = \"width\": unknown value \(did you mean 'half_width'\?\); "
     r"allowed: one of mean, std, half_width, scene$"),
    (dict(variables={"t": {"kind": "std", "input": "x", "lower": 1.0, "upper": 0.01}}),
     r"^variables\.t\.upper = 0\.01: must be > 1; allowed: a finite number > 1$"),
    (dict(variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0,
                           "start": 2.0}}),
     r"^variables\.t\.start = 2\.0: must be <= 1; allowed: a finite number in \[0\.01, 1\]$"),
    (dict(variables={"g": {"kind": "scene", "input": "g", "lower": 0.01, "upper": 1.0}}),
     r"^variables\.g\.input = 'g': not an input of the model \(x\); allowed: the model's "
     r"input carrying the scene value$"),
    (dict(constraints=1.0), r"^constraints\[0\]\.reliability = 1\.0: must be < 1; allowed: "
                            r"a finite number in \(0, 1\)$"),
    (dict(constraints=0), r"^constraints\[0\]\.reliability = 0\.0: must be > 0; allowed: "
                          r"a finite number in \(0, 1\)$"),
    (dict(method="sora"), r"^method = \"sora\": unknown value; allowed: one of ak, mc$"),
    (dict(verify={"method": "subset", "p0": 0.3}),
     r"^verify\.p0: got 0\.3 with n_per_level = 500; allowed: 1/p0 and n_per_level·p0 "
     r"integers"),
])
def test_a_wrong_argument_is_one_error_naming_it(kw, message):
    # each message whole: the field, its value and what is allowed
    args = dict(variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
                cost="1/t", constraints=0.99, verify="none")
    with pytest.raises(StudyError, match=message):
        design_for_reliability(model=_linear([1.0], ["x"]), allowable=1.0, progress=False,
                               inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
                               tradeoff=0, **{**args, **kw})


def test_the_registry():
    assert list(DESIGN_METHODS) == ["ak", "mc"]
    assert DESIGN_METHODS["mc"].settings["n"].default == 10_000


# ----------------------------------------------------------------------------- properties
@settings(max_examples=50, deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_the_optimiser_coordinates_round_trip(a, b):
    inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
    s = DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0),
                     DesignVariable("t", "std", "x", 1e-4, 1.0)], inputs, ["x"])
    d = s.from_unit([a, b])
    assert np.all(d >= s.lower) and np.all(d <= s.upper)
    assert np.allclose(s.to_unit(d), [a, b], atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(st.floats(0.01, 10.0), st.floats(0.01, 10.0))
def test_the_cost_language_computes_as_python(a, b):
    c = CostExpression("2/a + b^2 - sqrt(a) * exp(-b) + max(a, b) / min(a, 1)", ["a", "b"])
    expected = 2 / a + b ** 2 - math.sqrt(a) * math.exp(-b) + max(a, b) / min(a, 1)
    assert c({"a": a, "b": b}) == pytest.approx(expected, rel=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.2, 5.0))
def test_common_random_numbers_scale_the_same_draws(scale):
    # a std variable maps every base draw x0 to μ + (t/σ0)(x0 − μ): the CRN of the methods
    inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
    s = DesignSpace([DesignVariable("t", "std", "x", 0.01, 1.0)], inputs, ["x"])
    X0 = inputs.sample(50, "random", seed=1)
    Z = s.physical([0.1 * scale], X0)
    assert np.allclose(Z - 1.0, scale * (X0 - 1.0), rtol=1e-12, atol=1e-15)


# ----------------------------------------------------------------------------- study file
STUDY_TOML = """
scene = "slider-crank-lubricated"
cycles = 1
quantities = ["velocity"]
angle_step = 90.0
[inputs.clearance]
paths = ["joints.C.clearance"]
distribution = "normal"
mean = 0.3e-3
std = 0.02e-3
[allowable.velocity]
mean = 0.3
std = 0.0
[design]
cost = "c"
sense = "maximize"
constraints = 0.9
method = "mc"
seed = 3
tradeoff = 0
verify = "none"
[design.mc]
n = 10
max_designs = 2
[design.variables.c]
kind = "mean"
input = "clearance"
lower = 0.2e-3
upper = 0.4e-3
"""
STUDY = tomllib.loads(STUDY_TOML)


def test_the_design_section_of_a_study_file_is_checked():
    s = load_study(STUDY)
    assert s.design["variables"] == {"c": {"kind": "mean", "lower": 0.2e-3, "upper": 0.4e-3,
                                           "input": "clearance"}}
    assert s.design["constraints"] == [{"reliability": 0.9, "quantity": "all",
                                        "basis": "whole-cycle"}]
    assert s.design["settings"]["mc"] == {"n": 10, "max_designs": 2}
    assert load_study({k: v for k, v in STUDY.items() if k != "design"}).design is None
    d = STUDY["design"]
    for table, message in [
            ({**d, "cost": "c +"}, r"<mapping>: design\.cost = \"c \+\""),
            ({**d, "cost": "open(c)"}, r"design\.cost = \"open\(c\)\": .*the function 'open'"),
            ({k: v for k, v in d.items() if k != "cost"}, r"design\.cost.*missing"),
            ({**d, "constraints": [{"reliability": 0.9, "basis": "angle"}]},
             r"design\.constraints\[0\]\.basis = \"angle\": unknown value \(did you mean "
             r"'per-angle'\?\); allowed: one of whole-cycle, per-angle"),
            ({**d, "method": "sora"}, r"design\.method = \"sora\""),
            ({**d, "mc": {"n": 1}}, r"design\.mc\.n = 1"),
            ({**d, "variables": {"c": {"kind": "mean", "input": "gap", "lower": 0.1,
                                       "upper": 0.2}}},
             r"design\.variables\.c\.input = \"gap\": unknown value; allowed: one of clearance"),
            ({**d, "variables": {"c": {"kind": "mean", "input": "clearance", "lower": 0.3,
                                       "upper": 0.2}}}, r"design\.variables\.c\.upper = 0\.2"),
            ({**d, "variables": {"nu": {"kind": "scene", "lower": 0.01, "upper": 0.1}}},
             r"design\.variables\.nu\.paths.*allowed: paths = "),
            ({**d, "verify": "exact"}, r"design\.verify\.method = \"exact\""),
            ({**d, "varaibles": {}}, r"design.*varaibles")]:
        with pytest.raises(StudyError, match=message):
            load_study({**STUDY, "design": table})


def test_mechrel_design_runs_a_study_file(tmp_path, capsys):
    f = tmp_path / "study.toml"
    f.write_text(STUDY_TOML, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["design", str(f), "--jobs", "1", "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("study study: design for reliability (mc, ")
    assert "maximize c:" in printed and "all (whole-cycle) R >= 0.9: k = " in printed
    for name in ("design.csv", "design_constraints.csv", "design_tradeoff.csv",
                 "design_tradeoff.png", "design_history.csv", "design.json"):
        assert (out / name).is_file(), name
    record = json.loads((out / "design.json").read_text())
    n = record["provenance"]["n_evaluations"]
    assert 10 <= n <= 30 and record["method"] == "mc"
    table = pd.read_csv(out / "design.csv")
    assert table["variable"].tolist() == ["c"]
    # a rerun on the same folder: every simulation comes from the cache
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EstimateWarning)
        lines, r = run_design(load_study(str(f)), out=out, progress=False)
    assert r.provenance["n_cached"] == r.provenance["n_evaluations"] == n
    assert r.design == pytest.approx(record["optimum"])


def test_mechrel_design_without_a_design_section(tmp_path, capsys):
    f = tmp_path / "study.toml"
    f.write_text(STUDY_TOML.split("[design]")[0], encoding="utf-8")
    assert main(["design", str(f), "--no-progress"]) != 0
    assert "the study has no [design] section" in capsys.readouterr().err
