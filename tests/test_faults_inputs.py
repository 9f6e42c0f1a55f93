"""Inputs that used to end in a traceback or a misleading message, and the paths a scene or
study file may name: one clear error each, before anything runs."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap

import pytest

from mechrel.cli.main import main
from mechrel.errors import AssemblyError, SceneError, SimulationError, StudyError
from mechrel.scene import load_scene
from mechrel.scene.loader import MAX_DEPTH
from mechrel.simulation import simulate
from mechrel.studies.study import load_study
from mechrel.uq import Normal, UncertainInputs, linear_model, monte_carlo, sobol_design
from mechrel.uq._common import physical_memory

STUDY = """\
scene = "{scene}"
cycles = 1
[inputs.clearance]
paths = ["joints.C.clearance"]
distribution = "normal"
mean = 0.2e-3
std = 0.01e-3
"""


# ---------------------------------------------------------------- nesting, byte-order mark
@pytest.mark.parametrize("depth", [MAX_DEPTH + 1, 2000])
def test_deeply_nested_scene_and_study_files(depth, tmp_path):
    text = "name = 'x'\ndeep = " + "[" * depth + "]" * depth + "\n"
    scene = tmp_path / "s.toml"
    scene.write_text(text)
    # MAX_DEPTH + 1 parses, then is refused; 2000 exceeds the parser's recursion
    problem = (r"deep(\[0\])*: tables and arrays nested more than 32 levels deep"
               if depth < 100 else r"tables or arrays nested too deeply to parse")
    with pytest.raises(SceneError, match=rf"^{scene}: {problem}; allowed: at most 32 levels"):
        load_scene(scene)
    study = tmp_path / "st.toml"
    study.write_text(STUDY.format(scene="slider-crank") + "[scene_overrides]\n" + text[11:])
    with pytest.raises(StudyError, match=rf"^{study}: (scene_overrides\.)?{problem}"):
        load_study(study)


def test_deep_mapping_sources_are_refused_too():
    deep: dict = {}
    node = deep
    for _ in range(2000):
        node["a"] = {}
        node = node["a"]
    with pytest.raises(SceneError, match="nested more than 32 levels"):
        load_scene({"name": "x", "deep": deep})
    with pytest.raises(StudyError, match="nested more than 32 levels"):
        load_study({"scene": "slider-crank", "deep": deep})


def test_byte_order_mark_is_accepted_in_scene_and_study_files_alike(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_bytes(b"\xef\xbb\xbf" + b'extends = "slider-crank"\nname = "bom"\n')
    assert load_scene(scene).name == "bom"
    study = tmp_path / "st.toml"
    study.write_bytes(b"\xef\xbb\xbf" + STUDY.format(scene="s.toml").encode())
    assert load_study(study).scene == str(scene)


# ---------------------------------------------------------------- paths named in files
@pytest.fixture
def outside(tmp_path):
    """A scene file outside the user's folder, with content that must never be echoed."""
    secret = tmp_path / "secret"
    secret.mkdir()
    (secret / "base.toml").write_text('extends = "slider-crank"\nname = "TOP-SECRET-VALUE"\n'
                                      "gravity = 'TOP-SECRET-VALUE'\n")
    user = tmp_path / "user"
    user.mkdir()
    return secret / "base.toml", user


@pytest.mark.parametrize("how", ["relative", "absolute"])
def test_extends_may_not_leave_the_folder_of_the_file_given(outside, how):
    base, user = outside
    ext = "../secret/base.toml" if how == "relative" else str(base)
    scene = user / "s.toml"
    scene.write_text(f'extends = "{ext}"\nname = "s"\n')
    with pytest.raises(SceneError) as info:
        load_scene(scene)
    msg = str(info.value)
    # (a long value is shortened in the message, as every value is)
    assert re.match(rf"{re.escape(str(scene))}: extends = .+?: not read: it is outside "
                    rf"'{re.escape(str(user))}', the folder of the scene file given; allowed:", msg)
    assert "TOP-SECRET-VALUE" not in msg
    # given directly by the user, the same file is loaded (and its own error is shown)
    with pytest.raises(SceneError, match="TOP-SECRET-VALUE"):
        load_scene(base)


def test_extends_within_the_folder_and_chains_stay_confined(tmp_path, outside):
    base, user = outside
    (user / "lib").mkdir()
    (user / "lib" / "a.toml").write_text('extends = "../b.toml"\nname = "a"\n')  # .. but inside
    (user / "b.toml").write_text('extends = "slider-crank"\nname = "b"\ngravity = [0.0, 0.0]\n')
    (user / "s.toml").write_text('extends = "lib/a.toml"\nname = "s"\n')
    assert load_scene(user / "s.toml").gravity == (0.0, 0.0)
    # a base inside the folder may not reach out of it either, nor through a symbolic link
    (user / "b.toml").write_text(f'extends = "{base}"\nname = "b"\n')
    with pytest.raises(SceneError, match=r"b.toml: extends = .*not read: it is outside"):
        load_scene(user / "s.toml")
    (user / "link.toml").symlink_to(base)
    (user / "s.toml").write_text('extends = "link.toml"\nname = "s"\n')
    with pytest.raises(SceneError, match="not read: it is outside") as info:
        load_scene(user / "s.toml")
    assert "TOP-SECRET-VALUE" not in str(info.value)


