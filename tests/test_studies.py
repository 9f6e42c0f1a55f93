"""Study files and the reliability / sensitivity / accuracy commands."""

from __future__ import annotations

import json

import pytest

from mechrel.cli.main import main
from mechrel.errors import StudyError
from mechrel.scene import load_scene, scene_hash
from mechrel.studies.study import embedded_studies, load_study


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
    (_raw(sensitivty={}), r"sensitivty.*unknown field.*did you mean 'sensitivity'"),
    (_raw(quantities=["jerk"]), r"quantities.*'jerk' is not one of"),
    (_raw(angle_step=-18), r"angle_step.*-18.*must be > 0"),
    (_raw(allowable={"velocity": {"mean": "fast"}}), r"allowable\.velocity\.mean.*'fast'.*not a number"),
    (_raw(reliability={"methods": ["form"]}), r"reliability\.methods.*'form' is not one of"),
    (_raw(inputs={"c": {"paths": "joints.C1.clearance", "distribution": "normal", "mean": 1,
                        "std": 1}}), r"inputs\.c\.paths.*non-empty list"),
    ({"inputs": {}}, r"scene: missing required field"),
])
def test_invalid_study_fields_are_named(raw, message):
    with pytest.raises(StudyError, match=message):
        load_study(raw)


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
    summary = json.loads((out / "summary.json").read_text())
    prov = summary["provenance"]["fosm"]
    assert prov["n_model_evaluations"] == 3 and "model_cache_key" in prov
    # the scene it ran: its name, source and the hash of the scene with the study's overrides
    scene = load_scene("nine-bar-lubricated",
                       overrides={"solver.rtol": 1e-5, "solver.atol": 1e-8})
    assert prov["model"]["scene_hash"] == scene_hash(scene)
    assert prov["model"]["scene_source"] == "embedded:nine-bar-lubricated"
    assert prov["model"]["solver"]["rtol"] == 1e-5
    # a second run resumes from the evaluation cache: no simulation at all
    main(["reliability", str(study_file), "--method", "fosm", "--jobs", "1",
          "--out", str(out), "--no-progress"])
    assert "0 model evaluations" in capsys.readouterr().out
    again = json.loads((out / "summary.json").read_text())["provenance"]["fosm"]
    assert again["model"] == prov["model"]  # from the cache, the same account of the model


def test_bad_study_on_the_command_line_is_one_clear_error(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('scene = "nine-bar-lubricated"\n[inputs.x]\ndistribution = "normal"\n'
                   'mean = 1.0\nstd = -1.0\n')
    assert main(["reliability", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mechrel: error:") and "std" in err and "Traceback" not in err
