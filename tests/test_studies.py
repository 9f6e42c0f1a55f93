"""Study files and the reliability / sensitivity / accuracy commands."""

from __future__ import annotations

import importlib.util
import json
import math
import re
import sys
from pathlib import Path

import pandas as pd
import pytest

from mechrel.cli.main import main
from mechrel.errors import StudyError
from mechrel.scene import load_scene, scene_hash
from mechrel.study.study import embedded_studies, load_study


# slider-crank-lubricated, one cycle at the sampling tolerance: ~0.1 s per sample
SMALL_STUDY = """\
scene = "slider-crank-lubricated"
cycles = 1
[scene_overrides]
"solver.rtol" = 1e-5
"solver.atol" = 1e-8
"""
# clearance 0.2 ± 0.3 mm: a sample with clearance <= 0 cannot be simulated (a SceneError,
# recorded as the sample's failure without simulating), about a quarter of them
FAILING_INPUT = """\
[inputs.clearance]
paths = ["joints.C.clearance"]
distribution = "normal"
mean = 0.2e-3
std = 0.3e-3
"""


def _raw(**changes):
    raw = {"scene": "nine-bar-lubricated", "cycles": 1,
           "inputs": {"clearance": {"paths": ["joints.C1.clearance"], "distribution": "normal",
                                    "mean": 0.5e-3, "std": 0.02e-3}}}
    raw.update(changes)
    return raw


def test_default_study_loads_and_builds_its_model():
    assert "nine-bar-lubricated" in embedded_studies()
    study = load_study("nine-bar-lubricated")
    model = study.model()
    assert model.input_names == ("clearance", "viscosity", "speed")
    assert model.targets["speed"] == ["drivers.crank2.speed", "-drivers.crank1.speed"]
    assert model.scene.solver.rtol == 1e-5  # the study's scene_overrides reach the scene
    inputs = study.uncertain_inputs()
    assert inputs.names == model.input_names
    assert study.allowables()["displacement"].mean == 0.012


@pytest.mark.parametrize("raw, message", [
    (_raw(sensitivty={}), r"sensitivty = \{\}: unknown field 'sensitivty' for a study \(did you "
                          r"mean 'sensitivity'\?\); allowed: fields (\w+, )*allowable, angle_step"),
    (_raw(quantities=["jerk"]), r"quantities\[0\] = \"jerk\": unknown value; allowed: one of "
                                r"displacement, velocity, acceleration"),
    (_raw(angle_step=-18), r"angle_step = -18: must be > 0; allowed: a finite number > 0"),
    (_raw(allowable={"velocity": {"mean": "fast"}}),
     r"allowable\.velocity\.mean = \"fast\": expected a number, got a string; allowed: a "
     r"finite number > 0"),
    (_raw(reliability={"methods": ["directional"]}),
     r"reliability\.methods\[0\] = \"directional\": unknown value.*; allowed: one of fosm, mc, "
     r"pce, form, sorm, is, subset"),
    (_raw(inputs={"c": {"paths": "joints.C1.clearance", "distribution": "normal", "mean": 1,
                        "std": 1}}),
     r"inputs\.c\.paths = \"joints\.C1\.clearance\": not a non-empty array; allowed: a "
     r"non-empty array of dotted scene paths"),
    ({"inputs": {}}, r"scene: missing required field of a study; allowed: an embedded scene "
                     r"name or a path"),
])
def test_invalid_study_fields_are_named(raw, message):
    with pytest.raises(StudyError, match="^<mapping>: " + message):
        load_study(raw)


