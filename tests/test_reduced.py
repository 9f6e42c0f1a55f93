"""The equations of motion in the clearance joints' eccentricities and the free angles
(mechrel.mechanics.reduced): the placed configuration satisfies every constraint, ∂q/∂z spans
the admissible motions, and the accelerations satisfy the constrained equations of motion and
agree with the absolute formulation at every state tried. The scenes: the fully driven ones
with clearance joints, and six undriven ones: the double pendulum (two free angles, no
clearance joint), the same pendulum with its middle hinge a lubricated bearing (two free
angles and one eccentricity), the four-bar without its driver (one free angle, the crank's,
then the closed loop of the coupler and rocker; two eccentricities), a cart on a rail with a
pendulum (a free position and a free angle), the same with a lubricated hinge (and one
eccentricity), and a block on an incline (one free position, no revolute joint)."""

from __future__ import annotations

import math
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechrel.forces.params import P_C
from mechrel.mechanics.applied import applied_forces
from mechrel.mechanics.constraints import constraints
from mechrel.mechanics.construction import OFFSET, construction
from mechrel.mechanics.dynamics import accelerations
from mechrel.mechanics.kinematics import assemble
from mechrel.mechanics.joints import gaps_into
from mechrel.mechanics.reduced import (expand, expand_rows, make_reduced_work, output_row,
                                       reduced_coordinates, reduced_gaps_into, reduced_rhs_into)
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene

from test_kinematics import _numpy_gamma

EPS = np.finfo(float).eps
ETA = float(np.nextafter(0.0, 1.0))  # the smallest subnormal, 2^-1074: underflow's absolute error
SCENES = ("nine-bar-lubricated", "slider-crank-lubricated", "four-bar", "nine-bar-dry",
          "double-pendulum", "pendulum-lubricated", "four-bar-undriven", "cart-pendulum",
          "cart-pendulum-lubricated", "block-incline")
DATA_SCENES = Path(__file__).parent / "data" / "scenes"
CART_PENDULUM = DATA_SCENES / "cart-pendulum-lubricated.toml"
# the double pendulum's middle hinge as a lubricated bearing (0.1 mm, 5 mm radius, 10 mm long,
# 0.2 Pa s): undriven, so the construction gives both links free angles
PENDULUM_LUBRICATED = DATA_SCENES / "double-pendulum-lubricated.toml"


def undriven_four_bar():
    """The embedded four-bar with its crank's driver taken out: a four-bar pendulum swinging
    under gravity from the embedded configuration, over 0.5 s."""
    raw = tomllib.loads((resources.files("mechrel.scene") / "data" / "four-bar.toml").read_text())
    del raw["drivers"]
    raw.update(name="four-bar-undriven", analysis={"duration": 0.5, "sample_step": 1e-3})
    return load_scene(raw)


def cart_pendulum(lubricated=False):
    """A cart (2 kg) on a horizontal rail with a pendulum (a uniform 0.4 m, 0.5 kg bar) hinged
    on it, released at rest 60° from hanging, over 1 s: two undriven freedoms, the cart's
    position on its line (a free position) and the pendulum's angle (a free angle). No
    horizontal force acts, so the horizontal momentum stays zero. With ``lubricated`` the
    hinge is a lubricated bearing (the double pendulum's: 0.1 mm, 5 mm radius, 10 mm long,
    0.2 Pa s), and the journal's eccentricity adds two coordinates. The scene is
    ``tests/data/scenes/cart-pendulum-lubricated.toml``; without ``lubricated`` its hinge is
    ideal."""
    if lubricated:
        return load_scene(CART_PENDULUM)
    return load_scene(CART_PENDULUM, overrides={"name": "cart-pendulum",
                                                "joints.hinge.model": "ideal"})


