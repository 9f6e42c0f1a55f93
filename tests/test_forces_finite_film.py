"""Finite-length bearing (tabulated correction of the short bearing) against the 2-D Reynolds
solver, its table, its symmetries and its hard cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechrel.errors import SceneError
from mechrel.forces import finite_film_forces, pack_params, short_film_forces
from mechrel.forces.finite_film import correction
from mechrel.forces.finite_table import (
    EPS_NODES, GRID, LD_NODES, TABLE_PATH, THETA_NODES, build_table,
)
from mechrel.forces.joint import EPS_GUARD, clearance_force
from mechrel.forces.reynolds import half_sommerfeld_directions
from mechrel.scene import load_scene
from mechrel.simulation import simulate

# Raimondi & Boyd (1958), ASLE Trans. 1, 159-209, full bearing, Reynolds condition:
# (L/D, ε) → (S, attitude °); the same values and source as tests/test_forces_short_film.py
RAIMONDI_BOYD = {
    (1.0, 0.6): (0.121, 50.58), (1.0, 0.8): (0.0446, 36.24), (1.0, 0.9): (0.0188, 26.45),
    (0.5, 0.6): (0.319, 48.14), (0.5, 0.8): (0.0923, 33.31), (0.5, 0.9): (0.0313, 23.66),
    (0.25, 0.6): (1.07, 46.72), (0.25, 0.8): (0.261, 31.04), (0.25, 0.9): (0.0736, 21.85),
}

MU, R_S, C = 0.1, 0.0145, 5e-4
EPS0 = 0.1
K2D = MU * R_S**4 / C**2  # scale of half_sommerfeld_directions' unit forces (μR⁴/c²)


def finite(eps, ed, ew, LD, lam=0.0):
    return finite_film_forces(eps, ed, ew, MU, R_S, LD * 2 * R_S, C, lam, EPS0)


def reference(eps, LD, directions, grid=(360, 24)):
    """2-D half-Sommerfeld forces for (ε̇, εw/2) = (cos ϑ, sin ϑ) (1/s), in N."""
    return K2D * half_sommerfeld_directions(eps, LD, directions, n_theta=grid[0], n_z=grid[1])


def _rel(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1]) / math.hypot(b[0], b[1])


# The finite model against the numerical solution. Reference grid 360 × 24: its own error is
# < 0.5 % (against 720 × 48, second order, tests/test_forces_short_film.py); the table (built
# on 720 × 48) plus its cubic interpolation add < 0.6 % (measured worst case over L/D in
# {0.3, 0.5, 0.8, 1, 1.4, 2, 3}, ε up to 0.97 and five directions). Bound: the 2 %.
@pytest.mark.parametrize("LD", [0.5, 1.0, 1.4, 2.0])
@pytest.mark.parametrize("eps", [0.2, 0.5, 0.8, 0.9])
def test_steady_rotation_and_pure_squeeze_within_two_percent(LD, eps):
    # ϑ = π/2: steady rotation (ε̇ = 0, εw/2 = 1); ϑ = 0: pure squeeze (ε̇ = 1)
    ref = reference(eps, LD, [0.5 * math.pi, 0.0])
    assert _rel(finite(eps, 0.0, 2.0, LD), ref[0]) < 0.02
    assert _rel(finite(eps, 1.0, 0.0, LD), ref[1]) < 0.02


@pytest.mark.parametrize("LD, eps", [(0.3, 0.35), (0.8, 0.65), (1.2, 0.87), (3.0, 0.95),
                                     (0.6, 0.97), (3.5, 0.1)])
def test_off_the_table_nodes_within_two_percent(LD, eps):
    # L/D, ε and the direction all between table nodes: tests the interpolation
    dirs = [0.4, 1.9, 2.9, -1.0]
    ref = reference(eps, LD, dirs)
    for k, v in enumerate(dirs):
        F = finite(eps, math.cos(v), 2.0 * math.sin(v), LD)
        assert _rel(F, ref[k]) < 0.02, (LD, eps, v)


def test_table_is_reproducible_from_the_solver():
    # one (L/D, ε) row of the shipped table, rebuilt with the same grid: equal to rounding
    with np.load(TABLE_PATH) as d:
        Q = d["q"]
        assert tuple(d["grid"]) == GRID
        assert np.allclose(d["ld"], LD_NODES) and np.allclose(d["eps"], EPS_NODES)
    i, j = 4, 12  # L/D = 1, ε = 0.9775
    row = build_table([LD_NODES[i]], [EPS_NODES[j]], THETA_NODES)
    assert np.allclose(row[0, 0], Q[i, j], rtol=1e-9, atol=1e-12)


def test_interpolation_reproduces_the_nodes():
    with np.load(TABLE_PATH) as d:
        Q = d["q"]
    for i, j, k in [(0, 0, 0), (4, 10, 6), (8, 18, 12), (5, 3, 1), (2, 17, 11)]:
        q = correction(LD_NODES[i], EPS_NODES[j], THETA_NODES[k])
        assert q == pytest.approx(tuple(Q[i, j, k]), rel=1e-12, abs=1e-12)
        # mirror symmetry: q(−ϑ) = conj q(ϑ)
        if k > 0:
            qm = correction(LD_NODES[i], EPS_NODES[j], -THETA_NODES[k])
            assert qm == pytest.approx((q[0], -q[1]), rel=1e-12, abs=1e-12)


def test_mirror_symmetry_homogeneity_and_continuity_in_eps_dot():
    for LD in (0.5, 1.4):
        for eps in (0.3, 0.85):
            Fr, Ft = finite(eps, 1.3, 2.4, LD)
            Gr, Gt = finite(eps, 1.3, -2.4, LD)
            assert Gr == pytest.approx(Fr, rel=1e-12) and Gt == pytest.approx(-Ft, rel=1e-12)
            # degree-1 homogeneity in (ε̇, εw): the correction depends on the direction only
            Hr, Ht = finite(eps, 3 * 1.3, 3 * 2.4, LD)
            assert Hr == pytest.approx(3 * Fr, rel=1e-12) and Ht == pytest.approx(3 * Ft, rel=1e-12)
            # ε̇ → ±0 (also subnormal) gives the steady force
            S = finite(eps, 0.0, 2.4, LD)
            for ed in (1e-300, -1e-300, 5e-324, -5e-324, 1e-12, -1e-12):
                assert finite(eps, ed, 2.4, LD) == pytest.approx(S, rel=1e-9)


def test_hard_cases_stay_finite():
    LD = 1.4
    assert finite(0.0, 0.0, 0.0, LD, lam=1.0) == (0.0, 0.0)     # at rest, centred
    assert finite(0.5, 0.0, 0.0, LD) == (0.0, 0.0)              # at rest, off centre
    for ed, ew in ((1e4, 0.0), (0.0, 500.0), (-1e4, 500.0), (3.0, -40.0)):
        for eps in (0.99, 0.995, EPS_GUARD):
            Fr, Ft = finite(eps, ed, ew, LD)
            assert math.isfinite(Fr) and math.isfinite(Ft)
    # above the table (ε > 0.99) the correction is held: the force keeps the short bearing's
    # divergence and is continuous at 0.99
    a = finite(0.99, 2.0, 3.0, LD)
    b = finite(0.99 + 1e-12, 2.0, 3.0, LD)
    assert _rel(b, a) < 1e-8
    q99 = complex(*correction(LD, 0.99, math.atan2(1.5, 2.0)))
    s = short_film_forces(0.999, 2.0, 3.0, MU, R_S, LD * 2 * R_S, C, 0.0, EPS0)
    f = finite(0.999, 2.0, 3.0, LD)
    assert complex(*f) == pytest.approx(complex(*s) * q99, rel=1e-12)


def test_frame_invariance_and_half_frequency_whirl():
    p = pack_params(model="lubricated", clearance=C, bearing_radius=R_S + C, length=0.04,
                    stiffness=1e10, restitution=0.9, viscosity=MU, bearing="finite")
    e = np.array([3e-4, 1e-4])
    v = np.array([0.02, -0.05])
    wB, wS = 4.0, -7.0
    F = np.array(clearance_force(*e, *v, wB, wS, 0.0, p)[:2])
    a = 0.7
    Q = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    G = np.array(clearance_force(*(Q @ e), *(Q @ v), wB, wS, 0.0, p)[:2])
    assert np.allclose(G, Q @ F, rtol=1e-12, atol=1e-12 * np.abs(F).max())
    Om = 13.0
    v2 = v + Om * np.array([-e[1], e[0]])
    H = np.array(clearance_force(*e, *v2, wB + Om, wS + Om, 0.0, p)[:2])
    assert np.allclose(H, F, rtol=1e-10, atol=1e-12 * np.abs(F).max())
    vw = 0.5 * (wB + wS) * np.array([-e[1], e[0]])
    assert clearance_force(*e, *vw, wB, wS, 0.0, p)[:2] == pytest.approx((0.0, 0.0), abs=1e-15)


@pytest.mark.parametrize("length, ld", [(0.004, "0.1379"), (0.2, "6.897")])
def test_l_over_d_outside_the_table_is_rejected(length, ld):
    with pytest.raises(SceneError) as info:
        pack_params(model="lubricated", clearance=C, bearing_radius=R_S + C, length=length,
                    stiffness=1e10, restitution=0.9, viscosity=MU, bearing="finite")
    msg = str(info.value)
    assert msg.startswith("length") and "L/D = length / (2 journal radius) in [0.25, 4]" in msg
    assert f"(here L/D = {ld})" in msg and info.value.path == "length"
    with pytest.raises(SceneError, match=r"joints\.C1\.length"):
        load_scene("nine-bar-lubricated", overrides={"joints.C1.lubricant.bearing": "finite",
                                                     "joints.C1.length": length})


def test_nine_bar_with_finite_films_and_a_transition_joint():
    ov = {"joints.C1.lubricant.bearing": "finite", "joints.C2.lubricant.bearing": "finite"}
    res = simulate(load_scene("nine-bar-lubricated", overrides=ov))
    assert res.stats["status"] == "ok"
    long = simulate(load_scene("nine-bar-lubricated"))
    for name in ("C1", "C2"):
        eps = res.orbits[name]["eps"]
        assert np.all(np.isfinite(eps)) and eps.max() < 1.0
    # the finite film (L/D = 1.38) carries less than the long one: the journals run closer to
    # the wall on average
    assert res.orbits["C1"]["eps"].mean() > long.orbits["C1"]["eps"].mean()
    tr = simulate(load_scene("slider-crank-lubricated", overrides={
        "joints.C.model": "transition", "joints.C.lubricant.viscosity": 1e-5,
        "joints.C.lubricant.bearing": "finite"}))
    assert tr.stats["status"] == "ok" and tr.orbits["C"]["eps"].max() > 1.0
    assert np.all(np.isfinite(tr.energy["balance"]))


# ------------------------------------------------ Swift–Stieber (Reynolds-condition) table ---

def finite_rc(eps, ed, ew, LD):
    return finite_film_forces(eps, ed, ew, MU, R_S, LD * 2 * R_S, C, 0.0, EPS0, True)


def test_reynolds_condition_finite_film_against_raimondi_boyd():
    # The published steady table (Raimondi & Boyd 1958; values and source in
    # tests/test_forces_short_film.py) read off the compiled finite film with cavitation
    # "reynolds": S within 2 % (the table's 3 digits, our 240 × 16 grid, the interpolation),
    # attitude within 1.5°.
    w = 10.0
    for (LD, eps), (S_rb, phi_rb) in RAIMONDI_BOYD.items():
        Ll = LD * 2 * R_S
        Fr, Ft = finite_rc(eps, 0.0, eps * w, LD)
        S = (R_S / C) ** 2 * MU * (w / (2 * math.pi)) / (math.hypot(Fr, Ft) / (Ll * 2 * R_S))
        assert S == pytest.approx(S_rb, rel=0.02), (LD, eps)
        assert abs(math.degrees(math.atan2(Ft, -Fr)) - phi_rb) < 1.5, (LD, eps)


@pytest.mark.parametrize("LD, eps", [(1.0, 0.5), (1.4, 0.8), (0.7, 0.93), (2.5, 0.3)])
def test_reynolds_condition_finite_film_against_the_solver(LD, eps):
    # Against the complementarity solution on the table's own grid (240 × 16), on and off
    # the nodes, four directions: only the table's interpolation error remains (< 2 %).
    from mechrel.forces.reynolds import reynolds_condition_directions
    dirs = [0.0, 0.5 * math.pi, 2.2, -0.7]
    ref = K2D * reynolds_condition_directions(eps, LD, dirs, n_theta=240, n_z=16)
    for k, v in enumerate(dirs):
        assert _rel(finite_rc(eps, math.cos(v), 2.0 * math.sin(v), LD), ref[k]) < 0.02


@pytest.mark.slow
@pytest.mark.parametrize("LD", [0.5, 1.0, 1.4, 2.0])
@pytest.mark.parametrize("eps", [0.2, 0.5, 0.8, 0.9])
def test_reynolds_condition_finite_film_against_a_finer_solution(LD, eps):
    # the matrix, against a 480 × 32 complementarity solution (grid error of the
    # table's 240 × 16 grid included): within 2 %
    from mechrel.forces.reynolds import reynolds_condition_directions
    ref = K2D * reynolds_condition_directions(eps, LD, [0.5 * math.pi, 0.0], n_theta=480,
                                              n_z=32)
    assert _rel(finite_rc(eps, 0.0, 2.0, LD), ref[0]) < 0.02
    assert _rel(finite_rc(eps, 1.0, 0.0, LD), ref[1]) < 0.02


def test_reynolds_condition_needs_the_finite_film():
    for bearing in ("long", "short"):
        with pytest.raises(SceneError) as info:
            pack_params(model="lubricated", clearance=C, bearing_radius=R_S + C, length=0.04,
                        stiffness=1e10, restitution=0.9, viscosity=MU, bearing=bearing,
                        cavitation="reynolds")
        msg = str(info.value)
        assert msg.startswith("cavitation") and "needs bearing 'finite'" in msg
    with pytest.raises(SceneError, match=r"joints\.C1\.lubricant\.cavitation = \"reynolds\""):
        load_scene("nine-bar-lubricated", overrides={"joints.C1.lubricant.cavitation": "reynolds"})
    sc = load_scene("nine-bar-lubricated", overrides={"joints.C1.lubricant.cavitation": "reynolds",
                                                      "joints.C1.lubricant.bearing": "finite"})
    assert sc.joints["C1"].lubricant.cavitation == "reynolds"
