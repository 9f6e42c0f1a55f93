"""The rare-event methods in study files, the study runner and ``mechrel reliability``.

Tolerances
----------
* FORM and SORM on a margin linear in the standard normal space: exact up to the
  finite-difference round-off of the default step (ε·|g|/h ≈ 1e-11): asserted to 1e-8.
* Sampling estimators (importance sampling, subset simulation), fixed seeds:
  |P̂ − P_exact| ≤ 3·δ·P̂, δ the estimator's own coefficient of variation (3σ of its normal
  approximation).
* The mechanism: the design point of a one-input, monotone limit state is the input at which
  the output equals the allowable; FORM stops when |g| ≤ tol·|g(0)| (tol = 1e-3), so the output
  there is within 1e-3·|g(0)| of the allowable, plus the integration error's noise (≈ 1e-4 of
  the output at the study's tolerance), asserted with the factor 2 margin 2e-3·|g(0)|.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from scipy import special

from mechrel.cli.main import main
from mechrel.errors import StudyError
from mechrel.study import rare
from mechrel.study.study import load_study, rare_event_methods, study_methods
from mechrel.uq import FunctionModel
from mechrel.uq.estimators import METHODS as REGISTRY

MU = 6.0  # mean of the analytic "velocity" cycle extreme
LABELS = pd.MultiIndex.from_tuples(
    [("velocity", 0.0), ("velocity", "max_abs"), ("velocity", "max"),
     ("acceleration", 0.0), ("acceleration", "max_abs"), ("acceleration", "max")],
    names=["quantity", "crank_angle"])


def _outputs(X):
    """Velocity extreme 6 + x1 + x2, acceleration extreme 3 + x3 (x_i standard normal)."""
    v = MU + X[:, 0] + X[:, 1]
    a = 3.0 + X[:, 2]
    return np.column_stack([v, v, v, a, a, a])


MODEL = FunctionModel(_outputs, ["x1", "x2", "x3"], LABELS, key="rare-study-test", vectorized=True)


def _study(allowable, quantities=("velocity",), **sections):
    raw = {"scene": "nine-bar-lubricated", "quantities": list(quantities),
           "inputs": {k: {"distribution": "normal", "mean": 0.0, "std": 1.0}
                      for k in ("x1", "x2", "x3")},
           "allowable": allowable, "reliability": {"seed": 7}}
    raw.update(sections)
    return load_study(raw)


def _run(study, keys):
    return rare.estimate(study, MODEL, study.uncertain_inputs(), keys, seed=7,
                         common={"n_jobs": 1, "backend": "loky", "cache": None,
                                 "progress": False})


def test_the_study_methods_are_the_registrys():
    # properties of the registry, not a copy of it: every registered method but the
    # sensitivity ones is a study method by its key, in the registry's order; the rare-event
    # ones are the study's rare-event tables; each has a presenter
    from mechrel.study.presenters import Presenter, presenter_class

    study = [m for m in REGISTRY.values() if m.kind != "sensitivity"]
    assert list(study_methods()) == [m.key for m in study]
    assert len({m.key for m in REGISTRY.values()}) == len(REGISTRY)  # keys are unique
    assert all(study_methods()[m.key] is m for m in study)
    keys = [m.key for m in REGISTRY.values() if m.kind == "rare_event"]
    assert keys and list(rare_event_methods()) == keys
    for m in REGISTRY.values():
        assert issubclass(presenter_class(m), Presenter), m.name


def test_linear_whole_cycle_margin_is_exact_by_form_and_sorm_and_sampled_within_cov():
    beta = 4.0
    a = MU + math.sqrt(2.0) * beta  # P(6 + x1 + x2 > a) = Φ(−4)
    study = _study({"velocity": {"mean": a, "std": 0.0}},
                   subset={"n_per_level": 500, "p0": 0.1}, **{"is": {"n": 400}})
    results, notes = _run(study, ["form", "sorm", "is", "subset"])
    exact = special.ndtr(-beta)
    assert results["form"].beta == pytest.approx(beta, abs=1e-8)
    assert results["sorm"].pf == pytest.approx(exact, rel=1e-7)
    for k in ("is", "subset"):
        r = results[k]
        assert abs(r.pf - exact) <= 3 * r.cov * r.pf, (k, r.pf, r.cov)
    # SORM and IS start from the FORM design point of the run: no second search
    assert results["sorm"].form is results["form"]
    table = rare.table(results)
    assert list(table.index) == ["form", "sorm", "is", "subset"]
    assert table.loc["form", "pf"] == pytest.approx(exact, rel=1e-7)
    assert np.isnan(table.loc["form", "cov"]) and table.loc["subset", "cov"] > 0
    assert (table["n_evaluations"] > 0).all()
    # the design point in physical units: x1 = x2 = β/√2, x3 untouched; α² = ½, ½, 0
    dp = rare.design_points(results).loc[("form", 0)]   # its one design point
    assert dp.loc[["x1", "x2"], "x"].to_numpy() == pytest.approx([beta / math.sqrt(2)] * 2,
                                                                 abs=1e-6)
    assert dp.loc[["x1", "x2", "x3"], "importance"].to_numpy() == pytest.approx([.5, .5, 0],
                                                                               abs=1e-8)
    lines = rare.summary_lines(results)
    assert len(lines) == 4 and lines[0].startswith("  form (form): whole-cycle P_f = 3.17e-05")
    assert "c.o.v." in lines[3] and "α² x1 0.50" in lines[0]
    # one count: a line gives the rows its estimate rests on, SORM's and IS's include FORM's
    # (and say so), the run's total counts each row once
    per, total = rare.evaluation_counts(results, {k: r.evaluations for k, r in results.items()})
    n = {k: c.evaluations for k, (c, _) in per.items()}
    assert [per[k][1] for k in ("form", "sorm", "is", "subset")] == [None, "form", "form", None]
    assert n == {k: int(table.loc[k, "n_evaluations"]) for k in n}
    assert total.evaluations == n["form"] + (n["sorm"] - n["form"]) + (n["is"] - n["form"]) \
        + n["subset"]
    assert total.computed + total.cached == total.evaluations  # no cache: all computed
    for line, k in zip(lines, ("form", "sorm", "is", "subset")):
        assert f"; {per[k][0].text()}" in line
    assert f"{n['form']} of them form's" in lines[1] and "form's" not in lines[3]


def test_random_allowables_and_series_systems_over_quantities():
    # velocity: allowable N(11, 1) → g = A − 6 − x1 − x2 ~ N(5, 3), β₁ = 5/√3;
    # acceleration: fixed 6.5 → β₂ = 3.5; series: 1 − (1 − p₁)(1 − p₂)
    study = _study({"velocity": {"mean": 11.0, "std": 1.0},
                    "acceleration": {"mean": 6.5, "std": 0.0}},
                   quantities=("velocity", "acceleration"),
                   subset={"n_per_level": 1000, "p0": 0.1})
    ls = rare.whole_cycle_limit_state(study, MODEL)
    assert [c.name for c in ls.components] == ["velocity", "acceleration"]
    assert list(ls.random_allowables) == ["allowable[velocity]"]
    b1, b2 = 5 / math.sqrt(3), 3.5
    p1, p2 = special.ndtr(-b1), special.ndtr(-b2)
    results, _ = _run(study, ["form", "subset"])
    # FORM finds the design point of each component (velocity at β₁ = 2.89, acceleration at
    # β₂ = 3.5; a single search from the origin used to find only the acceleration's, whose
    # margin is the smaller there, and reported 0.1 of the truth): both are linear in u and
    # independent (α₁·α₂ = 0), so the union of their half-spaces is the exact series system.
    # Ditlevsen's bounds are exact for two modes (1e-8: the bivariate normal's Owen-T round-off);
    # P_f is the union estimator's (c.o.v. < √(m/n) = 1e-2 for m = 2 modes, n = 2·10⁴ draws:
    # asserted to 3 of it)
    exact = 1 - (1 - p1) * (1 - p2)
    f = results["form"]
    assert sorted(f.design_points["beta"]) == pytest.approx([b1, b2], abs=1e-8)
    assert f.to_frame()["pf_lower"].iloc[0] == pytest.approx(exact, rel=1e-8)
    assert f.to_frame()["pf_upper"].iloc[0] == pytest.approx(exact, rel=1e-8)
    assert f.pf == pytest.approx(exact, rel=3e-2)
    r = results["subset"]
    assert abs(r.pf - exact) <= 3 * r.cov * r.pf
    # the one-sided event bounds the signed extreme ("max"), the same here
    one = _study({"velocity": {"mean": MU + 3 * math.sqrt(2), "std": 0.0}},
                 reliability={"event": "one-sided"})
    assert rare.whole_cycle_limit_state(one, MODEL).components[0].outputs == (("velocity",
                                                                                "max"),)


def test_a_limit_state_always_violated_is_a_stated_warning_and_never_violated_an_error():
    study = _study({"velocity": {"mean": 0.01, "std": 0.0}},
                   subset={"n_per_level": 100, "p0": 0.1}, **{"is": {"n": 100}})
    results, notes = _run(study, ["subset", "is"])
    assert results["subset"].pf == 1.0
    assert any(n.startswith("subset: P_f = 1: the limit state is always violated") for n in notes)
    assert any(n.startswith("subset: subset_simulation: 1 of the level-0 samples fail") and
               "not a rare event" in n for n in notes)
    never = _study({"velocity": {"mean": MU + 40.0, "std": 0.0}},
                   subset={"n_per_level": 100, "p0": 0.1, "max_levels": 2})
    with pytest.raises(StudyError, match=r"^<mapping>: subset \(subset_simulation\): "
                                         r"subset_simulation: level 2 reached max_levels = 2 .*"
                                         r"or the limit state is never violated"):
        _run(never, ["subset"])


def test_settings_the_method_rejects_when_it_runs_name_the_study_and_method():
    study = _study({"velocity": {"mean": 9.0, "std": 0.0}}, subset={"n_per_level": 15})
    with pytest.raises(StudyError, match=r"^<mapping>: subset \(subset_simulation\): p0: got "
                                         r"0\.1 with n_per_level = 15; allowed: 1/p0 and"):
        _run(study, ["subset"])


@pytest.mark.parametrize("section, message", [
    ({"subset": {"p0": 1.5}}, r"subset\.p0 = 1\.5: not a valid subset_simulation setting; "
                              r"allowed: a finite number in \(0, 1\)"),
    ({"subset": {"n_per_level": 5}}, r"subset\.n_per_level = 5: not a valid subset_simulation "
                                     r"setting; allowed: an integer > 9"),
    ({"form": {"scheme": "backward"}}, r"form\.scheme = \"backward\": not a valid form setting "
                                       r"\(finite-difference scheme\); allowed: \['central', "
                                       r"'forward'\]"),
    ({"is": {"n": 1}}, r"is\.n = 1: not a valid importance_sampling setting; allowed: an "
                       r"integer > 1"),
    ({"sorm": {"formula": "exact"}}, r"sorm\.formula = \"exact\""),
    ({"sorm": {"design_point": [1, 2]}}, r"sorm\.design_point = .*unknown field 'design_point'"),
    ({"subset": {"rho": 1.0}}, r"subset\.rho = 1\.0: .*allowed: a finite number in \[0, 1\)"),
    ({"subset": 3}, r"subset = 3: expected a table"),
])
def test_method_tables_are_checked_when_the_study_loads(section, message):
    with pytest.raises(StudyError, match=r"^<mapping>: " + message):
        _study({"velocity": {"mean": 9.0, "std": 0.0}}, **section)


def test_method_names_are_checked_on_the_command_line(capsys):
    with pytest.raises(SystemExit):
        main(["reliability", "nine-bar-lubricated", "--method", "subsets"])
    err = capsys.readouterr().err
    assert "invalid choice: 'subsets'" in err and "'subset'" in err and "'is'" in err


def test_reliability_command_runs_form_and_subset_on_the_mechanism(tmp_path, capsys):
    # slider-crank, one cycle, one input: the whole-cycle velocity error against a fixed
    # allowable, the extreme at the mean + 1σ clearance. The extreme grows with the clearance
    # (checked), so P_f = P(clearance > mean + σ) = Φ(−1) and FORM is exact in this 1-D
    # monotone case: β = 1, the design point at 0.55 mm, the output there at the allowable.
    from mechrel.uq import evaluate

    text = ('scene = "slider-crank-lubricated"\ncycles = 1\nquantities = ["velocity"]\n'
            '[scene_overrides]\n"solver.rtol" = 1e-5\n"solver.atol" = 1e-8\n'
            '[inputs.clearance]\npaths = ["joints.C.clearance"]\n'
            'distribution = "normal"\nmean = 0.5e-3\nstd = 0.05e-3\n'
            '[allowable.velocity]\nmean = ALLOW\nstd = 0.0\n'
            '[form]\nstep = 0.05\ntol = 1e-3\n'
            '[subset]\nn_per_level = 20\np0 = 0.5\nmax_levels = 4\n'
            '[reliability]\nseed = 3\nmethods = ["form", "subset"]\n')
    study_file = tmp_path / "study.toml"
    study_file.write_text(text.replace("ALLOW", "1.0"))
    model = load_study(str(study_file)).model()
    k = model.output_index.get_loc(("velocity", "max_abs"))
    ev = evaluate(model, np.array([[0.5e-3], [0.55e-3], [0.6e-3]]), n_jobs=1, progress=False)
    y0, y1, y2 = ev.Y[:, k]
    assert y0 < y1 < y2
    study_file.write_text(text.replace("ALLOW", repr(float(y1))))
    out = tmp_path / "out"
    assert main(["reliability", str(study_file), "--jobs", "1", "--out", str(out),
                 "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "  form (form): whole-cycle P_f" in printed
    assert "  subset (subset_simulation): whole-cycle P_f" in printed and "c.o.v." in printed
    # the verdict trusts the sampling method and checks FORM against its interval
    assert "whole cycle: trust subset" in printed and "whole cycle: form agrees" in printed
    table = pd.read_csv(out / "rare_events.csv", index_col="method")
    assert list(table.index) == ["form", "subset"]
    # FORM's surface criterion |g| ≤ 1e-3·|g(0)| on a near-linear g: |β − 1| ≈ 1e-3, plus the
    # integration noise; asserted to 1e-2
    assert table.loc["form", "beta"] == pytest.approx(1.0, abs=1e-2)
    dp = pd.read_csv(out / "design_point.csv", index_col=["method", "point", "input"])
    x_star = dp.loc[("form", 0, "clearance"), "x"]
    assert x_star == pytest.approx(0.55e-3, abs=1e-2 * 0.05e-3)
    assert dp.loc[("form", 0, "clearance"), "importance"] == pytest.approx(1.0)
    y_star = evaluate(model, np.array([[x_star]]), n_jobs=1, progress=False).Y[0, k]
    assert abs(y_star - y1) <= 2e-3 * abs(y1 - y0)
    # subset: P_f = Φ(−1) = 0.16 ≥ p0³ is reached within 3 levels of 20: within 3 c.o.v.
    sub = table.loc["subset"]
    assert abs(sub["pf"] - special.ndtr(-1.0)) <= 3 * sub["cov"] * sub["pf"]
    assert not (out / "reliability.csv").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["provenance"]["subset"]["method"] == "subset_simulation"
    assert summary["methods"] == ["form", "subset"]
    # one count of model evaluations: the methods' lines, the total line, the file agree
    counts = summary["evaluations"]
    for k in ("form", "subset"):
        c = counts[k]
        assert c["n_evaluations"] == table.loc[k, "n_evaluations"] == \
            summary["provenance"][k]["n_evaluations"]
        assert c["n_computed"] + c["n_cached"] == c["n_evaluations"]
        assert f"; {c['n_evaluations']} model evaluations ({c['n_computed']} computed" in printed
    total = counts["total"]
    assert total["n_evaluations"] == counts["form"]["n_evaluations"] + \
        counts["subset"]["n_evaluations"]
    assert f"  {total['n_evaluations']} model evaluations ({total['n_computed']} computed" in \
        printed


def test_nine_bar_script_finds_its_deepest_allowable_and_reads_the_levels():
    # studies/rare_events_ninebar.py on the analytic extreme 6 + x1 + x2: P(Y > I) = Φ(−(I−6)/√2)
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "studies" / "rare_events_ninebar.py"
    spec = importlib.util.spec_from_file_location("study_script_rare_events_ninebar", path)
    script = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = script
    spec.loader.exec_module(script)
    inputs = _study({"velocity": {"mean": 9.0, "std": 0.0}}).uncertain_inputs()
    common = {"n_jobs": 1, "cache": None, "progress": False}
    exact = lambda a: special.ndtr(-(np.asarray(a) - MU) / math.sqrt(2.0))  # noqa: E731
    allowable, res, tries = script.find_deepest(MODEL, inputs, "velocity", MU + 3.0,
                                                n_per_level=300, seed=11, common=common,
                                                target=1e-4)
    assert 1e-5 <= res.pf <= 1e-4 and tries[-1][1] == res.pf
    assert abs(res.pf - exact(allowable)) <= 3 * res.cov * res.pf
    # the intermediate levels: P(Y > y_i) = p0^(i+1) at y_i = I − b_i, each within 3 c.o.v.
    # (the cumulative Au–Beck c.o.v. up to that level)
    y, p = script.level_curve(res, allowable)
    cov = np.sqrt(np.cumsum(res.levels["cov"].to_numpy()[:-1] ** 2))
    assert len(y) >= 3 and np.all(np.diff(y) > 0)
    assert np.all(np.abs(p - exact(y)) <= 3 * cov * p)
