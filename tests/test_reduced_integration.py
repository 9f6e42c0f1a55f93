"""Radau on the reduced equations (the clearance joints' eccentricities) against Radau on the
absolute ones: which formulation runs where, and that the two integrate the same motion.

The per-quantity bounds are the formulations' own integration errors, estimated the usual way
(a run against one at a ten times tighter tolerance) and measured on the lubricated nine-bar:
at rtol 1e-10 the absolute formulation's slider acceleration is within 1.1e-5 of the peak of
its rtol 1e-11 run, the reduced one's within 1e-7; displacement and velocity within 1e-7. Two
formulations that integrate the same equations differ by at most the sum of their errors,
so the test allows twice each estimate (an estimate from one tighter run is itself only
accurate to a factor of about two). A difference in the equations shows far above that: one
per cent more viscosity in one joint of the nine-bar moves the slider's errors by 0.4 %
(displacement, velocity) and 1 % (acceleration) of their peaks at rtol 1e-10.
"""

from __future__ import annotations

import numpy as np
import pytest

from mechrel.errors import SimulationError
from mechrel.integrate.radau import Radau
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import simulate

LUBRICATED = ("nine-bar-lubricated", "slider-crank-lubricated")
KINDS = ("displacement", "velocity", "acceleration")


def _dev(a, b, kind):
    """Max |a − b| of the slider's error over the cycle, relative to b's peak (θ = 0, fixed
    by the initial state, left out)."""
    e, eb = a.error("slider", kind)[1:], b.error("slider", kind)[1:]
    return float(np.max(np.abs(e - eb)) / np.max(np.abs(eb)))


def _run(name, formulation, rtol):
    res = simulate(load_scene(name), rtol=rtol, atol=rtol * 1e-3, formulation=formulation)
    assert res.stats["status"] == "ok" and res.stats["formulation"] == formulation
    return res


@pytest.fixture(scope="module", params=LUBRICATED)
def runs(request):
    name = request.param
    return name, {(f, r): _run(name, f, r) for f in ("absolute", "reduced")
                  for r in (1e-5, 1e-7, 1e-10, 1e-11)}


def test_auto_is_reduced_where_it_applies_and_absolute_elsewhere():
    for name in ("nine-bar-lubricated", "slider-crank-lubricated", "four-bar"):
        sys_ = compile_scene(load_scene(name)).dynamic
        if sys_.cl_b.shape[0]:
            assert Radau().formulation_for(sys_) == "reduced", name
    # undriven: the free angles are coordinates to integrate, with or without clearance
    pendulum = compile_scene(load_scene("double-pendulum")).dynamic
    assert Radau().formulation_for(pendulum) == "reduced"
    # fully driven and ideal: nothing to integrate
    assert Radau().formulation_for(compile_scene(load_scene("nine-bar")).dynamic) == "absolute"
    assert Radau(formulation="absolute").formulation_for(
        compile_scene(load_scene("nine-bar-lubricated")).dynamic) == "absolute"


def test_a_scene_chooses_radaus_formulation():
    # [solver] formulation: the scene's choice reaches radau, a keyword of simulate overrides
    # it, and a scene that leaves it unset has no such field in its canonical form (so no
    # scene hash moved when the field was added)
    from mechrel.scene import canonical_json, with_overrides

    base = load_scene("slider-crank-lubricated", overrides={"analysis.cycles": 0.25})
    absolute = with_overrides(base, {"solver.formulation": "absolute"})
    assert "formulation" not in canonical_json(base)
    assert '"formulation":"absolute"' in canonical_json(absolute)
    assert simulate(base).stats["formulation"] == "reduced"
    assert simulate(absolute).stats["formulation"] == "absolute"
    assert simulate(absolute, formulation="reduced").stats["formulation"] == "reduced"


def test_asking_for_reduced_where_it_cannot_apply_says_why():
    ideal = compile_scene(load_scene("nine-bar")).dynamic
    with pytest.raises(SimulationError, match=r"radau's formulation = 'reduced': the mechanism "
                                              r"has no clearance joint and no undriven degree of "
                                              r"freedom: nothing to integrate.*use 'auto' or "
                                              r"'absolute'"):
        Radau(formulation="reduced").formulation_for(ideal)
    # a revolute joint that holds a prescribed offset is not a node the construction knows
    offset = compile_scene(load_scene("nine-bar-lubricated")).dynamic
    offset = offset._replace(rev_off=np.full_like(offset.rev_off, 1e-4))
    with pytest.raises(SimulationError, match=r"radau's formulation = 'reduced': the mechanism "
                                              r"cannot be placed in closed form"):
        Radau(formulation="reduced").formulation_for(offset)
    with pytest.raises(SimulationError, match=r"radau's formulation = 'exact': allowed: 'auto', "
                                              r"'absolute', 'reduced'"):
        Radau(formulation="exact")


