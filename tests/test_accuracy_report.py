"""The accuracy-vs-time report on a cheap scene."""

import numpy as np

from mechrel.scene import load_scene
from mechrel.study.accuracy import accuracy_report


def test_report_orders_errors_and_recommends_fastest_meeting_target():
    # Ideal slider-crank forward dynamics over a quarter revolution: pointwise errors converge.
    # Outputs every 0.1 rad (1.9e-4 s): RK4 never steps past an output instant, so its steps
    # must stay below that spacing to be what the test says they are.
    scene = load_scene("slider-crank", overrides={"analysis.cycles": 0.25,
                                                  "analysis.sample_step_angle": 0.1})
    cands = [("rk4", {"step": 1.6e-4}), ("rk4", {"step": 4e-5}),
             ("dopri5", {"rtol": 1e-5, "atol": 1e-8}), ("dopri5", {"rtol": 1e-9, "atol": 1e-12})]
    rep = accuracy_report(scene, candidates=cands, target=1e-6, repeats=1)
    t = rep.table.set_index(["integrator", "setting"])
    assert (rep.table["failed"] == "").all()
    # RK4 is 4th order: a 4x smaller step lowers the error by ~4^4 = 256; require > 50 to
    # leave room for the output-sampling and Baumgarte contributions.
    rk = rep.table[rep.table["integrator"] == "rk4"]["measure"].to_numpy()
    assert rk[0] / rk[1] > 50
    dp = rep.table[rep.table["integrator"] == "dopri5"]["measure"].to_numpy()
    assert dp[1] < dp[0]
    ok = rep.table[rep.table["measure"] <= 1e-6]
    assert rep.recommended is not None
    assert rep.recommended["wall_time"] == ok["wall_time"].min()
    assert rep.recommended["measure"] <= 1e-6
    assert np.isfinite(t["wall_time"]).all()


# ----------------------------------------------------------------------------- chaotic scenes
# Dry slider-crank over 0.3 revolutions (one impact phase, 0.01-0.06 s per run): cheap enough
# for ensembles in the default test run.

import dataclasses  # noqa: E402
import math  # noqa: E402
import warnings  # noqa: E402

import pytest  # noqa: E402
from scipy.stats import t as student  # noqa: E402

from mechrel.cli.main import main  # noqa: E402
from mechrel.errors import SimulationWarning, StudyError  # noqa: E402
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402
from mechrel.simulation.run import DRIFT_LIMIT  # noqa: E402
from mechrel.study.accuracy import (  # noqa: E402
    compare_ensembles, ensemble_needed, ensemble_statistics, perturbed_scenes)

REF = ("dopri5", {"rtol": 1e-11, "atol": 1e-14})


@pytest.fixture(scope="module")
def dry():
    return load_scene("slider-crank-dry", overrides={"analysis.cycles": 0.3})


def test_ensemble_members_depend_only_on_seed_and_index(dry):
    c = dry.joints["C"].clearance
    ecc = [m.joints["C"].initial_eccentricity for m in perturbed_scenes(dry, 4, seed=3)]
    # spawned child seeds: enlarging the ensemble keeps its first members
    assert ecc == [m.joints["C"].initial_eccentricity
                   for m in perturbed_scenes(dry, 6, seed=3)][:4]
    assert ecc != [m.joints["C"].initial_eccentricity for m in perturbed_scenes(dry, 4, seed=4)]
    assert len(set(ecc)) == 4
    assert np.allclose(np.hypot(*np.transpose(ecc)), 1e-6 * c, rtol=1e-12)
    # the 0.5 nm offset survives assembly (a perturbation below the assembly tolerance would
    # be dropped by the Newton iteration without any error)
    res = simulate(perturbed_scenes(dry, 2, seed=3)[1], method="dynamics")
    e0 = math.hypot(res.orbits["C"]["ex"][0], res.orbits["C"]["ey"][0])
    assert e0 == pytest.approx(1e-6 * c, rel=1e-3)


def test_ensemble_statistics_are_reproducible(dry):
    a = ensemble_statistics(dry, "dopri5", {"rtol": 1e-7, "atol": 1e-10}, ensemble=3, seed=5)
    b = ensemble_statistics(dry, "dopri5", {"rtol": 1e-7, "atol": 1e-10}, ensemble=3, seed=5)
    assert a.statistics.shape == (3, 3, 3)
    assert np.array_equal(a.statistics, b.statistics)
    assert np.array_equal(a.n_rhs, b.n_rhs)
    assert np.ptp(a.statistics, axis=0).max() > 0  # the members differ


def test_reference_against_itself_is_within_its_floor(dry):
    # Two independent 16-member ensembles of the reference (seeds 1 and 2). Each of the 9
    # statistics' difference / standard error is Student-t with 15 degrees of freedom (for
    # roughly normal member statistics); with the two-sided Bonferroni bound over the 9 the
    # false-alarm rate of this test is <= 1e-3.
    R = 16
    a = ensemble_statistics(dry, *REF, ensemble=R, seed=1)
    b = ensemble_statistics(dry, *REF, ensemble=R, seed=2)
    diff, se = compare_ensembles(a, b)
    assert (se > 0).all()
    limit = student.ppf(1 - 1e-3 / (2 * diff.size), R - 1)  # 5.18
    assert np.max(np.abs(diff) / se) < limit
    # the same seed pairs identical members: no difference at all
    d0, s0 = compare_ensembles(a, a)
    assert not d0.any() and not s0.any()


