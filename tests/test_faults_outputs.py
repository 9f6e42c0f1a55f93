"""Fault injection, outputs: atomic writes (a failed write leaves the previous file whole and no
temporary file), the output folder checked before any evaluation, a refused run leaves no
earlier run's results beside its summary, and a second run on a held folder is refused."""

from __future__ import annotations

import errno
import json
import os
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
    assert list(out.iterdir()) == []


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
