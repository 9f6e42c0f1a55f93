"""Integrators against the kinematic analysis, conservation, convergence orders and each other.

The closed-form slider-crank kinematics (x(θ) and its time derivatives) is tested in
tests/test_kinematics.py; here the kinematic analysis is the reference for forward dynamics.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from mechrel.errors import SimulationError
from mechrel.integrate import INTEGRATORS, Radau
from mechrel.integrate.radau import lu_factor, lu_solve
from mechrel.scene import load_scene, with_overrides
from mechrel.simulation import simulate


@pytest.fixture(scope="module")
def slider_crank():
    scene = load_scene("slider-crank")
    return scene, simulate(scene)


@pytest.fixture(scope="module")
def pendulum():
    return load_scene("double-pendulum")


def _tip(res, quantity="displacement"):
    return np.stack([res.outputs["tip_x"][quantity], res.outputs["tip_y"][quantity]])


def _slope(x, y):
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


# Settings per integrator for the driven slider-crank (5000 rpm, one cycle, outputs every 1°,
# i.e. every 3.3e-5 s). Measured errors (position / acceleration / |Φ|) in parentheses; the
# thresholds 1e-6 / 1e-4 / 1e-8 leave a margin of at least 100 on each.
#  rk4 at the output interval (2e-9 / 8e-10 / 2e-10): the step that samples the cycle;
#  dopri5 1e-10, 1e-12 (5e-11 / 6e-11 / 6e-13);
#  radau 1e-9, 1e-12 (6e-9 / 4e-9 / 2e-12), RADAU5's tolerance convention (global error ~ rtol);
#  scipy-radau, bdf, lsoda 1e-9, 1e-12 (≤ 5e-9 / 4e-9 / 3e-10): one decade looser than the
#  compiled methods because every step of these crosses from Python into compiled code.
DYNAMICS_SETTINGS = {
    "rk4": {},  # step: the scene's output interval, set in the test
    "dopri5": {"rtol": 1e-10, "atol": 1e-12},
    "radau": {"rtol": 1e-9, "atol": 1e-12},
    "scipy-radau": {"rtol": 1e-9, "atol": 1e-12},
    "bdf": {"rtol": 1e-9, "atol": 1e-12},
    "lsoda": {"rtol": 1e-9, "atol": 1e-12},
}


def test_every_registered_integrator_is_covered():
    assert set(DYNAMICS_SETTINGS) == set(INTEGRATORS)


@pytest.mark.parametrize("integrator", sorted(DYNAMICS_SETTINGS))
def test_slider_crank_dynamics_equals_kinematics(slider_crank, integrator):
    scene, kin = slider_crank
    settings = dict(DYNAMICS_SETTINGS[integrator])
    if integrator == "rk4":
        settings["step"] = scene.analysis_sample_step
    res = simulate(scene, method="dynamics", integrator=integrator, **settings)
    assert res.method == "dynamics" and res.stats["status"] == "ok"
    assert res.stats["integrator"] == integrator
    x, xk = res.outputs["slider"]["displacement"], kin.outputs["slider"]["displacement"]
    a, ak = res.outputs["slider"]["acceleration"], kin.outputs["slider"]["acceleration"]
    # the slider never reaches x = 0 (x ≥ l − r = 0.07 m): pointwise relative error
    assert np.max(np.abs(x - xk) / np.abs(xk)) <= 1e-6
    # the acceleration crosses zero: relative to its amplitude over the cycle
    assert np.max(np.abs(a - ak)) / np.max(np.abs(ak)) <= 1e-4
    assert res.stats["max_position_violation"] <= 1e-8


# ---------------------------------------------------------------------------- double pendulum
@pytest.fixture(scope="module")
def pendulum_reference(pendulum):
    # DOPRI5 at rtol 1e-13: it agrees with rtol 1e-12 to 2e-12 m on the tip over 2 s, and
    # conserves T + V to 1.4e-12 J (of 9.8 J kinetic energy): far below every error compared.
    return simulate(pendulum, integrator="dopri5", rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("integrator,settings", [
    ("dopri5", {}),  # its defaults (1e-8, 1e-10): measured 1.8e-8
    # the double pendulum is undriven: radau's default formulation integrates its two links'
    # angles (the construction's free angles); measured 2.0e-7 there and 7.8e-8 on the
    # absolute equations (defaults 1e-6: 4.1e-6 and 2.1e-6)
    ("radau", {"rtol": 1e-8, "atol": 1e-11}),
    ("radau", {"rtol": 1e-8, "atol": 1e-11, "formulation": "absolute"}),
])
def test_double_pendulum_conserves_energy(pendulum, integrator, settings):
    res = simulate(pendulum, integrator=integrator, **settings)
    E = res.energy["kinetic"] + res.energy["potential"]
    # Released from rest with the bars at the height of the pivot, T + V = 0 exactly: the
    # drift is measured relative to the energy exchanged, max T (≈ 9.8 J) over the 2 s.
    assert res.time[-1] == pytest.approx(2.0)
    assert np.max(np.abs(E - E[0])) / np.max(res.energy["kinetic"]) <= 1e-6


def test_rk4_is_fourth_order(pendulum):
    scene = with_overrides(pendulum, {"analysis.sample_step": 4e-3})
    ref = simulate(scene, integrator="dopri5", rtol=1e-13, atol=1e-15)
    steps = [4e-3, 2e-3, 1e-3, 5e-4]  # all divide the output interval: uniform steps
    errs = [np.max(np.abs(_tip(simulate(scene, integrator="rk4", step=h)) - _tip(ref)))
            for h in steps]
    # measured errors 2.1e-6 … 5.7e-10 m (≥ 400 times the reference's), slope 3.94
    assert abs(_slope(steps, errs) - 4.0) <= 0.3


def test_dopri5_error_decreases_with_tolerance(pendulum, pendulum_reference):
    tols = [1e-5, 1e-7, 1e-9]
    errs = [np.max(np.abs(_tip(simulate(pendulum, integrator="dopri5", rtol=tol,
                                        atol=tol * 1e-2)) - _tip(pendulum_reference)))
            for tol in tols]
    # measured 5.8e-5, 4.0e-7, 3.1e-9 m: about proportional to the tolerance
    assert errs[0] > errs[1] > errs[2]
    assert errs[0] / errs[2] >= 1e3
    assert errs[2] <= 1e-7


@pytest.mark.parametrize("formulation", ["reduced", "absolute"])
def test_radau_fixed_step_is_fifth_order(pendulum, formulation):
    """Radau IIA's classical order 2s − 1 = 5, with constant steps on the smooth, non-stiff
    pendulum, in its two free angles and in absolute coordinates."""
    scene = with_overrides(pendulum, {"analysis.sample_step": 0.04, "analysis.duration": 1.0})
    ref = simulate(scene, integrator="dopri5", rtol=1e-13, atol=1e-15)
    steps = [0.04, 0.02, 0.01, 0.005]
    errs = [np.max(np.abs(_tip(simulate(scene, integrator="radau", step=h, fixed_step=True,
                                        rtol=1e-12, atol=1e-14, formulation=formulation))
                          - _tip(ref)))
            for h in steps]
    # measured absolute 7.5e-5 … 1.9e-9 m, slope 5.09 (local slopes 5.3, 5.0, 5.0);
    # reduced 6.8e-5 … 1.3e-9 m, slope 5.20 (local 5.8, 4.9, 5.0)
    assert abs(_slope(steps, errs) - 5.0) <= 0.3


def test_radau_stiff_setting_converges_at_stage_order(pendulum):
    """The stiff setting: Baumgarte α = 1e4 /s makes the constraint-normal motion a fast mode
    (eigenvalue ≈ −2α) while the motion on the constraint manifold, the solution, is the same.
    With constant steps h α = 40 … 10 (far outside any explicit method's stability region),
    Radau IIA keeps the positions at the round-off level and the fast variables, the
    velocities, converge at the stage order s = 3: the order reduction of Radau IIA on
    singularly perturbed problems, error O(h^(2s−1)) + O(ε h^s) with ε = 1/(2α)
    (Hairer & Wanner II, §VI.3)."""
    base = with_overrides(pendulum, {"analysis.sample_step": 8e-3, "analysis.duration": 0.2})
    ref = simulate(base, integrator="dopri5", rtol=1e-13, atol=1e-15)
    stiff = with_overrides(base, {"solver.baumgarte_alpha": 1e4})
    steps = [4e-3, 2e-3, 1e-3]
    pos, vel = [], []
    for h in steps:  # the absolute formulation: the reduced one has no Baumgarte terms
        res = simulate(stiff, integrator="radau", step=h, fixed_step=True, rtol=1e-12,
                       atol=1e-14, formulation="absolute")
        pos.append(np.max(np.abs(_tip(res) - _tip(ref))))
        vel.append(np.max(np.abs(_tip(res, "velocity") - _tip(ref, "velocity"))))
    # measured: positions 1.5e-12 … 1e-14 m, velocities 8.9e-10 … 1.0e-11 m/s (slope 3.2)
    assert max(pos) <= 1e-10
    assert abs(_slope(steps, vel) - 3.0) <= 0.5
    # and the adaptive method takes far fewer steps than an explicit one on this problem
    r_radau = simulate(stiff, integrator="radau", rtol=1e-8, atol=1e-11, formulation="absolute")
    r_dopri = simulate(stiff, integrator="dopri5", rtol=1e-8, atol=1e-11)
    assert np.max(np.abs(_tip(r_radau) - _tip(ref))) <= 1e-7
    assert r_radau.stats["n_steps"] * 10 <= r_dopri.stats["n_steps"]


def test_radau_agrees_with_scipy_radau(pendulum, pendulum_reference):
    # Same method, different conventions: RADAU5 integrates at 0.1 rtol^(2/3) (global error
    # ≈ rtol; measured 1.6e-8 m at rtol 1e-8), SciPy at rtol itself (4e-10 m). Both are within
    # their tolerance of the reference, so they agree within the sum of their tolerances.
    tol = 1e-8
    ours = simulate(pendulum, integrator="radau", rtol=tol, atol=tol * 1e-2)
    theirs = simulate(pendulum, integrator="scipy-radau", rtol=tol, atol=tol * 1e-2)
    ref = _tip(pendulum_reference)
    scale = np.max(np.abs(ref))  # 1 m: the tip's reach
    assert np.max(np.abs(_tip(ours) - ref)) <= 10 * tol * scale
    assert np.max(np.abs(_tip(theirs) - ref)) <= 10 * tol * scale
    assert np.max(np.abs(_tip(ours) - _tip(theirs))) <= 2 * 10 * tol * scale
    assert ours.stats["n_jacobians"] >= 1 and ours.stats["n_lu"] >= ours.stats["n_jacobians"]



def test_radau_counts_newton_rejections_apart():
    # The lubricated nine-bar at rtol 3e-4 (the 1 % peak criterion of the benchmarks): its step
    # size is set by the convergence of the simplified Newton iteration as the films thin
    # (docs/dev/performance-log.md, "Cost per cycle against the floor"), so nearly all of its
    # rejected trial steps are Newton's (measured 124 of 125, the other one failed the error test).
    # The count must be a part of n_rejected, neither 0 nor all of it.
    r = simulate(load_scene("nine-bar-lubricated"), integrator="radau", rtol=3e-4, atol=3e-7)
    st = r.stats
    assert 0.9 * st["n_rejected"] <= st["n_newton_rejected"] < st["n_rejected"]
    # an explicit method has no Newton iteration, whatever it rejects
    e = simulate(load_scene("double-pendulum"), integrator="dopri5", rtol=1e-6, atol=1e-9)
    assert e.stats["n_rejected"] > 0 and e.stats["n_newton_rejected"] == 0


# ---------------------------------------------------------------------------- radau internals
@pytest.mark.parametrize("dtype", [np.float64, np.complex128])
def test_lu_with_partial_pivoting(dtype):
    # The pivots are LAPACK's: getrf picks the entry of largest |Re| + |Im| (izamax with
    # dcabs1), not of largest modulus. The complex column 0 holds 1 + 1j (|Re| + |Im| = 2,
    # modulus 1.41) and 1.5 (1.5 both ways), so the two rules pivot on different rows. Same
    # pivots, so the factors agree with LAPACK's to round-off (a backward-stable elimination in
    # another order of operations: cond(A) × eps ≈ 1e-14 here), and so does the solution.
    import scipy.linalg as sla

    rng = np.random.default_rng(1)
    A = rng.standard_normal((9, 9)).astype(dtype)
    if dtype == np.complex128:
        A += 1j * rng.standard_normal((9, 9))
        A[:, 0] = [0.1, 1.5, 1 + 1j, 0.2j, -0.3, 0.5, 0.7, -0.2 + 0.4j, 1.2]
    A[0, 0] = 0.0  # needs pivoting
    b = rng.standard_normal(9).astype(dtype)
    LU, piv = A.copy(), np.zeros(9, dtype=np.int64)
    assert lu_factor(LU, piv)
    ref, ref_piv = sla.lu_factor(A)
    assert piv.tolist() == ref_piv.tolist()
    np.testing.assert_allclose(LU, ref, rtol=1e-12, atol=1e-12)
    x = b.copy()
    lu_solve(LU, piv, x)
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-12, atol=1e-12)
    S = np.ones((3, 3), dtype=dtype)  # singular: reported, not divided by zero
    assert not lu_factor(S, np.zeros(3, dtype=np.int64))


def test_radau_settings_and_errors():
    assert Radau.stiff and Radau.name == "radau" and INTEGRATORS["radau"] is Radau
    assert Radau().settings == {"rtol": 1e-6, "atol": 1e-9}
    with pytest.raises(SimulationError, match="step"):
        Radau(fixed_step=True)


def test_radau_newton_failure_is_a_status_not_garbage(pendulum):
    # One fixed step of 0.5 s through the pendulum's fall with a stiff Baumgarte term: the
    # simplified Newton iteration cannot converge and fixed-step mode may not shrink the step.
    scene = with_overrides(pendulum, {"analysis.sample_step": 0.5, "analysis.duration": 0.5,
                                      "solver.baumgarte_alpha": 1e4,
                                      "solver.baumgarte_beta": 1e4})
    with pytest.raises(SimulationError, match="Newton"):
        simulate(scene, integrator="radau", step=0.5, fixed_step=True)


def test_radau_locates_contact_onsets():
    # Dry slider-crank (0.5 mm clearance, 5000 rpm), a quarter cycle: impacts are located
    # (onset rejections), and the slider follows DOPRI5's trajectory to within a fraction of
    # the clearance (pointwise agreement is not expected: dry contact is chaotic).
    scene = with_overrides(load_scene("slider-crank-dry"), {"analysis.cycles": 0.25})
    r = simulate(scene, integrator="radau", rtol=1e-7, atol=1e-10)
    d = simulate(scene, integrator="dopri5", rtol=1e-8, atol=1e-11)
    assert r.stats["status"] == "ok"
    assert r.stats["n_impacts"] >= 1 and r.stats["n_onset_rejections"] >= 1
    pr = np.max(np.abs(r.outputs["slider"]["displacement"] - d.outputs["slider"]["displacement"]))
    assert pr <= 1e-4  # within the 0.5 mm clearance


def test_lubricated_default_is_radau_and_accurate():
    # The stiff scene type: the default (radau, 1e-7/1e-10) against DOPRI5 at 1e-10 on one
    # cycle of the lubricated slider-crank (ε reaches 0.97). Measured: peak |acceleration|
    # 5e-7 relative, pointwise 3.7e-5 of the peak, displacement 2e-8 relative; the response
    # error (lubricated − ideal acceleration, up to 1.9e4 m/s²) differs by 0.8 m/s² (4e-5).
    # DOPRI5 needs 5690 steps here, radau 213.
    scene = with_overrides(load_scene("slider-crank-lubricated"), {"analysis.cycles": 1})
    ref = simulate(scene, integrator="dopri5", rtol=1e-10, atol=1e-13)
    res = simulate(scene)
    assert res.stats["integrator"] == "radau"
    a, a_ref = res.outputs["slider"]["acceleration"], ref.outputs["slider"]["acceleration"]
    peak = np.max(np.abs(a_ref))
    assert abs(np.max(np.abs(a)) - peak) / peak <= 1e-5
    assert np.max(np.abs(a - a_ref)) / peak <= 5e-4
    x, x_ref = res.outputs["slider"]["displacement"], ref.outputs["slider"]["displacement"]
    assert np.max(np.abs(x - x_ref) / np.abs(x_ref)) <= 1e-6
    assert res.stats["n_steps"] * 10 <= ref.stats["n_steps"]


# ------------------------------------------------------- the progress bar changes nothing ---

class _Bar:
    """Stands in for tqdm: records what the integrator reports."""

    instances: list = []

    def __init__(self, total, **_):
        self.total, self.n, self.closed = total, 0, False
        _Bar.instances.append(self)

    def update(self, k):
        assert k > 0
        self.n += k

    def close(self):
        self.closed = True


@pytest.mark.parametrize("name, overrides, settings", [
    # dry impacts amplify any change of the step sequence (chaotic): the strictest check. A
    # progress bar that split the run into chunks (restarting the step-size history at each)
    # changed this run's slider acceleration error by 90 % of its peak
    ("slider-crank-dry", {"analysis.cycles": 0.5}, {}),
    ("slider-crank-dry", {"analysis.cycles": 0.25}, {"integrator": "rk4", "step": 2e-6}),
    ("slider-crank-lubricated", {"analysis.cycles": 0.5}, {}),  # radau, Jacobian history
    ("slider-crank-lubricated", {"analysis.cycles": 0.1}, {"integrator": "lsoda"}),
])
def test_progress_bar_does_not_change_the_result(monkeypatch, name, overrides, settings):
    import tqdm.auto
    monkeypatch.setattr(tqdm.auto, "tqdm", _Bar)
    scene = load_scene(name, overrides=overrides)
    plain = simulate(scene, **settings)
    _Bar.instances.clear()
    shown = simulate(scene, progress=True, **settings)
    np.testing.assert_array_equal(shown.q, plain.q)
    np.testing.assert_array_equal(shown.a, plain.a)
    for key in ("n_steps", "n_rhs", "n_rejected", "n_impacts"):
        assert shown.stats[key] == plain.stats[key]
    bar, = _Bar.instances
    assert bar.n == bar.total == plain.time.size and bar.closed


def test_progress_bar_is_filled_when_the_run_ends_before_the_first_poll(monkeypatch):
    """A run that ends before the waiting thread first looks (a short LSODA run in CI did) still
    fills the bar: here the worker is joined inside ``start``, so it is never seen alive."""
    import threading

    import tqdm.auto
    monkeypatch.setattr(tqdm.auto, "tqdm", _Bar)
    start = threading.Thread.start

    def start_and_finish(self):
        start(self)
        self.join()

    monkeypatch.setattr(threading.Thread, "start", start_and_finish)
    scene = load_scene("slider-crank-lubricated", overrides={"analysis.cycles": 0.1})
    _Bar.instances.clear()
    result = simulate(scene, progress=True)
    bar, = _Bar.instances
    assert bar.n == bar.total == result.time.size and bar.closed


class _InterruptingBar(_Bar):
    """A bar whose first update raises KeyboardInterrupt, as Ctrl-C would while the main thread
    waits for the integration."""

    def update(self, k):
        raise KeyboardInterrupt


@pytest.mark.parametrize("name, settings", [
    ("nine-bar-dry", {}),
    # SciPy's solvers are stepped by the wrapper, which checks the request at every step
    # (inside solve_ivp it could only be checked between contact events)
    ("nine-bar-lubricated", {"integrator": "lsoda"}),
])
def test_ctrl_c_stops_the_integration_where_it_is(monkeypatch, name, settings):
    # twenty cycles take ≈ 3.4 s (dry with DOPRI5 0.17 s each, lubricated with LSODA 0.18 s);
    # the bar is polled every 0.1 s, so the interrupt arrives with some but not all output
    # instants stored, and the integrator must stop at its next step instead of running to
    # the end (the test takes ≈ 0.1 s of integration, so the long run costs nothing and
    # leaves a 30x margin on the timing)
    import tqdm.auto
    monkeypatch.setattr(tqdm.auto, "tqdm", _InterruptingBar)
    scene = load_scene(name, overrides={"analysis.cycles": 20})
    with pytest.raises(KeyboardInterrupt) as info:
        simulate(scene, progress=True, **settings)
    note, = info.value.__notes__
    done, total = map(int, re.search(r"after (\d+) of (\d+) output", note).groups())
    assert note.startswith(f"{settings.get('integrator', 'dopri5')}: integration stopped")
    assert 0 < done < total == 20 * 360 + 1


def _steps_result(steps, pause=0.0):
    """Drive an integration's steps by hand, waiting ``pause`` s between them."""
    import time

    kernel = next(steps)
    time.sleep(pause)
    out = kernel()
    time.sleep(pause)
    try:
        steps.send(out)
    except StopIteration as done:
        return done.value
    raise AssertionError("integrate_steps paused more than once")


@pytest.mark.parametrize("formulation", ["reduced", "absolute"])
def test_integrate_steps_interleaved_are_integrate_bitwise_and_time_their_own_steps(formulation):
    # Radau's run as its steps (the Python before its kernel, the kernel, the Python after
    # it): two runs of different mechanisms taken step by step in turn, with 0.3 s spent
    # elsewhere between the steps, give integrate()'s numbers bitwise, and each run's wall
    # time is its own (the two pauses, 0.6 s, are not in it; a run here takes milliseconds)
    from mechrel.mechanics.kinematics import assemble
    from mechrel.mechanics.system import compile_scene

    runs = []
    for clearance in (2e-4, 3e-4):
        scene = load_scene("slider-crank-lubricated",
                           overrides={"joints.C.clearance": clearance})
        c = compile_scene(scene)
        q, v = assemble(c.assembly, c.q_guess, 0.0)
        y0 = np.concatenate([q, v, np.zeros(2)])
        t = np.linspace(0.0, 0.004, 9)
        radau = Radau(rtol=1e-6, atol=1e-9, formulation=formulation)
        runs.append((radau, c.dynamic, y0, t))
    whole = [r.integrate(s, y0, np.zeros(s.n_contacts), t, log_from=0.002, dense_points=2)
             for r, s, y0, t in runs]
    steps = [r.integrate_steps(s, y0, np.zeros(s.n_contacts), t, log_from=0.002,
                               dense_points=2) for r, s, y0, t in runs]
    kernels = [next(g) for g in steps]  # both runs' Python before their kernels
    outs = [k() for k in kernels]  # then both kernels
    import time
    time.sleep(0.3)
    got = []
    for g, out in zip(steps, outs):
        try:
            g.send(out)
        except StopIteration as done:
            got.append(done.value)
    for a, b in zip(got, whole):
        assert a.stats.formulation == formulation
        for field in ("y", "ydot", "hist", "log", "hist_out"):
            assert np.array_equal(getattr(a, field), getattr(b, field)), field
        assert a.stats.n_steps == b.stats.n_steps
    one = _steps_result(runs[0][0].integrate_steps(runs[0][1], runs[0][2], np.zeros(1),
                                                   runs[0][3]), pause=0.3)
    assert one.stats.wall_time < 0.3, one.stats.wall_time
    assert got[0].stats.wall_time < 0.3, got[0].stats.wall_time


def test_an_integrator_without_before_and_after_keeps_its_advance_signature():
    # the subclass contract's _before/_after are optional: an _advance written before them
    # (no prep argument) is called as it always was
    from mechrel.integrate.base import DOPRI5

    calls = []

    class Plain(DOPRI5):
        def _advance(self, system, t0, y0, hist, t_out, ctl, log_from, n_dense):
            calls.append(n_dense)
            return super()._advance(system, t0, y0, hist, t_out, ctl, log_from, n_dense)

    scene = load_scene("double-pendulum")
    res = simulate(scene, integrator="dopri5")
    from mechrel.mechanics.kinematics import assemble
    from mechrel.mechanics.system import compile_scene
    c = compile_scene(scene)
    q, v = assemble(c.assembly, c.q_guess)
    y0 = np.concatenate([q, v, np.zeros(2)])
    got = Plain().integrate(c.dynamic, y0, np.zeros(0), res.time, dense_points=3)
    ref = DOPRI5().integrate(c.dynamic, y0, np.zeros(0), res.time, dense_points=3)
    assert calls == [3] and np.array_equal(got.y, ref.y)