def test_gross_setting_exceeds_and_tiny_target_is_below_floor(dry):
    period = compile_scene(dry).period
    cands = [("rk4", {"step": period / 500}), ("dopri5", {"rtol": 1e-2, "atol": 1e-5}),
             ("dopri5", {"rtol": 1e-9, "atol": 1e-12})]
    with warnings.catch_warnings():
        # the gross setting's drift of the ideal joints (several clearances) is the table's
        # to state (max_violation, its error), not a SimulationWarning per member run
        warnings.simplefilter("error", SimulationWarning)
        rep = accuracy_report(dry, candidates=cands, ensemble=4, seed=0, target=0.01)
    assert dataclasses.is_dataclass(rep) and rep.ensemble == 4
    gross = rep.to_frame().set_index("setting").loc["rtol=0.01, atol=1e-05"]
    assert gross["max_violation"] > DRIFT_LIMIT * dry.joints["C"].clearance
    with pytest.raises(dataclasses.FrozenInstanceError):
        rep.target = 1.0
    t = rep.to_frame().set_index("setting")
    assert {"ensemble", "floor", "bound", "verdict", "wall_total"} <= set(t.columns)
    assert (t["ensemble"] == 4).all() and (t["failed"] == "").all()
    assert t.loc["step=2.4e-05", "verdict"] == "exceeds"   # h = T/500: ~20 % off
    assert t.loc["rtol=0.01, atol=1e-05", "verdict"] != "meets"
    tight = t.loc["rtol=1e-09, atol=1e-12"]
    assert tight["verdict"] == "meets" and tight["bound"] <= 0.01
    assert rep.recommended["setting"] == "rtol=1e-09, atol=1e-12"
    assert (t["bound"] >= t["measure"]).all() and (t["floor"] > 0).all()
    # wall_time is the median member run, wall_total all 4: at least 2 runs are >= median
    assert (t["wall_total"] >= 2 * t["wall_time"]).all()

    # rtol 1e-12 against the 1e-11 reference: a difference of a few floors, far from the
    # Bonferroni-corrected 7.2 floors that would resolve it; a 1e-9 target is below the floor
    tiny = accuracy_report(dry, candidates=[("dopri5", {"rtol": 1e-12, "atol": 1e-15})],
                           ensemble=4, seed=0, target=1e-9)
    assert tiny.recommended is None
    assert "below the resolvable floor" in tiny.conclusion
    assert tiny.ensemble_needed > 4 and "members would be needed" in tiny.conclusion


def test_ensemble_needed_scales_with_floor_over_target_squared():
    n = ensemble_needed(0.02, 0.01, 8)  # t(7) * 0.02 = 0.038 > 0.01
    t = lambda r: student.ppf(0.95, r - 1)  # noqa: E731
    assert t(n) * 0.02 * math.sqrt(8 / n) <= 0.01 < t(n - 1) * 0.02 * math.sqrt(8 / (n - 1))
    assert n == pytest.approx(8 * (1.645 * 2) ** 2, rel=0.05)  # large R: t -> z
    assert ensemble_needed(0.001, 0.01, 8) == 8


@pytest.mark.parametrize("kwargs, match", [
    ({"ensemble": 1}, "at least 2"),
    ({"ensemble": 2.5}, "not an integer"),
    ({"ensemble": 4, "perturbation": 0.0}, "perturbation"),
    ({"ensemble": 4, "seed": -1}, "seed"),
    ({"target": 0.0}, "target"),
])
def test_bad_arguments(dry, kwargs, match):
    with pytest.raises(StudyError, match=match):
        accuracy_report(dry, candidates=[], **kwargs)


def test_ensemble_is_refused_for_converging_scenes():
    scene = load_scene("slider-crank-lubricated")
    with pytest.raises(StudyError, match="measured pointwise"):
        accuracy_report(scene, candidates=[], ensemble=4)


def test_cli_accuracy_ensemble_error_and_floor(capsys, tmp_path):
    assert main(["accuracy", "slider-crank-dry", "--ensemble", "1"]) == 2
    assert "at least 2" in capsys.readouterr().err
    assert main(["accuracy", "slider-crank-dry", "--set", "analysis.cycles=0.3", "--quick",
                 "--ensemble", "2", "--target", "1e-9", "--no-progress",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "R = 2" in out and "floor" in out
    # rtol 1e-8 (error 6e-5, floor 3e-5) may meet 1e-9 but cannot be resolved at R = 2
    assert "below the resolvable floor" in out and "members would be needed" in out
    assert (tmp_path / "accuracy.png").exists()


@pytest.mark.slow
def test_reference_against_itself_chaotic_two_cycles():
    # The full scene (2 revolutions), where the members' trajectories have separated: the same
    # Bonferroni t-test as above (false-alarm rate <= 1e-3), now at R = 8.
    scene = load_scene("slider-crank-dry")
    R = 8
    a = ensemble_statistics(scene, *REF, ensemble=R, seed=1)
    b = ensemble_statistics(scene, *REF, ensemble=R, seed=2)
    diff, se = compare_ensembles(a, b)
    assert np.max(np.abs(diff) / se) < student.ppf(1 - 1e-3 / (2 * diff.size), R - 1)
