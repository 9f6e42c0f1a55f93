"""Simulations that cannot succeed fail with a clear error, never NaN."""

import pytest

from mechrel.scene import load_scene
from mechrel.simulation import simulate


def test_lubricated_film_that_cannot_carry_the_load_is_a_clear_error():
    # A lubricated joint has no contact force: at 5000 rpm with a 1e-6 Pa s "oil" the film
    # cannot carry the slider's inertia load, ε is driven to 1 and the stiff integrator's step
    # collapses. That must be a SimulationError that says so, never NaN or a silent result.
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank-lubricated",
                       overrides={"joints.C.lubricant.viscosity": 1e-6, "analysis.cycles": 0.25})
    with pytest.raises(SimulationError, match=r"stopped at t = .*model = 'transition'"):
        simulate(scene)


def test_lubricated_journal_beyond_the_wall_is_a_failed_run_not_a_result():
    # With a 1e-12 Pa s film the integrator steps over the film's divergence and the journal
    # ends up outside the bearing (ε = 1.09 within a quarter revolution; 1.62 after two, and
    # reported as a normal result before this check). The lubricated model has no meaning
    # there: the run must fail, naming the joint, ε and the way out.
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank-lubricated",
                       overrides={"joints.C.lubricant.viscosity": 1e-12, "analysis.cycles": 0.25})
    with pytest.raises(SimulationError, match=r"joint C: the journal left the bearing "
                       r"\(eccentricity ratio ε = 1\.\d+ >= 1 at t = .*viscosity 1e-12 Pa s.*"
                       r"model = 'transition'"):
        simulate(scene)


def test_dry_penetration_beyond_the_clearance_is_a_failed_run_not_a_result():
    # Young's moduli of 1e7 Pa (rubber-soft, 2e4 times softer than steel) let the journal sink
    # 12 mm into its bearing (clearance 0.5 mm) within a quarter revolution: outside any
    # small-deformation contact law, so a failed run.
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank-dry", overrides={
        "joints.C.contact.youngs_modulus_bearing": 1e7,
        "joints.C.contact.youngs_modulus_journal": 1e7, "analysis.cycles": 0.25})
    with pytest.raises(SimulationError, match=r"joint C: penetration 0\.0\d+ m at t = .* exceeds "
                       r"the clearance \(0\.0005 m\).*Young's moduli"):
        simulate(scene)


def test_division_by_zero_in_the_compiled_kernels_is_a_simulation_error():
    # numba's compiled float division raises ZeroDivisionError (Python's error model). It used
    # to escape as such, which the UQ executor treats as a bug that stops a whole Monte Carlo
    # run; it is a failed run. Checked on the contract itself, with an integrator whose
    # kernel divides by zero.
    import numpy as np
    from mechrel.errors import SimulationError
    from mechrel.integrate.base import DOPRI5

    class Dividing(DOPRI5):
        def _advance(self, system, t0, y0, hist, t_out, ctl, log_from, n_dense):
            return 1.0 / 0.0

    with pytest.raises(SimulationError, match=r"dopri5 diverged between t = 0 s and 1 s "
                       r"\(ZeroDivisionError: float division by zero\).*extreme values"):
        Dividing().integrate(None, np.zeros(2), np.zeros(0), np.array([0.0, 1.0]))


def test_absurd_viscosity_is_a_failed_run():
    # a film of 1e200 Pa s on the slider-crank: the starting step came out as 0 (‖f‖ overflows),
    # the kernel divided by it and a ZeroDivisionError escaped. Now the starting step is
    # floored (events.H_START_FLOOR) and the run fails as a SimulationError like any other.
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank-lubricated",
                       overrides={"joints.C.lubricant.viscosity": 1e200, "analysis.cycles": 0.05})
    with pytest.raises(SimulationError, match=r"integrator 'radau' stopped at t = 0 s"):
        simulate(scene)


@pytest.mark.parametrize("integrator", ["bdf", "lsoda", "scipy-radau"])
def test_scipy_integrators_honour_max_steps(integrator):
    # SciPy's solvers used to run inside solve_ivp, which has no step limit: BDF through the
    # dry slider-crank's impacts did not finish 0.05 revolution in 120 s. The wrapper now steps
    # the OdeSolver itself and stops at max_steps, with advice that fits a stiff method.
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank-dry",
                       overrides={"analysis.cycles": 0.05, "solver.max_steps": 5})
    with pytest.raises(SimulationError, match=rf"'{integrator}' stopped at t = .*maximum number "
                       r"of steps reached after 5 steps.*raise solver.max_steps \(now 5\).*"
                       r"'dopri5'"):
        simulate(scene, integrator=integrator)


