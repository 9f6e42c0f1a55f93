"""The `mechrel` command: simulate, scenes, help and error reporting."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from mechrel.cli.main import main


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


def test_simulate_clearance_scene_with_overrides_and_parquet(tmp_path, capsys):
    out = tmp_path / "lub.parquet"
    rc = main(["simulate", "slider-crank-lubricated", "--set", "analysis.cycles=1",
               "--set", "joints.C.lubricant.viscosity=0.2", "--out", str(out), "--no-progress"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "acceleration error" in text and "joint C: max eccentricity ratio" in text
    frame = pd.read_parquet(out)
    for q in ("displacement", "velocity", "acceleration"):
        assert {f"slider.{q}", f"slider.{q}.ideal", f"slider.{q}.error"} <= set(frame.columns)
    orbits = pd.read_parquet(tmp_path / "lub-orbits.parquet")
    assert {"C.ex", "C.ey", "C.eps"} <= set(orbits.columns)


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