def test_the_two_formulations_integrate_the_same_motion(runs):
    name, r = runs
    for kind in KINDS:
        own_abs = _dev(r["absolute", 1e-10], r["absolute", 1e-11], kind)
        own_red = _dev(r["reduced", 1e-10], r["reduced", 1e-11], kind)
        between = _dev(r["reduced", 1e-10], r["absolute", 1e-10], kind)
        assert between <= 2.0 * (own_abs + own_red), (name, kind, between, own_abs, own_red)
        # and the reduced formulation converges: two decades of rtol, at least one of error
        assert own_red <= 1e-6, (name, kind, own_red)


def test_the_same_settings_are_at_least_as_accurate_in_the_reduced_formulation(runs):
    # docs/performance.md compares the formulations at equal accuracy; this is the claim that
    # the settings a scene or study gives never lose accuracy by the switch to reduced. Both
    # against the reduced rtol 1e-11 run, the best estimate of the motion (its own error
    # ≤ 1e-7 of the peak by the test above).
    name, r = runs
    best = r["reduced", 1e-11]
    for rtol in (1e-5, 1e-7):
        for kind in KINDS:
            red = _dev(r["reduced", rtol], best, kind)
            ab = _dev(r["absolute", rtol], best, kind)
            assert red <= ab, (name, rtol, kind, red, ab)


def test_reduced_runs_hold_the_constraints_and_close_the_energy_balance(runs):
    # the construction places the bodies exactly: |Φ| at the round-off of metre coordinates
    # (64 eps), where the absolute formulation holds them to its integration error (1e-9 m at
    # rtol 1e-7); the balance |ΔT + ΔV − W_in − W_cl| within 1e-4 of the energy scale, the
    # bound tests/test_clearance_hard_cases.py derives for rtol 1e-7
    name, r = runs
    eps = np.finfo(float).eps
    for rtol in (1e-5, 1e-7):
        res = r["reduced", rtol]
        assert res.stats["max_position_violation"] <= 64 * eps
        assert res.stats["max_velocity_violation"] <= 64 * eps * 10.0  # |q̇| up to ~10 m/s
        E = res.energy
        scale = max(E["kinetic"].max(), np.abs(E["input_work"]).max(),
                    np.abs(E["dissipated"]).max())
        assert np.max(np.abs(E["balance"])) <= 1e-4 * scale
        assert r["absolute", rtol].stats["max_position_violation"] > 64 * eps


# ------------------------------------------------------------------ undriven mechanisms
def _undriven(name):
    from test_reduced import PENDULUM_LUBRICATED, cart_pendulum, undriven_four_bar

    if name.startswith("cart-pendulum"):
        return cart_pendulum(lubricated=name.endswith("lubricated")), "cart"
    if name == "pendulum-lubricated":
        return load_scene(PENDULUM_LUBRICATED), "tip_y"
    if name == "four-bar-undriven":
        return undriven_four_bar(), "tip"
    return load_scene(name), "tip_y"


def _out_dev(a, b, output, kind):
    """Max |a − b| of an output over the run, relative to b's peak."""
    x, xb = a.outputs[output][kind], b.outputs[output][kind]
    return float(np.max(np.abs(x - xb)) / np.max(np.abs(xb)))


@pytest.fixture(scope="module", params=("double-pendulum", "pendulum-lubricated",
                                        "four-bar-undriven", "cart-pendulum",
                                        "cart-pendulum-lubricated"))
def undriven_runs(request):
    scene, output = _undriven(request.param)
    runs = {}
    for f in ("absolute", "reduced"):
        for rtol in (1e-10, 1e-11):
            res = simulate(scene, integrator="radau", rtol=rtol, atol=rtol * 1e-3,
                           formulation=f)
            assert res.stats["status"] == "ok" and res.stats["formulation"] == f
            runs[f, rtol] = res
    return request.param, output, runs