# Each wrong type or value: the field's full path, the value as written, and what is allowed.
# Before these checks most were a TypeError/ValueError from deep inside, a silent truncation
# (n = 8.9 ran 8 samples) or a late message without the field's path.
@pytest.mark.parametrize("changes, message", [
    ({"allowable": 5}, r"allowable = 5: expected a table, got a number; allowed: "
                       r"\[allowable\.QUANTITY\] tables with mean and std"),
    ({"allowable": {"velocity": 5}}, r"allowable\.velocity = 5: expected a table, got a number; "
                                     r"allowed: a table with mean and std"),
    ({"allowable": {"velocity": {"std": math.inf}}},
     r"allowable\.velocity\.std = inf: not a finite number; allowed: a finite number >= 0"),
    ({"reliability": 5}, r"reliability = 5: expected a table, got a number; allowed: a table"),
    ({"sensitivity": 5}, r"sensitivity = 5: expected a table, got a number; allowed: a table"),
    ({"scene_overrides": 5}, r"scene_overrides = 5: expected a table, got a number; allowed: a "
                             r"table of dotted scene paths and values"),
    ({"quantities": 5}, r"quantities = 5: not a non-empty array; allowed: a non-empty array of "
                        r"distinct values from displacement, velocity, acceleration"),
    ({"quantities": "velocity"}, r"quantities = \"velocity\": not a non-empty array; allowed"),
    ({"quantities": ["velocity", "velocity"]}, r"quantities = \[\"velocity\", \"velocity\"\]: a "
                                               r"value is repeated; allowed"),
    ({"reliability": {"methods": "mc"}},
     r"reliability\.methods = \"mc\": not a non-empty array; allowed: a non-empty array of "
     r"distinct values from fosm, mc, pce"),
    ({"reliability": {"methods": []}}, r"reliability\.methods = \[\]: not a non-empty array"),
    ({"reliability": {"pce_order": "three"}},
     r"reliability\.pce_order = \"three\": expected an integer, got a string; allowed: an "
     r"integer >= 1"),
    ({"reliability": {"pce_order": 2.7}}, r"reliability\.pce_order = 2\.7: expected an integer"),
    ({"reliability": {"pce_order": 0}}, r"reliability\.pce_order = 0: must be >= 1"),
    ({"reliability": {"n": 8.9}}, r"reliability\.n = 8\.9: expected an integer, got a number; "
                                  r"allowed: an integer >= 2"),
    ({"reliability": {"n": 0.5}}, r"reliability\.n = 0\.5: expected an integer"),
    ({"sensitivity": {"n": "x"}}, r"sensitivity\.n = \"x\": expected an integer, got a string; "
                                  r"allowed: an integer >= 2"),
    ({"reliability": {"event": "both-sided"}},
     r"reliability\.event = \"both-sided\": unknown value \(did you mean 'two-sided'\?\); "
     r"allowed: one of one-sided, two-sided"),
    # the key's old name (it clashed with the method FORM): one error naming the new key
    ({"reliability": {"form": "one-sided"}},
     r"reliability\.form = \"one-sided\": renamed: the key is now event \(the name form "
     r"clashed with the method FORM\); allowed: reliability\.event = one of 'one-sided', "
     r"'two-sided'"),
    ({"reliability": {"rule": "halton"}}, r"reliability\.rule = \"halton\": unknown value; "
                                          r"allowed: one of random, latin_hypercube, sobol"),
    ({"reliability": {"seed": -1}}, r"reliability\.seed = -1: must be >= 0; allowed: an "
                                    r"integer >= 0"),
    ({"sensitivity": {"seed": 1.5}}, r"sensitivity\.seed = 1\.5: expected an integer"),
    ({"reliability": {"max_failure_fraction": 1.5}},
     r"reliability\.max_failure_fraction = 1\.5: must be <= 1; allowed: a finite number in "
     r"\[0, 1\]"),
    ({"sensitivity": {"max_failure_fraction": -0.1}},
     r"sensitivity\.max_failure_fraction = -0\.1: must be >= 0"),
    ({"angle_step": math.inf}, r"angle_step = inf: not a finite number; allowed: a finite "
                               r"number > 0 \(degrees\)"),
    ({"angle_step": 7}, r"angle_step = 7: does not divide 360 degrees; allowed: a divisor of 360"),
    # every float quotient that large is a whole number: 1e-300 "divided" 360, then the
    # model's 3.6e302 angles ended in NumPy's "Maximum allowed size exceeded"
    ({"angle_step": 1e-300}, r"angle_step = 1e-300: 3\.6e\+302 angles a cycle; allowed: a "
                             r"divisor of 360 \(degrees\) >= 0\.001 \(at most 360000 angles a "
                             r"cycle\), e\.g\. 18, 10 or 5$"),
    ({"cycles": 1.5}, r"cycles = 1\.5: expected an integer, got a number; allowed: an integer "
                      r">= 1"),
    ({"correlation": {"clearance,speed": 0.5}},
     r"correlation\.\"clearance,speed\" = 0\.5: not a pair of two input names; allowed"),
    ({"inputs": {"clearance": {"paths": ["joints.C1.clearance"], "distribution": "normal",
                               "mean": 5e-4, "std": 2e-5},
                 "again": {"paths": ["-joints.C1.clearance"], "distribution": "normal",
                           "mean": 5e-4, "std": 2e-5}}},
     r"inputs\.again\.paths = \[\"-joints\.C1\.clearance\"\]: scene path "
     r"'joints\.C1\.clearance' is also set by inputs\.clearance; allowed: each scene path set "
     r"by one input only"),
])
def test_wrong_types_and_values_name_field_value_and_allowed(changes, message):
    with pytest.raises(StudyError, match="^<mapping>: " + message):
        load_study(_raw(**changes))