def test_scipy_event_location_survives_a_grazing_restart():
    # LSODA through the dry slider-crank's chattering contact (≈ 16 500 event restarts in the
    # first 1.8 ms): at t = 1.02 ms solve_ivp's own event handling raised "f(a) and f(b) must
    # have different signs" (the step's end states showed a sign change of a ~0 gap that its
    # dense output did not), a ValueError that escaped as a crash. The wrapper now places such
    # an event at the step's end, and the run completes (≈ 6 s).
    import numpy as np
    scene = load_scene("slider-crank-dry", overrides={"analysis.cycles": 0.15})
    res = simulate(scene, integrator="lsoda")
    assert res.stats["n_impacts"] >= 1 and np.all(np.isfinite(res.a))
    # the hard-case tests' bound |Φ| ≤ 1e-3 c (c = 0.5 mm); measured 5.7e-8 m
    assert res.stats["max_position_violation"] < 1e-3 * 0.5e-3


def test_output_grid_beyond_memory_is_named_before_anything_is_allocated():
    # a sample step of 1e-12 rad on the 5000 rpm slider-crank asks for 6e12 output instants
    # (7e6 GiB): before, numpy raised MemoryError deep inside; now the field is named
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank", overrides={"analysis.sample_step_angle": 1e-12})
    with pytest.raises(SimulationError, match=r"embedded:slider-crank: "
                       r"analysis\.sample_step_angle: 6\.28e\+12 output instants .* GiB, more "
                       r"than this machine's"):
        simulate(scene)


@pytest.mark.parametrize("name, rtol", [("double-pendulum", 0.05), ("slider-crank-dry", 0.01),
                                        ("slider-crank-lubricated", 0.1)])
def test_loose_tolerances_take_a_first_step(name, rtol):
    # A tight atol scales the components that are zero at rest (velocities), so Hairer's first
    # estimate of the starting step, 0.01 ||y|| / ||f||, fell below the underflow limit
    # (1e-14 s for the double pendulum at rtol 0.05) and the run stopped before its first step
    # with "step size underflow after 0 steps". The starting step is now floored at 1e-11 s
    # (events.H_START_FLOOR) and the error test takes it from there.
    from mechrel.integrate.events import H_START_FLOOR, H_UNDERFLOW
    assert H_START_FLOOR == 1e3 * H_UNDERFLOW
    scene = load_scene(name, overrides={"solver.rtol": rtol, "analysis.cycles": 0.25}
                       if name != "double-pendulum" else {"solver.rtol": rtol})
    res = simulate(scene)
    assert res.stats["n_steps"] > 0 and res.stats["status"] == "ok"


@pytest.mark.parametrize("call, error, message", [
    (lambda sc: simulate("slider-crank"), TypeError,
     r"simulate: scene must be a Scene, got str 'slider-crank'; load it first"),
    (lambda sc: __import__("mechrel.scene", fromlist=["with_overrides"]).with_overrides(
        "slider-crank", {}), TypeError, r"with_overrides: scene must be a Scene, got str"),
    (lambda sc: simulate(sc, rtol="x"), "SimulationError",
     r"solver\.rtol: expected a number, got 'x'"),
    (lambda sc: simulate(sc, tol=1e-6), "SimulationError",
     r"solver settings of 'dopri5': unknown 'tol'; allowed: atol, rtol, step"),
    (lambda sc: simulate(sc, integrator="dopri5", fixed_step=True), "SimulationError",
     r"solver settings of 'dopri5': unknown 'fixed_step'"),
    # named like simulate's private path's parameters: they used to be taken for them (an
    # AttributeError "'str' object has no attribute 'adaptive'" from deep inside)
    (lambda sc: simulate(sc, integrator="dopri5", solver="dopri5"), "SimulationError",
     r"solver settings of 'dopri5': unknown 'solver'; allowed: atol, rtol, step"),
    (lambda sc: simulate(sc, integrator="dopri5", provenance=False), "SimulationError",
     r"solver settings of 'dopri5': unknown 'provenance'"),
    # the ideal slider-crank is solved by kinematic analysis, which needs no integrator: a
    # misspelt one was silently ignored there
    (lambda sc: simulate(sc, integrator="dopri"), "SimulationError",
     r"solver\.integrator: unknown integrator 'dopri'; allowed: auto, bdf, dopri5"),
    (lambda sc: simulate(sc, integrator=""), "SimulationError",
     r"unknown integrator ''"),
])
def test_api_misuse_is_one_clear_error(call, error, message):
    from mechrel.errors import SimulationError
    error = SimulationError if error == "SimulationError" else error
    with pytest.raises(error, match=message):
        call(load_scene("slider-crank"))