def block_incline():
    """A 1.5 kg block on a frictionless rail inclined 30° down (direction (cos 30°, −sin 30°)),
    released at rest, over 1 s: one free position and no revolute joint (the construction
    gives the block a node at its sliding point). Along the rail it accelerates at
    g sin 30° = 4.905 m/s², exactly."""
    u = [math.cos(math.pi / 6), -math.sin(math.pi / 6)]
    return load_scene({
        "name": "block-incline", "gravity": [0.0, -9.81],
        "description": "block sliding down a frictionless incline",
        "ground": {"points": {"O": [0.0, 0.0]}},
        "bodies": {"block": {"mass": 1.5, "inertia": 0.01, "position": [0.0, 0.0],
                             "angle": 0.0, "points": {"S": [0.0, 0.0]}}},
        "joints": {"rail": {"type": "translational", "connects": ["block.S", "ground.O"],
                            "direction": u, "angle": 0.0}},
        "outputs": {"block": {"point": "block.S", "axis": u}},
        "analysis": {"duration": 1.0, "sample_step": 1e-2}})


def _scene(name):
    if name == "cart-pendulum":
        return cart_pendulum()
    if name == "cart-pendulum-lubricated":
        return cart_pendulum(lubricated=True)
    if name == "block-incline":
        return block_incline()
    if name == "pendulum-lubricated":
        return load_scene(PENDULUM_LUBRICATED)
    if name == "four-bar-undriven":
        return undriven_four_bar()
    return load_scene(name)


def _setup(name):
    compiled = compile_scene(_scene(name))
    system = compiled.dynamic
    q0, _ = assemble(compiled.assembly, compiled.q_guess, 0.0)
    con = construction(system)
    return system, con, make_reduced_work(system, con, q0), q0


_CASES = {name: _setup(name) for name in SCENES}


def test_every_clearance_scene_is_placed_by_its_eccentricities():
    # each clearance joint's two points are two nodes e apart: one OFFSET step per joint
    # (the nine-bar's crank pins to the rods' eyes) or, where the joint is a group's inner
    # joint (the slider-crank's rod-slider pin, the four-bar's rocker pin), a circle centred
    # e away from its link's other node and then the OFFSET step to the far end
    for name, (system, con, _, _) in _CASES.items():
        assert con is not None, name
        nc = system.cl_b.shape[0]
        assert con.cl_nodes.shape == (nc, 2)
        assert sorted(con.op[con.op[:, 0] == OFFSET, 3].tolist()) == list(range(nc)), name
    four = _CASES["four-bar"][1]
    shifted = four.op[(four.op[:, 5] >= 0) | (four.op[:, 7] >= 0)]
    assert shifted.shape[0] == 1  # the circle of the coupler–rocker group, moved by joint B


def _state(con, system, t, radius, angle, rates, free, spin):
    """A reduced state: joint k's eccentricity radius[k] × clearance at angle[k], its rate
    rates[k] × clearance × 50 /s (the nine-bar's journals move ~25 clearances per second);
    free coordinate f at free[f] (rad, or m for a free position), moving at spin[f] (rad/s,
    m/s)."""
    nc = system.cl_b.shape[0]
    nf = con.n_free
    c = system.cl_p[:, P_C]
    z = np.ravel(np.column_stack([radius[:nc] * c * np.cos(angle[:nc]),
                                  radius[:nc] * c * np.sin(angle[:nc])]))
    zd = np.asarray(rates[:2 * nc]) * np.repeat(c, 2) * 50.0
    return np.concatenate([z, free[:nf], zd, spin[:nf], np.zeros(2)])  # and the work


states = dict(
    name=st.sampled_from(SCENES),
    t=st.floats(0.0, 0.7),
    radius=st.lists(st.floats(0.0, 0.95), min_size=2, max_size=2),
    angle=st.lists(st.floats(-math.pi, math.pi), min_size=2, max_size=2),
    rates=st.lists(st.floats(-3.0, 3.0), min_size=4, max_size=4),
    free=st.lists(st.floats(-math.pi, math.pi), min_size=2, max_size=2),
    spin=st.lists(st.floats(-20.0, 20.0), min_size=2, max_size=2),
)


