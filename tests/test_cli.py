"""The `mechrel` command: simulate, scenes, help and error reporting."""

from __future__ import annotations

import json

import pandas as pd
from pathlib import Path
import pytest

from mechrel.cli.main import main
from mechrel.errors import MechrelError


def test_simulate_writes_table_figure_and_provenance(tmp_path, capsys):
    out = tmp_path / "sc.csv"
    assert main(["simulate", "slider-crank", "--out", str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "scene slider-crank (kinematics)" in text and "stroke 100.000 mm" in text
    frame = pd.read_csv(out)
    assert list(frame.columns[:3]) == ["time", "crank_angle", "slider.displacement"]
    assert out.with_suffix(".png").is_file()
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["provenance"]["scene"] == "slider-crank" and "scene_hash" in meta["provenance"]
    assert meta["warnings"] == []


def test_simulate_names_the_drift_of_the_ideal_joints_in_one_line(tmp_path, capsys):
    # a run whose ideal joints drift by clearances (DOPRI5 at rtol 1e-3) is printed and
    # written, with the warning once on stderr and in the provenance file
    out = tmp_path / "drift.csv"
    assert main(["simulate", "slider-crank-dry", "--set", "solver.rtol=1e-3", "--set",
                 "analysis.cycles=1", "--out", str(out), "--no-progress"]) == 0
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line]
    assert len(lines) == 1 and lines[0].startswith(
        "mechrel: warning: embedded:slider-crank-dry: the ideal joints drifted apart by ")
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["warnings"] == [lines[0].removeprefix("mechrel: warning: ")]


def test_simulate_clearance_scene_with_overrides_and_parquet(tmp_path, capsys):
    out = tmp_path / "lub.parquet"
    rc = main(["simulate", "slider-crank-lubricated", "--set", "analysis.cycles=1",
               "--set", "joints.C.lubricant.viscosity=0.2", "--out", str(out), "--no-progress"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "acceleration error" in text and "joint C: max eccentricity ratio" in text
    assert "solver radau on the reduced equations: " in text  # which equations ran
    frame = pd.read_parquet(out)
    for q in ("displacement", "velocity", "acceleration"):
        assert {f"slider.{q}", f"slider.{q}.ideal", f"slider.{q}.error"} <= set(frame.columns)
    orbits = pd.read_parquet(tmp_path / "lub-orbits.parquet")
    assert {"C.ex", "C.ey", "C.eps"} <= set(orbits.columns)


def test_simulate_reports_the_error_extremes_found_on_the_solution(tmp_path, capsys):
    # the four-bar's dry pin B impacts between output instants: the summary gives the cycle's
    # error extremes from the integrator's solution beside the output grid's range, and the
    # JSON carries them; they are those of simulate(scene, extremes=True)
    import re

    import numpy as np

    from mechrel.scene import load_scene
    from mechrel.simulation import simulate

    out = tmp_path / "fb.csv"
    assert main(["simulate", "four-bar", "--set", "analysis.cycles=1", "--out", str(out),
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    ref = simulate(load_scene("four-bar", overrides={"analysis.cycles": 1}), extremes=True)
    assert text.count("error extremes over the last cycle, on the solution:") == 2
    d = ref.extremes["tip"]["acceleration"]
    line = re.search(r"^      acceleration error (\S+) … (\S+) m/s², max \|error\| (\S+) "
                     r"m/s² at (\S+)°$", text, flags=re.M)
    assert line is not None
    printed = [float(v) for v in line.groups()]
    expected = [d["min"], d["max"], d["max_abs"], d["max_abs_angle"]]
    # printed to 4 significant digits (the angle to 0.01°)
    assert printed[:3] == pytest.approx(expected[:3], rel=5e-4)
    assert printed[3] == pytest.approx(expected[3], abs=0.005)
    # the solution's extreme bounds the output grid's range (the grid's instants are on it)
    assert d["max_abs"] >= np.abs(ref.error("tip", "acceleration")).max()
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["extremes"]["tip"]["acceleration"]["max_abs"] == d["max_abs"]
    # an ideal scene has no error to find extremes of: no such lines
    assert main(["simulate", "slider-crank", "--no-progress"]) == 0
    assert "error extremes" not in capsys.readouterr().out


@pytest.mark.parametrize("argv, fragment", [
    (["simulate", "slider-crank", "--set", "bodies.crank.mass=-1"], "bodies.crank.mass"),
    (["simulate", "no-such-scene"], "no-such-scene"),
    (["simulate", "slider-crank", "--out", "x.txt"], "allowed: .csv, .parquet"),
    (["simulate", "slider-crank", "--out", "."], "has extension '(none)'"),
    (["simulate", "slider-crank", "--out", "a.csv/b.csv"], "cannot create the folder 'a.csv'"),
    (["simulate", "slider-crank", "--integrator", "dopri"], "unknown integrator 'dopri'"),
])
def test_bad_input_is_one_line_without_traceback(argv, fragment, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.csv").write_text("a file where a folder is needed")
    assert main(argv + ["--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mechrel: error:") and fragment in err and "Traceback" not in err


def test_scenes_lists_and_describes(capsys):
    assert main(["scenes"]) == 0
    listing = capsys.readouterr().out
    for name in ("nine-bar", "nine-bar-lubricated", "slider-crank", "double-pendulum"):
        assert name in listing
    assert main(["scenes", "nine-bar"]) == 0
    text = capsys.readouterr().out
    assert "C1 (revolute" in text and "crank1 (constant-speed" in text


def test_help_names_every_command(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    for cmd in ("simulate", "scenes", "reliability", "sensitivity", "accuracy"):
        assert cmd in text


def test_a_wrong_out_fails_before_the_simulation(tmp_path, monkeypatch, capsys):
    # --out was checked only when the table was written, after a possibly long simulation
    import mechrel.simulation

    def never(*args, **kwargs):
        raise AssertionError("simulated although --out is wrong")

    monkeypatch.setattr(mechrel.simulation, "simulate", never)
    assert main(["simulate", "nine-bar-dry", "--out", str(tmp_path / "r.xlsx"),
                 "--no-progress"]) == 2
    assert "allowed: .csv, .parquet" in capsys.readouterr().err


@pytest.mark.parametrize("target, problem", [("0", "must be > 0"),
                                             ("nan", "not a finite number")])
def test_accuracy_target_is_refused_by_the_parser(target, problem, capsys):
    # it reached the report as "mechrel: error: target: 0.0 is not a positive relative
    # error", not in argparse's form that every other option's refusal has
    with pytest.raises(SystemExit) as info:
        main(["accuracy", "slider-crank-dry", "--target", target])
    assert info.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        f"mechrel accuracy: error: argument --target: {target}: {problem}; allowed: a finite "
        "number > 0")


# --------------------------------------------------------------------------- the CLI package

def test_python_dash_m_mechrel_is_the_command():
    import subprocess
    import sys

    import mechrel

    src = str(Path(mechrel.__file__).parents[1])
    proc = subprocess.run([sys.executable, "-m", "mechrel", "--help"], capture_output=True,
                          text=True, env={**__import__("os").environ, "PYTHONPATH": src},
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    for cmd in ("simulate", "scenes", "reliability", "sensitivity", "accuracy"):
        assert cmd in proc.stdout


def test_every_command_module_is_registered_explicitly():
    # a subcommand is a module of mechrel.cli with register functions, all listed in COMMANDS
    import importlib
    import pkgutil

    import mechrel.cli
    from mechrel.cli.main import registrations

    found = set()
    for info in pkgutil.iter_modules(mechrel.cli.__path__):
        module = importlib.import_module(f"mechrel.cli.{info.name}")
        found |= {getattr(module, n) for n in dir(module)
                  if n.startswith("register") and n != "registrations"}
    assert found == set(registrations())


STUDY = """\
scene = "slider-crank-lubricated"
cycles = 1
[scene_overrides]
"solver.rtol" = 1e-5
"solver.atol" = 1e-8
[inputs.clearance]
paths = ["joints.C.clearance"]
distribution = "normal"
mean = 0.5e-3
std = 0.02e-3
[reliability]
methods = ["fosm"]
"""


def test_set_splits_study_fields_from_scene_paths():
    from mechrel.cli.studies import split_overrides

    study, scene = split_overrides(["reliability.n=64", "inputs.clearance.std=1e-5",
                                    "joints.C.model=dry", "solver.rtol=1e-6"])
    assert study == {"reliability.n": 64, "inputs.clearance.std": 1e-5}
    assert scene == {"joints.C.model": "dry", "solver.rtol": 1e-6}
    with pytest.raises(MechrelError, match="scene_overrides"):
        split_overrides(["scene_overrides.x=1"])


def test_set_reaches_the_study_and_its_scene(tmp_path, capsys):
    study_file = tmp_path / "s.toml"
    study_file.write_text(STUDY)
    out = tmp_path / "out"
    rc = main(["reliability", str(study_file), "--set", "solver.rtol=1e-6",
               "--set", "inputs.clearance.std=1e-5", "--jobs", "1", "--out", str(out),
               "--no-progress"])
    assert rc == 0, capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    prov = summary["provenance"]["fosm"]
    assert prov["model"]["solver"]["rtol"] == 1e-6  # the scene override, after the study's 1e-5
    assert "std=1e-05" in " ".join(prov["inputs"]["marginals"])


@pytest.mark.parametrize("argv, fragment", [
    (["--set", "joints.C9.clearance=1e-3"], "unknown joint 'C9'"),
    (["--set", "reliability.n=1"], "reliability.n"),
    (["--set", "inputs.clearance.std=-1"], "std"),
    (["--set", "nonsense"], "expected PATH=VALUE"),
    (["--scheduler", "nonsense://x"], "--scheduler = 'nonsense://x'"),
])
def test_bad_study_arguments_fail_before_anything_runs(argv, fragment, tmp_path, capsys,
                                                       monkeypatch):
    import mechrel.study.runner as runner

    def never(*args, **kwargs):
        raise AssertionError("ran although an argument is wrong")

    monkeypatch.setattr(runner, "run_reliability", never)
    study_file = tmp_path / "s.toml"
    study_file.write_text(STUDY)
    assert main(["reliability", str(study_file), "--out", str(tmp_path / "o"),
                 "--no-progress"] + argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("mechrel: error:") and fragment in err and "Traceback" not in err


def test_scheduler_runs_the_study_on_an_existing_dask_cluster(tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    study_file = tmp_path / "s.toml"
    study_file.write_text(STUDY)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        rc = main(["reliability", str(study_file), "--scheduler", cluster.scheduler_address,
                   "--out", str(tmp_path / "dask"), "--no-progress"])
        assert rc == 0, capsys.readouterr().err
    local = main(["reliability", str(study_file), "--jobs", "1", "--out", str(tmp_path / "seq"),
                  "--no-progress"])
    assert local == 0
    dask = json.loads((tmp_path / "dask" / "summary.json").read_text())
    seq = json.loads((tmp_path / "seq" / "summary.json").read_text())
    assert dask["provenance"]["fosm"]["executor"]["backend"] == "dask"
    assert seq["provenance"]["fosm"]["executor"]["backend"] == "sequential"
    # the same numbers as the in-process run
    a = pd.read_csv(tmp_path / "dask" / "reliability.csv")
    b = pd.read_csv(tmp_path / "seq" / "reliability.csv")
    pd.testing.assert_frame_equal(a, b)


@pytest.mark.parametrize("argv, fragment", [
    (["--jobs", "0"], "argument --jobs: 0: must be >= 1 or -1; allowed: an integer >= 1, or -1"),
    (["--seed", "-3"], "argument --seed: -3: must be >= 0; allowed: an integer >= 0 (a seed)"),
])
def test_bad_numbers_are_refused_by_the_parser(argv, fragment, capsys):
    with pytest.raises(SystemExit) as info:
        main(["reliability", "nine-bar-lubricated", "--no-progress"] + argv)
    assert info.value.code == 2 and fragment in capsys.readouterr().err


def test_set_on_sensitivity_and_its_warnings_in_the_json(tmp_path, capsys):
    # the ideal slider-crank with two length tolerances (kinematics only, fast): --set changes
    # the study's N and a scene value; eight Saltelli samples are too few, and it says so
    f = tmp_path / "s.toml"
    f.write_text('scene = "slider-crank"\nangle_step = 30.0\n'
                 '[inputs.crank]\npaths = ["bodies.crank.length(O,A)"]\n'
                 'distribution = "normal"\nmean = 0.05\nstd = 1e-5\n'
                 '[inputs.rod]\npaths = ["bodies.rod.length(A,B)"]\n'
                 'distribution = "normal"\nmean = 0.12\nstd = 1e-5\n')
    out = tmp_path / "o"
    assert main(["sensitivity", str(f), "--set", "sensitivity.n=8", "--set",
                 "solver.assembly_tolerance=1e-13", "--jobs", "1", "--out", str(out),
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "(N = 8, 0 Saltelli blocks dropped for failures)" in text
    # the one count of model evaluations, the same in the summary and the file
    assert "  32 model evaluations (32 computed) in " in text
    record = json.loads((out / "sensitivity.json").read_text())
    assert record["evaluations"]["total"] == {"n_evaluations": 32, "n_computed": 32,
                                              "n_cached": 0, "n_failed": 0}
    assert record["provenance"]["n_computed"] == 32
    assert record["provenance"]["model"]["solver"]["assembly_tolerance"] == 1e-13
    assert any("too few samples" in w for w in record["warnings"])
    assert "  warning: sobol:" in text