def test_radaus_formulation_in_a_scene_run_by_another_integrator_is_named():
    # the dry slider-crank runs DOPRI5 by default: radau's equations cannot apply there
    from mechrel.errors import SimulationError
    scene = load_scene("slider-crank-dry", overrides={"solver.formulation": "absolute"})
    with pytest.raises(SimulationError, match=r"solver\.formulation = 'absolute': the equations "
                       r"that 'radau' integrates, but this scene runs 'dopri5' \(set "
                       r"solver\.integrator = 'radau', or leave solver\.formulation unset\)"):
        simulate(scene)
    res = simulate(scene, integrator="radau", rtol=1e-5, atol=1e-8)  # radau: it applies
    assert res.stats["formulation"] == "absolute"


@pytest.mark.parametrize("name", ["slider-crank", "slider-crank-dry"])
def test_over_constrained_mechanism_is_named(name):
    # a second driver on the rod: 10 constraint equations for 9 coordinates. Before, the ideal
    # slider-crank failed with "constraint Jacobian is rank deficient" from the integrator, the
    # dry one ran 1e7 DOPRI5 steps into "maximum number of steps reached"
    from mechrel.errors import SimulationError
    from mechrel.scene.loader import thaw
    raw = thaw(load_scene(name).raw)
    raw["drivers"]["r"] = {"body": "rod", "law": "constant-speed", "angle0": 0.0, "speed": 1.0}
    with pytest.raises(SimulationError, match=r"over-constrained: with ideal joints the mechanism "
                       r"has 10 constraint equations for 9 coordinates \(3 bodies\): joints\.O "
                       r"\(x\), .*drivers\.crank, drivers\.r; allowed: at most one equation"):
        simulate(load_scene(raw))


# ---- drift of the ideal joints: a result wrong by more than the effect it resolves says so
# Runs on the absolute equations hold the ideal joints by Baumgarte stabilisation only: with
# loose tolerances they drift apart, and the mechanism (and every output error) moves by the
# drift. The errors a run reports are of the clearance's size, so a drift of DRIFT_LIMIT
# (a tenth) of the smallest clearance is a tenth of the answer: the result carries a warning.

def _drifting(cycles=1.0):
    # DOPRI5 at rtol 1e-3 on the dry slider-crank drifts by 2.2 clearances over one turn
    # (8.3 over the scene's two), against 9e-8 at the scene's own rtol 1e-8
    return load_scene("slider-crank-dry", overrides={"solver.rtol": 1e-3,
                                                     "analysis.cycles": cycles})


def test_drift_of_the_ideal_joints_is_a_warning_with_the_result():
    from mechrel.errors import SimulationWarning
    from mechrel.simulation.run import DRIFT_LIMIT

    with pytest.warns(SimulationWarning) as caught:
        res = simulate(_drifting())
    drift = res.stats["max_position_violation"]
    assert drift >= DRIFT_LIMIT * 5e-4                      # the clearance of joint C
    assert len(res.warnings) == 1 and [str(w.message) for w in caught] == list(res.warnings)
    text = res.warnings[0]
    assert text.startswith("embedded:slider-crank-dry: the ideal joints drifted apart by ")
    # the ratio stated is the run's own drift over the clearance, to the 3 digits printed
    assert f"{drift / 5e-4:.3g} times the smallest clearance (0.0005 m, joint C)" in text
    assert "allowed: less than 0.1 of the clearance" in text
    assert "tighten solver.rtol and solver.atol (now dopri5 with rtol 0.001, atol 1e-11)" in text
    assert "formulation" not in text                         # DOPRI5 has no reduced equations
    assert res.to_frame().attrs["warnings"] == [text]


@pytest.mark.parametrize("name", ["slider-crank-dry", "slider-crank-lubricated",
                                  "nine-bar-lubricated"])