@settings(max_examples=60, deadline=None)
@given(**states)
def test_reduced_states_satisfy_the_constrained_equations_of_motion(name, t, radius, angle,
                                                                      rates, free, spin):
    # The definition of the constrained motion, checked with the dense constraints(), the
    # NumPy γ of the tests and applied_forces, none of which the reduced evaluation uses:
    # Φ(q) = 0 and Φ_q q̇ + Φ_t = 0 (the construction is exact: |Φ| at round-off of metre
    # coordinates, 64 eps), Φ_q ∂q/∂z = 0 (the columns are admissible motions), Φ_q q̈ = γ,
    # and M q̈ − Q = Φ_qᵀ λ for some λ (Lagrange's equations of the first kind). The last
    # holds when Rᵀ (M q̈ − Q) = 0 and the columns of R span the null space of Φ_q (Φ_q R = 0
    # and [Φ_q; Rᵀ] of full rank, so R has the n − m = 2 nc + nf columns the null space
    # needs).
    # Rᵀ (M q̈ − Q) is formed here from expand()'s q̈ (its own acceleration pass with z̈) and
    # applied_forces() at expand()'s q and q̇: it vanishes up to the round-off of solving
    # Rᵀ M R z̈ = Rᵀ (Q − M q̈₀), amplified by cond(Rᵀ M R), relative to |R| (|Q| + |M q̈|):
    # 64 eps cond. (That holds only if the forces of the reduced evaluation are those of the
    # body q describes: with each orientation taken from the unit vector between two nodes
    # instead of the angle, a stiff film's force moved by 1e-10 N and this check failed.)
    system, con, rw, _ = _CASES[name]
    y = _state(con, system, t, radius, angle, rates, free, spin)
    nz = (y.size - 2) // 2
    out = np.empty(2 * nz + 2)
    hist = np.zeros(system.n_contacts)
    assert reduced_rhs_into(t, y, hist, system, con, rw, out)
    assert np.array_equal(out[:nz], y[nz:2 * nz])
    R = rw.vc[:nz].T.copy()  # ∂q/∂z
    Mr = R.T @ (system.mass[:, None] * R)
    q, v, a = expand(t, y, out[nz:2 * nz], system, con, rw)
    assert np.allclose(reduced_coordinates(system, con, q, v), y, rtol=0.0,
                       atol=64 * EPS * max(1.0, np.abs(y).max()))
    phi, phit, J = constraints(q, t, system)
    assert np.abs(phi).max() <= 64 * EPS
    # the rounding model with gradual underflow, fl(x ∘ y) = (x ∘ y)(1 + δ) + η with
    # |η| ≤ ETA = 2^-1074: the relative bounds get an absolute 64 ETA, which matters only when
    # a rate is subnormal (hypothesis drew spin = 2.2e-313 rad/s: residual one ETA, 5e-324)
    assert np.abs(J @ v + phit).max() <= 64 * EPS * np.abs(J).max() * np.abs(v).max() + 64 * ETA
    assert np.abs(J @ R).max() <= 64 * EPS * np.abs(J).max() * np.abs(R).max()
    g = _numpy_gamma(q, v, t, system)
    assert np.abs(J @ a - g).max() <= 64 * EPS * (np.abs(J).max() * np.abs(a).max()
                                                  + np.abs(g).max()) + 64 * ETA
    assert np.linalg.matrix_rank(np.vstack([J, R.T])) == q.size
    Q = np.zeros(q.size)
    applied_forces(t, q, v, hist, system, Q)
    r = system.mass * a - Q
    scale = np.linalg.norm(R) * (np.linalg.norm(Q) + np.linalg.norm(system.mass * a))
    assert np.linalg.norm(R.T @ r) <= 64 * EPS * np.linalg.cond(Mr) * scale


