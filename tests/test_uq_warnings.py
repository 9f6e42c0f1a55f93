"""Estimates that say how far they can be trusted: EstimateWarning and results' warnings."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from mechrel.errors import EstimateWarning, MechrelWarning
from mechrel.uq import (
    Allowable,
    FunctionModel,
    Normal,
    UncertainInputs,
    fosm,
    monte_carlo,
    normality_check,
    polynomial_chaos,
    sobol_indices,
)


def _abs(x):
    return np.array([abs(x[0]), x[0] + x[1]])


def _linear(x):
    return np.array([2.0 * x[0] + x[1], x[0] - 3.0 * x[1]])


def _square(x):
    return np.array([x[0] ** 2 + 0.1 * x[1]])


def _wiggle(x):
    return np.array([np.sin(6.0 * x[0]) + 0.05 * x[1]])


ALLOW = Allowable(1.0, 0.1)
INPUTS = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})


def _quiet(func, **kw):
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        res = func(**kw)
    return res, [w for w in got if issubclass(w.category, MechrelWarning)]


def test_a_smooth_model_gives_no_warning():
    res, got = _quiet(fosm, model=FunctionModel(_linear, ["a", "b"], ["p", "q"]), inputs=INPUTS,
                      allowable=ALLOW, progress=False)
    assert got == [] and res.warnings == ()


def test_a_kink_is_a_zero_gradient_and_an_unresolved_response():
    # |a| at a = 0: the central difference is exactly 0 (σ = 0, β = ∞ silently, before), and
    # the forward and backward slopes are +1 and −1
    model = FunctionModel(_abs, ["a", "b"], ["kink", "smooth"])
    with pytest.warns(EstimateWarning) as record:
        res = fosm(model=model, inputs=INPUTS, allowable=ALLOW, progress=False)
    texts = [str(w.message) for w in record]
    assert len(res.warnings) == 2 and set(res.warnings) == set(texts)
    assert "gradient is zero at 1 of 2 outputs, e.g. kink" in res.warnings[1]
    assert "does not resolve the response at 1 of 2 outputs, e.g. kink" in res.warnings[0]
    assert res.table.loc["kink", "std"] == 0  # the number stays; the warning says what it is


class _DryModel(FunctionModel):
    nonsmooth = "dry contact in joint C: impacts make the response non-smooth, often chaotic"


def test_fosm_on_a_model_with_dry_contact_warns():
    model = _DryModel(_linear, ["a", "b"], ["p", "q"])
    with pytest.warns(EstimateWarning, match=r"fosm: the model is not smooth \(dry contact in "
                                             r"joint C"):
        res = fosm(model=model, inputs=INPUTS, allowable=ALLOW, progress=False)
    assert len(res.warnings) == 1


def test_the_mechanism_model_says_when_it_is_not_smooth():
    from mechrel.uq.problem.mechanism import MechanismModel

    assert MechanismModel("slider-crank-lubricated", ["joints.C.clearance"]).nonsmooth is None
    dry = MechanismModel("slider-crank-dry", ["joints.C.clearance"]).nonsmooth
    assert dry.startswith("dry contact in joint C")


def test_fosm_mean_and_r_outside_the_monte_carlo_interval_warn():
    # a² with a ~ N(0, 1): FOSM's mean is 0 and its σ 0 (zero gradient), the true mean 1
    model = FunctionModel(_square, ["a", "b"], ["sq"])
    f, _ = _quiet(fosm, model=model, inputs=INPUTS, allowable=ALLOW, progress=False)
    mc, _ = _quiet(monte_carlo, model=model, inputs=INPUTS, n=256, seed=1, rule="random",
                   progress=False, allowable=ALLOW)
    with pytest.warns(EstimateWarning, match="mean μ_i lies outside the 95% Monte Carlo "
                                             "interval of the mean at 1 of 1 outputs"):
        nc = normality_check(fosm=f, monte_carlo=mc)
    assert any("mean" in w for w in nc.warnings)


def _angle_and_extreme(x):
    # at 0°: linear (FOSM exact); the cycle's max |error|: a² + b (FOSM's mean 0, the true 1)
    return np.array([2.0 * x[0] + x[1], x[0] ** 2 + x[1]])


def test_the_fosm_vs_monte_carlo_warnings_leave_out_the_cycle_extremes():
    # a cycle extreme is a maximum over the cycle, not a first-order response, and only Monte
    # Carlo estimates the whole cycle: the comparison (and its count) is over the analysis
    # angles. Before, this model warned "mean ... outside ... at 1 of 2 outputs, e.g.
    # (displacement, max_abs)".
    import pandas as pd

    index = pd.MultiIndex.from_tuples([("displacement", 0.0), ("displacement", "max_abs")],
                                      names=["quantity", "crank_angle"])
    model = FunctionModel(_angle_and_extreme, ["a", "b"], index)
    f, _ = _quiet(fosm, model=model, inputs=INPUTS, allowable=ALLOW, progress=False)
    mc, _ = _quiet(monte_carlo, model=model, inputs=INPUTS, n=256, seed=1, rule="random",
                   progress=False, allowable=ALLOW)
    nc, got = _quiet(normality_check, fosm=f, monte_carlo=mc)
    assert got == [] and nc.warnings == ()
    # the extreme's row is still compared in the table: FOSM's mean 0 against MC's ≈ 1
    assert not nc.table["flag"].iloc[0] and nc.table["flag"].iloc[1]
    # the same model with the extreme at an analysis angle: the warning names 1 of 2 outputs
    plain = FunctionModel(_angle_and_extreme, ["a", "b"], ["p", "q"])
    f2, _ = _quiet(fosm, model=plain, inputs=INPUTS, allowable=ALLOW, progress=False)
    mc2, _ = _quiet(monte_carlo, model=plain, inputs=INPUTS, n=256, seed=1, rule="random",
                    progress=False, allowable=ALLOW)
    with pytest.warns(EstimateWarning, match="interval of the mean at 1 of 2 outputs"):
        normality_check(fosm=f2, monte_carlo=mc2)


def test_a_pce_that_does_not_fit_warns_and_passes_it_on():
    model = FunctionModel(_wiggle, ["a", "b"], ["w"])
    with pytest.warns(EstimateWarning, match=r"pce: the leave-one-out error of the order-2 "
                                             r"expansion exceeds 0\.1 at 1 of 1 outputs"):
        pce = polynomial_chaos(model=model, inputs=INPUTS, order=2, seed=3, progress=False)
    assert float(pce.loo_error.iloc[0]) > 0.1
    with pytest.warns(EstimateWarning, match="computed on that surrogate"):
        rel = pce.reliability(n=1024, seed=1, allowable=ALLOW)
    assert len(rel.warnings) == 1
    # a quadratic is reproduced by an order-2 expansion: no warning
    fit, got = _quiet(polynomial_chaos, model=FunctionModel(_square, ["a", "b"], ["sq"]),
                      inputs=INPUTS, order=2, seed=3, progress=False)
    assert got == [] and fit.warnings == () and float(fit.loo_error.iloc[0]) < 1e-20


def test_sobol_with_too_few_samples_warns():
    model = FunctionModel(_linear, ["a", "b"], ["p", "q"])
    with pytest.warns(EstimateWarning, match="confidence half-width above 0.1"):
        res = sobol_indices(model=model, inputs=INPUTS, n=8, seed=1, progress=False)
    assert res.warnings
    big, got = _quiet(sobol_indices, model=model, inputs=INPUTS, n=1024, seed=1,
                      progress=False)
    assert got == [] and big.warnings == ()


def _reliability_cli(tmp_path, capsys, *, angle_step, reliability):
    """``mechrel reliability`` on the slider-crank with its crank's length uncertain (a study
    file with ``reliability`` as its [reliability] table); the captured output."""
    from mechrel.cli.main import main

    f = tmp_path / "s.toml"
    f.write_text(f'scene = "slider-crank"\nangle_step = {angle_step}\n[inputs.crank]\n'
                 'paths = ["bodies.crank.length(O,A)"]\ndistribution = "normal"\n'
                 f'mean = 0.05\nstd = 1e-5\n[reliability]\n{reliability}')
    assert main(["reliability", str(f), "--out", str(tmp_path / "o"), "--no-progress",
                 "--jobs", "1"]) == 0
    return capsys.readouterr()


def test_the_reliability_summary_carries_warnings_and_ends_with_a_verdict(tmp_path, capsys):
    captured = _reliability_cli(tmp_path, capsys, angle_step=30.0,
                                reliability='methods = ["fosm", "mc"]\nn = 16\nseed = 1\n')
    lines = captured.out.strip().splitlines()
    assert "EstimateWarning" not in captured.err  # in the summary, not twice
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    # the velocity at the dead centres does not depend on the crank's length: zero gradient
    assert any("gradient is zero" in w for w in summary["warnings"])
    assert any(line.startswith("  warning: fosm: the finite-difference gradient is zero")
               for line in lines)
    # the verdict: one line per quantity and the whole cycle, last in the console
    assert [v.split(":")[0] for v in summary["verdict"]] == [
        "displacement", "velocity", "acceleration", "whole cycle"]
    assert lines[-5] == "  verdict:" and lines[-1].strip() == summary["verdict"][-1]
    assert "trust Monte Carlo (16 successful samples" in summary["verdict"][0]
    # counts over the analysis angles (0°, 30°, ..., 360°: 13 per quantity), not the cycle
    # extremes, which the model appends (3 per quantity)
    normality = [line for line in lines if line.startswith("  normality check:")]
    assert len(normality) == 1 and normality[0].endswith(" of 39 (quantity, angle) points")
    for v in summary["verdict"][:3]:
        assert " of 13 angles" in v or "at every angle" in v


def test_the_verdict_on_a_dry_scene_says_fosm_does_not_apply(tmp_path):
    # the dry slider-crank (one cycle, 18° analysis points, 8 samples): FOSM warns that the model
    # is not smooth, and the verdict trusts Monte Carlo and says why not FOSM
    from mechrel.study.runner import run_reliability
    from mechrel.study.study import load_study

    study = load_study({"scene": "slider-crank-dry", "cycles": 1, "angle_step": 18.0,
                        "scene_overrides": {"solver.rtol": 1e-6, "solver.atol": 1e-9},
                        "inputs": {"clearance": {"paths": ["joints.C.clearance"],
                                                 "distribution": "normal", "mean": 0.5e-3,
                                                 "std": 0.02e-3}},
                        "reliability": {"methods": ["fosm", "mc"], "n": 8, "seed": 2}})
    with pytest.warns(EstimateWarning, match="fosm: the model is not smooth"):
        lines, results = run_reliability(study, n_jobs=1, progress=False,
                                         out=tmp_path / "o")
    assert any("dry contact in joint C" in w for w in results["fosm"].warnings)
    verdict = json.loads((tmp_path / "o" / "summary.json").read_text())["verdict"]
    for v in verdict[:3]:
        assert "trust Monte Carlo (8 successful samples" in v
        assert "FOSM is not applicable (dry contact in joint C" in v


def test_sobol_indices_outside_the_unit_interval_beyond_their_interval_warn():
    # the check on its own, on indices as SALib can return them at small N: −0.3 ± 0.1 lies
    # outside [0, 1] beyond its interval (warned), −0.05 ± 0.1 and 1.04 ± 0.05 do not
    import pandas as pd

    from mechrel.uq.estimators.sobol import sobol_warnings

    idx = pd.Index(["y"])
    cols = pd.Index(["a", "b", "c"], name="input")
    frames = {"S1": pd.DataFrame([[-0.3, -0.05, 1.04]], index=idx, columns=cols),
              "S1_conf": pd.DataFrame([[0.1, 0.1, 0.05]], index=idx, columns=cols),
              "ST": pd.DataFrame([[0.2, 0.3, 0.9]], index=idx, columns=cols),
              "ST_conf": pd.DataFrame([[0.01, 0.01, 0.01]], index=idx, columns=cols)}
    out = sobol_warnings(frames, 64)
    assert len(out) == 1
    assert out[0].startswith("sobol: 1 first-order indices lie outside [0, 1] by more than "
                             "their confidence interval (e.g. a on y: -0.300 ± 0.100)")


def test_a_sobol_design_of_a_size_not_a_power_of_2_is_a_caveat_of_the_result():
    # SciPy's own warning ("balance properties ... require n to be a power of 2") names no
    # remedy; ours names the balanced sizes on either side and travels with the result
    model = FunctionModel(_linear, ["a", "b"], ["p", "q"])
    kw = dict(model=model, inputs=INPUTS, rule="sobol", seed=1, allowable=ALLOW, progress=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = monte_carlo(n=100, **kw)
    assert [str(w.message) for w in caught] == [
        "monte_carlo: rule='sobol' with n = 100 points: not a power of 2, so the points are not "
        "a balanced Sobol' net and the estimate may converge no faster than with "
        "rule='random'; n = 64 or 128 keeps the balance"]
    assert caught[0].category is EstimateWarning
    assert res.warnings == (str(caught[0].message),)
    ok, got = _quiet(monte_carlo, n=128, **kw)
    assert got == [] and ok.warnings == ()
    # the other rules have no such caveat at any size
    rnd, got = _quiet(monte_carlo, n=100, **{**kw, "rule": "random"})
    assert got == [] and rnd.warnings == ()


def test_the_cli_states_the_sobol_caveat_once_in_the_summary(tmp_path, capsys):
    captured = _reliability_cli(
        tmp_path, capsys, angle_step=90.0,
        reliability='methods = ["mc"]\nn = 24\nrule = "sobol"\nseed = 1\n')
    assert "balance" not in captured.err  # neither SciPy's warning nor ours on stderr
    lines = [line for line in captured.out.splitlines() if "not a power of 2" in line]
    assert lines == ["  warning: monte_carlo: rule='sobol' with n = 24 points: not a power "
                     "of 2, so the points are not a balanced Sobol' net and the estimate may "
                     "converge no faster than with rule='random'; n = 16 or 32 keeps the "
                     "balance"]
