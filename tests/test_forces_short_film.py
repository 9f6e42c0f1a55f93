"""Short (Ocvirk) bearing with rotation and squeeze, and the 2-D Reynolds reference solver.

References used here, each independent of the closed form under test:

* Ocvirk's steady forces (:func:`ocvirk_steady`, the classical textbook result);
* the full-film (2π) short-bearing squeeze force, −(μRL³/c²) π ε̇ (1 + 2ε²)/(1 − ε²)^{5/2}, to
  which the half-Sommerfeld forces of +ε̇ and −ε̇ must add up (the full-film pressure is odd in
  ε̇, and its positive parts at ±ε̇ tile the circle);
* the finite-volume Reynolds solver :func:`mechrel.forces.reynolds.reynolds_forces`, whose
  second-order grid convergence is checked first, at L/D → 0 (short bearing) and L/D → ∞
  (long bearing).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from mechrel.errors import SceneError
from mechrel.forces import (
    film_forces_eps_w, ocvirk_steady, pack_params, short_film_forces,
)
from mechrel.forces.joint import EPS_GUARD, clearance_force
from mechrel.forces.reynolds import reynolds_forces
from mechrel.scene import load_scene
from mechrel.simulation import simulate

MU, R_S, C = 0.1, 0.0145, 5e-4
L = 0.04  # the paper's bearing, L/D ≈ 1.4
LAM, EPS0 = 1.0, 0.1

eps_st = st.floats(0.0, 0.999)
eps_pos = st.floats(0.01, 0.99)
rate_st = st.floats(-1e4, 1e4)
w_st = st.floats(-500.0, 500.0)


def short(eps, ed, ew, L=L, lam=0.0):
    return short_film_forces(eps, ed, ew, MU, R_S, L, C, lam, EPS0)


# ------------------------------------------------------------------- closed-form identities ---

@settings(max_examples=200, deadline=None)
@given(eps=eps_pos, w=w_st)
def test_steady_is_ocvirk(eps, w):
    # ε̇ = 0: the half-Sommerfeld region is the converging half behind n; the Sommerfeld
    # substitution must reproduce Ocvirk's closed form to rounding (1e-12 relative: a handful
    # of trigonometric evaluations, conditioned like 1/(1 − ε²)).
    Fr, Ft = short(eps, 0.0, eps * w)
    Rr, Rt = ocvirk_steady(eps, w, MU, R_S, L, C)
    scale = math.hypot(Rr, Rt) + 1e-300
    assert abs(Fr - Rr) <= 1e-12 * scale / (1 - eps) and abs(Ft - Rt) <= 1e-12 * scale / (1 - eps)


@settings(max_examples=200, deadline=None)
@given(eps=eps_st, ed=st.floats(1e-3, 1e4))
def test_pure_squeeze_halves_add_up_to_the_full_film(eps, ed):
    Fp, Tp = short(eps, ed, 0.0)
    Fm, Tm = short(eps, -ed, 0.0)
    om = 1.0 - eps * eps
    full = -MU * R_S * L**3 / C**2 * math.pi * ed * (1 + 2 * eps**2) / om**2.5
    assert Fp - Fm == pytest.approx(full, rel=1e-11)
    assert abs(Tp) <= 1e-12 * abs(full) and abs(Tm) <= 1e-12 * abs(full)
    assert Fp < 0 < Fm  # the film resists approach and separation alike


@settings(max_examples=200, deadline=None)
@given(eps=eps_pos, ed=rate_st, w=w_st)
def test_mirror_symmetry_and_linearity_in_mu(eps, ed, w):
    # w → −w mirrors the film about n: F_r unchanged, F_t flips (exactly, by the symmetric
    # region), and every force is linear in μ
    Fr, Ft = short(eps, ed, eps * w)
    Gr, Gt = short(eps, ed, -eps * w)
    s = math.hypot(Fr, Ft) + 1e-300
    assert abs(Fr - Gr) <= 1e-12 * s / (1 - eps) and abs(Ft + Gt) <= 1e-12 * s / (1 - eps)
    Hr, Ht = short_film_forces(eps, ed, eps * w, 3 * MU, R_S, L, C, 0.0, EPS0)
    assert Hr == pytest.approx(3 * Fr, rel=1e-14, abs=1e-300)
    assert Ht == pytest.approx(3 * Ft, rel=1e-14, abs=1e-300)


def quad_reference(eps, ed, ew, L=L):
    """The region integrals in θ by adaptive quadrature (SciPy quad, rtol 1e-12), split at the
    thinnest film θ = 0 and at the region's ends: F = −(μRL³/c²)∫_{G>0} G (cos θ, sin θ)/H³."""
    a = 0.5 * ew
    phi = math.atan2(a, ed)
    lo, hi = -0.5 * math.pi - phi, 0.5 * math.pi - phi

    def integral(f):
        pts = sorted({lo, hi, *[k * 2 * math.pi for k in (-1, 0, 1) if lo < k * 2 * math.pi < hi]})
        return sum(quad(f, x0, x1, epsabs=0, epsrel=1e-12, limit=200)[0]
                   for x0, x1 in zip(pts[:-1], pts[1:]))

    def G(t):
        return ed * math.cos(t) - a * math.sin(t)

    def H3(t):
        # 1 − ε cos θ = (1 − ε) + ε (1 − cos θ), without cancellation near θ = 0
        return ((1.0 - eps) + eps * 2.0 * math.sin(0.5 * t) ** 2) ** 3

    k = MU * R_S * L**3 / C**2
    return (-k * integral(lambda t: G(t) * math.cos(t) / H3(t)),
            -k * integral(lambda t: G(t) * math.sin(t) / H3(t)))