@settings(max_examples=60, deadline=None)
@given(**states)
def test_reduced_accelerations_are_the_absolute_formulations(name, t, radius, angle, rates,
                                                             free, spin):
    # At a state that satisfies the constraints, the absolute formulation (Schur complement
    # of the Lagrange-multiplier equations, Baumgarte terms vanishing with Φ and Φ̇) must give
    # the same accelerations. How sensitive its own solve is to round-off is measured here,
    # by moving q and q̇ by one ulp (random signs, four draws): with thin films that spread
    # reaches 1e-8 m/s² on 1e3 m/s² accelerations. The two formulations must agree within
    # ten times that spread (measured: within twice). The same holds for the drivers' power,
    # −Σ λ_d θ̇_d there and q̇ᵀ (M q̈ − Q) here, and the clearance power is the same force
    # laws' at the same state. The round-off of q̇ᵀ (M R z̈ − (Q − M q̈₀)), as the evaluation
    # forms it, is bounded by the sizes of its terms: 64 eps Σ |q̇_i| (M_i (|R| |z̈|)_i +
    # |M q̈₀|_i + |Q|_i) (the sum R z̈ is formed term by term, so its round-off scales with
    # |R| |z̈|, not with |R z̈|, which cancels where a link's free angle and its neighbour's
    # accelerate against each other). An undriven mechanism has no drivers' power at all
    # (0 there), so its q̇ᵀ (M q̈ − Q) is that round-off alone (measured on the lubricated
    # pendulum with its journal moving at 5 mm/s: 1.7e-19 W where the film's |Q| sets the
    # scale, 2.2e-18 W where |R| |z̈| ≈ 8 m/s² cancels to |q̈| ≈ 1e-10 m/s²).
    system, con, rw, _ = _CASES[name]
    y = _state(con, system, t, radius, angle, rates, free, spin)
    nz = (y.size - 2) // 2
    out = np.empty(2 * nz + 2)
    hist = np.zeros(system.n_contacts)
    reduced_rhs_into(t, y, hist, system, con, rw, out)
    q, v, a = expand(t, y, out[nz:2 * nz], system, con, rw)
    extra = np.zeros(2)
    absolute, _, p_in, p_cl = accelerations(t, np.concatenate([q, v, extra]), hist, system)
    rng = np.random.default_rng(0)
    spread = spread_in = 0.0
    for _ in range(4):
        qq = q * (1 + rng.choice([-1.0, 1.0], q.size) * EPS)
        vv = v * (1 + rng.choice([-1.0, 1.0], v.size) * EPS)
        other, _, other_in, _ = accelerations(t, np.concatenate([qq, vv, extra]), hist, system)
        spread = max(spread, np.abs(other - absolute).max())
        spread_in = max(spread_in, abs(other_in - p_in))
    assert np.abs(a - absolute).max() <= 10 * spread + 64 * EPS * np.abs(absolute).max()
    Q = np.zeros(q.size)
    applied_forces(t, q, v, hist, system, Q)
    # M |R| |z̈|; after expand() rw.a holds q̈ itself, and |M q̈₀| ≤ |M q̈| + M |R| |z̈|
    terms = system.mass * (np.abs(rw.vc[:nz].T) @ np.abs(out[nz:2 * nz]))
    assert abs(out[2 * nz] - p_in) <= 10 * spread_in + 64 * EPS * (
        np.abs(v) @ (2.0 * terms + np.abs(system.mass * rw.a) + np.abs(Q)))
    assert out[2 * nz + 1] == pytest.approx(p_cl, rel=64 * EPS, abs=1e-300)


def test_a_state_the_mechanism_cannot_take_is_nan_not_a_number_passed_on():
    # an eccentricity of 1 m breaks the nine-bar's groups (rod 3 and rod 4 cannot reach P):
    # the evaluation says so and fills dy/dt with NaN, and expand() raises
    system, con, rw, _ = _CASES["nine-bar-lubricated"]
    y = np.zeros(10)
    y[0] = 1.0
    out = np.zeros(10)
    assert not reduced_rhs_into(0.1, y, np.zeros(0), system, con, rw, out)
    assert np.all(np.isnan(out))
    with pytest.raises(ValueError, match="cannot be placed at the reduced state"):
        expand(0.1, y, np.zeros(4), system, con, rw)


