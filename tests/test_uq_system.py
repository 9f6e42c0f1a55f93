"""Systems and the whole cycle: the rare-event methods on failure events with several design
points, and each method's warnings for its known failure modes (docs/uq.md, "The whole cycle as
a series system" and "Where each method does not apply").

Tolerances
----------
* FORM on linear modes: a design point's β is converged to the surface tolerance (|g| ≤ 1e-6
  |g₀|: β to ~1e-6) and the union of the modes' half-spaces is exact when they are disjoint
  (the union estimator then has zero variance) or when Ditlevsen's bounds coincide (two modes):
  asserted to 1e-6; with overlapping modes, the union estimator's c.o.v. is below √(m/n)
  (m modes, n = 2·10⁴ draws), asserted to 3 of it.
* SORM (Hohenbichler–Rackwitz) on the four-branch system: its two curved branches are exact
  paraboloids at β = 3 with κ = 0.4, where the formula's own error is about 1 % (Tvedt's three
  terms would be closer): asserted to 2 %.
* FORM on the whole cycle of a mechanism: a first-order system of the design points it finds,
  within a factor stated in docs/uq.md (measured 0.62× at 1e-3, 0.91× at 1e-6; asserted within
  [0.5, 1.1] and [0.7, 1.1] of the reference).
* Sampling methods (mixture importance sampling, subset simulation): their 95 % interval covers
  the reference in at least 90 % of 20 seeds (the issue's requirement; each run's interval is
  its own: a binomial count of 18/20 or more has probability 0.92 at a true coverage of 95 %,
  and 0.68 at 90 %).
* References: closed forms (two design points, a parallel system), a 1-D directional integral
  (the four-branch system), and for the mechanism ``tests/data/slider_crank_whole_cycle.json``
  (crude Monte Carlo of 4·10⁶ samples at 1e-3; a mixture importance sampling of 4·10⁵ samples,
  checked by a subset simulation of 2·10⁴ per level, at 1e-6: ``python
  benchmarks/bench_system_reliability.py --reference``).
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import special

from mechrel.errors import StudyError
from mechrel.study.rare import verdict_lines
from mechrel.uq import (
    FunctionModel,
    LimitState,
    MechanismModel,
    Normal,
    UncertainInputs,
    fosm,
    form,
    importance_sampling,
    sorm,
    subset_simulation,
)
from mechrel.uq.problem.allowables import parse_sector
from mechrel.uq.problem.analytic import slider_crank_tolerance_model

sys.path.insert(0, str(Path(__file__).resolve().parent / "data"))
from system_problems import (  # noqa: E402  (the problems bench_system_reliability.py shares)
    ALLOWABLES,
    four_branch,
    four_branch_exact,
    slider_crank,
)

STD2 = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
REFERENCE = json.loads(
    (Path(__file__).parent / "data" / "slider_crank_whole_cycle.json").read_text()
)


def _tie(X):
    return 3.5 - np.abs(X[:, 0])


def _asymmetric(X):
    return np.minimum(3.5 - X[:, 0], 3.8 + X[:, 0])


def _two(X):
    return np.column_stack([3.0 - X[:, 0], 3.0 - X[:, 1]])


def _linear(X):
    return 3.0 * math.sqrt(2) - X[:, 0] - X[:, 1]


def _model(func, outputs=("g",)):
    return FunctionModel(func, STD2.names, list(outputs), key=func.__name__, vectorized=True)


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kwargs)


def _covers(result, ref):
    t = result.to_frame().iloc[0]
    return bool(t["pf_lo"] <= ref <= t["pf_hi"])


# ---------------------------------------------------------------- FORM and SORM on systems
def test_form_finds_both_design_points_of_one_opaque_margin():
    """The margin g = 3.5 − |u₁| in one model output: the search from the origin stalls on the
    tie (zero gradient); the probes find both sides; their half-spaces are disjoint, so the
    union is exactly 2Φ(−3.5). A single search from a given start finds one side and says so."""
    with pytest.warns(UserWarning, match="2 design points"):
        r = form(model=_model(_tie), inputs=STD2)
    assert sorted(r.design_points["beta"]) == pytest.approx([3.5, 3.5], abs=1e-6)
    assert r.pf == pytest.approx(2 * special.ndtr(-3.5), rel=1e-6)
    assert r.to_frame()["pf_lower"].iloc[0] == pytest.approx(r.pf, rel=1e-9)
    with pytest.warns(UserWarning, match="outside every design point's half-space"):
        one = form(model=_model(_tie), inputs=STD2, search="single", start=[0.1, 0.0])
    assert one.pf == pytest.approx(special.ndtr(-3.5), rel=1e-6)
    s = _quiet(sorm, model=_model(_tie), inputs=STD2, design_point=r)
    assert s.pf == pytest.approx(2 * special.ndtr(-3.5), rel=1e-6)


def test_form_on_an_asymmetric_tie_and_a_linear_margin():
    r = _quiet(form, model=_model(_asymmetric), inputs=STD2)
    assert r.pf == pytest.approx(special.ndtr(-3.5) + special.ndtr(-3.8), rel=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a correct case raises no warning
        lin = form(model=_model(_linear), inputs=STD2)
    assert lin.warnings == () and len(lin.design_points) == 1
    assert lin.beta == pytest.approx(3.0, abs=1e-8)


def test_form_on_a_parallel_system_is_exact_for_linear_components():
    """Both of two independent β = 3 modes must fail: Φ(−3)² = 1.8e-6. Classic FORM's joint
    design point at |u| = 3√2 gave Φ(−4.24) = 1.1e-5, 6× too high."""
    ls = LimitState.parallel(LimitState.margin("a"), LimitState.margin("b"))
    with pytest.warns(UserWarning, match="parallel system"):
        r = form(model=_model(_two, ("a", "b")), inputs=STD2, limit_state=ls)
    assert r.pf == pytest.approx(special.ndtr(-3.0) ** 2, rel=1e-6)
    assert np.array(r.u_star) == pytest.approx([3.0, 3.0], abs=1e-6)
    with pytest.raises(StudyError, match="parallel system; mechrel has no second-order formula"):
        sorm(model=_model(_two, ("a", "b")), inputs=STD2, limit_state=ls, design_point=r)
    # centred on the corner of the failure quadrant, the weights are skewed: at n = 1000 the
    # interval covered the truth in 92 % of 100 seeds, at n = 4000 in 98 % (importance.py)
    coverage = [
        _covers(
            _quiet(
                importance_sampling,
                model=_model(_two, ("a", "b")),
                inputs=STD2,
                limit_state=ls,
                design_point=r,
                n=4000,
                seed=s,
                progress=False,
            ),
            special.ndtr(-3.0) ** 2,
        )
        for s in range(20)
    ]
    assert sum(coverage) >= 18


def test_four_branch_system_by_form_sorm_and_sampling():
    exact = four_branch_exact()  # 4.4573e-3
    assert exact == pytest.approx(4.46e-3, rel=2e-3)
    model = _model(four_branch)
    f = _quiet(form, model=model, inputs=STD2)
    assert len(f.design_points) == 4 and f.design_points["beta"].to_numpy() == pytest.approx(
        3.0, abs=1e-5
    )
    # the union of four β = 3 half-spaces, opposite pairs disjoint, orthogonal pairs independent
    linear_union = 4 * special.ndtr(-3.0) - 4 * special.ndtr(-3.0) ** 2
    assert f.pf == pytest.approx(linear_union, rel=3 * math.sqrt(4 / 20000))
    s = _quiet(sorm, model=model, inputs=STD2, design_point=f)
    assert s.pf == pytest.approx(exact, rel=2e-2)
    cov_is = [
        _covers(
            _quiet(
                importance_sampling,
                model=model,
                inputs=STD2,
                design_point=f,
                n=1000,
                seed=k,
                progress=False,
            ),
            exact,
        )
        for k in range(20)
    ]
    cov_ss = [
        _covers(
            _quiet(subset_simulation, model=model, inputs=STD2, n_per_level=1000, seed=k), exact
        )
        for k in range(20)
    ]
    assert sum(cov_is) >= 18 and sum(cov_ss) >= 18


def test_importance_sampling_on_two_design_points_covers_the_truth():
    """Centred on one design point (the old estimator) the interval excluded the truth in 20 of
    20 runs; the mixture over both covers it."""
    model, exact = _model(_tie), 2 * special.ndtr(-3.5)
    f = _quiet(form, model=model, inputs=STD2)
    runs = [
        _quiet(
            importance_sampling,
            model=model,
            inputs=STD2,
            design_point=f,
            n=1000,
            seed=k,
            progress=False,
        )
        for k in range(20)
    ]
    assert sum(_covers(r, exact) for r in runs) >= 18
    assert all(r.to_frame()["n_design_points"].iloc[0] == 2 for r in runs)


# ---------------------------------------------------------------- the whole cycle of a mechanism
def test_the_analytic_slider_crank_is_the_simulators():
    """The closed-form test mechanism has the simulator's numbers: an ideal slider-crank with
    crank and rod tolerances against its nominal design (kinematic analysis, 3600 points per
    cycle for the extremes; the analytic model's fine grid of 180 intervals per 18° sector holds
    the same points): every output to 1e-9 of its quantity's largest error."""
    sim = MechanismModel(
        "slider-crank",
        {"crank": ["bodies.crank.length(O,A)"], "rod": ["bodies.rod.length(A,B)"]},
        angle_step=18.0,
        cycles=1,
        sectors=True,
    )
    ana = slider_crank_tolerance_model(angle_step=18.0, points_per_sector=180)
    assert list(sim.output_index) == list(ana.output_index)
    for x in ([0.0501, 0.1199], [0.04985, 0.12012]):
        y, z = sim.evaluate(np.array(x)), ana.evaluate(np.array(x + [0.0]))
        for q in ("displacement", "velocity", "acceleration"):
            m = np.array([lbl[0] == q for lbl in sim.output_index])
            assert np.max(np.abs(y[m] - z[m])) <= 1e-9 * np.max(np.abs(z[m]))


