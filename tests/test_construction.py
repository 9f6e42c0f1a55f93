"""The closed-form kinematic analysis (mechrel.mechanics.construction): which mechanisms it
builds, that what it builds solves the constraint equations, its agreement with Newton–Raphson,
frame invariance, the assembly branch, and the hand-over to Newton where it cannot build."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechrel.errors import AssemblyError
from mechrel.mechanics import kinematics
from mechrel.mechanics.constraints import constraints
from mechrel.mechanics.drivers import driver_law
from mechrel.mechanics.construction import (ANGLE_CONSTANT, ANGLE_FREE, CIRCLE_LINE, CIRCLES,
                                            LOCATE, OFFSET, POSE_ANGLE, POSE_TWO, SLIDE,
                                            _construct, construction)
from mechrel.mechanics.kinematics import _kinematics, assemble, kinematic_analysis
from mechrel.mechanics.system import D_ANGLE0, D_SPEED, compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import output_times

from test_kinematics import _numpy_gamma

EPS = np.finfo(float).eps
DRIVEN = ("nine-bar", "slider-crank", "four-bar")


def _setup(name, overrides=None):
    scene = load_scene(name, overrides=overrides)
    compiled = compile_scene(scene)
    tol = scene.solver.assembly_tolerance
    q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol)
    times = np.linspace(0.0, 2 * compiled.period, 2 * 360 + 1)  # two cycles at 1°
    return scene, compiled, q0, times, tol


def test_the_embedded_driven_scenes_are_built_of_class_two_groups():
    expect = {
        # the two driven cranks, each locating its pin; rod 3 and rod 4 meet at P; the plate
        # and rod 5 at Q, which places the plate and locates R; rod 7 and the slider's line
        # meet at S
        "nine-bar": [POSE_ANGLE, LOCATE, POSE_ANGLE, LOCATE, CIRCLES, POSE_TWO, POSE_TWO,
                     CIRCLES, POSE_TWO, POSE_TWO, LOCATE, CIRCLE_LINE, POSE_TWO, POSE_ANGLE],
        "slider-crank": [POSE_ANGLE, LOCATE, CIRCLE_LINE, POSE_TWO, POSE_ANGLE],
        "four-bar": [POSE_ANGLE, LOCATE, CIRCLES, POSE_TWO, POSE_TWO],
    }
    for name, ops in expect.items():
        plan = construction(compile_scene(load_scene(name)).ideal)
        assert plan.op[:, 0].tolist() == ops, name
        assert plan.n_branches == sum(o in (CIRCLES, CIRCLE_LINE) for o in ops)
        # the distances the circles use are the links' lengths (nine-bar: rod 3 0.326 m from
        # A to P, rod 4 0.497 m from B to P)
    nine = construction(compile_scene(load_scene("nine-bar")).ideal)
    assert nine.par[4, :2].tolist() == pytest.approx([0.326, 0.497], abs=1e-12)


def test_an_undriven_link_swings_at_a_free_angle():
    # the double pendulum: no driver, so each link is posed at a free angle about its placed
    # hinge (ground O, then A); free angle f's row of the passes' drv follows the drivers'
    # (none here), its index in column 5
    plan = construction(compile_scene(load_scene("double-pendulum")).ideal)
    assert plan.op[:, 0].tolist() == [POSE_ANGLE, LOCATE, POSE_ANGLE]
    assert plan.op[[0, 2], 3].tolist() == [ANGLE_FREE, ANGLE_FREE]
    assert plan.op[[0, 2], 1].tolist() == [0, 1] and plan.op[[0, 2], 5].tolist() == [0, 1]
    assert plan.n_free == 2 and plan.n_branches == 0
    # the four-bar without its driver: the crank gets the one free angle, and the coupler and
    # rocker close the loop by circles, as in the driven four-bar; the driven scenes, none
    from test_reduced import undriven_four_bar
    plan = construction(compile_scene(undriven_four_bar()).ideal)
    assert plan.op[:, 0].tolist() == [POSE_ANGLE, LOCATE, CIRCLES, POSE_TWO, POSE_TWO]
    assert plan.op[0, 3] == ANGLE_FREE and plan.n_free == 1
    for name in DRIVEN:
        assert construction(compile_scene(load_scene(name)).ideal).n_free == 0, name


def test_an_undriven_slider_slides_at_a_free_position():
    # the cart with a pendulum: nothing is placed from the ground, so the cart (a slider with
    # no placed node) takes a free position, its node at P0 + s u on the rail (P0 the hinge
    # at s = 0, u the rail's direction), its angle the rail's; then the pendulum swings at a
    # free angle about the hinge. Free coordinate 0 is the position, 1 the angle.
    from test_reduced import block_incline, cart_pendulum
    plan = construction(compile_scene(cart_pendulum()).ideal)
    assert plan.op[:, 0].tolist() == [SLIDE, POSE_ANGLE, POSE_ANGLE]
    assert plan.op[0, 2] == 0 and plan.op[0, 4:6].tolist() == [0, 0]  # the cart; drv row 0
    assert plan.op[1, 3] == ANGLE_CONSTANT and plan.op[2, 3] == ANGLE_FREE
    assert plan.op[2, 4:6].tolist() == [1, 1] and plan.n_free == 2
    assert plan.par[0, :4].tolist() == [0.0, 0.0, 1.0, 0.0]
    # with a lubricated hinge the pendulum's end is the cart's node offset by e
    plan = construction(compile_scene(cart_pendulum(lubricated=True)).dynamic)
    assert plan.op[:, 0].tolist() == [SLIDE, POSE_ANGLE, OFFSET, POSE_ANGLE]
    assert plan.n_free == 2 and plan.cl_nodes.shape == (1, 2)
    # a block with no revolute joint slides on its own sliding point, down the incline
    plan = construction(compile_scene(block_incline()).ideal)
    assert plan.op[:, 0].tolist() == [SLIDE, POSE_ANGLE] and plan.n_free == 1
    assert np.allclose(plan.par[0, 2:4], [math.cos(math.pi / 6), -math.sin(math.pi / 6)],
                       rtol=0.0, atol=EPS)
    # a slider that a driven group places is not free: the slider-crank's, by a circle
    assert SLIDE not in construction(compile_scene(load_scene("slider-crank")).ideal).op[:, 0]


def test_mechanisms_not_built_that_way_are_left_to_newton():
    # the driver moved to the slider: the slider's angle held twice, the crank free
    scene = load_scene("slider-crank", overrides={"drivers.crank.body": "slider"})
    assert construction(compile_scene(scene).ideal) is None
    # a clearance joint held at a prescribed eccentricity (the assembly system): the joint's
    # two points do not coincide, so they are not one node
    scene = load_scene("slider-crank-dry",
                       overrides={"joints.C.initial_eccentricity": [1e-4, 0.0]})
    compiled = compile_scene(scene)
    assert construction(compiled.assembly) is None
    assert construction(compiled.ideal) is not None


@pytest.mark.parametrize("name", DRIVEN)
def test_what_the_closed_form_builds_solves_the_constraint_equations(name):
    # Φ(q) = 0, Φ_q q̇ = −Φ_t and Φ_q q̈ = γ define the kinematic solution (on one assembly
    # branch); checked here with the dense constraints() and the NumPy γ of the tests, not
    # with anything the closed form uses. The closed form is exact, so what is left is
    # round-off: a few dozen operations on coordinates below 3 m give |Φ| of a few ulp of
    # 3 m (64 eps ≈ 1.4e-14 m allows ten times what was measured), and the velocity and
    # acceleration equations hold normwise to 64 eps (measured: below 0.5 eps).
    _, compiled, q0, times, tol = _setup(name)
    system = compiled.ideal
    Q, V, A, viol = kinematic_analysis(system, q0, times, tol=tol)
    assert viol <= 64 * EPS
    for k, t in enumerate(times):
        phi, phit, J = constraints(Q[k], t, system)
        assert np.max(np.abs(phi)) <= 64 * EPS
        scale = np.linalg.norm(J, np.inf)
        assert np.max(np.abs(J @ V[k] + phit)) <= 64 * EPS * scale * np.max(np.abs(V[k]))
        g = _numpy_gamma(Q[k], V[k], t, system)
        assert np.max(np.abs(J @ A[k] - g)) <= 64 * EPS * (
            scale * np.max(np.abs(A[k])) + np.max(np.abs(g)))


@pytest.mark.parametrize("name", DRIVEN)
def test_the_closed_form_agrees_with_newton_within_newtons_tolerance(name):
    # Newton stops at |Φ| <= tol = 1e-12 (m), the closed form is exact to round-off: to first
    # order their positions differ by Φ_q⁻¹ Φ(q_Newton), so by at most ‖Φ_q⁻¹‖∞ × tol (the
    # norm computed at each instant; 37-78 on these scenes). The velocities and accelerations
    # are compared with LAPACK's solves of Φ_q q̇ = −Φ_t and Φ_q q̈ = γ at the closed form's own
    # positions: backward-stable solves agree to cond(Φ_q) × eps ≈ 80 × 2.2e-16 = 1.8e-14,
    # and 1e-12 leaves a margin of about 50 (normwise per instant: single components pass
    # through zero).
    _, compiled, q0, times, tol = _setup(name)
    system = compiled.ideal
    Q, V, A, _ = kinematic_analysis(system, q0, times, tol=tol)
    Qn, _, _, _, done = _kinematics(q0, times, system, tol, 50)
    assert done == times.size
    for k, t in enumerate(times):
        _, phit, J = constraints(Q[k], t, system)
        bound = np.linalg.norm(np.linalg.inv(J), np.inf) * tol
        assert np.max(np.abs(Q[k] - Qn[k])) <= bound
        v = np.linalg.solve(J, -phit)
        a = np.linalg.solve(J, _numpy_gamma(Q[k], v, t, system))
        assert np.linalg.cond(J) * EPS < 2e-14
        for got, ref in ((V[k], v), (A[k], a)):
            assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))


def _moved(system, q0, phi, d):
    """``system`` and its configuration ``q0`` rotated by ``phi`` (rad) and moved by ``d`` (m)
    as a whole: the ground's points, the guide lines, every prescribed angle."""
    c, s = math.cos(phi), math.sin(phi)
    R = np.array([[c, -s], [s, c]])
    rev_sj = system.rev_sj.copy()
    on_ground = system.rev_j < 0
    rev_sj[on_ground] = rev_sj[on_ground] @ R.T + d
    dr_par = system.dr_par.copy()
    dr_par[:, D_ANGLE0] += phi
    moved = system._replace(rev_sj=rev_sj, tr_p0=system.tr_p0 @ R.T + d,
                            tr_n=system.tr_n @ R.T, tr_angle=system.tr_angle + phi,
                            fa_angle=system.fa_angle + phi, dr_par=dr_par)
    q = q0.reshape(-1, 3).copy()
    q[:, :2] = q[:, :2] @ R.T + d
    q[:, 2] += phi
    return moved, q.reshape(-1), R