def test_the_centred_joints_are_the_ideal_mechanism():
    # z = 0, ż = 0: the positions and velocities are the ideal mechanism's (its kinematic
    # analysis, to its round-off), whatever the forces
    from mechrel.mechanics.kinematics import kinematic_analysis

    compiled = compile_scene(load_scene("nine-bar-lubricated"))
    system, con, rw, q0 = _CASES["nine-bar-lubricated"]
    times = np.linspace(0.0, 2.0 / 3.0, 25)
    Qi, Vi, _, _ = kinematic_analysis(compiled.ideal, q0, times)
    for k, t in enumerate(times):
        q, v, _ = expand(t, np.zeros(10), np.zeros(4), system, con, rw)
        assert np.abs(q - Qi[k]).max() <= 1e-14 * 3 and np.abs(v - Vi[k]).max() <= 1e-12


@settings(max_examples=30, deadline=None)
@given(**states)
def test_gaps_and_expanded_rows_are_the_absolute_states(name, t, radius, angle, rates, free,
                                                        spin):
    # The gaps read from z are those of the placed bodies (joints.gaps_into on expand()'s
    # state: the same gap_of of the same e, computed from the bodies' points, to the
    # round-off of metre coordinates), and expand_rows() is expand() row by row, with the
    # derivative row (q̇, q̈, P_in, P_cl) of the reduced evaluation. output_row(), the row an
    # integrator writes right after evaluating an output instant, is the same row: q, q̇ and
    # the work bitwise (the same placement), q̈ = q̈₀ + R z̈ to the round-off of that sum,
    # 64 eps (|q̈₀| + |R| |z̈|), against the acceleration pass run with z̈.
    system, con, rw, _ = _CASES[name]
    y = _state(con, system, t, radius, angle, rates, free, spin)
    y[-2:] = 3.0, -1.0  # work integrals pass through
    nz = (y.size - 2) // 2
    out = np.empty(2 * nz + 2)
    hist = np.zeros(system.n_contacts)
    reduced_rhs_into(t, y, hist, system, con, rw, out)
    n = rw.q.size
    row, drow = np.empty(2 * n + 2), np.empty(2 * n + 2)
    output_row(y, out, rw, row, drow)
    bound = 64 * EPS * (np.abs(rw.a) + np.abs(rw.vc[:nz].T) @ np.abs(out[nz:2 * nz]))
    q, v, a = expand(t, y, out[nz:2 * nz], system, con, rw)
    assert np.array_equal(row, np.concatenate([q, v, y[-2:]]))
    assert np.array_equal(drow[:n], v) and np.array_equal(drow[-2:], out[-2:])
    assert np.all(np.abs(drow[n:2 * n] - a) <= bound)
    nh = system.n_contacts
    g, gd, ga, gda = np.empty(nh), np.empty(nh), np.empty(nh), np.empty(nh)
    reduced_gaps_into(y, system, g, gd)
    gaps_into(t, np.concatenate([q, v, y[-2:]]), system, ga, gda)
    assert np.allclose(g, ga, rtol=0.0, atol=64 * EPS)
    # the rate of |e| is ė·e/|e|: at e = 0 (a centred journal) it has no limit, and the
    # bodies' points give e of round-off size in some direction; elsewhere the two agree
    held = np.array([radius[k] > 1e-6 for k in range(system.cl_b.shape[0])
                     if system.cl_hist[k] >= 0], dtype=bool)
    assert np.allclose(gd[held], gda[held], rtol=0.0,
                       atol=64 * EPS * max(1.0, np.abs(v).max()) / max(min(radius), 1e-6))
    n = q.size
    Ya, YDa = np.empty((2, 2 * n + 2)), np.empty((2, 2 * n + 2))
    Y, YD = np.vstack([y, y]), np.vstack([out, out])
    Y[1, 0] = np.inf  # a row that is not finite comes out NaN, and is counted
    assert expand_rows(np.array([t, t]), Y, YD, system, con, rw, Ya, YDa) == 1
    assert np.array_equal(Ya[0], np.concatenate([q, v, y[-2:]]))
    assert np.array_equal(YDa[0], np.concatenate([v, a, out[-2:]]))
    assert np.isnan(Ya[1]).all() and np.isnan(YDa[1]).all()