def test_whole_cycle_form_sees_the_design_points_of_every_peak_and_sign():
    model, inputs, states = slider_crank()
    f = _quiet(form, model=model, inputs=inputs, limit_state=states["1e-3"])
    dps = f.design_points
    sectors = {parse_sector(o[1])[1] for o in dps["output"]}
    assert set(dps["sign"]) == {"+", "-"} and len(sectors) >= 2
    ref = REFERENCE["1e-3"]["pf"]
    assert 0.5 * ref <= f.pf <= 1.1 * ref
    f6 = _quiet(form, model=model, inputs=inputs, limit_state=states["1e-6"])
    assert 0.7 * REFERENCE["1e-6"]["pf"] <= f6.pf <= 1.1 * REFERENCE["1e-6"]["pf"]
    # one design point (the first found) is a fraction of the truth, and says so
    with pytest.warns(UserWarning, match="members not searched"):
        one = form(model=model, inputs=inputs, limit_state=states["1e-3"], max_design_points=1)
    assert one.pf < 0.4 * ref


def test_whole_cycle_sampling_methods_within_their_interval():
    """Three seeds in the default run (the 20-seed coverage is the slow test below): each
    estimate within 3 of its own c.o.v. of the reference."""
    model, inputs, states = slider_crank()
    ls = states["1e-3"]
    f = _quiet(form, model=model, inputs=inputs, limit_state=ls)
    ref = REFERENCE["1e-3"]["pf"]
    for k in range(3):
        i = _quiet(
            importance_sampling,
            model=model,
            inputs=inputs,
            limit_state=ls,
            design_point=f,
            n=2000,
            seed=k,
            progress=False,
        )
        s = _quiet(
            subset_simulation, model=model, inputs=inputs, limit_state=ls, n_per_level=1000, seed=k
        )
        assert abs(i.pf - ref) <= 3 * i.cov * i.pf and abs(s.pf - ref) <= 3 * s.cov * s.pf


