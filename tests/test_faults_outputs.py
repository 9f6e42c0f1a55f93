"""Fault injection, outputs: atomic writes (a failed write leaves the previous file whole and no
temporary file), the output folder checked before any evaluation, a refused run leaves no
earlier run's results beside its summary, and a second run on a held folder is refused."""

from __future__ import annotations

import errno
import json
import os
import re
from pathlib import Path

import pandas as pd
import pytest

from mechrel.cli.main import main
from mechrel.errors import OutputError
from mechrel.io import save_figure, write_json, write_table
from mechrel.io.lock import LOCK_NAME, hold_folder

# as in test_studies.py: one cycle of the lubricated slider-crank, ~0.1 s per sample; about a
# quarter of the clearance samples are <= 0 and fail (so Monte Carlo with n = 16 refuses)
FAILING_STUDY = """\
scene = "slider-crank-lubricated"
cycles = 1
[scene_overrides]
"solver.rtol" = 1e-5
"solver.atol" = 1e-8
[inputs.clearance]
paths = ["joints.C.clearance"]
distribution = "normal"
mean = 0.2e-3
std = 0.3e-3
[reliability]
n = 16
seed = 1
"""
FRAME = pd.DataFrame({"a": [1.0, 2.0, 3.0], "b": ["x", "y", "z"]})


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if ".tmp" in p.name)


def _enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_failed_table_write_keeps_the_previous_file_whole(tmp_path, monkeypatch):
    target = tmp_path / "t.csv"
    write_table(FRAME, target)
    before = target.read_bytes()

    def half_then_full(self, path, **kwargs):  # a disk that fills up in the middle
        Path(path).write_text("a,b\n1.0,")
        _enospc()
    monkeypatch.setattr(pd.DataFrame, "to_csv", half_then_full)
    with pytest.raises(OutputError, match=rf"^--out: cannot write '{target}' \(No space left on "
                                          r"device\); the previous file, if any, is unchanged"):
        write_table(FRAME.assign(a=0.0), target)
    assert target.read_bytes() == before
    assert _leftovers(tmp_path) == []


def test_failed_json_and_figure_writes_leave_nothing_half_written(tmp_path, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    write_json({"a": 1}, tmp_path / "s.json")
    fig = plt.figure()
    save_figure(fig, tmp_path / "f.png")
    png = (tmp_path / "f.png").read_bytes()
    assert png.startswith(b"\x89PNG")  # the format comes from the target's suffix
    monkeypatch.setattr(os, "replace", _enospc)  # fails at the very last step
    with pytest.raises(OutputError, match="No space left on device"):
        write_json({"a": 2}, tmp_path / "s.json")
    with pytest.raises(OutputError, match="No space left on device"):
        save_figure(fig, tmp_path / "f.png")
    plt.close(fig)
    assert json.loads((tmp_path / "s.json").read_text()) == {"a": 1}
    assert (tmp_path / "f.png").read_bytes() == png
    assert _leftovers(tmp_path) == []


def test_folder_in_place_of_an_output_file(tmp_path):
    (tmp_path / "t.csv").mkdir()
    with pytest.raises(OutputError, match=r"is a folder; allowed: a file name ending in \.csv"):
        write_table(FRAME, tmp_path / "t.csv")
    (tmp_path / "s.json").mkdir()
    with pytest.raises(OutputError, match=rf"^--out: '{tmp_path}/s.json' is a folder; allowed: a "
                                          r"file name \(remove or rename the folder\)$"):
        write_json({}, tmp_path / "s.json")


@pytest.mark.parametrize("command, taken", [("reliability", "reliability.png"),
                                            ("sensitivity", "sensitivity.csv")])
def test_output_folder_is_checked_before_any_evaluation(command, taken, tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(FAILING_STUDY)
    out = tmp_path / "out"
    (out / taken).mkdir(parents=True)
    assert main([command, str(study), "--out", str(out), "--no-progress", "--jobs", "1"]) == 2
    assert capsys.readouterr().err == (
        f"mechrel: error: out = '{out}': {taken} is a folder, where this run writes a file; "
        f"allowed: a folder without a folder named {taken} (remove or rename it)\n")
    assert sorted(p.name for p in out.iterdir()) == [taken]  # no cache: nothing was evaluated


def test_unwritable_output_folder_is_refused_before_any_evaluation(tmp_path, capsys,
                                                                   monkeypatch):
    """A read-only folder (simulated: the tests may run as root)."""
    import tempfile as tempfile_mod
    study = tmp_path / "study.toml"
    study.write_text(FAILING_STUDY)

    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))
    monkeypatch.setattr(tempfile_mod, "mkstemp", read_only)
    out = tmp_path / "out"
    assert main(["reliability", str(study), "--out", str(out), "--no-progress"]) == 2
    assert capsys.readouterr().err == (
        f"mechrel: error: out = '{out}': cannot create the folder or a file in it (Read-only "
        "file system); allowed: a writable folder (created if missing)\n")
    assert not out.exists()  # made for the run, and removed again as it stayed empty