def test_study_file_errors_name_the_file(tmp_path):
    bad = tmp_path / "latin1.toml"
    bad.write_bytes('scene = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(StudyError, match=f"^{re.escape(str(bad))}: the file is not UTF-8 text "
                                         r".*; allowed: a UTF-8 TOML file"):
        load_study(bad)
    study_file = tmp_path / "bom.toml"
    study_file.write_bytes(b"\xef\xbb\xbf" + (SMALL_STUDY + FAILING_INPUT).encode())  # BOM skipped
    assert load_study(study_file).scene == "slider-crank-lubricated"
    study_file.write_text(SMALL_STUDY + FAILING_INPUT + '[reliability]\nrule = "halton"\n')
    with pytest.raises(StudyError, match=f"^{re.escape(str(study_file))}: reliability\\.rule"):
        load_study(study_file)


def test_study_settings_are_filled_in_when_loaded():
    study = load_study(_raw(reliability={"methods": ["mc"], "max_failure_fraction": 0.25}))
    assert study.reliability == {"methods": ("mc",), "event": "two-sided", "n": 256,
                                 "rule": "sobol", "seed": None, "pce_order": 2,
                                 "pce_max_evaluations": 100_000,
                                 "max_failure_fraction": 0.25}
    assert study.sensitivity == {"n": 256, "seed": None, "max_failure_fraction": 0.05}


def test_a_study_without_quantities_analyses_those_of_its_output_kind():
    # the rocker is a body output: its quantities are the angle and its rates, not a point's
    # displacement, velocity and acceleration (which the study defaulted to, so that a study
    # of a body output without `quantities` failed with "quantities: ['displacement', ...]
    # must be a non-empty subset of ['angle', ...]")
    base = {"scene": "four-bar", "output": "rocker",
            "inputs": {"c": {"paths": ["joints.B.clearance"], "distribution": "normal",
                             "mean": 0.2e-3, "std": 0.02e-3}}}
    given = {"angle": {"mean": 4e-3}, "angular_velocity": {"mean": 2.0},
             "angular_acceleration": {"mean": 3e3}}
    study = load_study({**base, "allowable": given})
    assert study.quantities == ("angle", "angular_velocity", "angular_acceleration")
    assert study.model().quantities == study.quantities
    assert study.allowables()["angle"].mean == 4e-3
    # a quantity without a default allowable needs one: named at load, not a KeyError later
    with pytest.raises(StudyError, match=r"^<mapping>: allowable\.angular_velocity: missing: this "
                       r"quantity has no default allowable; allowed: \[allowable\."
                       r"angular_velocity\] with mean > 0 \(rad/s\) and std >= 0$"):
        load_study({**base, "allowable": {"angle": {"mean": 4e-3}}})
    # the point output (the scene's first) keeps the three point quantities and their defaults
    tip = load_study({**base, "output": "tip"})
    assert tip.quantities == ("displacement", "velocity", "acceleration")
    assert load_study("nine-bar-lubricated").quantities == tip.quantities