@pytest.mark.slow
@pytest.mark.parametrize("level", ["1e-3", "1e-6"])
def test_whole_cycle_sampling_methods_cover_the_reference(level):
    # 20 seeds each: a 95 % interval covers the reference in >= 18 (P(X < 18) = 0.075 for
    # X ~ Binomial(20, 0.95))
    model, inputs, states = slider_crank()
    ls = states[level]
    f = _quiet(form, model=model, inputs=inputs, limit_state=ls)
    ref = REFERENCE[level]["pf"]
    cov_is = [_covers(_quiet(importance_sampling, model=model, inputs=inputs, limit_state=ls,
                             design_point=f, n=2000, seed=k, progress=False), ref)
              for k in range(20)]
    cov_ss = [_covers(_quiet(subset_simulation, model=model, inputs=inputs, limit_state=ls,
                             n_per_level=1000, seed=k), ref)
              for k in range(20)]
    assert sum(cov_is) >= 18 and sum(cov_ss) >= 18


def test_the_references_agree_with_each_other():
    """The stored 1e-6 reference (mixture importance sampling) and its check (subset
    simulation) agree within 3 of their combined c.o.v.; the 1e-3 one is a crude Monte Carlo of
    4·10⁶ samples (c.o.v. 1.5 %)."""
    r = REFERENCE["1e-6"]
    both = math.hypot(r["cov"] * r["pf"], r["subset_cov"] * r["subset_pf"])
    assert abs(r["pf"] - r["subset_pf"]) <= 3 * both
    assert REFERENCE["1e-3"]["cov"] <= 0.02
    assert REFERENCE["1e-3"]["allowable"] == ALLOWABLES["1e-3"]