@pytest.mark.parametrize("eps", [0.3, 0.9, 0.999, 1 - 1e-6, 1 - 1e-8])
@pytest.mark.parametrize("ed, w", [(-2.0, 0.0), (-2.0, 0.3), (-2.0, 30.0), (2.0, 30.0),
                                   (0.0, 30.0), (1.0, -7.0)])
def test_against_quadrature_up_to_the_wall(eps, ed, w):
    # Everywhere, including separation at ε = 1 − 1e-8 (only the thick film is loaded; the
    # force stays O(μRL³ε̇/c²) while the Sommerfeld factors are 1/β⁵ ≈ 1e20): the 12-point
    # rule's 1e-11, quad's 1e-12, plus the rounding of cos ψ + ε (absolute 2e-16 on a value
    # ~β²/2 on the thick side: 4e-16/β² relative; 2e-8 at ε = 1 − 1e-8, measured 6e-9).
    F = short(eps, ed, eps * w)
    R = quad_reference(eps, ed, eps * w)
    assert _rel(F, R) < 1e-10 + 4e-16 / (1 - eps * eps)


# ------------------------------------------------------------------------ hard cases, finite ---

@settings(max_examples=300, deadline=None)
@given(eps=eps_st, ed=rate_st, w=w_st)
def test_finite_everywhere_and_dissipative(eps, ed, w):
    Fr, Ft = short(eps, ed, eps * w, lam=LAM)
    assert math.isfinite(Fr) and math.isfinite(Ft)
    # without rotation the (non-negative) film pressure only resists the radial motion, and
    # the region is symmetric about n: F_t is an odd integrand summed over a symmetric rule,
    # zero up to rounding (1e-12 relative)
    Sr, St = short(eps, ed, 0.0, lam=LAM)
    assert Sr * ed <= 0.0 and abs(St) <= 1e-12 * abs(Sr)


@pytest.mark.parametrize("ed", [0.0, 1e-300, -1e-300, 5e-324, -5e-324, 1e-9, -1e-9])
def test_continuous_in_eps_dot_at_zero(ed):
    # the region turns continuously with φ = atan2(εw/2, ε̇): at ε̇ → ±0 it is the steady one
    for eps in (0.1, 0.5, 0.9):
        Fr, Ft = short(eps, ed, eps * 30.0)
        Rr, Rt = ocvirk_steady(eps, 30.0, MU, R_S, L, C)
        assert Fr == pytest.approx(Rr, rel=1e-8) and Ft == pytest.approx(Rt, rel=1e-8)