def test_undriven_mechanisms_integrate_the_same_motion_in_their_free_angles(undriven_runs):
    # An undriven link's angle is a coordinate of the reduced equations (the construction's
    # free angle): the double pendulum (two free angles), the same pendulum with a
    # lubricated middle hinge (and one eccentricity), the four-bar without its driver (one
    # free angle, two eccentricities, a dry joint that impacts); and an undriven slider's
    # position (a free position): the cart with a pendulum (and a lubricated hinge). The
    # bound is the module's: the two formulations differ by at most the sum of their own
    # errors, each estimated against a ten times tighter run, with a factor of two for that
    # estimate.
    name, output, r = undriven_runs
    for kind in KINDS:
        own_abs = _out_dev(r["absolute", 1e-10], r["absolute", 1e-11], output, kind)
        own_red = _out_dev(r["reduced", 1e-10], r["reduced", 1e-11], output, kind)
        between = _out_dev(r["reduced", 1e-10], r["absolute", 1e-10], output, kind)
        assert between <= 2.0 * (own_abs + own_red), (name, kind, between, own_abs, own_red)
    # the constraints to round-off (64 eps of metre coordinates, q̇ up to ~10 m/s), and the
    # energy balance |ΔT + ΔV − W_in − W_cl|, an integration error: within Radau's internal
    # tolerance 0.1 rtol^(2/3) (mechrel.integrate.radau) of the energy scale, and smaller at
    # the tighter setting (measured at rtol 1e-10: 8.4e-8 J of 9.8 J on the double pendulum,
    # 0.4 of the bound; 1.6e-8 J at 1e-11)
    eps = np.finfo(float).eps
    res = r["reduced", 1e-10]
    assert res.stats["max_position_violation"] <= 64 * eps
    assert res.stats["max_velocity_violation"] <= 64 * eps * 10.0
    E = res.energy
    scale = max(E["kinetic"].max(), np.abs(E["dissipated"]).max())
    balance = np.max(np.abs(E["balance"]))
    assert balance <= 0.1 * 1e-10 ** (2 / 3) * scale, name
    assert np.max(np.abs(r["reduced", 1e-11].energy["balance"])) < balance, name


@pytest.mark.parametrize("lubricated", (False, True))
def test_a_free_position_keeps_the_carts_horizontal_momentum(lubricated):
    # The cart with a pendulum: no horizontal force, released at rest, so the horizontal
    # momentum m_cart ẋ_cart + m_pend ẋ_pend stays zero. The absolute formulation keeps it
    # to round-off (a Runge–Kutta method conserves linear invariants of its state: 64 eps of
    # the scale); in the reduced state (s, φ, ṡ, φ̇) it is not linear, so it is an integration
    # error there: within Radau's internal tolerance 0.1 rtol^(2/3) of the momentum scale
    # m_pend max|ẋ_pend| (measured at rtol 1e-10: 3.1e-9 N s against a scale of 0.53 N s,
    # 0.27 of the bound)
    from test_reduced import cart_pendulum

    scene = cart_pendulum(lubricated=lubricated)
    rtol = 1e-10
    for f, rel in (("reduced", 0.1 * rtol ** (2 / 3)), ("absolute", 64 * np.finfo(float).eps)):
        v = simulate(scene, integrator="radau", rtol=rtol, atol=rtol * 1e-3, formulation=f).v
        p = 2.0 * v[:, 0] + 0.5 * v[:, 3]
        assert np.abs(p).max() <= rel * 0.5 * np.abs(v[:, 3]).max(), (lubricated, f)


def test_a_block_on_an_incline_slides_at_g_sin_30():
    # one free position and no revolute joint: s̈ = g sin 30° = 4.905 m/s² exactly, so
    # s = ½ g sin 30° t². Radau's stages and its dense output (the collocation polynomial of
    # degree 3) are exact for a quadratic, so only round-off is left: 64 eps of the largest
    # value (measured: 2.2e-15 m of 2.45 m)
    from test_reduced import block_incline

    res = simulate(block_incline(), integrator="radau", rtol=1e-6, atol=1e-9)
    assert res.stats["formulation"] == "reduced" and res.stats["status"] == "ok"
    t, out = res.time, res.outputs["block"]
    a = 9.81 * 0.5
    eps = np.finfo(float).eps
    assert np.abs(out["displacement"] - 0.5 * a * t ** 2).max() <= 64 * eps * 0.5 * a
    assert np.abs(out["velocity"] - a * t).max() <= 64 * eps * a
    assert np.abs(out["acceleration"] - a).max() <= 64 * eps * a
