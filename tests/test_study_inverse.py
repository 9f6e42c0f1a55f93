"""The inverse question in study files, the study runner and ``mechrel reliability
--target-reliability``.

The mechanism case: the one-cycle lubricated slider-crank with one uncertain input, the
clearance c ~ N(0.5 mm, 0.05 mm); its velocity error's cycle extreme grows with c (checked on a
grid below), so the R_t-quantile of the extreme is the extreme at the clearance's quantile,
c_t = μ + σ Φ⁻¹(R_t): one simulation gives the exact answer.

Tolerances
----------
* Monte Carlo: the order-statistic interval holds with probability ≥ 95 % whatever the law (the
  seed is fixed); the estimate is an order statistic of the samples, exactly.
* Inverse FORM on a monotone one-input model: the most probable target point is u = Φ⁻¹(R_t)
  after one step, so the allowable is the extreme simulated at c_t: the same simulation,
  asserted to 1e-12 relative.
"""

from __future__ import annotations

import re

import json
import math
import tomllib

import numpy as np
import pandas as pd
import pytest
from scipy import special

from mechrel.cli.main import main
from mechrel.errors import StudyError
from mechrel.study import inverse
from mechrel.study.runner import reliability_results, run_reliability
from mechrel.study.study import load_study
from mechrel.uq import evaluate
from mechrel.uq.inverse import _INVERSE, INVERSE_METHODS, register_inverse
from mechrel.uq.inverse.order_statistics import order_statistic_ranks
from mechrel.uq.inverse.quantile import InverseEstimate
from mechrel.uq.estimators import Method, Setting

MEAN, STD = 0.5e-3, 0.05e-3
STUDY_TOML = """
scene = "slider-crank-lubricated"
cycles = 1
quantities = ["velocity"]
angle_step = 90.0
[scene_overrides]
"solver.rtol" = 1e-5
"solver.atol" = 1e-8
[inputs.clearance]
paths = ["joints.C.clearance"]
distribution = "normal"
mean = 0.5e-3
std = 0.05e-3
[allowable.velocity]
mean = 1.0
std = 0.2
[reliability]
seed = 5
n = 128
rule = "random"
methods = ["mc"]
[form]
step = 0.05
tol = 1e-3
"""
STUDY = tomllib.loads(STUDY_TOML)


@pytest.fixture(scope="module")
def exact():
    """The exact allowables at R_t = 0.9 and 0.95: the extreme at the clearance's quantile; the
    extreme rises with the clearance."""
    model = load_study(STUDY).model()
    k = model.output_index.get_loc(("velocity", "max_abs"))
    grid = MEAN + STD * np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    y = evaluate(model, grid[:, None], progress=False).Y[:, k]
    assert np.all(np.diff(y) > 0)
    at = MEAN + STD * special.ndtri(np.array([0.9, 0.95]))
    return dict(zip((0.9, 0.95), evaluate(model, at[:, None], progress=False).Y[:, k]))


def test_the_inverse_table_of_a_study_file_is_checked():
    s = load_study(STUDY)
    assert s.inverse == {"target": None, "methods": ("auto",)}
    s = load_study({**STUDY, "inverse": {"target": 0.999, "methods": ["subset", "form"]}})
    assert s.inverse == {"target": 0.999, "methods": ("subset", "form")}
    for table, message in [
            ({"target": 1.0}, r"<mapping>: inverse\.target = 1\.0: must be < 1; allowed: a "
                              r"finite number in \(0, 1\)"),
            ({"target": "high"}, r"inverse\.target = \"high\""),
            ({"methods": ["ml"]}, r"inverse\.methods\[0\] = \"ml\": unknown value; allowed: "
                                  r"one of mc, subset, form, auto"),
            ({"methods": []}, r"inverse\.methods = \[\]: not a non-empty array"),
            ({"tagret": 0.9}, r"inverse.*tagret")]:
        with pytest.raises(StudyError, match=message):
            load_study({**STUDY, "inverse": table})


