"""Inputs that used to end in a traceback or a misleading message, and the paths a scene or
study file may name: one clear error each, before anything runs."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mechrel.cli.main import main
from mechrel.errors import AssemblyError, SceneError, SimulationError, StudyError
from mechrel.scene import load_scene
from mechrel.scene.loader import MAX_DEPTH, list_scenes
from mechrel.simulation import simulate
from mechrel.study.study import load_study
from mechrel.uq import Normal, UncertainInputs, linear_model, monte_carlo, sobol_design
from mechrel._machine import physical_memory

ROOT = Path(__file__).resolve().parents[1]

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
def _trap_folder(tmp_path, names):
    """A folder ``cwd`` with a module for each of ``names`` (standard modules' names) that, if
    imported, leaves a file in ``markers``; returns (cwd, markers)."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    markers = tmp_path / "markers"
    markers.mkdir()
    for name in names:
        (cwd / f"{name}.py").write_text(
            f"import os\nopen(os.path.join({str(markers)!r}, '{name}-%d' % os.getpid()), 'w')"
            ".close()\n")
    return cwd, markers


def test_workers_do_not_import_modules_from_the_current_folder(tmp_path):
    """Files named like standard modules in the folder a run starts in are not executed by
    the worker processes (nor by loky's helper processes)."""
    cwd, markers = _trap_folder(tmp_path, ("pickle", "signal", "struct", "runpy"))
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


# ---------------------------------------------------------------- sizes
@pytest.mark.parametrize("setting, what", [("subset.n_per_level", "subset.n_per_level"),
                                           ("is.n", "is.n")])
def test_huge_rare_event_sample_counts_are_refused_before_any_evaluation(setting, what,
                                                                         tmp_path, capsys):
    # they ended in a MemoryError traceback (the study's n was checked, these were not); now
    # every chosen method's settings are checked before the first one runs (IS runs FORM)
    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(scene="slider-crank-lubricated"))
    out = tmp_path / "o"
    method = setting.split(".")[0]
    assert main(["reliability", str(study), "--method", method, "--set",
                 f"{setting}=1000000000000", "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"mechrel: error: {what} = 1000000000000: 1e+12 model runs of "), err
    assert err.count("\n") == 1 and "allowed: " + what + " up to about" in err
    assert not out.exists()  # nothing evaluated, no folder left
    # and from Python
    from mechrel.uq import Normal, UncertainInputs, linear_model
    from mechrel.uq.estimators import METHODS

    inputs = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1)})
    model = linear_model([3.0], [[1.0, 1.0]], inputs.names)
    name = "subset_simulation" if method == "subset" else "importance_sampling"
    key = setting.split(".")[1]
    with pytest.raises(StudyError, match=rf"^{key} = 1000000000000: 1e\+12 model runs of 3 "
                                         "inputs and outputs"):
        METHODS[name].function(model=model, inputs=inputs, **{key: 10**12}, progress=False,
                               design_point=None) if name == "importance_sampling" else \
            METHODS[name].function(model=model, inputs=inputs, **{key: 10**12},
                                   progress=False)