def test_sound_runs_carry_no_warning(name):
    import warnings

    from mechrel.errors import SimulationWarning

    with warnings.catch_warnings():
        warnings.simplefilter("error", SimulationWarning)
        res = simulate(load_scene(name, overrides={"analysis.cycles": 0.5}))
    c = min(j.clearance for j in res.scene.joints.values() if j.is_clearance)
    # the scenes' own settings drift by at most 1e-5 of the clearance, four decades below the
    # limit (measured: 9e-8 c dry with DOPRI5; ~1e-13 c on the reduced equations that the
    # lubricated scenes run; 4e-6 c even when forced onto the absolute ones)
    assert res.warnings == () and res.stats["max_position_violation"] < 1e-5 * c


def test_absolute_equations_cannot_resolve_a_tenth_of_a_micrometre_and_say_so():
    # The finding behind the check: at 0.1 µm of clearance the absolute equations' tolerance
    # on 0.1 m positions cannot resolve the gap (drift ~566 c, slider error 5.7e-5 m, 500
    # clearances); the reduced equations hold the ideal joints exactly and run clean
    # (test_clearance_hard_cases.py::test_lubricated_clearance_of_a_tenth_of_a_micrometre).
    from mechrel.errors import SimulationWarning

    scene = load_scene("slider-crank-lubricated", overrides={
        "joints.C.clearance": 1e-7, "solver.formulation": "absolute", "analysis.cycles": 0.5})
    with pytest.warns(SimulationWarning, match=r"times the smallest clearance \(1e-07 m, joint "
                      r"C\).*or, for a driven mechanism, use solver\.formulation = 'reduced'"):
        res = simulate(scene)
    assert res.stats["formulation"] == "absolute" and res.warnings


@pytest.mark.parametrize("ratio, warns", [(0.0, False), (0.0999, False), (0.1, True),
                                          (1e3, True), (float("nan"), True)])
def test_drift_limit_is_a_tenth_of_the_smallest_clearance(ratio, warns):
    # the smallest of two clearances is the scale; a NaN drift (an undefined run) warns
    from mechrel.mechanics.system import compile_scene
    from mechrel.simulation.run import _drift_caveats

    scene = load_scene("four-bar")                       # A lubricated 0.1 mm, B dry 0.2 mm
    got = _drift_caveats(scene, compile_scene(scene), ratio * 1e-4,
                         {"integrator": "radau", "formulation": "reduced"})
    assert bool(got) is warns
    if warns:
        assert "clearance (0.0001 m, joint A)" in got[0] and "formulation" not in got[0]


def test_drift_advice_follows_the_integrator():
    # adaptive: its tolerances, with their values; Radau on the absolute equations: also the
    # reduced ones; a fixed step (RK4): a smaller step, not tolerances it does not have
    from mechrel.mechanics.system import compile_scene
    from mechrel.simulation.run import _drift_caveats

    scene = load_scene("slider-crank-dry")
    c = compile_scene(scene)

    def text(stats):
        return _drift_caveats(scene, c, 1e-3, stats)[0]

    assert text({"integrator": "rk4", "settings": {"step": 2.5e-5}}).endswith(
        "allowed: less than 0.1 of the clearance); use a smaller solver.step (now rk4 with "
        "step 2.5e-05)")
    assert text({"integrator": "radau", "formulation": "absolute",
                 "settings": {"rtol": 1e-6, "atol": 1e-9}}).endswith(
        "tighten solver.rtol and solver.atol or, for a driven mechanism, use "
        "solver.formulation = 'reduced' (its ideal joints held exactly) (now radau with rtol "
        "1e-06, atol 1e-09)")


def test_a_drifting_sample_fails_its_row_with_the_reason():
    # A study's number must not carry the integrator's drift: the sample fails, and the
    # executor records and counts the reason (numbers replaced by '#', one reason for all)
    import numpy as np

    from mechrel.uq import ModelFailure, RowFailures
    from mechrel.uq.problem.mechanism import MechanismModel

    m = MechanismModel("slider-crank-dry", ["joints.C.clearance"], quantities=["displacement"],
                       angle_step=90.0, cycles=1, overrides={"solver.rtol": 1e-3})
    with pytest.raises(RowFailures) as info:
        m.evaluate_batch([m.nominal, m.nominal * 1.01])
    reasons = info.value.reasons
    assert len(reasons) == 2 and len(set(reasons)) == 1
    assert reasons[0].startswith("SimulationError: slider-crank-dry: the ideal joints drifted "
                                 "apart by # (max |Φ|, m or rad), # times the smallest clearance")
    with pytest.raises(ModelFailure, match="drifted apart"):
        m.evaluate(np.asarray(m.nominal))
