"""The clearance-joint element: sign conventions, models, invariance, continuity, energy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechrel.forces import (
    P_CF, P_E1, P_EPSMAX, clearance_force, contact_stiffness, film_forces, ln_normal_force,
    pack_params, transition_energy,
)

C, RB, LEN = 5e-4, 0.015, 0.04
RS = RB - C
K = contact_stiffness(RB, RS, 206e9, 0.3, 206e9, 0.3)
COMMON = dict(clearance=C, bearing_radius=RB, length=LEN, stiffness=K, restitution=0.9,
              friction_coefficient=0.05, viscosity=0.1)
P_DRY = pack_params(model="dry", **COMMON)
P_LUB = pack_params(model="lubricated", **COMMON)
P_TR = pack_params(model="transition", **COMMON)
MODELS = {"dry": P_DRY, "lubricated": P_LUB, "transition": P_TR}


def call(p, e, v, wB=0.0, wS=0.0, imp=0.0):
    return np.array(clearance_force(e[0], e[1], v[0], v[1], wB, wS, imp, p))


def rot(a, x):
    ca, sa = math.cos(a), math.sin(a)
    return np.array([ca * x[0] - sa * x[1], sa * x[0] + ca * x[1]])


# ------------------------------------------------------------------------------ dry contact ---

def test_dry_normal_force_points_to_centre():
    # journal pushed beyond the clearance along +x, approaching: force on it is along −x
    d = (C + 2e-6) - C  # the penetration exactly as the joint computes it from |e|
    f = call(P_DRY, (C + d, 0.0), (0.05, 0.0))
    fn = ln_normal_force(d, 0.05, max(0.05, 1e-3), K, 1.5, 0.9)
    assert f[0] == pytest.approx(-fn, rel=1e-14) and f[1] == 0.0
    assert f[2] == 0.0 and f[3] == 0.0  # no slip -> no friction moment
    assert f[4] == pytest.approx(K * d**2.5 / 2.5, rel=1e-14)
    # same along an oblique direction
    n = np.array([0.6, -0.8])
    f = call(P_DRY, (C + d) * n, (0.0, 0.0))
    assert f[:2] == pytest.approx(-K * d**1.5 * n, rel=1e-9)


def test_dry_friction_sign_and_moments():
    # contact at +x (n = +x, t = +y). Journal spinning +ω_S: its contact point moves along +t,
    # so friction on the journal is along −t and its moment opposes ω_S; the bearing's moment
    # is −R_B F_T (drives the bearing along with the journal).
    d = 2e-6
    f = call(P_DRY, (C + d, 0.0), (0.0, 0.0), wB=0.0, wS=10.0)
    fn = K * d**1.5
    ft = -0.05 * fn  # slip 10 × 14.5 mm = 0.145 m/s > v1: full Coulomb
    assert f[1] == pytest.approx(ft, rel=1e-12)
    assert f[2] == pytest.approx(RS * ft, rel=1e-12) and f[2] < 0
    assert f[3] == pytest.approx(-RB * ft, rel=1e-12) and f[3] > 0
    # slip from the translation v·t and from the bearing's rotation enter with their signs
    g = call(P_DRY, (C + d, 0.0), (0.0, 0.2), wB=0.0, wS=0.0)
    h = call(P_DRY, (C + d, 0.0), (0.0, 0.0), wB=-0.2 / RB, wS=0.0)
    assert g[1] < 0 and h[1] < 0 and g[1] == pytest.approx(h[1], rel=1e-12)


def test_dry_without_friction_coefficient_is_purely_normal():
    p = P_DRY.copy()
    p[P_CF] = 0.0
    e = np.array([C + 3e-6, 1e-6])
    f = call(p, e, (0.3, -0.7), wB=5.0, wS=-40.0)
    n = e / np.linalg.norm(e)
    assert abs(f[0] * n[1] - f[1] * n[0]) <= 1e-15 * np.hypot(f[0], f[1])
    assert f[2] == 0.0 and f[3] == 0.0


def test_free_flight_and_centre_are_zero_for_dry():
    for e in ((0.0, 0.0), (C * 0.999, 0.0), (1e-310, -1e-310)):
        assert np.all(call(P_DRY, e, (1.0, 2.0), 3.0, 4.0) == 0.0)


def test_impact_speed_history():
    d, vn = 1e-6, 0.02
    e, v = (C + d, 0.0), (vn, 0.0)
    fresh = call(P_DRY, e, v, imp=0.0)
    captured_same = call(P_DRY, e, v, imp=vn)
    assert fresh[0] == captured_same[0]  # before capture: max(δ̇, floor), equal at onset
    captured_slow = call(P_DRY, e, v, imp=0.004)
    assert captured_slow[0] < fresh[0]  # slower captured impact -> larger damping term
    # below the floor (1e-3 m/s) the captured speed is floored
    assert np.all(call(P_DRY, e, v, imp=1e-6) == call(P_DRY, e, v, imp=1e-3))


# ------------------------------------------------------------------------------- lubricated ---

def test_squeeze_film_resists_approach_in_global_frame():
    n = np.array([math.cos(2.0), math.sin(2.0)])
    e = 0.6 * C * n
    out = call(P_LUB, e, 0.1 * n)     # moving outward (ε̇ > 0)
    inw = call(P_LUB, e, -0.1 * n)    # moving inward
    assert out[:2] @ n < 0 < inw[:2] @ n
    assert np.all(out[2:] == 0.0)


def test_lubricated_matches_film_forces_in_local_frame():
    a = 0.7
    n = np.array([math.cos(a), math.sin(a)])
    t = np.array([-n[1], n[0]])
    eps, ed, gd, wB, wS = 0.55, 30.0, 4.0, 2.0, -9.0
    e = eps * C * n
    v = ed * C * n + gd * eps * C * t
    f = call(P_LUB, e, v, wB, wS)
    fr, ft = film_forces(eps, ed, wS + wB - 2 * gd, 0.1, RS, LEN, C, 1.0, 0.1)
    # n, t from hypot of the rotated e: relative rounding ~1e-15
    assert f[:2] == pytest.approx(fr * n + ft * t, rel=1e-12)


def test_lubricated_film_is_not_clamped_below_one():
    # n = +y, t = (−1, 0): v·n = v_y, v·t = −v_x, γ̇ = −v_x/|e|, w = ω_S + ω_B + 2 v_x/|e|.
    # The lubricated model has no contact: the film's divergence as ε → 1 is its only barrier,
    # so it is evaluated at the actual ε (no clamp at ε_max = 0.99, which let journals leave
    # the bearing); ε is only capped at EPS_GUARD = 1 − 1e-9 so that trial states at ε ≥ 1
    # stay finite.
    from mechrel.forces.joint import EPS_GUARD

    n, t = np.array([0.0, 1.0]), np.array([-1.0, 0.0])
    v = np.array([0.3, 0.01])
    for r in (0.5 * C, 0.99 * C, 0.999 * C, 0.999999 * C, 1.3 * C, 3.0 * C):
        f = call(P_LUB, r * n, v, 1.0, 2.0)
        eps = r / C
        w = 3.0 + 2 * v[0] / r
        ew = eps * w * min(1.0, EPS_GUARD / eps)
        fr, ft = film_forces(min(eps, EPS_GUARD), v[1] / C, ew / min(eps, EPS_GUARD), 0.1,
                             RS, LEN, C, 1.0, 0.1)
        assert np.all(np.isfinite(f))
        # same formula evaluated with ε w assembled differently: a few ulp
        assert f[:2] == pytest.approx(fr * n + ft * t, rel=1e-9)
    # the radial film force keeps growing toward ε = 1 (outward motion: it pushes inward)
    radial = [call(P_LUB, r * n, v, 1.0, 2.0)[1] for r in (0.99 * C, 0.999 * C, 0.99999 * C)]
    assert radial[0] < 0 and radial[1] < 10 * radial[0] and radial[2] < 100 * radial[1]


@given(
    a=st.floats(-math.pi, math.pi),
    eps=st.floats(0.0, 0.99),
    Om=st.floats(-100.0, 100.0),
    model=st.sampled_from(["lubricated", "transition"]),
)
@settings(max_examples=300, deadline=None)
def test_rigid_rotation_produces_no_film_force(a, eps, Om, model):
    # whole joint rotating rigidly at Ω: v = Ω × e, ω_B = ω_S = Ω -> w = 0, ε̇ = 0
    e = eps * C * np.array([math.cos(a), math.sin(a)])
    v = Om * np.array([-e[1], e[0]])
    f = call(MODELS[model], e, v, Om, Om)
    # residual from rounding of v·n and of ε w = (2|e|Ω − 2 v·t)/c (cancellation of O(Ω|e|)
    # terms): ~1e-16 Ω ε relative to the scale C_s Ω ε /(1−ε²)^1.5 of a wedge force at that ε.
    cs = 6 * 0.1 * RS**3 * LEN / C**2
    scale = cs * (abs(Om) + 1e-300) / (1 - eps * eps) ** 1.5
    assert np.hypot(f[0], f[1]) <= 1e-12 * scale


@given(
    a=st.floats(-math.pi, math.pi),
    b=st.floats(-math.pi, math.pi),
    r=st.floats(0.0, 1.02),
    vx=st.floats(-1.0, 1.0), vy=st.floats(-1.0, 1.0),
    wB=st.floats(-50.0, 50.0), wS=st.floats(-50.0, 50.0),
    imp=st.sampled_from([0.0, 1e-3, 0.05]),
    model=st.sampled_from(["dry", "lubricated", "transition"]),
)
@settings(max_examples=400, deadline=None)
def test_rotating_the_frame_rotates_the_force(a, b, r, vx, vy, wB, wS, imp, model):
    p = MODELS[model]
    e = r * C * np.array([math.cos(a), math.sin(a)])
    v = np.array([vx, vy])
    f = call(p, e, v, wB, wS, imp)
    g = call(p, rot(b, e), rot(b, v), wB, wS, imp)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(g))
    # forces rotate, moments and energy are scalars. n, t come from the rotated e with ~1e-16
    # relative rounding; the film amplifies relative errors of ε by ≤ 1/(1−ε²) ≈ 50 at ε_max, and
    # the dry law amplifies errors of δ = |e| − c by c/δ. 1e-9 of the largest term plus an
    # absolute 1e-7 N (δ down to ~1e-13 m) covers both with margin.
    tol = 1e-9 * np.max(np.abs(f)) + 1e-7
    assert np.all(np.abs(rot(b, f[:2]) - g[:2]) <= tol)
    assert np.all(np.abs(f[2:] - g[2:]) <= tol)


@given(
    r=st.floats(0.0, 1.05), a=st.floats(-math.pi, math.pi),
    vx=st.floats(-2.0, 2.0), vy=st.floats(-2.0, 2.0),
    wB=st.floats(-50.0, 50.0), wS=st.floats(-50.0, 50.0),
    imp=st.floats(0.0, 1.0),
)
@settings(max_examples=400, deadline=None)
def test_dry_contact_is_dissipative(r, a, vx, vy, wB, wS, imp):
    # P = F·v + M_S ω_S + M_B ω_B is the power of the joint forces on the bodies. It contains
    # the elastic power −K δ^n δ̇ = −dE_el/dt, so P + dE_el/dt = −(F_N − K δ^n) δ̇ + F_T v_T is the
    # power of the non-conservative part, which must be ≤ 0: the LN damping term opposes δ̇, the
    # clip F_N = 0 only acts while separating (δ̇ < 0), and friction opposes the slip.
    e = r * C * np.array([math.cos(a), math.sin(a)])
    v = np.array([vx, vy])
    f = call(P_DRY, e, v, wB, wS, imp)
    nrm = math.hypot(e[0], e[1])  # δ exactly as the joint computes it
    delta = nrm - C
    ddot = (v[0] * e[0] / nrm + v[1] * e[1] / nrm) if nrm > 0 else 0.0
    P = f[:2] @ v + f[2] * wS + f[3] * wB
    dEdt = K * delta**1.5 * ddot if delta > 0 else 0.0
    # rounding: each term ~ |F||v|·1e-16
    assert P + dEdt <= 1e-12 * (np.hypot(f[0], f[1]) * (np.hypot(vx, vy) + 50 * RB) + 1e-300)


# ------------------------------------------------------------------------------- transition ---

def test_transition_regions():
    rng = np.random.default_rng(5)
    e1 = P_TR[P_E1]
    for _ in range(50):
        a = rng.uniform(-math.pi, math.pi)
        n = np.array([math.cos(a), math.sin(a)])
        v = rng.normal(size=2) * 0.1
        wB, wS = rng.normal(size=2) * 10
        # below ε_max the transition joint is the lubricated one (beyond it the transition
        # film is clamped, the lubricated film is not)
        inside = rng.uniform(0, P_TR[P_EPSMAX]) * C * n
        assert np.all(call(P_TR, inside, v, wB, wS) == call(P_LUB, inside, v, wB, wS))
        beyond = (C + e1 * (1 + rng.uniform(0.01, 5))) * n
        dry = call(P_DRY, beyond, v, wB, wS)
        tr = call(P_TR, beyond, v, wB, wS)
        assert np.all(tr[:4] == dry[:4])
        # E_el of the blend = potential of s(δ) K δ^n (continuous at e1, not K δ^{n+1}/(n+1))
        d = np.linalg.norm(beyond) - C
        assert tr[4] == pytest.approx(transition_energy(d, K, 1.5, e1), rel=1e-14)
        # inside the band: linear blend (eq. 19) with film at ε_max
        s = rng.uniform(0.01, 0.99)
        band = (C + s * e1) * n
        # film of the transition joint at ε_max with the actual ε̇ and w
        r_b = np.linalg.norm(band)
        tt = np.array([-n[1], n[0]])
        fr, ft = film_forces(P_TR[P_EPSMAX], (v @ n) / C, wS + wB - 2 * (v @ tt) / r_b, 0.1,
                             RS, LEN, C, 1.0, 0.1)
        lub = np.concatenate([fr * n + ft * tt, [0.0, 0.0]])
        dry = call(P_DRY, band, v, wB, wS)
        s_exact = (np.linalg.norm(band) - C) / e1
        blend = s_exact * dry[:4] + (1 - s_exact) * lub[:4]
        tr = call(P_TR, band, v, wB, wS)
        assert tr[:4] == pytest.approx(blend, rel=1e-9, abs=1e-9 * np.max(np.abs(blend)))


@given(a=st.floats(-math.pi, math.pi), vx=st.floats(-1, 1), vy=st.floats(-1, 1),
       wB=st.floats(-30, 30), wS=st.floats(-30, 30))
@settings(max_examples=200, deadline=None)
def test_transition_is_continuous_in_e(a, vx, vy, wB, wS):
    n = np.array([math.cos(a), math.sin(a)])
    v = np.array([vx, vy])
    e1 = P_TR[P_E1]
    for r0 in (P_TR[P_EPSMAX] * C, C, C + e1):
        lo = call(P_TR, r0 * (1 - 1e-11) * n, v, wB, wS)
        hi = call(P_TR, r0 * (1 + 1e-11) * n, v, wB, wS)
        # a step of 1e-11 |e| (≈1e-14 m) changes s by ≤ 1e-9 and the dry force by
        # ≤ dF/dδ Δe ≈ (1.5 K e1^0.5 + K e1^0.5) 1e-14 ≈ 1e-5 N, i.e. ~3e-9 of the dry force at
        # the band end, K e1^1.5 ≈ 3.1 kN; the film (clamped beyond ε_max) changes by
        # ≤ 3ε/(1−ε²) Δε ≈ 2e-9 relative. Jumps would be O(1) of these scales.
        scale = np.max(np.abs(lo)) + np.max(np.abs(hi)) + K * e1**1.5
        assert np.all(np.abs(lo - hi) <= 1e-7 * scale)


def test_transition_energy_is_potential_of_blended_elastic_force():
    e1 = 1e-5
    for d in (0.3e-5, 1e-5, 2.5e-5):
        h = 1e-9 * d
        dU = (transition_energy(d + h, K, 1.5, e1) - transition_energy(d - h, K, 1.5, e1)) / (2 * h)
        s = min(1.0, d / e1)
        # central difference, error O(h²) relative plus rounding 1e-16 U/h ~ 1e-7
        assert dU == pytest.approx(s * K * d**1.5, rel=1e-6)


# ------------------------------------------------------------------------------ degeneracies ---

@pytest.mark.parametrize("model", ["dry", "lubricated", "transition"])
def test_centre_and_denormals_are_finite(model):
    p = MODELS[model]
    for e in ((0.0, 0.0), (-0.0, 0.0), (5e-324, 0.0), (1e-310, 2e-310), (1e-200, -1e-200)):
        for v in ((0.0, 0.0), (1.0, -2.0), (5e-324, 0.0)):
            f = call(p, e, v, 3.0, -7.0)
            assert np.all(np.isfinite(f))
            # the film vanishes like (ε/ε0)^λ at the centre: |F| ≤ C_s π |ε̇| ε/ε0 · O(1)
            assert np.hypot(f[0], f[1]) <= 1e-100
    for e in ((C * (1 - 1e-12), 0.0), (C * 1.5, 0.0), (0.0, C + 1e-3)):
        assert np.all(np.isfinite(call(p, e, (1.0, 1.0), 3.0, -7.0)))