def test_refused_run_leaves_no_earlier_results_beside_its_summary(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(FAILING_STUDY)
    out = tmp_path / "out"
    out.mkdir()
    for name in ("reliability.csv", "whole_cycle.csv", "reliability.png"):
        (out / name).write_text("an earlier run's result")
    assert main(["reliability", str(study), "--method", "mc", "--jobs", "1", "--out", str(out),
                 "--no-progress"]) == 2
    assert "samples failed" in capsys.readouterr().err
    assert json.loads((out / "summary.json").read_text())["refused"]["method"] == "mc"
    names = sorted(p.name for p in out.iterdir())
    # the refusal's set (its manifest names it); the lock is gone with the run
    assert names == [".mechrel-set-reliability.json", "evaluations.sqlite", "failures.csv",
                     "summary.json"]


def test_second_run_on_a_held_folder_is_refused_at_once(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(FAILING_STUDY)
    out = tmp_path / "out"
    out.mkdir()
    with hold_folder(out):  # as another run would: the lock is per open file, so this works
        assert main(["reliability", str(study), "--out", str(out), "--no-progress"]) == 2
        assert (out / LOCK_NAME).read_text() == f"{os.getpid()}\n"
    assert capsys.readouterr().err == (
        f"mechrel: error: out = '{out}': another run (pid {os.getpid()}) holds {out}; allowed: "
        "wait for it to finish, or give this run another output folder\n")
    assert sorted(p.name for p in out.iterdir()) == []  # nothing evaluated; no lock left
    with hold_folder(out):  # released: it can be taken again
        pass


def test_simulate_checks_every_file_it_writes_before_running(tmp_path, capsys):
    (tmp_path / "r.png").mkdir()
    assert main(["simulate", "slider-crank", "--out", str(tmp_path / "r.csv")]) == 2
    assert capsys.readouterr().err == (
        f"mechrel: error: --out: '{tmp_path}/r.png', which this run writes beside r.csv, is a "
        "folder; allowed: a file name (remove or rename the folder)\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.png"]


def test_a_file_system_without_locks_is_one_clear_error(tmp_path, monkeypatch):
    from mechrel.io import lock

    def no_locks(fd):
        raise OSError(errno.ENOLCK, os.strerror(errno.ENOLCK))
    monkeypatch.setattr(lock, "_try_lock", no_locks)
    with pytest.raises(OutputError, match=r"cannot lock the folder \(No locks available\); "
                                          r"allowed: a folder on a file system that supports"):
        with hold_folder(tmp_path):
            pass


# ---------------------------------------------------------------- results as one set
def _set(folder: Path) -> dict:
    """The files of a folder (no subfolders, no cache) and their bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())
            if p.is_file() and p.name != "evaluations.sqlite"}


def test_a_set_replaces_the_previous_set_whole(tmp_path):
    from mechrel.io.results import MANIFEST, result_set

    with result_set(tmp_path, "demo") as stage:
        for name in ("a.csv", "b.png", "c.json"):
            (stage / name).write_text(f"first {name}")
    with result_set(tmp_path, "demo") as stage:  # a later run writes no c.json
        for name in ("a.csv", "b.png"):
            (stage / name).write_text(f"second {name}")
    files = _set(tmp_path)
    manifest = json.loads(files.pop(MANIFEST.format(name="demo")))
    assert files == {"a.csv": b"second a.csv", "b.png": b"second b.png"}
    assert [f["name"] for f in manifest["files"]] == ["a.csv", "b.png"]
    assert manifest["removes"] == ["c.json"]
    # a folder from a version without manifests: the files the command names are its set
    (tmp_path / "d.csv").write_text("an earlier run's, no manifest")
    with result_set(tmp_path, "other", known=["d.csv"]) as stage:
        (stage / "e.csv").write_text("e")
    assert not (tmp_path / "d.csv").exists()
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_dir()) == []


def test_a_failure_before_the_set_is_complete_leaves_the_previous_set(tmp_path):
    from mechrel.io.results import result_set

    with result_set(tmp_path, "demo") as stage:
        (stage / "a.csv").write_text("first")
        (stage / "b.csv").write_text("first")
    before = _set(tmp_path)
    for failure in (OutputError("--out: cannot write 'b.csv' (No space left on device)"),
                    KeyboardInterrupt()):
        with pytest.raises(type(failure)):
            with result_set(tmp_path, "demo") as stage:
                (stage / "a.csv").write_text("second")
                raise failure
        assert _set(tmp_path) == before
    (tmp_path / "b.csv").unlink()
    (tmp_path / "b.csv").mkdir()  # a folder where the set has a file: refused before any move
    with pytest.raises(OutputError, match=r"b\.csv is a folder, where this run writes a file"):
        with result_set(tmp_path, "demo") as stage:
            (stage / "a.csv").write_text("second")
            (stage / "b.csv").write_text("second")
    assert (tmp_path / "a.csv").read_text() == "first"
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_dir()) == ["b.csv"]


def test_a_run_killed_while_staging_or_committing_is_cleaned_up_or_finished(tmp_path):
    """Kill -9 (nothing runs at exit): while staging, the next run removes the staging folder
    of the dead process (the previous set stands); during the renames of the commit, the next
    run on the set rolls the journal forward (the new set stands)."""
    import subprocess
    import sys

    from mechrel.io import results

    with results.result_set(tmp_path, "demo") as stage:
        (stage / "a.csv").write_text("first")
        (stage / "b.csv").write_text("first")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    stale = tmp_path / f".mechrel-stage-demo-{dead}-abcdefgh"
    stale.mkdir()
    (stale / "a.csv").write_text("half")
    # a journal as a killed commit leaves it: a.csv moved, b.csv not yet
    journal = tmp_path / ".mechrel-commit-demo"
    journal.mkdir()
    (journal / "b.csv").write_text("second")
    (tmp_path / "a.csv").write_text("second")
    (journal / ".mechrel-set.json").write_text(json.dumps(
        {"set": "demo", "pid": int(dead), "files": [{"name": "a.csv"}, {"name": "b.csv"}],
         "removes": []}))
    with results.result_set(tmp_path, "other") as stage:  # another set: not touched
        (stage / "x.csv").write_text("x")
    assert stale.exists() and journal.exists()
    with results.result_set(tmp_path, "demo") as stage:
        assert not stale.exists() and not journal.exists()
        assert (tmp_path / "b.csv").read_text() == "second"  # rolled forward first
        (stage / "a.csv").write_text("third")
    assert (tmp_path / "a.csv").read_text() == "third" and not (tmp_path / "b.csv").exists()


def test_simulate_writes_table_figure_and_provenance_as_one_set(tmp_path, capsys,
                                                                monkeypatch):
    import matplotlib.figure

    out = tmp_path / "r.csv"
    assert main(["simulate", "slider-crank-lubricated", "--no-progress", "--out", str(out),
                 "--set", "analysis.cycles=0.25"]) == 0
    assert (tmp_path / "r-orbits.csv").is_file()
    # a later run without clearance joints leaves no orbits of the earlier one beside its table
    assert main(["simulate", "slider-crank", "--no-progress", "--out", str(out)]) == 0
    capsys.readouterr()
    first = _set(tmp_path)
    assert sorted(first) == [".mechrel-set-r.csv.json", "r.csv", "r.json", "r.png"]

    def half_then_full(self, fname, **kwargs):  # the disk fills up while the figure is saved
        Path(fname).write_bytes(b"\x89PNG half")
        _enospc()
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", half_then_full)
    assert main(["simulate", "slider-crank", "--no-progress", "--out", str(out),
                 "--set", "drivers.crank.speed=50"]) == 2
    err = capsys.readouterr().err
    assert "No space left on device" in err and err.count("\n") == 1
    assert _set(tmp_path) == first  # the earlier table, figure and provenance, together
    assert [p.name for p in tmp_path.iterdir() if p.is_dir()] == []


def test_results_respect_the_umask_and_a_replaced_file_keeps_its_mode(tmp_path):
    from mechrel.io.results import result_set

    old = os.umask(0o027)
    try:
        write_table(FRAME, tmp_path / "t.csv")
        write_json({"a": 1}, tmp_path / "s.json")
        with result_set(tmp_path / "out", "demo") as stage:
            write_table(FRAME, stage / "r.csv")
        assert (tmp_path / "t.csv").stat().st_mode & 0o777 == 0o640  # was 0600 whatever umask
        assert (tmp_path / "s.json").stat().st_mode & 0o777 == 0o640
        assert (tmp_path / "out" / "r.csv").stat().st_mode & 0o777 == 0o640
        # a file the user shared more widely stays shared when a run replaces it
        os.chmod(tmp_path / "out" / "r.csv", 0o644)
        os.chmod(tmp_path / "t.csv", 0o664)
        write_table(FRAME, tmp_path / "t.csv")
        with result_set(tmp_path / "out", "demo") as stage:
            write_table(FRAME, stage / "r.csv")
        assert (tmp_path / "t.csv").stat().st_mode & 0o777 == 0o664
        assert (tmp_path / "out" / "r.csv").stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(old)


STUDY_FOSM = FAILING_STUDY.replace("std = 0.3e-3", "std = 0.01e-3") + 'methods = ["fosm"]\n'


def test_summary_holds_no_path_of_this_machine(tmp_path, capsys):
    study = tmp_path / "studies" / "study.toml"
    study.parent.mkdir()
    study.write_text(STUDY_FOSM)
    out = tmp_path / "results" / "run"
    assert main(["reliability", str(study), "--jobs", "1", "--no-progress", "--out",
                 str(out)]) == 0
    assert f"wrote {out}/" in capsys.readouterr().out  # the terminal says where, as given
    for name in ("summary.json", ".mechrel-set-reliability.json"):
        text = (out / name).read_text()
        assert str(tmp_path) not in text, name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["source"] == "../../studies/study.toml"  # relative to the summary


def test_a_refusal_after_the_folder_was_locked_leaves_nothing_behind(tmp_path, capsys):
    """N = 1e12 is refused after the output folder is created and locked: the folder (made
    by this run) and its lock file are gone again; an existing folder keeps no lock file."""
    study = tmp_path / "study.toml"
    study.write_text(STUDY_FOSM)
    out = tmp_path / "new" / "run"
    assert main(["reliability", str(study), "--method", "mc", "--n", "1000000000000", "--out",
                 str(out), "--no-progress"]) == 2
    assert "model runs of" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()  # nor the parent it made
    out.mkdir(parents=True)
    assert main(["reliability", str(study), "--method", "mc", "--n", "1000000000000", "--out",
                 str(out), "--no-progress"]) == 2
    assert list(out.iterdir()) == []


def test_a_lock_file_removed_as_it_is_taken_is_taken_again(tmp_path, monkeypatch):
    """The race of removing lock files: a run that locks the file its holder has just removed
    (and released) notices that the name now belongs to no file, or another, and starts
    again; two runs never both hold the folder."""
    from mechrel.io import lock

    real = lock._try_lock
    calls = []

    def removed_meanwhile(fd):
        calls.append(fd)
        if len(calls) == 1:
            (tmp_path / LOCK_NAME).unlink()  # its previous holder removes it, then lets go
        return real(fd)
    monkeypatch.setattr(lock, "_try_lock", removed_meanwhile)
    with hold_folder(tmp_path):
        assert len(calls) == 2
        assert (tmp_path / LOCK_NAME).read_text() == f"{os.getpid()}\n"
    assert not (tmp_path / LOCK_NAME).exists()


# ---------------------------------------------------------------- draw and animate
@pytest.fixture
def no_simulation(monkeypatch):
    """Any simulation or assembly is a failure: the checks must come first."""
    import mechrel.io.drawing
    import mechrel.simulation

    def forbidden(*args, **kwargs):
        raise AssertionError("simulated before the arguments and the output were checked")
    monkeypatch.setattr(mechrel.simulation, "simulate", forbidden)
    monkeypatch.setattr(mechrel.io.drawing, "draw_scene", forbidden)


@pytest.mark.parametrize("argv, message", [
    (["draw", "slider-crank", "--dpi", "0"], r"argument --dpi: 0: must be >= 10; allowed: an "
                                             r"integer in \[10, 1200\] \(dots per inch\)"),
    (["draw", "slider-crank", "--dpi", "-5"], r"argument --dpi: -5: must be >= 10"),
    (["draw", "slider-crank", "--dpi", "1000000"], r"argument --dpi: 1000000: must be <= 1200"),
    (["draw", "slider-crank", "--dpi", "1e6"], r"argument --dpi: 1000000.0: expected an "
                                               r"integer"),
    (["draw", "slider-crank", "--time", "nan"], r"argument --time: nan: not a finite number"),
    (["animate", "slider-crank", "--fps", "0"], r"argument --fps: 0: must be >= 1; allowed: an "
                                                r"integer in \[1, 100\] \(frames per second\)"),
    (["animate", "slider-crank", "--fps", "1000000000"], r"argument --fps: 1000000000: must be "
                                                         r"<= 100"),
    (["animate", "slider-crank", "--magnify", "-1"], r"argument --magnify: -1: must be > 0"),
    (["animate", "slider-crank", "--magnify", "inf"], r"argument --magnify: inf: not a finite"),
    (["animate", "slider-crank", "--frames", "1"], r"argument --frames: 1: must be >= 2"),
])
def test_draw_and_animate_arguments_are_refused_before_anything_runs(argv, message, tmp_path,
                                                                     capsys, no_simulation):
    suffix = ".png" if argv[0] == "draw" else ".gif"
    with pytest.raises(SystemExit) as info:
        main([*argv, "--out", str(tmp_path / f"x{suffix}")])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert re.search(message, err.splitlines()[-1]), err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command, name", [("draw", "x.png"), ("animate", "x.gif")])
def test_draw_and_animate_check_the_output_before_anything_runs(command, name, tmp_path,
                                                                capsys, monkeypatch,
                                                                no_simulation):
    import tempfile as tempfile_mod

    (tmp_path / name).mkdir()  # a folder in the way
    assert main([command, "slider-crank", "--out", str(tmp_path / name)]) == 2
    assert capsys.readouterr().err == (
        f"mechrel: error: --out = '{tmp_path}': {name} is a folder, where this run writes a "
        f"file; allowed: a folder without a folder named {name} (remove or rename it)\n")
    assert main([command, "slider-crank", "--out", str(tmp_path / "x.jpg")]) == 2
    assert "unknown file type '.jpg'" in capsys.readouterr().err

    def read_only(*args, **kwargs):  # simulated: the tests may run as root
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))
    monkeypatch.setattr(tempfile_mod, "mkstemp", read_only)
    assert main([command, "slider-crank", "--out", str(tmp_path / "ro" / name)]) == 2
    assert "cannot create the folder or a file in it (Read-only file system)" in \
        capsys.readouterr().err


SHORT = ["--set", "analysis.cycles=0.25", "--no-progress", "--frames", "3"]


@pytest.mark.parametrize("failure", ["full disk", "interrupt"])
def test_an_animation_is_written_whole_or_not_at_all(failure, tmp_path, capsys, monkeypatch):
    """A full disk or Ctrl-C while the GIF is written leaves the earlier GIF as it was (it
    left a truncated GIF that looked valid); no temporary file is left."""
    from matplotlib import animation

    gif = tmp_path / "a.gif"
    assert main(["animate", "slider-crank", *SHORT, "--out", str(gif)]) == 0
    before = gif.read_bytes()
    real = animation.PillowWriter.finish

    def cut(self):  # the frames are rendered; writing the file fails half-way
        Path(self.outfile).write_bytes(before[: len(before) // 2])
        if failure == "full disk":
            _enospc()
        raise KeyboardInterrupt
    monkeypatch.setattr(animation.PillowWriter, "finish", cut)
    code = main(["animate", "slider-crank", *SHORT, "--out", str(gif), "--fps", "5"])
    err = capsys.readouterr().err
    assert code == (2 if failure == "full disk" else 130), err
    assert err.endswith("No space left on device); the previous file, if any, is unchanged; "
                        "allowed: a path in a writable folder on a disk with free space\n"
                        if failure == "full disk" else "mechrel: interrupted (Ctrl-C)\n")
    assert gif.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]  # no temporary file
    monkeypatch.setattr(animation.PillowWriter, "finish", real)
