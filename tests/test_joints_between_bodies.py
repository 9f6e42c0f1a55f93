"""Joints between moving bodies: translational joints (a point and the relative angle of one
body on a line of another) and pin-in-slot joints (a point on a line, rotation free).

The constraint terms against finite differences of Φ; the kinematics of the crank and slotted
lever (oscillating, d > r, and turning fully, Whitworth's d < r) in all three forms (a block
sliding in the lever, the crank pin in the lever's slot, a rod through a ground swivel) against
their closed form, by the construction and by Newton–Raphson, over random geometries; the
embedded Whitworth and inverted slider-crank against theirs; energy conservation of undriven
mechanisms with the new joints in both formulations; the reduced equations on a turning lever;
errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mechrel.errors import AssemblyError
from mechrel.mechanics.constraints import constraint_terms, constraints
from mechrel.mechanics.construction import TURN, construction
from mechrel.mechanics.dynamics import make_workspace
from mechrel.mechanics.kinematics import _jacobian_into, _kinematics, assemble, kinematic_analysis
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import simulate


# --------------------------------------------------------------------------- scenes
def slotted_lever(r, d, ell, *, form="block", theta0=math.pi / 2, speed=10.0, driven=True,
                  gravity=(0.0, -9.81)):
    """A crank O2-A (O2 at the origin, radius r, at angle theta0 at t = 0) and a lever turning
    about O4 = (0, -d) whose line passes through A; the lever's end B is ell from O4 along it.
    ``form``: "block" (a block pinned to the crank pin slides in the lever: a translational
    joint between moving bodies), "pin" (the crank pin in the lever's slot: pin-in-slot) or
    "swivel" (a rod pinned to the crank pin slides through a swivel at the ground point O4:
    a ground pin in the rod's slot; the "lever" is then the rod). Written from joint positions
    (global_points), every frame parallel to the ground's at t = 0."""
    a = (r * math.cos(theta0), r * math.sin(theta0))
    o4 = (0.0, -d)
    e = (a[0] - o4[0], a[1] - o4[1])
    n = math.hypot(*e)
    e = (e[0] / n, e[1] / n)
    b = (o4[0] + ell * e[0], o4[1] + ell * e[1])
    mid = ((o4[0] + b[0]) / 2, (o4[1] + b[1]) / 2)
    bodies = {
        "crank": {"mass": 0.4, "inertia": 0.4 * r * r / 12, "position": [a[0] / 2, a[1] / 2],
                  "global_points": {"O2": [0.0, 0.0], "A": list(a)}},
        "lever": {"mass": 1.0, "inertia": ell * ell / 12, "position": list(mid),
                  "global_points": {"O4": list(o4), "B": list(b), "A": list(a)}},
    }
    joints = {"O2": {"type": "revolute", "connects": ["ground.O2", "crank.O2"]}}
    if form == "block":
        bodies["block"] = {"mass": 0.2, "inertia": 3e-5, "position": list(a),
                           "global_points": {"A": list(a)}}
        joints["A"] = {"type": "revolute", "connects": ["block.A", "crank.A"]}
        joints["slot"] = {"type": "translational", "connects": ["block.A", "lever.O4"],
                          "direction": list(e), "angle": 0.0}
        joints["O4"] = {"type": "revolute", "connects": ["ground.O4", "lever.O4"]}
    elif form == "pin":
        joints["slot"] = {"type": "pin-in-slot", "connects": ["crank.A", "lever.O4"],
                          "direction": list(e)}
        joints["O4"] = {"type": "revolute", "connects": ["ground.O4", "lever.O4"]}
    else:  # the rod (called lever) pinned at A, sliding through the swivel at O4
        joints["A"] = {"type": "revolute", "connects": ["crank.A", "lever.A"]}
        joints["slot"] = {"type": "pin-in-slot", "connects": ["ground.O4", "lever.A"],
                          "direction": list(e)}
    raw = {"name": f"slotted-{form}", "gravity": list(gravity),
           "ground": {"points": {"O2": [0.0, 0.0], "O4": list(o4)}},
           "bodies": bodies, "joints": joints,
           "outputs": {"B": {"point": "lever.B", "axis": [1.0, 0.0]}}}
    if driven:
        raw["drivers"] = {"crank": {"body": "crank", "law": "constant-speed", "angle0": 0.0,
                                    "speed": speed}}
        raw["analysis"] = {"cycles": 1, "cycle_driver": "crank",
                           "sample_step_angle": math.radians(5.0)}
    else:
        raw["analysis"] = {"duration": 1.0, "sample_step": 0.01}
    return raw


def lever_closed_form(r, d, theta0, w, t):
    """The lever's direction φ (continuous), φ̇ and φ̈ for the crank at θ = θ0 + ω t: the line
    O4-A with u = A − O4 = (r cos θ, r sin θ + d), φ = atan2(u_y, u_x),
    φ̇ = r ω (r + d sin θ) / D, φ̈ = r d ω² cos θ (d² − r²) / D², D = |u|² =
    r² + d² + 2 r d sin θ (derived in docs/scenes.md, "The inverted slider-crank")."""
    th = theta0 + w * t
    phi = np.unwrap(np.arctan2(r * np.sin(th) + d, r * np.cos(th)))
    D = r * r + d * d + 2 * r * d * np.sin(th)
    phid = r * w * (r + d * np.sin(th)) / D
    return phi, phid, r * d * w * w * np.cos(th) * (d * d - r * r) / D**2


def _max_rel(x, ref):
    return float(np.max(np.abs(x - ref)) / max(np.max(np.abs(ref)), 1e-300))


# --------------------------------------------------------------------------- constraint terms
def _states(scene, rng, n=4):
    c = compile_scene(scene)
    q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    for _ in range(n):  # near the assembled state, off the constraints, moving at random
        yield (c.ideal, q0 + rng.normal(0.0, 0.02, q0.size), rng.normal(0.0, 3.0, q0.size),
               float(rng.uniform(0.0, 0.5)))


SCENES = {form: slotted_lever(0.1, 0.05, 0.2, form=form, theta0=0.7)
          for form in ("block", "pin", "swivel")}
SCENES["ground slot"] = {  # a slider-crank whose slider is the rod's pin in a ground slot
    "name": "pin-in-ground-slot", "ground": {"points": {"O": [0.0, 0.0], "G": [0.3, 0.01]}},
    "bodies": {"crank": {"mass": 0.3, "inertia": 1e-4, "position": [0.025, 0.0],
                         "global_points": {"O": [0.0, 0.0], "A": [0.05, 0.0]}},
               "rod": {"mass": 0.2, "inertia": 2e-4, "position": [0.11, 0.005],
                       "global_points": {"A": [0.05, 0.0], "B": [0.17, 0.01]}}},
    "joints": {"O": {"type": "revolute", "connects": ["ground.O", "crank.O"]},
               "A": {"type": "revolute", "connects": ["crank.A", "rod.A"]},
               "slot": {"type": "pin-in-slot", "connects": ["rod.B", "ground.G"],
                        "direction": [1.0, 0.0]}},
    "drivers": {"crank": {"body": "crank", "law": "constant-speed", "angle0": 0.0,
                          "speed": 100.0}},
    "analysis": {"cycles": 1, "cycle_driver": "crank", "sample_step_angle": 0.1}}


@pytest.mark.parametrize("name", list(SCENES))
def test_constraint_terms_are_the_derivatives_of_phi(name):
    # Φ_q against central differences of Φ (h = 1e-6: truncation h² |Φ'''| ≈ 1e-12, far under
    # the 1e-8 bound), the sparse rows of the right-hand side equal to the dense ones
    # (round-off), Φ̇ = Φ_q q̇ + Φ_t, and γ = −(Φ_q q̇)_q q̇ (the joints do not depend on time,
    # the driver's speed is constant) against central differences of Φ_q q̇ along q̇
    rng = np.random.default_rng(sum(map(ord, name)))
    scene = load_scene(SCENES[name])
    for sys_, q, v, t in _states(scene, rng):
        sys_ = sys_._replace(baumgarte=np.zeros(2))  # c = γ exactly
        phi, phit, J = constraints(q, t, sys_)
        h = 1e-6
        Jfd = np.column_stack([(constraints(q + h * e, t, sys_)[0]
                                - constraints(q - h * e, t, sys_)[0]) / (2 * h)
                               for e in np.eye(q.size)])
        assert np.max(np.abs(J - Jfd)) <= 1e-8 * np.max(np.abs(J))
        ws = make_workspace(sys_)
        constraint_terms(t, q, v, sys_, ws)
        Js = np.empty_like(J)
        _jacobian_into(ws, sys_.row_body, Js)
        assert np.max(np.abs(Js - J)) <= 1e-14 * np.max(np.abs(J))
        assert np.max(np.abs(ws.phi - phi)) <= 1e-15
        assert np.max(np.abs(ws.phidot - (J @ v + phit))) <= 1e-13 * np.max(np.abs(J @ v))
        gfd = -(constraints(q + h * v, t, sys_)[2] @ v
                - constraints(q - h * v, t, sys_)[2] @ v) / (2 * h)
        assert np.max(np.abs(ws.c - gfd)) <= 1e-7 * max(np.max(np.abs(gfd)), 1.0)


def test_rows_labels_and_bodies():
    c = compile_scene(load_scene(SCENES["block"]))
    labels = c.labels["ideal"]
    # the new rows come after the fixed angles and before the drivers (always last)
    assert labels[-3:] == ("joints.slot (on line)", "joints.slot (angle)", "drivers.crank")
    index = c.body_index
    assert c.ideal.row_body[-3].tolist() == [index["block"], index["lever"]]
    c = compile_scene(load_scene(SCENES["swivel"]))
    # a ground pin: the moving body (the rod) first
    assert c.ideal.row_body[c.labels["ideal"].index("joints.slot (on line)")].tolist() == [
        c.body_index["lever"], -1]


# --------------------------------------------------------------------------- closed form
def _check_lever(raw, r, d, theta0, w, newton, ell):
    scene = load_scene(raw)
    c = compile_scene(scene)
    plan = construction(c.ideal)
    assert plan is not None and TURN in plan.op[:, 0]  # the RPR dyad, in closed form
    T = np.linspace(0.0, 2 * math.pi / w, 73)
    q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    if newton:  # every instant by Newton–Raphson and the LU of Φ_q instead
        Q, V, A, viol, done = _kinematics(q0, T, c.ideal, 1e-12, 50)
        assert done == T.size
    else:
        Q, V, A, viol = kinematic_analysis(c.ideal, q0, T)
    assert viol <= 1e-12
    phi, phid, phidd = lever_closed_form(r, d, theta0, w, T)
    b = c.body_index["lever"]
    # the lever's frame is parallel to the ground's at t = 0: its angle is φ − φ(0)
    angle, rate, acc = Q[:, 3 * b + 2], V[:, 3 * b + 2], A[:, 3 * b + 2]
    # 1e-10 of each quantity's scale over the cycle: the requirement; round-off
    # (1e-16) times the position problem's conditioning (at most (r/|d − r|)² = 25 here) is
    # far below it, Newton's tolerance 1e-12 too
    assert _max_rel(angle, phi - phi[0]) <= 1e-10
    assert _max_rel(rate, phid) <= 1e-10
    assert _max_rel(acc, phidd) <= 1e-10
    # and the lever's end B along x, by the point output's formula: B = O4 + ell (cos φ, sin φ)
    # on a lever turning about O4; on the swivel's rod B = A + (ell − ρ0) (cos φ, sin φ), ρ0
    # the distance from A to the swivel at t = 0
    res = simulate(scene, method="kinematics")
    phi, phid, _ = lever_closed_form(r, d, theta0, w, res.time)
    if raw["name"].endswith("swivel"):
        th = theta0 + w * res.time
        arm = ell - math.hypot(r * math.cos(theta0), r * math.sin(theta0) + d)
        vx = -r * w * np.sin(th) - arm * phid * np.sin(phi)
    else:
        vx = -ell * phid * np.sin(phi)
    assert _max_rel(res.outputs["B"]["velocity"], vx) <= 1e-10


geometry = st.tuples(
    st.floats(0.02, 0.2),                       # crank r (m)
    st.one_of(st.floats(0.2, 0.8), st.floats(1.25, 5.0)),  # d / r: turning or swinging lever
    st.floats(0.05, 0.5),                       # lever length (m)
    st.floats(0.0, 2 * math.pi),                # crank angle at t = 0
    st.floats(1.0, 100.0),                      # crank speed (rad/s)
    st.sampled_from(["block", "pin", "swivel"]),
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(geometry)
def test_slotted_lever_kinematics_is_the_closed_form(g):
    r, ratio, ell, theta0, w, form = g
    d = ratio * r
    raw = slotted_lever(r, d, ell, form=form, theta0=theta0, speed=w)
    _check_lever(raw, r, d, theta0, w, newton=False, ell=ell)


@pytest.mark.parametrize("form", ["block", "pin", "swivel"])
@pytest.mark.parametrize("ratio", [0.5, 3.0])
def test_slotted_lever_by_newton_is_the_closed_form(form, ratio):
    r, theta0, w = 0.1, 1.0, 20.0
    _check_lever(slotted_lever(r, ratio * r, 0.3, form=form, theta0=theta0, speed=w), r,
                 ratio * r, theta0, w, newton=True, ell=0.3)


def test_pin_in_a_ground_slot_is_a_slider_crank():
    # the rod's pin B in a fixed slot along y = 0.01: the slider-crank with offset e = 0.01,
    # x_B = r cos θ + sqrt(l² − (e − r sin θ)²), placed in closed form (a circle meeting the
    # slot's line) and by Newton
    scene = load_scene(SCENES["ground slot"])
    c = compile_scene(scene)
    assert construction(c.ideal) is not None
    r, L, e, w = 0.05, math.hypot(0.12, 0.01), 0.01, 100.0
    T = np.linspace(0.0, 2 * math.pi / w, 61)
    th = w * T
    s = np.sqrt(L * L - (e - r * np.sin(th)) ** 2)
    xb = r * np.cos(th) + s
    sd = (e - r * np.sin(th)) * r * w * np.cos(th) / s
    vb = -r * w * np.sin(th) + sd
    q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    for Q, V, *_ in (kinematic_analysis(c.ideal, q0, T), _kinematics(q0, T, c.ideal, 1e-12, 50)):
        rod = c.body_index["rod"]
        ang, x = Q[:, 3 * rod + 2], Q[:, 3 * rod]
        bx = x + np.cos(ang) * 0.06 - np.sin(ang) * 0.005  # B in the rod's frame: (0.06, 0.005)
        assert _max_rel(bx, xb) <= 1e-10
        vx = V[:, 3 * rod] - V[:, 3 * rod + 2] * (np.sin(ang) * 0.06 + np.cos(ang) * 0.005)
        assert _max_rel(vx, vb) <= 1e-10


# --------------------------------------------------------------------------- embedded scenes
def _ideal(name):
    scene = load_scene(name)
    return load_scene(name, overrides={f"joints.{j.name}.model": "ideal"
                                       for j in scene.clearance_joints})


def test_whitworth_is_its_closed_form():
    # crank r = 0.1 from vertical, lever about O4 = (0, −0.05), its end B 0.2 m along it, rod
    # BC = 0.61 m, the ram C on y = 0.26: C_x = B_x + s, s = sqrt(L² − g²), g = y_c − B_y;
    # ṡ = g Ḃ_y / s, s̈ = (g B̈_y − Ḃ_y² − ṡ²) / s (s² + g² = L² differentiated twice)
    scene = _ideal("whitworth")
    res = simulate(scene)
    assert res.method == "kinematics"
    r, d, ell, L, yc = 0.1, 0.05, 0.2, 0.61, 0.26
    w = scene.drivers["crank"].speed
    phi, phid, phidd = lever_closed_form(r, d, math.pi / 2, w, res.time)
    bx, by = ell * np.cos(phi), -d + ell * np.sin(phi)
    bvx, bvy = -ell * phid * np.sin(phi), ell * phid * np.cos(phi)
    bax = -ell * (phidd * np.sin(phi) + phid ** 2 * np.cos(phi))
    bay = ell * (phidd * np.cos(phi) - phid ** 2 * np.sin(phi))
    g = yc - by
    s = np.sqrt(L * L - g * g)
    sd = g * bvy / s
    sdd = (g * bay - bvy ** 2 - sd ** 2) / s
    ram = res.outputs["ram"]
    assert _max_rel(ram["displacement"], bx + s) <= 1e-10
    assert _max_rel(ram["velocity"], bvx + sd) <= 1e-10
    assert _max_rel(ram["acceleration"], bax + sdd) <= 1e-10
    lever = res.outputs["lever"]
    assert _max_rel(lever["angle"], phi - math.pi / 2) <= 1e-10  # drawn vertical: φ(0) = π/2
    assert _max_rel(lever["angular_velocity"], phid) <= 1e-10
    assert _max_rel(lever["angular_acceleration"], phidd) <= 1e-10
    # a Whitworth: the lever turns fully, twice in the two crank revolutions, unevenly:
    # φ̇ from r ω / (r + d) = 2ω/3 to r ω / (r − d) = 2ω
    assert lever["angle"][-1] == pytest.approx(4 * math.pi, abs=1e-9)
    assert lever["angular_velocity"].min() == pytest.approx(2 * w / 3, rel=1e-6)
    assert lever["angular_velocity"].max() == pytest.approx(2 * w, rel=1e-6)


def test_inverted_slider_crank_is_its_closed_form():
    scene = _ideal("inverted-slider-crank")
    res = simulate(scene)
    r, d, ell = 0.05, 0.15, 0.35
    w = scene.drivers["crank"].speed
    phi, phid, phidd = lever_closed_form(r, d, math.pi / 2, w, res.time)
    tip = res.outputs["tip"]
    assert _max_rel(tip["displacement"], ell * np.cos(phi)) <= 1e-10
    assert _max_rel(tip["velocity"], -ell * phid * np.sin(phi)) <= 1e-10
    assert _max_rel(tip["acceleration"],
                    -ell * (phidd * np.sin(phi) + phid ** 2 * np.cos(phi))) <= 1e-10
    rocker = res.outputs["rocker"]
    assert _max_rel(rocker["angle"], phi - math.pi / 2) <= 1e-10
    assert _max_rel(rocker["angular_velocity"], phid) <= 1e-10
    assert _max_rel(rocker["angular_acceleration"], phidd) <= 1e-10
    # the rocker swings by ± asin(r / d) about the vertical
    assert np.max(np.abs(rocker["angle"])) == pytest.approx(math.asin(r / d), rel=1e-4)


@pytest.mark.parametrize("name, overrides", [
    ("whitworth", {}), ("inverted-slider-crank", {"joints.O4.model": "lubricated"})])
def test_the_clearance_scenes_run_in_both_formulations(name, overrides):
    # a quarter cycle with the clearance joint lubricated (a dry one's impacts make the two
    # runs part ways, chaos): the reduced equations apply (the construction places the RPR
    # dyad for any eccentricity) and agree with the absolute ones to the integrators'
    # tolerance (rtol 1e-7 of the 0.1-0.7 m positions against errors of 1e-4 m: 1e-3); the
    # errors are of the clearance's size
    scene = load_scene(name, overrides={"analysis.cycles": 0.25, **overrides})
    assert construction(compile_scene(scene).dynamic) is not None
    red = simulate(scene, integrator="radau", rtol=1e-7, atol=1e-10)
    ab = simulate(scene, integrator="radau", rtol=1e-7, atol=1e-10, formulation="absolute")
    assert red.stats["formulation"] == "reduced" and ab.stats["formulation"] == "absolute"
    out = next(iter(scene.outputs))
    e1, e2 = red.error(out, "displacement"), ab.error(out, "displacement")
    c = scene.clearance_joints[0].clearance
    assert 0 < np.max(np.abs(e1)) < 20 * c
    assert np.max(np.abs(e1 - e2)) <= 1e-3 * np.max(np.abs(e1))


def test_a_turning_lever_keeps_a_continuous_angle_in_the_reduced_equations():
    # The reduced equations place the lever from the eccentricity: its angle was continued
    # from the first configuration's, so a lever that turns fully came back with jumps of 2π
    # (an angle error of −4π after two turns). Now each output row's angles are the next
    # evaluations' reference.
    scene = load_scene("whitworth", overrides={"analysis.cycles": 1.25})
    res = simulate(scene)
    assert res.stats["formulation"] == "reduced"
    err = res.error("lever", "angle")
    assert np.max(np.abs(err)) < 1e-2  # radians: the clearance's effect, no 2π
    assert res.outputs["lever"]["angle"][-1] > 2 * math.pi


# --------------------------------------------------------------------------- energy
@pytest.mark.parametrize("form", ["block", "pin", "swivel"])
@pytest.mark.parametrize("integrator, settings", [
    ("dopri5", {"rtol": 1e-10, "atol": 1e-12}),
    ("radau", {"rtol": 1e-9, "atol": 1e-12}),                              # reduced: free angle
    ("radau", {"rtol": 1e-9, "atol": 1e-12, "formulation": "absolute"}),
])
def test_undriven_slotted_lever_conserves_energy(form, integrator, settings):
    # No driver, no clearance, no friction: released from rest with the crank at 20° under
    # gravity, the lever swinging (d > r), T + V must stay constant. The drift is measured
    # relative to the energy exchanged (max T over the run); bound 1e-6: the integrators'
    # tolerances (1e-9 .. 1e-10 per step) accumulate over some hundred steps, and the
    # absolute formulation's Baumgarte terms act only on the round-off violation
    raw = slotted_lever(0.1, 0.25, 0.4, form=form, theta0=math.radians(20.0), driven=False)
    res = simulate(load_scene(raw), integrator=integrator, **settings)
    assert res.stats["formulation"] == settings.get("formulation", "reduced" if
                                                    integrator == "radau" else "absolute")
    E = res.energy["kinetic"] + res.energy["potential"]
    assert res.energy["kinetic"].max() > 0.1  # it moves: some tenths of a joule exchanged
    assert np.max(np.abs(E - E[0])) / np.max(res.energy["kinetic"]) <= 1e-6
    assert res.stats["max_position_violation"] <= 1e-9


# --------------------------------------------------------------------------- errors
def test_an_assembly_failure_names_the_joint_and_its_residual():
    # the lever's slot cannot reach the crank pin: the slot is moved 0.3 m off the pivot, more
    # than the distance from O4 to A
    raw = slotted_lever(0.1, 0.25, 0.4, form="pin", theta0=1.0)
    raw["bodies"]["lever"]["global_points"]["O4"] = [0.0, -0.25]
    raw["joints"]["slot"]["connects"] = ["crank.A", "lever.B"]
    raw["bodies"]["lever"]["global_points"]["B"] = [0.5, -0.25]
    raw["joints"]["slot"]["direction"] = [0.0, 1.0]  # x = 0.5 cannot reach |A − O4| < 0.35
    with pytest.raises(AssemblyError, match=r"joints\.slot \(on line\): \|Φ\| = [0-9.e-]+"):
        simulate(load_scene(raw))


def test_a_mechanism_the_construction_does_not_place_falls_back_to_the_absolute_equations():
    # the slotted lever driven, pushing the crank pin round, with a lubricated crank pivot: a
    # driven line meeting a circle is no step of the construction; radau's 'auto' integrates
    # the absolute equations, and asking for the reduced ones says why
    from mechrel.errors import SimulationError

    raw = slotted_lever(0.1, 0.25, 0.4, form="pin", theta0=1.0, driven=False)
    raw["drivers"] = {"lever": {"body": "lever", "law": "harmonic", "angle0": 0.0,
                                "amplitude": 0.1, "frequency": 5.0}}
    raw["joints"]["O2"].update(model="lubricated", clearance=0.1e-3, bearing_radius=5e-3,
                               length=10e-3, lubricant={"viscosity": 0.2})
    raw["analysis"] = {"duration": 0.1, "sample_step": 0.005}
    scene = load_scene(raw)
    assert construction(compile_scene(scene).dynamic) is None
    res = simulate(scene, integrator="radau", rtol=1e-8, atol=1e-11)
    assert res.stats["formulation"] == "absolute"
    with pytest.raises(SimulationError, match="cannot be placed in closed form"):
        simulate(scene, integrator="radau", formulation="reduced")