_FRAME = {name: _setup(name) for name in ("nine-bar", "slider-crank")}


@settings(max_examples=30, deadline=None)
@given(name=st.sampled_from(sorted(_FRAME)), phi=st.floats(-math.pi, math.pi),
       dx=st.floats(-2.0, 2.0), dy=st.floats(-2.0, 2.0))
def test_the_closed_form_does_not_depend_on_the_frame(name, phi, dx, dy):
    # The same mechanism turned and moved as a whole: every body's position turns and moves
    # with it, its angle turns, its velocity and acceleration turn. Only round-off differs:
    # coordinates up to 5 m instead of 3, through a sequence of square roots and 2 × 2 solves
    # whose amplification is bounded by cond(Φ_q) <= 80 (test above): 80 × 64 eps ≈ 1.1e-12
    # normwise per instant.
    _, compiled, q0, times, tol = _FRAME[name]
    # contiguous, as kinematic_analysis passes them (a strided view compiles a second overload)
    times = np.ascontiguousarray(times[::20])
    system = compiled.ideal
    Q, V, A, _, _ = _construct(q0, times, system, construction(system))
    moved, q0m, R = _moved(system, q0, phi, np.array([dx, dy]))
    Qm, Vm, Am, done, _ = _construct(q0m, times, moved, construction(moved))
    assert done == times.size
    expect_q = Q.reshape(len(times), -1, 3).copy()
    expect_q[..., :2] = expect_q[..., :2] @ R.T + (dx, dy)
    expect_q[..., 2] += phi
    for got, ref, turned in ((Qm, expect_q.reshape(Q.shape), True), (Vm, V, False),
                             (Am, A, False)):
        if not turned:
            ref = ref.reshape(len(times), -1, 3).copy()
            ref[..., :2] = ref[..., :2] @ R.T
            ref = ref.reshape(Q.shape)
        err = np.max(np.abs(got - ref), axis=1) / np.max(np.abs(ref), axis=1)
        assert np.max(err) <= 80 * 64 * EPS