def test_study_scene_is_relative_to_the_study_file_and_confined(outside, monkeypatch, capsys):
    base, user = outside
    (user / "mine.toml").write_text('extends = "slider-crank-lubricated"\nname = "mine"\n')
    study = user / "study.toml"
    study.write_text(STUDY.format(scene="mine.toml"))
    monkeypatch.chdir(base.parent)  # not relative to the current folder
    assert load_study(study).scene == str(user / "mine.toml")
    for ext in ("../secret/base.toml", str(base)):
        study.write_text(STUDY.format(scene=ext))
        with pytest.raises(StudyError) as info:
            load_study(study)
        assert re.match(rf"{re.escape(str(study))}: scene = .+?: not read: it is "
                        rf"outside '{re.escape(str(user))}', the folder of the study file",
                        str(info.value))
        assert "TOP-SECRET-VALUE" not in str(info.value)
    # the user may name it directly: --scene (an override of the study's scene)
    assert load_study(study, overrides={"scene": str(user / "mine.toml")}).scene == \
        str(user / "mine.toml")
    assert main(["reliability", str(study), "--scene", str(base), "--method", "fosm",
                 "--jobs", "1", "--no-progress", "--out", str(user / "o")]) == 2
    assert "TOP-SECRET-VALUE" in capsys.readouterr().err  # given directly: its own error


# ---------------------------------------------------------------- the whole command first
@pytest.mark.parametrize("option, value, message", [
    ("--seed", "-1", r"argument --seed: -1: must be >= 0; allowed: an integer >= 0 \(a seed\)"),
    ("--jobs", "0", r"argument --jobs: 0: must be >= 1 or -1; allowed: an integer >= 1, or -1 "
                    r"\(all cores or all the cluster's workers\)"),
])
def test_bad_arguments_are_refused_before_anything_runs(option, value, message, tmp_path,
                                                        capsys):
    with pytest.raises(SystemExit) as info:
        main(["reliability", "nine-bar-lubricated", option, value, "--out", str(tmp_path / "o")])
    assert info.value.code == 2
    assert re.search(message, capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_huge_sample_count_is_refused_by_the_memory_it_needs(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(scene="slider-crank-lubricated"))
    out = tmp_path / "o"
    assert main(["reliability", str(study), "--n", "1000000000000", "--out", str(out),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mechrel: error: n = 1000000000000: 1e+12 model runs of ")
    assert f"more than this machine's {physical_memory() / 2**30:.3g} GiB; allowed: n up to " in err
    assert not (out / "evaluations.sqlite").exists()  # refused before FOSM ran
    inputs = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1)})
    model = linear_model([0.0], [[1.0, 1.0]], inputs.names)
    with pytest.raises(StudyError, match=r"^n = 1000000000000: 1e\+12 model runs of 3 inputs"):
        monte_carlo(model=model, inputs=inputs, n=10**12, allowable=None)
    with pytest.raises(StudyError, match=r"^n = 1000000000000: 4e\+12 model runs of 2 inputs"):
        sobol_design(inputs, n=10**12)
    # the bound: about physical memory / (3 copies x 8 bytes x (d + n_out)) samples
    limit = physical_memory() / (3 * 8 * 3)
    with pytest.raises(StudyError):
        monte_carlo(model=model, inputs=inputs, n=int(limit * 1.01), allowable=None)


# ---------------------------------------------------------------- messages that misled
def test_step_budget_that_cannot_finish_is_refused_up_front():
    scene = load_scene("slider-crank-dry", overrides={"solver.integrator": "rk4",
                                                      "solver.step": 1e-12})
    with pytest.raises(SimulationError, match=r"^solver.step = 1e-12 s: the analysis span of "
                                              r"0.024 s needs 2.4e\+10 steps of rk4, more than "
                                              r"solver.max_steps = 10000000; allowed: "
                                              r"solver.step >= 2.4e-09 s"):
        simulate(scene)


def test_overflowing_scene_values_are_named_not_blamed_on_the_mechanism():
    scene = load_scene("slider-crank", overrides={"drivers.crank.speed": 1e300})
    with pytest.raises(AssemblyError) as info:  # from the kinematic analysis
        simulate(scene)
    msg = str(info.value)
    assert msg.startswith("embedded:slider-crank: the run failed with values of extreme "
                          "magnitude in the scene, which overflow float64 arithmetic: "
                          "drivers.crank.speed = 1e+300; allowed: values of physical magnitude")


def test_derived_contact_stiffness_names_the_joint():
    # the force law's ranges are checked when the scene loads (the one validator, run by the
    # scene loader), so the overflowing derived stiffness is refused there, with the joint
    with pytest.raises(SceneError, match=r"^joints.C: stiffness = inf is invalid: allowed a "
                                         r"finite number; it is computed from bearing_radius, "
                                         r"clearance and the contact's elastic moduli") as info:
        load_scene("slider-crank", overrides={"joints.C.model": "dry",
                                              "joints.C.bearing_radius": 1e301,
                                              "joints.C.clearance": 1e300})
    assert info.value.path == "joints.C.stiffness"


# ---------------------------------------------------------------- workers and the cwd
def test_workers_do_not_import_modules_from_the_current_folder(tmp_path):
    """Files named like standard modules in the folder a run starts in are not executed by
    the worker processes (nor by loky's helper processes)."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    markers = tmp_path / "markers"
    markers.mkdir()
    for name in ("pickle", "signal", "struct", "runpy"):
        (cwd / f"{name}.py").write_text(
            f"import os\nopen(os.path.join({str(markers)!r}, '{name}-%d' % os.getpid()), 'w')"
            ".close()\n")
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent("""
        import numpy as np
        from mechrel.uq import evaluate, linear_model
        model = linear_model([0.0], [[1.0, 2.0]], ("a", "b"))
        ev = evaluate(model, np.ones((8, 2)), n_jobs=2, progress=False, chunk_size=2)
        print(ev.n_ok, ev.settings["backend"])
    """))
    done = subprocess.run([sys.executable, str(script)], cwd=cwd, capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["8", "loky"]
    assert sorted(p.name for p in markers.iterdir()) == []