def test_input_path_that_is_not_in_the_scene_is_named():
    raw = _raw(inputs={"c": {"paths": ["joints.C9.clearance"], "distribution": "normal",
                             "mean": 1e-3, "std": 1e-4}})
    with pytest.raises(StudyError, match=r"'joints\.C9\.clearance' is not a value of the scene"):
        load_study(raw).model()


def test_reliability_command_writes_tables_figure_and_provenance(tmp_path, capsys):
    # FOSM only (2d + 1 = 3 simulations of a quarter... one cycle): the command end to end.
    study_file = tmp_path / "study.toml"
    study_file.write_text(
        'scene = "nine-bar-lubricated"\ncycles = 1\n'
        '[scene_overrides]\n"solver.rtol" = 1e-5\n"solver.atol" = 1e-8\n'
        '[inputs.clearance]\npaths = ["joints.C1.clearance", "joints.C2.clearance"]\n'
        'distribution = "normal"\nmean = 0.5e-3\nstd = 0.02e-3\n')
    out = tmp_path / "out"
    rc = main(["reliability", str(study_file), "--method", "fosm", "--jobs", "1",
               "--out", str(out), "--no-progress"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "FOSM min R" in text and "3 model evaluations" in text
    for name in ("reliability.csv", "reliability.png", "summary.json"):
        assert (out / name).is_file()
    # the β printed beside an R is that R's index Φ⁻¹(R) (two-sided R here, the default
    # form), not the paper's one-sided β: checked against the table's R to the 3 printed decimals
    from scipy.special import ndtri
    table = pd.read_csv(out / "reliability.csv")
    found = re.findall(r"^  (\w+): +FOSM min R \S+ at (\S+)° "
                       r"\(β = Φ⁻¹\(R\) = (\S+), two-sided\)$", text, flags=re.M)
    # one line per quantity, each checked (the pattern once matched no line, so that the
    # loop below checked nothing)
    assert [f[0] for f in found] == ["displacement", "velocity", "acceleration"]
    for q, angle, beta in found:
        angles = pd.to_numeric(table["crank_angle"], errors="coerce")  # "max", ...: NaN
        row = table[(table["quantity"] == q) & (angles == float(angle))]
        assert abs(float(beta) - ndtri(float(row["fosm.reliability"].iloc[0]))) <= 5e-4
    summary = json.loads((out / "summary.json").read_text())
    prov = summary["provenance"]["fosm"]
    assert prov["n_evaluations"] == 3 and "model_cache_key" in prov
    # the scene it ran: its name, source and the hash of the scene with the study's overrides
    scene = load_scene("nine-bar-lubricated",
                       overrides={"solver.rtol": 1e-5, "solver.atol": 1e-8})
    assert prov["model"]["scene_hash"] == scene_hash(scene)
    assert prov["model"]["scene_source"] == "embedded:nine-bar-lubricated"
    assert prov["model"]["solver"]["rtol"] == 1e-5
    # a second run resumes from the evaluation cache: no simulation at all
    main(["reliability", str(study_file), "--method", "fosm", "--jobs", "1",
          "--out", str(out), "--no-progress"])
    assert "  3 model evaluations (3 from the cache) in " in capsys.readouterr().out
    again = json.loads((out / "summary.json").read_text())["provenance"]["fosm"]
    assert (again["n_evaluations"], again["n_computed"], again["n_cached"]) == (3, 0, 3)
    assert again["model"] == prov["model"]  # from the cache, the same account of the model


def test_bad_study_on_the_command_line_is_one_clear_error(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('scene = "nine-bar-lubricated"\n[inputs.x]\ndistribution = "normal"\n'
                   'mean = 1.0\nstd = -1.0\n')
    assert main(["reliability", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mechrel: error:") and "std" in err and "Traceback" not in err


@pytest.mark.parametrize("command", ["reliability", "sensitivity"])
@pytest.mark.parametrize("option, value, message", [
    ("--n", "0", r"argument --n: 0: must be >= 2; allowed: an integer >= 2 \(a sample count\)"),
    ("--n", "1", r"argument --n: 1: must be >= 2"),  # was: passed here, failed late
    ("--n", "1.5", r"argument --n: 1\.5: expected an integer, got a number"),
    ("--max-failure-fraction", "1.5", r"argument --max-failure-fraction: 1\.5: must be <= 1; "
                                      r"allowed: a finite number in \[0, 1\]"),
    ("--max-failure-fraction", "x", r"argument --max-failure-fraction: \"x\": expected a "
                                    r"number, got a string"),
])
def test_command_line_values_are_checked(command, option, value, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "nine-bar-lubricated", option, value, "--out", str(tmp_path / "o")])
    assert info.value.code == 2
    assert re.search(message, capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("command", ["reliability", "sensitivity"])
def test_out_that_is_a_file_is_one_clear_error_before_running(command, tmp_path, capsys):
    study_file = tmp_path / "study.toml"
    study_file.write_text(SMALL_STUDY + FAILING_INPUT)
    taken = tmp_path / "taken"
    taken.write_text("not a folder")
    assert main([command, str(study_file), "--out", str(taken), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err == (f"mechrel: error: out = '{taken}': an existing file, not a folder; "
                   "allowed: a folder (created if missing)\n")


def test_study_errors_come_before_any_simulation(tmp_path, capsys):
    study_file = tmp_path / "study.toml"
    study_file.write_text(SMALL_STUDY + FAILING_INPUT + '[reliability]\nrule = "halton"\n')
    out = tmp_path / "out"
    assert main(["reliability", str(study_file), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"mechrel: error: {study_file}: reliability.rule = \"halton\"")
    assert not out.exists()  # nothing ran: no output folder, no evaluation cache


def _failing_study(tmp_path, extra=""):
    study_file = tmp_path / "failing.toml"
    study_file.write_text(SMALL_STUDY + FAILING_INPUT + extra)
    study = load_study(study_file)
    return study_file, study.uncertain_inputs()


def test_refused_monte_carlo_writes_the_failures_and_says_how_to_proceed(tmp_path, capsys):
    from mechrel.uq import monte_carlo_design

    study_file, inputs = _failing_study(tmp_path, "[reliability]\nn = 16\nseed = 1\n")
    failing = monte_carlo_design(inputs, n=16, rule="sobol", seed=1)[:, 0] <= 0
    assert failing.sum() / 16 > 0.1  # more than the default max_failure_fraction
    out = tmp_path / "out"
    argv = ["reliability", str(study_file), "--method", "mc", "--jobs", "1", "--out", str(out),
            "--no-progress"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"mechrel: error: monte_carlo: {failing.sum()} of 16 samples failed")
    assert f"Wrote {out}/failures.csv" in err and "--max-failure-fraction" in err
    failures = pd.read_csv(out / "failures.csv")
    assert list(failures.columns) == ["method", "sample", "clearance", "reason"]
    assert (failures["method"] == "mc").all()
    assert failures["sample"].tolist() == list(failing.nonzero()[0])
    assert failures["reason"].str.startswith("SceneError: <mapping>: joints.C.clearance = #").all()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["refused"]["method"] == "mc"
    assert summary["failures"]["mc"]["n_failed"] == failing.sum()
    assert not (out / "reliability.csv").exists()

    # raised knowingly on the command line: the estimate over the successful samples, and the
    # failures still written and printed by reason (from the cache: no sample runs again)
    assert main(argv + ["--max-failure-fraction", "0.5"]) == 0
    text = capsys.readouterr().out
    assert (f"failed samples (mc, left out of its estimate): {failing.sum()} of 16 samples "
            f"failed ({failing.sum()}× SceneError:") in text
    assert f"  16 model evaluations (16 from the cache, {failing.sum()} failed) in " in text
    assert len(pd.read_csv(out / "failures.csv")) == failing.sum()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_failure_fraction"] == 0.5 and "refused" not in summary
    assert (out / "reliability.csv").is_file()


def test_study_file_sets_the_failure_threshold_and_pce_prints_its_dropped_samples(tmp_path,
                                                                                 capsys):
    from mechrel.uq import pce_design

    extra = "[reliability]\nmethods = ['pce']\npce_order = 1\nseed = 1\n"
    study_file, inputs = _failing_study(tmp_path, extra)
    X, _ = pce_design(inputs, order=1, seed=1)
    n_failing = int((X[:, 0] <= 0).sum())
    assert n_failing / len(X) > 0.1
    argv = ["reliability", str(study_file), "--jobs", "1", "--out", str(tmp_path / "out"),
            "--no-progress"]
    assert main(argv) == 2
    assert "polynomial_chaos: " in capsys.readouterr().err
    study_file.write_text(SMALL_STUDY + FAILING_INPUT + extra + "max_failure_fraction = 0.5\n")
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert f"failed samples (pce, left out of its estimate): {n_failing} of {len(X)}" in text


def test_refused_sensitivity_writes_its_failures(tmp_path, capsys):
    from mechrel.uq import sobol_design

    study_file, inputs = _failing_study(tmp_path, "[sensitivity]\nn = 4\nseed = 1\n")
    failing = sobol_design(inputs, n=4, seed=1)[:, 0] <= 0
    out = tmp_path / "out"
    assert main(["sensitivity", str(study_file), "--jobs", "1", "--out", str(out),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mechrel: error: sobol_indices: ") and "[sensitivity]" in err
    failures = pd.read_csv(out / "sensitivity_failures.csv")
    assert (failures["method"] == "sobol").all() and len(failures) == failing.sum()
    summary = json.loads((out / "sensitivity.json").read_text())
    assert summary["refused"]["method"] == "sobol"
    assert summary["failures"]["sobol"]["n_failed"] == failing.sum()


STUDY_SCRIPTS = Path(__file__).resolve().parents[1] / "studies"


def _script(name):
    spec = importlib.util.spec_from_file_location(f"study_script_{name}",
                                                  STUDY_SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it executes
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", ["fosm_vs_mc", "sensitivity", "reliability_paper",
                                  "bearing_models"])
@pytest.mark.parametrize("cycles", ["0", "1.5"])
def test_study_scripts_report_errors_in_one_line(name, cycles, tmp_path, capsys):
    argv = ["--cycles", cycles, "--quick", "--out", str(tmp_path), "--no-progress"]
    assert _script(name).main(argv) == 2
    err = capsys.readouterr().err  # "PROG: error: ...", PROG from sys.argv[0] as argparse's
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.endswith(f": error: cycles: {float(cycles)!r} must be a whole number of cycles "
                        ">= 1 (the last whole cycle is analysed)\n")


def test_study_script_cases_are_checked_by_argparse(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:  # before: lub-3pi ran, then a KeyError for bogus
        _script("fosm_vs_mc").main(["--cases", "lub-3pi,bogus", "--out", str(tmp_path)])
    assert info.value.code == 2
    assert ("argument --cases: unknown case 'bogus'; allowed: comma-separated cases from "
            "dry-3pi, lub-3pi") in capsys.readouterr().err


def test_the_embedded_design_study_asks_for_the_largest_clearance(capsys):
    # `mechrel design` with no STUDY runs it; its model is the default study's (same inputs and
    # scene), its allowables fixed, its one variable the clearance input's mean
    from mechrel.cli.main import main

    assert "nine-bar-clearance-design" in embedded_studies()
    study = load_study("nine-bar-clearance-design")
    default = load_study("nine-bar-lubricated")
    assert study.model().cache_key() == default.model().cache_key()
    assert study.uncertain_inputs().names == default.uncertain_inputs().names
    assert all(std == 0.0 for _, std in study.allowable.values())
    d = study.design
    assert (d["cost"], d["sense"], d["method"]) == ("c", "maximize", "ak")
    assert d["variables"]["c"]["kind"] == "mean" and d["variables"]["c"]["input"] == "clearance"
    assert d["constraints"] == [{"basis": "whole-cycle", "quantity": "all", "reliability": 0.999}]
    with pytest.raises(SystemExit):
        main(["design", "--help"])
    assert "nine-bar-clearance-design" in " ".join(capsys.readouterr().out.split())