def test_the_assembly_branch_is_the_first_guess():
    # The slider-crank assembled with the slider on the other side of the crank pivot: the
    # rod's other intersection with the slider's line. Closed form of that branch: the
    # slider at x_A − sqrt(L² − y_A²), with the crank pin A = r (cos θ, sin θ).
    scene = load_scene("slider-crank")
    compiled = compile_scene(scene)
    guess = compiled.q_guess.copy()
    guess[3:9] = [-0.01, 0.0, math.pi, -0.07, 0.0, 0.0]  # rod and slider mirrored about A
    q0, _ = assemble(compiled.ideal, guess, 0.0)
    times = output_times(scene, compiled)
    Q, V, A, _ = kinematic_analysis(compiled.ideal, q0, times)
    th = Q[:, 2]
    xa, ya = 0.05 * np.cos(th), 0.05 * np.sin(th)
    slider = xa - np.sqrt(0.12 ** 2 - ya ** 2)
    assert np.max(np.abs(Q[:, 6] - slider)) <= 1e-15
    Qn, Vn, An, _, _ = _kinematics(q0, times, compiled.ideal, 1e-12, 50)  # Newton agrees
    assert np.max(np.abs(Q - Qn)) <= 1e-12
    # and the default guess is on the first branch
    Q1, _, _, _ = kinematic_analysis(compiled.ideal, assemble(compiled.ideal,
                                                              compiled.q_guess, 0.0)[0], times)
    assert np.min(Q1[:, 6]) > 0.06 and np.max(Q[:, 6]) < -0.06