def test_a_costly_polynomial_chaos_says_what_it_costs_and_is_refused(tmp_path, capsys):
    from mechrel.uq import Normal, UncertainInputs, linear_model, polynomial_chaos
    from mechrel.uq.surrogates.pce import MAX_EVALUATIONS, design_size

    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(scene="slider-crank-lubricated")
                     + "[inputs.mass]\npaths = ['bodies.rod.mass']\ndistribution = 'normal'\n"
                       "mean = 0.2\nstd = 0.01\n"
                       "[inputs.length]\npaths = ['bodies.crank.length(O,A)']\n"
                       "distribution = 'normal'\nmean = 0.05\nstd = 1e-5\n")
    out = tmp_path / "o"
    assert main(["reliability", str(study), "--method", "pce", "--set",
                 "reliability.pce_order=200", "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err
    # C(203, 3) = 1 373 701 terms, 2 per term, rounded up to 2^22 Sobol' points
    assert err == (f"mechrel: error: {study}: reliability.pce_order = 200: an expansion of "
                   "order 200 in 3 inputs has 1373701 terms, 4194304 model evaluations (2 per "
                   "term, rounded up to a power of 2 for Sobol' points), more than "
                   f"reliability.pce_max_evaluations = {MAX_EVALUATIONS}; allowed: "
                   "reliability.pce_order <= 56 for 3 inputs, or "
                   "reliability.pce_max_evaluations = 4194304 (or more) to run them "
                   "knowingly\n")
    assert not out.exists()
    assert design_size(3, 56) <= MAX_EVALUATIONS < design_size(3, 57)
    inputs = UncertainInputs.from_specs({k: Normal(0, 1) for k in "abc"})
    model = linear_model([0.0], [[1.0, 1.0, 1.0]], inputs.names)
    with pytest.raises(StudyError, match=r"^order = 200: .* more than max_evaluations = 100000"):
        polynomial_chaos(model=model, inputs=inputs, order=200, progress=False)
    # asked for knowingly: allowed (a small limit shows it without running millions)
    r = polynomial_chaos(model=model, inputs=inputs, order=1, max_evaluations=None,
                         progress=False)
    assert r.n_evaluations == design_size(3, 1)
    with pytest.raises(StudyError, match=r"order <= 0 for 3 inputs, or max_evaluations = 8"):
        polynomial_chaos(model=model, inputs=inputs, order=1, max_evaluations=7,
                         progress=False)


# ---------------------------------------------------------------- a scheduler that is not one
@pytest.fixture
def server():
    """A local TCP server that answers as a web server (as a Dask dashboard does) or never
    answers; yields a function of the mode returning its tcp:// address."""
    import socket
    import threading

    sockets = []

    def start(mode):
        srv = socket.socket()
        srv.bind(("127.0.0.1", 0))
        srv.listen(5)
        sockets.append(srv)

        def serve():
            while True:
                try:
                    conn, _ = srv.accept()
                except OSError:
                    return
                sockets.append(conn)
                if mode == "http":
                    conn.recv(65536)
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
        threading.Thread(target=serve, daemon=True).start()
        return f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    yield start
    for s in sockets:
        s.close()


def test_a_dashboard_port_is_not_taken_for_a_scheduler(server, tmp_path, capsys):
    pytest.importorskip("distributed")
    address = server("http")
    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(scene="slider-crank-lubricated"))
    assert main(["reliability", str(study), "--method", "fosm", "--scheduler", address,
                 "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err == (f"mechrel: error: --scheduler = '{address}': what answers there does not "
                   "speak Dask's protocol (a web page, e.g. the dashboard, or another server: "
                   "MemoryError); allowed: the address of a running Dask scheduler, e.g. "
                   "tcp://127.0.0.1:8786 (port 8786; 8787 is its dashboard's)\n")


def test_a_scheduler_that_never_answers_times_out_with_one_line(server):
    pytest.importorskip("distributed")
    import time

    from mechrel.cli.studies import dask_backend

    address = server("silent")
    t0 = time.monotonic()
    with pytest.raises(StudyError, match=rf"^--scheduler = '{address}': no answer within 1 s; "
                                         r"allowed: the address of a running Dask scheduler"):
        with dask_backend(address, timeout=1.0):
            pass
    assert time.monotonic() - t0 < 30  # waited for ever before


# ---------------------------------------------------------------- names, depth, terminal
def test_a_bare_scene_name_is_looked_up_beside_the_study_not_in_the_current_folder(
        tmp_path, monkeypatch):
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    (cwd / "mine").write_text('name = "TOP-SECRET-VALUE"\ngravity = "TOP-SECRET-VALUE"\n')
    studies = tmp_path / "studies"
    studies.mkdir()
    study = studies / "study.toml"
    study.write_text(STUDY.format(scene="mine"))
    monkeypatch.chdir(cwd)
    with pytest.raises(StudyError) as info:
        load_study(study)
    assert str(info.value) == (
        f"{study}: scene = \"mine\": not an embedded scene, nor a file in '{studies}', the "
        f"folder of the study file; allowed: an embedded scene name ({', '.join(list_scenes())}"
        ") or a scene file in the study file's folder or below it")
    (studies / "mine").write_text('extends = "slider-crank-lubricated"\nname = "mine"\n')
    assert load_study(study).scene == str(studies / "mine")  # the one beside the study
    study.write_text(STUDY.format(scene="slider-crnk"))
    with pytest.raises(StudyError, match=r"not an embedded scene \(did you mean "
                                         r"'slider-crank'\?\)"):
        load_study(study)


def test_the_compile_helper_does_not_import_modules_from_the_current_folder(tmp_path):
    """The helper process of a cold Radau compilation (mechrel.warmup.split_compile,
    ``python -c``) started with the current folder first on its import path; it runs here on
    a warm cache (it loads what it would compile), which starts it all the same."""
    cwd, markers = _trap_folder(tmp_path, ("pickle", "json", "struct", "signal"))
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent("""
        from mechrel.warmup import split_compile
        from mechrel.scene import load_scene
        scene = load_scene("slider-crank-lubricated",
                           overrides=["solver.rtol=1e-5", "solver.atol=1e-8"])
        print(" ".join(sorted(split_compile(scene))))
    """))
    done = subprocess.run([sys.executable, str(script)], cwd=cwd, capture_output=True,
                          text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    assert {"rhs", "start"} <= set(done.stdout.split())  # it ran: the jobs waited for
    assert sorted(p.name for p in markers.iterdir()) == []


def test_set_values_nested_too_deeply_are_one_line(capsys):
    for depth in (MAX_DEPTH + 1, 1000):
        value = "[" * depth + "]" * depth
        assert main(["simulate", "slider-crank", "--set", f"gravity={value}"]) == 2
        err = capsys.readouterr().err
        assert err.startswith('mechrel: error: gravity: override value "[[[[')
        assert err.endswith(f": tables and arrays nested more than {MAX_DEPTH} levels deep; "
                            f"allowed: at most {MAX_DEPTH} levels\n") and err.count("\n") == 1


FORGED = "x\nmechrel: error: forged"
CLI = [sys.executable, "-c", "import sys; from mechrel.cli.main import main; sys.exit(main())"]
ESCAPE = "\x1b[2J\x1b]0;title\x07"


@pytest.mark.parametrize("case", ["study name", "scene name", "--set key", "--set value",
                                  "unrecognised argument", "output folder", "warning"])
def test_control_characters_reach_the_terminal_escaped(case, tmp_path, capsys):
    """Names, keys, values and paths with control characters: no escape sequence reaches the
    terminal (one cleared the screen), and a newline cannot forge a line of its own."""
    import json

    study = tmp_path / "study.toml"
    study.write_text(f'name = {json.dumps("s" + ESCAPE + FORGED)}\n'
                     + STUDY.format(scene="slider-crank-lubricated")
                     + '[reliability]\nmethods = ["fosm"]\n')
    argv = {
        "study name": ["reliability", str(study), "--jobs", "1", "--no-progress", "--out",
                       str(tmp_path / "o")],
        "scene name": ["scenes", "a" + ESCAPE + FORGED],
        "--set key": ["simulate", "slider-crank", "--set", f"joints.C{ESCAPE}{FORGED}=1"],
        "--set value": ["simulate", "slider-crank", "--set",
                        f"joints.C.clearance={ESCAPE}{FORGED}"],
        "unrecognised argument": ["simulate", "slider-crank", "extra" + ESCAPE + FORGED],
        "output folder": ["reliability", str(study), "--jobs", "1", "--no-progress", "--out",
                          str(tmp_path / ("o" + ESCAPE + FORGED))],
        "warning": None,
    }[case]
    if argv is None:  # mechrel's warnings, as the command line shows them
        from mechrel.cli.main import _show_warning
        from mechrel.errors import EstimateWarning
        _show_warning(EstimateWarning(f"input {ESCAPE}{FORGED}"), EstimateWarning, "f.py", 1)
    elif case == "study name":  # as a terminal gets it: matplotlib's warnings included
        done = subprocess.run(CLI + argv, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        capsys.readouterr()
        print(done.stdout, end="")
        print(done.stderr, end="", file=sys.stderr)
    else:
        try:
            main(argv)
        except SystemExit as exc:  # argparse's own errors
            assert exc.code == 2
    captured = capsys.readouterr()
    for stream in (captured.out, captured.err):
        assert "\x1b" not in stream and "\x07" not in stream, stream
        assert not any(line.startswith("mechrel: error: forged") for line in stream.splitlines())
    assert "\\x1b" in captured.out + captured.err or "\\u001b" in captured.out + captured.err
    if case == "study name":
        summary = (tmp_path / "o" / "summary.json").read_text()
        assert "\x1b" not in summary and json.loads(summary)["study"] == "s" + ESCAPE + FORGED


# ---------------------------------------------------------------- found by exploring bad input
def test_the_analysis_is_not_an_uncertain_input():
    # a sampled analysis.cycles moved the analysed cycle under the output's angles: one sample
    # below half a cycle ended a whole Monte Carlo run with an IndexError
    from mechrel.uq import MechanismModel

    for path in ("analysis.cycles", "-analysis.sample_step_angle"):
        with pytest.raises(StudyError, match=rf"^inputs\.x: '{path}': the analysis \(its "
                           r"cycles, duration and sample step\) is the model's own, not an "
                           r"uncertain input; allowed: a value of the mechanism, e\.g\. "):
            MechanismModel("slider-crank-lubricated", {"x": [path]})


def test_a_subnormal_sample_step_is_refused_by_the_memory_it_needs():
    # 5e-324 rad divided by the crank speed is 0 s, and 2 s / 1e-310 s overflows: both used to
    # end in a ZeroDivisionError or an OverflowError traceback
    for scene, field, value in (("slider-crank-dry", "analysis.sample_step_angle", 5e-324),
                                ("double-pendulum", "analysis.sample_step", 1e-310)):
        with pytest.raises(SimulationError, match=rf"^embedded:{scene}: {field}: inf output "
                           r"instants over [0-9.]+ s need about inf GiB, more than "):
            simulate(load_scene(scene, overrides={field: value}))


def test_a_correlation_given_for_both_orders_of_a_pair_is_refused(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(scene="slider-crank-lubricated") + textwrap.dedent("""\
        [inputs.viscosity]
        paths = ["joints.C.lubricant.viscosity"]
        distribution = "normal"
        mean = 0.1
        std = 0.01
        [correlation]
        "clearance,viscosity" = 0.5
        "viscosity,clearance" = -0.5
        """))
    with pytest.raises(StudyError, match=rf'^{study}: correlation\."viscosity,clearance" = '
                       r'-0\.5: the pair is given twice \(also as "clearance,viscosity" = 0\.5\); '
                       r"allowed: each pair once$"):
        load_study(study)


def test_a_cost_too_deep_to_evaluate_is_refused_with_the_limit():
    # a flat sum of 1000 terms is a syntax tree 1002 levels deep: it ended in a RecursionError
    from mechrel.uq.design.expression import MAX_DEPTH, CostExpression

    ok = CostExpression("+".join(["a"] * (MAX_DEPTH - 2)), ["a"])
    assert ok({"a": 1.0}) == MAX_DEPTH - 2
    with pytest.raises(StudyError, match=r"^cost = 'a\+a\+.*\.\.\.' \(1999 characters\): nested "
                       r"1002 levels deep \(each term of a long sum or product is one level "
                       r"more\); allowed: at most 200 levels, e\.g\. a sum of up to about 198 "
                       r"terms$"):
        CostExpression("+".join(["a"] * 1000), ["a"])


def test_a_file_name_the_system_refuses_is_one_line(tmp_path, capsys):
    # ENAMETOOLONG wherever the path is first touched: the scene read, a figure or an output
    # folder written (each an OSError traceback before)
    long = "a" * 300
    assert main(["simulate", long + ".toml"]) == 2
    err = capsys.readouterr().err
    assert err == (f"mechrel: error: {long}.toml: cannot read the file: File name too long; "
                   "allowed: a readable TOML file\n")
    for argv in (["draw", "slider-crank", "--out", str(tmp_path / (long + ".png"))],
                 ["reliability", "nine-bar-lubricated", "--n", "4", "--no-progress",
                  "--out", str(tmp_path / long)]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith(f"mechrel: error: {tmp_path / long}") and err.endswith(
            ": File name too long; allowed: a path this system can read or write\n"), err


def test_the_summary_of_a_scene_without_a_cycle_driver_gives_the_time_not_nan(capsys):
    # no cycle driver: the extremes cover the whole run, and their instant has no crank angle
    scene = str(ROOT / "tests" / "data" / "scenes" / "cart-pendulum-lubricated.toml")
    assert main(["simulate", scene]) == 0
    out = capsys.readouterr().out
    assert "nan" not in out
    assert "error extremes over the run, on the solution:" in out
    assert re.search(r"max \|error\| [-0-9.e+]+ mm at t = [0-9.e+-]+ s\n", out)


@pytest.mark.parametrize("spec, ratio", [
    ({"distribution": "lognormal", "mean": 0.4, "std": 1e160}, "2.5e+160"),
    ({"distribution": "lognormal", "mean": 1.0, "std": 1e-170}, "1e-170"),
    ({"distribution": "gamma", "mean": 0.4, "std": 1e-200}, "2.5e-200"),
    ({"distribution": "gamma", "mean": 1.0, "std": 1e160}, "1e+160"),
])
def test_distribution_parameters_that_overflow_float64_are_refused(spec, ratio):
    # the lognormal's ln(1 + (std/mean)^2) and the gamma's (mean/std)^2 ended in an
    # OverflowError traceback, or reached SciPy as an infinite or zero parameter
    kind = spec["distribution"]
    mean, std = (re.escape(repr(spec[k])) for k in ("mean", "std"))
    with pytest.raises(StudyError, match=rf"^inputs\.x: a {kind} of mean = {mean} and "
                       rf"std = {std}: its parameters overflow or underflow float64 "
                       rf"\(std / mean = {re.escape(ratio)}\); allowed: std / mean between "
                       r"1e-150 and 1e150$"):
        UncertainInputs.from_specs({"x": spec})
    # the widest ratios allowed work
    for r in (1e-150, 1e150):
        u = UncertainInputs.from_specs({"x": {**spec, "mean": 1.0, "std": r}})
        assert np.isfinite(u.marginals[0].scipy().ppf([0.1, 0.5, 0.9])).all()


@pytest.mark.parametrize("spec, where", [
    ({"distribution": "normal", "mean": 1e308, "std": 1e308}, "from -inf to inf"),
    ({"distribution": "gumbel", "mean": 0.4, "std": 1e308}, "from -inf to nan"),
    ({"distribution": "normal", "mean": 0.0, "std": 1e307}, "from -inf to inf"),
])
def test_a_distribution_whose_values_overflow_where_methods_reach_is_refused(spec, where):
    # they were drawn and reached the model as "X: all inputs must be finite" (no input
    # named), with SciPy's overflow warnings on stderr; std 1e307 is finite, but 37.5 of them
    # (the farthest z any map reaches) are not
    kind = spec["distribution"]
    with pytest.raises(StudyError, match=rf"^inputs\.x: this {kind} distribution's values "
                       rf"overflow float64 within 37\.5 standard deviations of its "
                       rf"standard-normal image \(x {re.escape(where)}\), where sampling and "
                       r"the reliability methods reach; allowed: a distribution of physical "
                       r"magnitude, finite there$"):
        UncertainInputs.from_specs({"x": spec})
    # wide but finite there: taken, and sampled finite
    u = UncertainInputs.from_specs({"x": {**spec, "mean": 0.0, "std": 1e300}})
    assert np.isfinite(u.sample(64, "sobol", 0)).all()


def test_a_distribution_whose_moments_overflow_is_refused():
    # representable draws, but a standard deviation SciPy computes as inf (the width squared
    # overflows): FOSM and the reported moments would read it
    spec = {"distribution": "uniform", "lower": -1e307, "upper": 1e307}
    with pytest.raises(StudyError, match=r"^inputs\.x: this uniform distribution's mean or "
                       r"standard deviation overflows float64 \(mean 0, std inf\), which FOSM "
                       r"and the reported moments use; allowed: a distribution of physical "
                       r"magnitude, finite there$"):
        UncertainInputs.from_specs({"x": spec})
    u = UncertainInputs.from_specs({"x": {**spec, "lower": -1e150, "upper": 1e150}})
    assert np.isfinite(u.std).all() and np.isfinite(u.sample(16, "sobol", 0)).all()


def test_non_finite_inputs_of_an_evaluation_are_named():
    from mechrel.uq import evaluate

    model = linear_model([0.0], [[1.0, 2.0]], ["a", "b"])
    X = np.array([[1.0, 2.0], [np.inf, 1.0], [3.0, np.nan]])
    with pytest.raises(StudyError, match=r"^X: inputs \['a', 'b'\] are not finite in 2 of 3 "
                       r"rows \(first: row 1, \{'a': inf, 'b': 1\.0\}\); allowed: finite "
                       r"inputs$"):
        evaluate(model, X, progress=False)