def test_rest_centre_and_wall():
    assert short(0.0, 0.0, 0.0, lam=LAM) == (0.0, 0.0)        # journal at rest, centred
    assert short(0.5, 0.0, 0.0) == (0.0, 0.0)                 # at rest, off centre: no film
    Fr, Ft = short(0.0, 10.0, 0.0, lam=LAM)                   # centre, moving: λ factor → 0
    assert Fr == 0.0 and Ft == 0.0
    for ed, ew in ((1e4, 0.0), (0.0, 500.0)):                 # at the numerical cap
        Fr, Ft = short(EPS_GUARD, ed, EPS_GUARD * ew)
        assert math.isfinite(Fr) and math.isfinite(Ft)
        assert abs(Fr) + abs(Ft) > 1e6  # ∝ 1/β⁵ or 1/β⁴ with β² = 2e-9: huge, not inf
    # separating from the wall only the thick film is loaded: finite and moderate
    Fr, Ft = short(EPS_GUARD, -1e4, EPS_GUARD * 500.0)
    assert math.isfinite(Fr) and math.isfinite(Ft) and 0 < Fr < 1e5


def _joint_params(bearing):
    return pack_params(model="lubricated", clearance=C, bearing_radius=R_S + C, length=L,
                       stiffness=1e10, restitution=0.9, viscosity=MU, bearing=bearing)


@pytest.mark.parametrize("bearing", ["long", "short"])
def test_frame_invariance_and_half_frequency_whirl(bearing):
    p = _joint_params(bearing)
    e = np.array([3e-4, 1e-4])
    v = np.array([0.02, -0.05])
    wB, wS = 4.0, -7.0
    F = np.array(clearance_force(*e, *v, wB, wS, 0.0, p)[:2])
    # rotate the whole joint by α: the force rotates with it
    a = 0.7
    Q = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    G = np.array(clearance_force(*(Q @ e), *(Q @ v), wB, wS, 0.0, p)[:2])
    assert np.allclose(G, Q @ F, rtol=1e-12, atol=1e-12 * np.abs(F).max())
    # observe it from a frame turning at Ω: ω_B, ω_S and γ̇ all shift by Ω (v gains Ω × e)
    Om = 13.0
    v2 = v + Om * np.array([-e[1], e[0]])
    H = np.array(clearance_force(*e, *v2, wB + Om, wS + Om, 0.0, p)[:2])
    assert np.allclose(H, F, rtol=1e-12, atol=1e-12 * np.abs(F).max())
    # whirl at half the mean speed with ε̇ = 0: w = ω_S + ω_B − 2γ̇ = 0, no film pressure
    gdot = 0.5 * (wB + wS)
    vw = gdot * np.array([-e[1], e[0]])
    assert clearance_force(*e, *vw, wB, wS, 0.0, p)[:2] == pytest.approx((0.0, 0.0), abs=1e-15)


# ------------------------------------------------------------- the Reynolds reference solver ---

def _rel(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1]) / math.hypot(*b)


def test_reynolds_solver_converges_at_second_order():
    # Halving both spacings divides the error by ~4 (cell-centred FV, H³ at exact faces,
    # midpoint forces): successive differences d_h = |F_h − F_h/2| must shrink by 4 ± 1.2.
    args = (0.6, -2.0, 0.6 * 8.0, MU, R_S, 1.0 * 2 * R_S, C)
    F = [reynolds_forces(*args, n_theta=n, n_z=m) for n, m in ((60, 8), (120, 16), (240, 32))]
    d1, d2 = _rel(F[0], F[1]), _rel(F[1], F[2])
    assert 2.8 < d1 / d2 < 5.2


@pytest.mark.parametrize("eps", [0.2, 0.5, 0.8, 0.9])
@pytest.mark.parametrize("motion", ["rotation", "squeeze", "mixed"])
def test_short_bearing_is_the_reynolds_limit_l_over_d_to_zero(eps, motion):
    # At L/D = 0.01 the neglected circumferential flow is O((L/D)²) small; on a 360 × 16 grid
    # the remaining grid error is ≤ 2e-3 (measured; second order, previous test), so the short
    # model must be within 1 % of the numerical solution.
    ed, ew = {"rotation": (0.0, 10.0 * eps), "squeeze": (5.0, 0.0),
              "mixed": (-3.0, 4.0 * eps)}[motion]
    Ls = 0.01 * 2 * R_S
    num = reynolds_forces(eps, ed, ew, MU, R_S, Ls, C, n_theta=360, n_z=16)
    assert _rel(short(eps, ed, ew, L=Ls), num) < 0.01