def test_newton_takes_over_at_the_first_instant_the_closed_form_cannot_build(monkeypatch):
    # As if the closed form stopped at instant 100 (a tangent position, a residual above
    # the tolerance): the analysis continues from there by Newton–Raphson, starting from the
    # last built instant, and returns one result for all instants.
    _, compiled, q0, times, tol = _setup("nine-bar")
    system = compiled.ideal
    calls = []

    def stops_at_100(q_guess, t, sys, plan):
        calls.append(t.size)
        Q, V, A, _, viol = _construct(q_guess, t[:100], sys, plan)
        return Q, V, A, 100, viol

    monkeypatch.setattr(kinematics, "_construct", stops_at_100)
    Q, V, A, viol = kinematic_analysis(system, q0, times, tol=tol)
    assert calls == [times.size] and Q.shape == V.shape == A.shape == (times.size, q0.size)
    monkeypatch.undo()
    Qc, Vc, Ac, _ = kinematic_analysis(system, q0, times, tol=tol)
    assert np.array_equal(Q[:100], Qc[:100]) and np.array_equal(A[:100], Ac[:100])
    Qn, Vn, An, _, _ = _kinematics(Q[99], times[100:], system, tol, 50)
    assert np.array_equal(Q[100:], Qn) and np.array_equal(V[100:], Vn)
    assert viol <= tol
    assert np.max(np.abs(Q - Qc)) <= 1e-10  # the same motion (Newton's tolerance, as above)


def test_a_branch_that_ends_is_reported_by_newton():
    # The four-bar's rocker pivot moved away until the coupler and rocker cannot follow the
    # crank all the way round: the two circles (coupler 0.15 m around the crank pin A,
    # rocker 0.12 m around the pivot) meet only while |A O4| <= 0.27 m, and with the ground
    # link 0.25 m instead of 0.14 |A O4| reaches 0.25 + 0.05 = 0.30 m at half a turn. The
    # closed form stops there, Newton fails from there, and the error says when.
    scene = load_scene("four-bar")
    compiled = compile_scene(scene)
    system = compiled.ideal
    plan = construction(system)
    q0, _ = assemble(system, compiled.q_guess, 0.0)
    times = output_times(scene, compiled)
    base = _construct(q0, times, system, plan)
    assert base[3] == times.size
    rev_sj = system.rev_sj.copy()
    ground = np.flatnonzero(system.rev_j < 0)
    far = ground[np.argmax(np.abs(rev_sj[ground, 0]))]  # O4 = (0.14, 0)
    assert rev_sj[far].tolist() == [0.14, 0.0]
    rev_sj[far, 0] = 0.25
    longer = system._replace(rev_sj=rev_sj)
    q1, _ = assemble(longer, q0, 0.0)
    Q, V, A, done, _ = _construct(q1, times, longer, construction(longer))
    assert 0 < done < times.size
    A_pin = Q[-1, :2] + 0.025 * np.array([math.cos(Q[-1, 2]), math.sin(Q[-1, 2])])
    reach = math.hypot(*(A_pin - (0.25, 0.0)))  # the last instant built: just within reach
    th, _, _ = driver_law(longer.dr_law[0], longer.dr_par[0], times[done])
    assert reach <= 0.27 < math.hypot(0.05 * math.cos(th) - 0.25, 0.05 * math.sin(th))
    with pytest.raises(AssemblyError,
                       match=f"cannot be assembled at t = {times[done]:g} s: constraints stay"):
        kinematic_analysis(longer, q1, times)


