"""The promise of the method registry: a new method touches at most three files.

Here it touches none of mechrel's: the method is one module (the estimator and its result,
written below in this test file) and one :func:`~mechrel.uq.estimators.register` call, and it
runs through :func:`~mechrel.study.runner.run_reliability` and ``mechrel reliability
--method KEY``, its settings read from the study file's table of its key, its result written.

Tolerances
----------
* The mechanism case is the one of ``test_study_rare_events``: one input, a monotone cycle
  extreme, the allowable at the output of the mean + 1σ clearance, so P_f = Φ(−1) exactly;
  crude sampling of n points is asserted within 4 binomial standard deviations
  4·sqrt(P(1 − P)/n) of it (a false alarm every 16 000 seeds; the seed is fixed anyway).
* The same seed gives the same sample: the run through the CLI and the run through Python
  agree bitwise.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
import pytest
from scipy import special

from mechrel._checks import ARGS
from mechrel.cli.main import main
from mechrel.errors import StudyError
from mechrel.study.runner import run_reliability
from mechrel.study.study import load_study, study_methods
from mechrel.uq import evaluate
from mechrel.uq.estimators import _METHODS, Method, Setting, register
from mechrel.uq.estimators._problem import Problem, RareEventResult
from mechrel.uq.problem.inputs import as_seed_sequence


# ----------------------------------------------------------------- the new method's module ---
@dataclass(frozen=True)
class CrudeResult(RareEventResult):
    """Crude sampling of the limit state: ``table`` (one row) with ``pf``, ``beta``, ``cov``,
    ``pf_lo``, ``pf_hi`` (4σ binomial), ``n_evaluations``."""

    table: pd.DataFrame
    evaluations: Any
    provenance: dict = field(repr=False)
    warnings: tuple = ()


def crude_sampling(*, model: Any, inputs: Any, limit_state: Any = None, seed: Any = None,
                   n: int = 64, n_jobs: int = 1, backend: str = "loky", cache: Any = None,
                   progress: bool = True, chunk_size: int | None = None) -> CrudeResult:
    """P_f = P(g ≤ 0) by ``n`` standard normal samples of the limit state."""
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, n_jobs=n_jobs,
                      backend=backend, cache=cache, progress=progress, chunk_size=chunk_size,
                      what="crude_sampling")
    rng = np.random.default_rng(as_seed_sequence(seed))
    g, ok, _ = problem.g(rng.standard_normal((n, problem.d)))
    pf = float(np.mean(g[ok] <= 0))
    sd = np.sqrt(pf * (1 - pf) / ok.sum())
    table = pd.DataFrame({"pf": [pf], "beta": [-special.ndtri(pf)],
                          "cov": [sd / pf if pf > 0 else np.inf], "pf_lo": [max(pf - 4 * sd, 0)],
                          "pf_hi": [min(pf + 4 * sd, 1)], "n_evaluations": [problem.n_evaluations]},
                         index=pd.Index([limit_state.name], name="limit_state"))
    return CrudeResult(table, problem.all_evaluations(),
                       problem.provenance(method="crude_sampling", seed=seed, settings={"n": n}))


def _count(name, value):
    return ARGS.sample_count(name, value)


CRUDE = Method("crude_sampling", crude_sampling, CrudeResult, "rare_event",
               "crude sampling of the limit state", {"n": Setting(64, _count, "samples")},
               short="crude")
# ------------------------------------------------------------------------------------------


@pytest.fixture
def crude():
    register(CRUDE)
    # the same estimator as a method of a kind the runner has no presenter for: its table is
    # written to its own file
    register(Method("crude_table", crude_sampling, CrudeResult, "demo", "the same, tabulated",
                    {"n": Setting(64, _count)}))
    yield
    _METHODS.pop("crude_sampling")
    _METHODS.pop("crude_table")


STUDY = ('scene = "slider-crank-lubricated"\ncycles = 1\nquantities = ["velocity"]\n'
         '[scene_overrides]\n"solver.rtol" = 1e-5\n"solver.atol" = 1e-8\n'
         '[inputs.clearance]\npaths = ["joints.C.clearance"]\n'
         'distribution = "normal"\nmean = 0.5e-3\nstd = 0.05e-3\n'
         '[allowable.velocity]\nmean = ALLOW\nstd = 0.0\n'
         '[crude]\nn = 48\n'
         '[reliability]\nseed = 5\nmethods = ["crude"]\n')


@pytest.fixture
def study_file(tmp_path, crude):
    """The slider-crank study with the allowable at the output of the mean + 1σ clearance:
    P_f = Φ(−1) (the extreme grows with the clearance, checked)."""
    f = tmp_path / "study.toml"
    f.write_text(STUDY.replace("ALLOW", "1.0"))
    model = load_study(str(f)).model()
    k = model.output_index.get_loc(("velocity", "max_abs"))
    y = evaluate(model, np.array([[0.5e-3], [0.55e-3], [0.6e-3]]), n_jobs=1, progress=False).Y[:, k]
    assert y[0] < y[1] < y[2]
    f.write_text(STUDY.replace("ALLOW", repr(float(y[1]))))
    return f


def test_a_registered_method_is_a_study_method_and_a_cli_choice(crude, capsys):
    assert study_methods()["crude"] is CRUDE
    with pytest.raises(SystemExit):
        main(["reliability", "--help"])
    assert "crude" in capsys.readouterr().out.split("--method")[1]


def test_a_registered_method_runs_through_the_cli_with_its_study_settings(study_file, tmp_path,
                                                                          capsys):
    out = tmp_path / "cli"
    assert main(["reliability", str(study_file), "--method", "crude", "--jobs", "1",
                 "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "  crude (crude_sampling): whole-cycle P_f" in printed
    # the verdict treats it like any sampling method: trusted (the only estimate), with why
    assert "whole cycle: trust crude" in printed and "a sampling method" in printed
    table = pd.read_csv(out / "rare_events.csv", index_col="method")
    assert list(table.index) == ["crude"]
    row = table.loc["crude"]
    assert row["n_evaluations"] == 48  # the study file's [crude] n
    p = special.ndtr(-1.0)
    assert abs(row["pf"] - p) <= 4 * np.sqrt(p * (1 - p) / 48)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["provenance"]["crude"]["method"] == "crude_sampling"
    assert not (out / "reliability.csv").exists()  # no per-angle method ran

    # the same run from Python: the same numbers, bitwise
    lines, results = run_reliability(load_study(str(study_file)), methods=["crude"], n_jobs=1,
                                     out=tmp_path / "py", progress=False)
    again = pd.read_csv(tmp_path / "py" / "rare_events.csv", index_col="method")
    assert again.drop(columns="wall_time").equals(table.drop(columns="wall_time"))
    assert results["crude"].pf == row["pf"]


def test_a_method_of_a_new_kind_gets_its_table_written(study_file, tmp_path):
    study = load_study(str(study_file), overrides={"reliability.methods": ["crude_table"]})
    lines, results = run_reliability(study, n_jobs=1, out=tmp_path / "o", progress=False)
    table = pd.read_csv(tmp_path / "o" / "crude_table.csv")
    assert table["pf"].iloc[0] == results["crude_table"].pf
    assert table["n_evaluations"].iloc[0] == 64  # the registry's default: no [crude_table]
    assert "  crude_table: 64 model evaluations (64 computed), table in crude_table.csv" in lines


def test_a_per_angle_method_joins_the_reliability_table(study_file, tmp_path):
    # Monte Carlo's function registered once more as a "reliability" method with its own n:
    # called with the study's allowables and event, its table joins reliability.csv under its
    # key, and it equals Monte Carlo's own columns (same function, seed and samples)
    from mechrel.uq import MonteCarloResult, monte_carlo

    register(Method("mc_copy", monte_carlo, MonteCarloResult, "reliability", "a copy",
                    {"n": Setting(16, _count), "rule": Setting("sobol")}))
    try:
        study = load_study(str(study_file), overrides={"reliability.methods": ["mc", "mc_copy"],
                                                       "reliability.n": 16})
        lines, results = run_reliability(study, n_jobs=1, out=tmp_path / "o", progress=False)
    finally:
        _METHODS.pop("mc_copy")
    table = pd.read_csv(tmp_path / "o" / "reliability.csv")
    mine = table[[c for c in table.columns if c.startswith("mc_copy.")]]
    theirs = table[[c for c in table.columns if c.startswith("mc.")]]
    assert mine.shape[1] > 0
    assert np.array_equal(mine.to_numpy(), theirs.to_numpy(), equal_nan=True)
    assert any("mc_copy min R" in line for line in lines)


def test_a_registered_methods_settings_are_checked_in_the_study_file(crude):
    raw = {"scene": "slider-crank-lubricated", "inputs": {"clearance": {
        "paths": ["joints.C.clearance"], "distribution": "normal", "mean": 0.5e-3,
        "std": 0.05e-3}}, "crude": {"n": 1}}
    with pytest.raises(StudyError, match=r"crude\.n = 1: not a valid crude_sampling setting "
                                         r"\(samples\)"):
        load_study(raw)
    raw["crude"] = {"m": 3}
    with pytest.raises(StudyError, match=r"crude"):
        load_study(raw)


def test_every_registered_estimator_returns_a_result_with_its_evaluation_count():
    # one interface: keyword-only calls, and a result with .to_frame(), .provenance,
    # .warnings and .n_evaluations (the rows its model evaluations sent to the executor)
    from mechrel.uq import METHODS, Allowable, FunctionModel, LimitState, Normal, UncertainInputs
    from mechrel.uq.estimators.protocols import Result

    inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    model = FunctionModel(lambda X: 2.0 - X[:, 0] - 0.5 * X[:, 1], ["x1", "x2"], ["g"],
                          vectorized=True)
    calls = {"fosm": {"allowable": Allowable(1.0, 0.0)},
             "monte_carlo": {"n": 64, "allowable": Allowable(1.0, 0.0)},
             "polynomial_chaos": {"order": 1},
             "sobol_indices": {"n": 64},
             "form": {}, "sorm": {}, "importance_sampling": {"n": 100},
             "subset_simulation": {"n_per_level": 100},
             "active_learning": {"tolerance": 0.5}}
    assert set(calls) <= set(METHODS)
    for name, settings in calls.items():
        r = METHODS[name](model=model, inputs=inputs, seed=1, progress=False, **settings)
        assert isinstance(r, Result), name
        assert r.n_evaluations == r.evaluations.n, name
        assert isinstance(r.to_frame(), pd.DataFrame) and isinstance(r.warnings, tuple), name
    r = METHODS["monte_carlo"](model=model, inputs=inputs, seed=1, progress=False, n=64,
                               limit_state=LimitState.margin())
    assert isinstance(r, Result) and r.n_evaluations == 64
    r = METHODS["fosm"](model=model, inputs=inputs, progress=False,
                        limit_state=LimitState.margin())
    assert isinstance(r, Result) and r.n_evaluations == 5


@pytest.mark.parametrize("name", ["form", "sorm", "importance_sampling", "subset_simulation",
                                  "active_learning"])
def test_the_rare_event_methods_refuse_precomputed_evaluations(name):
    # the shared interface has evaluations=; a method that chooses its points as it goes says
    # why it cannot use them instead of a TypeError
    from mechrel.uq import METHODS, Normal, UncertainInputs, evaluate, linear_model

    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    model = linear_model([3.0], [[-1.0]], ["x"])
    ev = evaluate(model, np.zeros((2, 1)), progress=False)
    with pytest.raises(StudyError, match=rf"^{name}: evaluations = Evaluations: precomputed "
                                         r"evaluations cannot be used, the method chooses its "
                                         r"points as it goes; allowed: model= and inputs="):
        METHODS[name](model=model, inputs=inputs, evaluations=ev)