def _long_limit(eps, ed, ew, LD_pair=(8.0, 16.0)):
    """2-D half-Sommerfeld force per unit length, Richardson-extrapolated to L/D → ∞.

    The end leakage lowers the 2-D force by a fraction ∝ D/L (the pressure falls to 0 over an
    end zone of ~D): F(L/D) = F_∞ (1 − a D/L + O((D/L)²)); the extrapolate 2 F(16) − F(8)
    removes the linear term (remainder O(1/16²) a few, < 0.5 %)."""
    F = {}
    for LD in LD_pair:
        Ll = LD * 2 * R_S
        num = reynolds_forces(eps, ed, ew, MU, R_S, Ll, C, n_theta=240, n_z=int(10 * LD))
        F[LD] = np.array(num) / Ll
    return 2 * F[LD_pair[1]] - F[LD_pair[0]]


def test_long_bearing_is_the_reynolds_limit_l_over_d_to_infinity_in_rotation():
    # steady rotation: the long bearing (Sommerfeld pressure, odd about n, Gümbel half) is the
    # L/D → ∞ limit of the 2-D problem with ambient ends, within 1 %
    eps = 0.5
    long = np.array(film_forces_eps_w(eps, 0.0, eps * 10.0, MU, R_S, 1.0, C, 0.0, EPS0))
    assert _rel(_long_limit(eps, 0.0, eps * 10.0), long) < 0.01


def test_long_bearing_squeeze_limit_has_the_two_dimensional_pressure_level():
    # Pure squeeze: the 1-D long-bearing equation fixes the pressure only up to a constant,
    # p = (6μR²ε̇/(c² ε)) (H⁻² − K). Pinkus–Sternlicht take K = 1 (p = 0 at φ = ±π/2, the
    # π film). The 2-D problem with ambient ends fixes K: integrating it over θ gives
    # ∂z²∮H³p dθ = 0 with 0 at both ends, so ∮H³p dθ = 0 and K = ∮H/∮H³ = 1/(1 + 1.5ε²).
    # The extrapolated 2-D solution must match that level within 1 %, and differs from the
    # P–S squeeze force (7 % at ε = 0.5): a property of the long-bearing model, documented in
    # docs/forces.md.
    eps, ed = 0.5, 4.0
    K = 1.0 / (1.0 + 1.5 * eps**2)
    A = 6.0 * MU * R_S**2 / C**2

    def p(f):
        return max(A * ed / eps * ((1 - eps * math.cos(f)) ** -2 - K), 0.0)

    ref = -R_S * quad(lambda f: p(f) * math.cos(f), -math.pi, math.pi, epsrel=1e-12,
                      points=[0.0])[0]
    lim = _long_limit(eps, ed, 0.0)
    assert lim[0] == pytest.approx(ref, rel=0.01) and abs(lim[1]) < 1e-9 * abs(ref)
    ps = film_forces_eps_w(eps, ed, 0.0, MU, R_S, 1.0, C, 0.0, EPS0)[0]
    assert 0.05 < ref / ps - 1 < 0.09


# Raimondi & Boyd (1958), "A solution for the finite journal bearing and its application to
# analysis and design", ASLE Trans. 1, 159-209: full 360° bearing, Reynolds (Swift–Stieber)
# condition, steady rotation of the journal, bearing at rest. (L/D, ε) → (Sommerfeld number
# S = (R/c)² μN/P with N in rev/s and P = W/(LD), attitude angle φ in degrees), as tabulated
# there (and reproduced in design texts, e.g. Shigley's Mechanical Engineering Design).
RAIMONDI_BOYD = {
    (1.0, 0.6): (0.121, 50.58), (1.0, 0.8): (0.0446, 36.24), (1.0, 0.9): (0.0188, 26.45),
    (0.5, 0.6): (0.319, 48.14), (0.5, 0.8): (0.0923, 33.31), (0.5, 0.9): (0.0313, 23.66),
    (0.25, 0.6): (1.07, 46.72), (0.25, 0.8): (0.261, 31.04), (0.25, 0.9): (0.0736, 21.85),
}