def test_the_residual_returned_is_that_of_the_first_and_last_instant_built():
    # _construct returns max |Φ| of the first and last instant it built (what
    # kinematic_analysis compares with its tolerance): the constraint functions' own value
    # there, bitwise, for a whole run and for one that stops early (the four-bar whose rocker
    # pivot moved out of reach, as in the test above); and 0 when nothing was built.
    scene = load_scene("four-bar")
    compiled = compile_scene(scene)
    system = compiled.ideal
    q0, _ = assemble(system, compiled.q_guess, 0.0)
    times = output_times(scene, compiled)
    rev_sj = system.rev_sj.copy()
    ground = np.flatnonzero(system.rev_j < 0)
    rev_sj[ground[np.argmax(np.abs(rev_sj[ground, 0]))], 0] = 0.25
    longer = system._replace(rev_sj=rev_sj)
    q1, _ = assemble(longer, q0, 0.0)
    for sys_, q in ((system, q0), (longer, q1)):
        Q, V, A, done, viol = _construct(q, times, sys_, construction(sys_))
        assert Q.shape[0] == done > 0
        expect = max(float(np.max(np.abs(constraints(Q[k], times[k], sys_)[0])))
                     for k in (0, done - 1))
        assert viol == expect and viol <= 1e-12  # round-off of a construction (module doc)
    assert _construct(q0, times[:0], system, construction(system))[3:] == (0, 0.0)


def test_an_overflowing_instant_is_handed_over_not_passed_on():
    # A driver at 1e300 rad/s: the positions stay finite and satisfy Φ (the angle is what
    # the driver says), but ω² overflows the accelerations. The closed form must not return
    # them; Newton, which takes over, reports the failure (simulate then names the
    # overflowing scene value: tests/test_faults_inputs.py).
    _, compiled, q0, times, tol = _setup("slider-crank")
    system = compiled.ideal
    dr_par = system.dr_par.copy()
    dr_par[0, D_SPEED] = 1e300
    fast = system._replace(dr_par=dr_par)
    Q, V, A, done, viol = _construct(q0, times, fast, construction(fast))
    assert done == 0 and Q.shape == (0, q0.size) and viol == 0.0  # no instant: no residual
    with pytest.raises(AssemblyError):
        kinematic_analysis(fast, q0, times, tol=tol)


def test_a_construction_that_leaves_an_equation_unused_is_not_trusted(monkeypatch):
    # A plan whose first circle has the wrong radius (rod 3 taken 1 mm longer than it is)
    # builds positions that break joint P's equations at every instant. kinematic_analysis
    # evaluates Φ at the first and last instant built, finds it far above the tolerance, and
    # solves every instant by Newton: the result is exactly the Newton analysis's.
    _, compiled, q0, times, tol = _setup("nine-bar")
    system = compiled.ideal
    plan = construction(system)
    par = plan.par.copy()
    par[4, 0] += 1e-3  # the CIRCLES step of rods 3 and 4
    wrong = plan._replace(par=par)
    Qw = _construct(q0, times, system, wrong)[0]
    assert np.max(np.abs(constraints(Qw[0], times[0], system)[0])) > 1e-4
    monkeypatch.setattr(kinematics, "construction", lambda s: wrong)
    Q, V, A, viol = kinematic_analysis(system, q0, times, tol=tol)
    Qn, Vn, An, violn, _ = _kinematics(q0, times, system, tol, 50)
    assert np.array_equal(Q, Qn) and np.array_equal(A, An) and viol == violn