# ---------------------------------------------------------------- warnings, one failure mode each
class _Rough(FunctionModel):
    """A model that declares itself non-smooth (as a dry-contact mechanism does)."""

    nonsmooth = "a test's dry contact"


def test_form_warns_on_a_non_smooth_model():
    rough = _Rough(_linear, STD2.names, ["g"], key="rough", vectorized=True)
    with pytest.warns(UserWarning, match="the model is not smooth"):
        form(model=rough, inputs=STD2)


def test_fosm_on_a_tie_and_on_cycle_extremes_gives_no_number_from_round_off():
    with pytest.warns(UserWarning) as caught:
        r = fosm(model=_model(_tie), inputs=STD2, limit_state=LimitState.margin(), progress=False)
    text = " ".join(str(w.message) for w in caught)
    assert "not differentiable at the means" in text and "gradient of g is zero" in text
    assert math.isnan(r.beta) and math.isnan(r.pf)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok = fosm(
            model=_model(_linear), inputs=STD2, limit_state=LimitState.margin(), progress=False
        )
    assert ok.beta == pytest.approx(3.0, abs=1e-9) and ok.warnings == ()
    # the tolerance model: zero error at the nominal design; its cycle extremes get no β
    model, inputs, _ = slider_crank()
    from mechrel.uq import Allowable

    with pytest.warns(UserWarning, match="cycle extreme.* are not differentiable at the means"):
        f = fosm(model=model, inputs=inputs, allowable=Allowable(0.18e-3, 0.0), progress=False)
    t = f.to_frame()
    extreme = np.array([isinstance(lbl[1], str) for lbl in t.index])
    assert t.loc[extreme, ["beta", "std", "reliability"]].isna().all().all()
    assert t.loc[~extreme, "beta"].notna().any()
    ls = LimitState.exceedance([("displacement", "max_abs")], 0.18e-3, name="d")
    with pytest.warns(UserWarning, match="uses cycle extremes"):
        fosm(model=model, inputs=inputs, limit_state=ls, progress=False)


def test_importance_sampling_warns_on_too_few_effective_samples_and_missed_regions():
    """Centred on one of the four-branch system's four design points (a single search from a
    start off the origin's tie), the defensive part of the mixture finds the other branches:
    few effective samples, and failures where no design point's component reaches."""
    model = _model(four_branch)
    one = _quiet(form, model=model, inputs=STD2, search="single", start=[0.1, 0.1])
    assert len(one.design_points) == 1
    with pytest.warns(UserWarning) as caught:
        # the defensive part (w₀ n = 2000 samples) meets each missed branch (P ≈ 1e-3) a few times
        importance_sampling(
            model=model, inputs=STD2, design_point=one, n=20000, seed=3, progress=False
        )
    text = " ".join(str(w.message) for w in caught)
    assert "no design point's component of the mixture reaches" in text
    assert "effective" in text or "Pareto" in text
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = _quiet(form, model=_model(_linear), inputs=STD2)
        importance_sampling(
            model=_model(_linear), inputs=STD2, design_point=f, n=1000, seed=3, progress=False
        )


def _fails_near_origin(X):
    g = 3.0 - X[:, 0]
    g[np.hypot(X[:, 0], X[:, 1] + 1.5) < 0.5] = np.nan  # the model fails there
    return g


def test_importance_sampling_warns_on_model_failures_counted_as_failures_away_from_the_points():
    model = _model(_fails_near_origin)
    f = _quiet(form, model=model, inputs=STD2)
    with pytest.warns(
        UserWarning, match="failed model sample.* away from the design points count as failures"
    ):
        importance_sampling(
            model=model,
            inputs=STD2,
            design_point=f,
            n=2000,
            seed=1,
            progress=False,
            failures="as_failure",
            max_failure_fraction=0.5,
        )


def test_subset_warns_when_its_chains_do_not_move():
    """Conditional sampling with ρ close to 1 accepts nearly every candidate, but they hardly
    move: fine. Modified Metropolis with a huge spread rejects almost every candidate, so the
    chains stay at their seeds: a warning."""
    inputs = UncertainInputs.from_specs({f"x{i}": Normal(0.0, 1.0) for i in range(10)})
    model = FunctionModel(
        lambda X: 4.0 * math.sqrt(10) - X.sum(axis=1),
        inputs.names,
        ["g"],
        vectorized=True,
        key="ten",
    )
    with pytest.warns(UserWarning, match="of the chains moved|distinct seeds"):
        subset_simulation(
            model=model,
            inputs=inputs,
            n_per_level=500,
            seed=1,
            proposal="modified_metropolis",
            spread=50.0,
        )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        subset_simulation(model=_model(_linear), inputs=STD2, n_per_level=500, seed=1)