@pytest.mark.parametrize("LD, eps", sorted(RAIMONDI_BOYD))
def test_reynolds_condition_against_raimondi_boyd(LD, eps):
    # The LCP (Swift–Stieber) solution on a 120 × 16 grid (grid error ≤ 0.3 % in S, measured
    # against 240 × 32) against the published table: S within 2 % (the table's 3 significant
    # digits and its own 1958 finite-difference grid), attitude within 1.5°.
    S_rb, phi_rb = RAIMONDI_BOYD[(LD, eps)]
    w = 10.0  # journal speed (rad/s), bearing at rest: N = w/2π
    Ll = LD * 2 * R_S
    Fr, Ft = reynolds_forces(eps, 0.0, eps * w, MU, R_S, Ll, C, cavitation="reynolds",
                             n_theta=120, n_z=16)
    S = (R_S / C) ** 2 * MU * (w / (2 * math.pi)) / (math.hypot(Fr, Ft) / (Ll * 2 * R_S))
    phi = math.degrees(math.atan2(Ft, -Fr))
    assert S == pytest.approx(S_rb, rel=0.02)
    assert abs(phi - phi_rb) < 1.5


def test_reynolds_condition_against_half_sommerfeld():
    # Swift–Stieber lets the film run past the thinnest point until the pressure and its
    # gradient vanish: the loaded region and the load are larger than half-Sommerfeld's, and
    # the attitude angle smaller. The solution is non-negative.
    args = (0.6, 0.0, 0.6 * 10.0, MU, R_S, 2 * R_S, C)
    hs = reynolds_forces(*args, n_theta=120, n_z=16)
    Fr, Ft, (th, z, P) = reynolds_forces(*args, cavitation="reynolds", n_theta=120, n_z=16,
                                         return_pressure=True)
    rc = (Fr, Ft)
    assert np.all(P >= 0.0)
    assert math.hypot(*hs) < math.hypot(*rc) < 1.5 * math.hypot(*hs)
    assert math.atan2(rc[1], -rc[0]) < math.atan2(hs[1], -hs[0])
    with pytest.raises(ValueError, match="cavitation = 'jfo'"):
        reynolds_forces(*args, cavitation="jfo")


# ------------------------------------------------------------------------ in a simulation ---

def test_scene_selects_the_bearing_and_short_runs():
    long = simulate(load_scene("nine-bar-lubricated"))
    ov = {"joints.C1.lubricant.bearing": "short", "joints.C2.lubricant.bearing": "short"}
    sc = load_scene("nine-bar-lubricated", overrides=ov)
    assert sc.joints["C1"].lubricant.bearing == "short"
    res = simulate(sc)
    assert res.stats["status"] == "ok"
    for name in ("C1", "C2"):
        eps = res.orbits[name]["eps"]
        assert np.all(np.isfinite(eps)) and eps.max() < 1.0
    # at L/D = 1.4 the short bearing's film is stiffer at the wall and weaker near the centre
    # than the long one: the orbits differ visibly (not a no-op switch)
    d = np.abs(res.orbits["C1"]["eps"] - long.orbits["C1"]["eps"]).max()
    assert d > 0.01
    # the transition to dry contact works with the short film too
    tr = simulate(load_scene("slider-crank-lubricated", overrides={
        "joints.C.model": "transition", "joints.C.lubricant.viscosity": 1e-5,
        "joints.C.lubricant.bearing": "short"}))
    assert tr.stats["status"] == "ok" and tr.orbits["C"]["eps"].max() > 1.0
    assert np.all(np.isfinite(tr.energy["balance"]))


def test_scene_rejects_unknown_bearing():
    with pytest.raises(SceneError, match=r'joints\.C1\.lubricant\.bearing = "shrt": unknown '
                       r"value \(did you mean 'short'\?\); allowed: one of long, short, finite"):
        load_scene("nine-bar-lubricated", overrides={"joints.C1.lubricant.bearing": "shrt"})