def test_the_command_line_checks_the_target(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["reliability", "--target-reliability", "1"])
    assert exc.value.code == 2
    assert ("argument --target-reliability: 1: must be < 1; allowed: a finite number in (0, 1)"
            in capsys.readouterr().err)


def test_the_allowable_for_a_target_on_the_slider_crank(exact, tmp_path, capsys):
    f = tmp_path / "study.toml"
    f.write_text(STUDY_TOML + '[inverse]\nmethods = ["auto", "form"]\n', encoding="utf-8")
    out = tmp_path / "out"
    lines, results = run_reliability(load_study(str(f)), n_jobs=1, out=out, progress=False,
                                     target_reliability=0.9)
    r = results["inverse_mc"]
    # Monte Carlo: the forward run's 128 samples; the extreme rises with the clearance on them,
    # so the estimate and the interval are the extremes of the sorted clearances' ranks
    c = r.evaluations.X[:, 0]
    y = r.extremes.values(r.evaluations.Y)[:, 0]
    assert r.evaluations is results["mc"].evaluations
    assert np.all(np.diff(y[np.argsort(c)]) > 0)
    k, lo, hi = order_statistic_ranks(128, 0.9, 0.95)
    row = r.table.loc[("velocity", "velocity")]
    ys = np.sort(y)
    found = (row["allowable"], row["allowable_lo"], row["allowable_hi"])
    assert found == (ys[k - 1], ys[lo - 1], ys[hi - 1])
    cs, c_t = np.sort(c), MEAN + STD * special.ndtri(0.9)
    covered = row["allowable_lo"] <= exact[0.9] <= row["allowable_hi"]
    # (this seed's sample misses: 6 of its 128 clearances lie above c_t, 12.8 expected)
    assert covered == (cs[lo - 1] <= c_t <= cs[hi - 1])
    # FORM: the extreme at the clearance's quantile, the exact answer
    fo = results["inverse_form"].table.loc[("velocity", "velocity")]
    assert fo["allowable"] == pytest.approx(exact[0.9], rel=1e-12)
    # the whole cycle of one quantity: its allowable, as a factor on the study's 1.0 m/s
    whole = results["inverse_form"].table.loc[("all", "velocity")]
    assert whole["factor"] == pytest.approx(fo["allowable"])
    table = pd.read_csv(out / "inverse.csv")

    # the command line, on the same folder: every evaluation comes from the cache
    assert main(["reliability", str(f), "--target-reliability", "0.9", "--jobs", "1",
                 "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    # (the one count of issue 35: N evaluations, all N of them from the cache, none computed)
    assert re.search(r"  (\d+) model evaluations \(\1 from the cache\) in", printed)
    pd.testing.assert_frame_equal(pd.read_csv(out / "inverse.csv"), table)
    assert ("allowable for whole-cycle R = 0.9 (mc: the forward Monte Carlo's 128 samples, 95% "
            "intervals):") in printed
    assert "allowable for whole-cycle R = 0.9 (form:" in printed
    assert "(velocity 0.2 m/s) is not part of the inverse question" in printed
    assert ("allowable for R = 0.9: mc (its interval holds whatever the error's distribution)"
            in printed)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["target_reliability"] == 0.9 and set(summary["inverse"]) == {"mc", "form"}
    dp = summary["inverse"]["form"]["details"]["design_points"][0]
    assert dp["u"] == pytest.approx(special.ndtri(0.9))
    assert summary["provenance"]["inverse_mc"]["settings"]["rule"] == "user-supplied"
    # the reused samples are not listed twice among the run's evaluations
    assert "inverse_mc" not in summary["failures"]
    # a run without the target removes the earlier run's inverse.csv
    assert "inverse.csv" in reliability_results()
    run_reliability(load_study(str(f)), n_jobs=1, out=out, progress=False, methods=["fosm"])
    assert not (out / "inverse.csv").exists()
    assert "inverse" not in json.loads((out / "summary.json").read_text())


def test_a_registered_inverse_method_runs_from_the_study_file(exact, tmp_path):
    # the hook of the active-learning method: one function and one register_inverse call; here
    # the exact answer of a monotone one-input model, the extreme at the input's quantile
    def at_quantile(*, model, inputs, extremes, scalars, target, seed, confidence_level,
                    failures, max_failure_fraction, executor, shift=0.0):
        x = inputs.from_standard_normal(np.array([[special.ndtri(target) + shift]]))
        ev = evaluate(model, x, **executor)
        v = extremes.values(ev.Y)[0]
        q = pd.DataFrame({"value": [v[extremes.names.index(s)] for s in scalars],
                          "lo": math.nan, "hi": math.nan}, index=list(scalars))
        return InverseEstimate(q, (ev,), settings={"shift": shift})

    register_inverse(Method("at_quantile", at_quantile, InverseEstimate, "inverse",
                            "the extreme at the input's quantile", {"shift": Setting(0.0)},
                            short="quantile"))
    try:
        assert "quantile" in INVERSE_METHODS
        study = load_study({**STUDY, "inverse": {"target": 0.95, "methods": ["quantile"]},
                            "reliability": {**STUDY["reliability"], "methods": ["fosm"]}})
        lines, results = run_reliability(study, n_jobs=1, out=tmp_path / "o", progress=False)
    finally:
        _INVERSE.pop("quantile")
    r = results["inverse_quantile"]
    assert r.table.loc[("velocity", "velocity"), "allowable"] == pytest.approx(exact[0.95],
                                                                                rel=1e-12)
    head = "  allowable for whole-cycle R = 0.95 (quantile: 1 model evaluations"
    assert any(line.startswith(head) for line in lines)
    methods = pd.read_csv(tmp_path / "o" / "inverse.csv")["method"].tolist()
    assert methods == ["quantile", "quantile"]
    with pytest.raises(StudyError, match="'mc' is already registered"):
        register_inverse(INVERSE_METHODS["mc"])


def test_an_inverse_run_that_refuses_keeps_its_failed_samples(tmp_path, capsys):
    # clearances N(0.5 mm, 0.5 mm): 16 % are not positive, more than the 10 % allowed
    f = tmp_path / "study.toml"
    text = (STUDY_TOML.replace("std = 0.05e-3", "std = 0.5e-3")
            .replace('methods = ["mc"]', 'methods = ["fosm"]').replace("n = 128", "n = 64"))
    f.write_text(text + '[inverse]\ntarget = 0.5\nmethods = ["mc"]\n', encoding="utf-8")
    out = tmp_path / "out"
    assert main(["reliability", str(f), "--jobs", "1", "--out", str(out), "--no-progress"]) == 2
    assert "inverse_reliability (mc):" in capsys.readouterr().err
    failed = pd.read_csv(out / "failures.csv")
    assert set(failed["method"]) == {"inverse_mc"} and len(failed) > 6
    assert json.loads((out / "summary.json").read_text())["refused"]["method"] == "inverse_mc"


def test_the_studys_target_can_be_left_out_on_the_command_line(tmp_path, capsys):
    f = tmp_path / "study.toml"
    f.write_text(STUDY_TOML.replace('methods = ["mc"]', 'methods = ["fosm"]')
                 + "[inverse]\ntarget = 0.9\nmethods = [\"form\"]\n", encoding="utf-8")
    out = tmp_path / "out"
    assert main(["reliability", str(f), "--target-reliability", "none", "--jobs", "1",
                 "--out", str(out), "--no-progress"]) == 0
    assert "allowable for" not in capsys.readouterr().out
    assert not (out / "inverse.csv").exists()
    assert main(["reliability", str(f), "--jobs", "1", "--out", str(out), "--no-progress"]) == 0
    assert "allowable for whole-cycle R = 0.9 (form:" in capsys.readouterr().out
    assert (out / "inverse.csv").exists()


def test_methods_of_resolves_auto_with_the_runs_sample_count():
    s = load_study({**STUDY, "inverse": {"methods": ["auto", "subset", "form"]}})
    assert inverse.methods_of(s, 0.9, 128) == ["mc", "subset", "form"]
    assert inverse.methods_of(s, 0.99, 128) == ["subset", "form"]