# ---------------------------------------------------------------- the verdict across methods
def _est(rows):
    return pd.DataFrame(
        rows,
        columns=[
            "method",
            "group",
            "pf",
            "pf_lo",
            "pf_hi",
            "kind",
            "n_failures",
            "n_samples",
            "n_warnings",
        ],
    )


def test_the_verdict_names_disagreements_and_which_estimate_to_trust():
    est = _est(
        [
            ("subset", "all", 5e-4, 3e-4, 8e-4, "sampling", np.nan, np.nan, 0),
            ("is", "all", 1.4e-4, 1.2e-4, 1.6e-4, "sampling", np.nan, np.nan, 1),
            ("form", "all", 1.1e-4, np.nan, np.nan, "approximation", np.nan, np.nan, 1),
            ("mc", "all", 0.0, 0.0, 3.7e-3, "monte_carlo", 0.0, 1000.0, 0),
        ]
    )
    lines = verdict_lines(est, worst=(1e-3, "mc, displacement at 90°"))
    text = "\n".join(lines)
    assert "trust subset" in lines[0] and "no warning" in lines[0]
    assert (
        "is disagrees with subset: their intervals [0.00012, 0.00016] and [0.0003, 0.0008] do not "
        "overlap"
        in text
    )
    assert "form gives 0.22× the trusted P_f, outside its interval" in text
    assert "mc saw only 0 failures in 1000 samples (fewer than 10)" in text
    assert "is below the largest single-angle P_f (0.001, mc, displacement at 90°)" in text
    # only approximations and a Monte Carlo run without failures: nothing to trust, what to run,
    # and whether the approximation is at least consistent with the Monte Carlo bound
    weak = verdict_lines(est[est["method"].isin(["form", "mc"])])
    assert weak[0].startswith(
        "    whole cycle: no estimate to trust at this level: form carry no interval"
    )
    assert "mc saw 0 failures in 1000 samples" in weak[0] and "--method subset" in weak[0]
    assert "form's P_f = 0.00011 is inside mc's interval [0, 0.0037]" in weak[1]


def test_the_study_shows_warnings_verdict_and_figures_through_the_cli(tmp_path, capsys):
    """The slider-crank with crank and rod tolerances (ideal joints, errors against the nominal
    design) as a study: FORM and Monte Carlo on the whole cycle (16 samples: too few failures
    to be trusted, which the verdict says)."""
    from mechrel.cli.main import main

    study = tmp_path / "study.toml"
    study.write_text(
        'scene = "slider-crank"\ncycles = 1\nquantities = ["displacement"]\nangle_step = 45.0\n'
        '[inputs.crank]\npaths = ["bodies.crank.length(O,A)"]\ndistribution = "normal"\n'
        "mean = 0.05\nstd = 0.05e-3\n"
        '[inputs.rod]\npaths = ["bodies.rod.length(A,B)"]\ndistribution = "normal"\n'
        "mean = 0.12\nstd = 0.05e-3\n"
        "[allowable.displacement]\nmean = 0.2e-3\nstd = 0.0\n"
        "[form]\nmax_design_points = 4\n"
        "[reliability]\nseed = 3\nn = 16\n"
    )
    out = tmp_path / "out"
    assert (
        main(
            [
                "reliability",
                str(study),
                "--method",
                "form",
                "--method",
                "mc",
                "--jobs",
                "1",
                "--out",
                str(out),
                "--no-progress",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "  warning: form: " in printed and "design points (displacement" in printed
    # no failure in 16 samples: nothing to trust at this level, FORM checked against MC's bound
    assert (
        "  verdict:" in printed and "    whole cycle: no estimate to trust at this level" in printed
    )
    assert "whole cycle: form's P_f" in printed and "mc's interval" in printed
    for name in ("whole_cycle.png", "rare_events.png", "cycle_extremes.csv", "design_point.csv"):
        assert (out / name).is_file(), name
    ext = pd.read_csv(out / "cycle_extremes.csv")
    assert len(ext) == 16 and {"crank", "rod", "displacement.max_abs", "status"} <= set(ext.columns)
    dp = pd.read_csv(out / "design_point.csv")
    assert dp["point"].nunique() >= 2 and dp["member"].str.contains("max").all()
