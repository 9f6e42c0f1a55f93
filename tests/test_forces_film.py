"""Pinkus–Sternlicht film forces: limits, identities, independent Reynolds-equation checks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad, solve_ivp

from mechrel.forces import (
    film_forces, film_forces_eps_w, full_film_squeeze, half_sommerfeld_steady,
    small_eccentricity_factor,
)

# The paper's joint: R_B = 15 mm, c = 0.5 mm, L = 40 mm, 100 cP.
MU, R_S, L, C = 0.1, 0.0145, 0.04, 5e-4
CS = 6.0 * MU * R_S**3 * L / C**2  # force scale of the P–S formulas (N s)
LAM, EPS0 = 1.0, 0.1

eps_st = st.floats(0.0, 0.999)
eps_pos = st.floats(0.01, 0.99)
rate_st = st.floats(-1e4, 1e4)  # ε̇ in 1/s (|δ̇| up to 5 m/s)
w_st = st.floats(-500.0, 500.0)


def uncorrected(eps, ed, w):
    """P–S forces without the small-eccentricity correction (λ = 0)."""
    return film_forces(eps, ed, w, MU, R_S, L, C, 0.0, EPS0)


# ---------------------------------------------------------------------------------------------
# Independent reference: the long-bearing Reynolds equation integrated numerically.
# With h = c (1 − ε cos φ), φ measured from n (thinnest film at φ = 0), x = R φ along t:
#   d/dφ (H³ dp/dφ) = A (w ε sin φ − 2 ε̇ cos φ),  A = 6 μ R² / c²
# integrated once: H³ p' = A (w H − 2 ε̇ sin φ + C1). For the steady case (ε̇ = 0) C1 follows from
# periodicity of p (∮ p' dφ = 0); the Gumbel condition keeps the positive part of p.
# Force on the journal: F_r = −R L ∫ p⁺ cos φ dφ, F_t = −R L ∫ p⁺ sin φ dφ.
# ---------------------------------------------------------------------------------------------

def reynolds_forces(eps, w, eps_dot=0.0, gumbel=True):
    A = 6.0 * MU * R_S**2 / C**2
    H = lambda f: 1.0 - eps * math.cos(f)  # noqa: E731
    I2 = quad(lambda f: H(f) ** -2, -math.pi, math.pi, epsabs=0, epsrel=1e-13)[0]
    I3 = quad(lambda f: H(f) ** -3, -math.pi, math.pi, epsabs=0, epsrel=1e-13)[0]
    # periodicity: the sin φ / H³ term integrates to 0 over a period
    C1 = -w * I2 / I3

    def dp(f, y):
        h = H(f)
        return [A * (w / h**2 + (C1 - 2.0 * eps_dot * math.sin(f)) / h**3)]

    def zero(f, y):
        return y[0]

    # Reference pressure: p = 0 at the maximum film thickness (φ = ±π).
    sol = solve_ivp(dp, (-math.pi, math.pi), [0.0], method="DOP853", rtol=1e-13, atol=1e-12,
                    dense_output=True, events=zero)
    p = lambda f: sol.sol(f)[0]  # noqa: E731
    inner = [z for z in sol.t_events[0] if -math.pi + 1e-9 < z < math.pi - 1e-9]
    cuts = [-math.pi, *inner, math.pi]
    Fr = Ft = 0.0
    # absolute floor far below the forces compared (a component can be exactly 0 by symmetry)
    tiny = 1e-12 * R_S * L * A * (abs(w) + abs(eps_dot))
    for a, b in zip(cuts[:-1], cuts[1:]):
        if gumbel and p(0.5 * (a + b)) <= 0.0:
            continue
        Fr += quad(lambda f: -R_S * L * p(f) * math.cos(f), a, b, epsabs=tiny, epsrel=1e-12,
                   limit=200)[0]
        Ft += quad(lambda f: -R_S * L * p(f) * math.sin(f), a, b, epsabs=tiny, epsrel=1e-12,
                   limit=200)[0]
    return Fr, Ft, p(math.pi)


@pytest.mark.parametrize("eps", [0.05, 0.3, 0.6, 0.9, 0.97])
@pytest.mark.parametrize("w", [12.0, -7.5])
def test_half_sommerfeld_matches_numerical_reynolds(eps, w):
    Fr, Ft, p_end = reynolds_forces(eps, w)
    hr, ht = half_sommerfeld_steady(eps, w, MU, R_S, L, C)
    scale = abs(hr) + abs(ht)
    # periodicity of the numerical pressure (C1 from quadrature): sanity of the reference
    assert abs(p_end) < 1e-8 * 6 * MU * R_S**2 / C**2 * abs(w)
    # ODE (rtol 1e-13) + quad (rtol 1e-12) on a smooth pressure: 1e-9 leaves 3 orders of margin
    assert Fr == pytest.approx(hr, rel=1e-9, abs=1e-12 * scale)
    assert Ft == pytest.approx(ht, rel=1e-9, abs=1e-12 * scale)


@pytest.mark.parametrize("eps", [0.1, 0.5, 0.9])
def test_full_film_squeeze_matches_numerical_reynolds(eps):
    # Pure squeeze, full film (no cavitation): the constant of integration is irrelevant for the
    # force (∮ cos φ dφ = 0); C1 = 0 keeps p periodic because ∮ sin φ / H³ dφ = 0.
    Fr, _, _ = reynolds_forces(eps, 0.0, eps_dot=3.0, gumbel=False)
    # same quadrature tolerances as above
    assert Fr == pytest.approx(full_film_squeeze(eps, 3.0, MU, R_S, L, C), rel=1e-9)


@given(eps=st.floats(0.0, 0.999), w=w_st)
@settings(max_examples=300, deadline=None)
def test_steady_ps_equals_half_sommerfeld(eps, w):
    # ε̇ = 0 exactly: k = ∞, (k+3)/(k+1.5) = 1; both closed forms are the same algebraic
    # expression evaluated in a different order: a few ulp, amplified by 1/(1−ε²) ≤ 500.
    fr, ft = uncorrected(eps, 0.0, w)
    hr, ht = half_sommerfeld_steady(eps, w, MU, R_S, L, C)
    assert fr == pytest.approx(hr, rel=1e-12, abs=1e-300)
    assert ft == pytest.approx(ht, rel=1e-12, abs=1e-300)


@given(eps=eps_pos, w=w_st)
@settings(max_examples=200, deadline=None)
def test_ps_tends_to_half_sommerfeld_as_eps_dot_vanishes(eps, w):
    # The limit is approached linearly in ε̇ (the π ε̇ g term); at |ε̇| = 1e-9 the difference is
    # ~ C π 1e-9 / (1 − ε²)^1.5, i.e. relative 1e-9 / (1 − ε²)^0.5 / (ε |w|) of the steady force.
    hr, ht = half_sommerfeld_steady(eps, w, MU, R_S, L, C)
    for ed in (1e-9, -1e-9):
        fr, ft = uncorrected(eps, ed, w)
        bound = 10 * CS * math.pi * 1e-9 / (1 - eps * eps) ** 1.5
        assert abs(fr - hr) <= bound
        assert abs(ft - ht) <= bound


@given(eps=eps_pos, ed=st.floats(1e-3, 1e4))
@settings(max_examples=300, deadline=None)
def test_pure_squeeze_gumbel_halves_sum_to_full_film(eps, ed):
    # The full-film pressure is odd in ε̇ for w = 0, so p⁺(ε̇) − p⁺(−ε̇) = p(ε̇): the approach force
    # at +ε̇ MINUS the (opposite-signed) separation force at −ε̇ is the 2π film force; in
    # magnitudes |F(+ε̇)| + |F(−ε̇)| = |F_full|. Only with the corrected eq. (13) does this hold.
    fa, _ = uncorrected(eps, ed, 0.0)
    fs, _ = uncorrected(eps, -ed, 0.0)
    full = full_film_squeeze(eps, ed, MU, R_S, L, C)
    assert fa < 0.0 < fs  # approach pushed back toward the centre, separation pulled outward
    # the 4εT/(2+ε²) terms cancel exactly in the difference; the rest is a few roundings
    assert fa - fs == pytest.approx(full, rel=1e-12)
    assert abs(fa) + abs(fs) == pytest.approx(abs(full), rel=1e-12)


@given(eps=st.floats(0.0, 0.99), ed=rate_st, w=w_st)
@settings(max_examples=300, deadline=None)
def test_squeeze_film_resists_radial_motion(eps, ed, w):
    # The radial force opposes ε̇ whenever ε̇ ≠ 0 with w = 0, and is never outward while the
    # journal is still (the wedge-only radial force pulls toward the centre).
    fr, _ = film_forces(eps, ed, 0.0, MU, R_S, L, C, LAM, EPS0)
    assert fr * ed <= 0.0
    fr0, _ = film_forces(eps, 0.0, w, MU, R_S, L, C, LAM, EPS0)
    assert fr0 <= 0.0


def test_eps_dot_sign_flip_is_continuous():
    for eps in (1e-6, 0.2, 0.7, 0.999):
        for w in (0.0, 3.0, -40.0):
            f0 = np.array(uncorrected(eps, 0.0, w))
            scale = CS / (1 - eps * eps) ** 1.5
            for ed in (1e-12, 1e-300, 5e-324, 0.0, -0.0):
                for s in (1.0, -1.0):
                    f = np.array(uncorrected(eps, s * ed, w))
                    assert np.all(np.isfinite(f))
                    # |ΔF| ≤ C π |ε̇| g / (1−ε²)^1.5 + O(ε̇²): with |ε̇| ≤ 1e-12 this is ≤ 1e-11 scale
                    assert np.all(np.abs(f - f0) <= 1e-11 * scale)


def test_degenerate_points_are_finite():
    # ε = 0 and ε̇ = 0 exactly: no force, with and without the correction.
    for lam in (0.0, 1.0):
        assert all(v == 0.0 for v in film_forces(0.0, 0.0, 0.0, MU, R_S, L, C, lam, EPS0))
        assert all(v == 0.0 for v in film_forces(0.0, 0.0, 25.0, MU, R_S, L, C, lam, EPS0))
    # ε = 0 with ε̇ ≠ 0: the uncorrected force is the half-film squeeze −π C ε̇ (the 2π film halved)
    fr, ft = uncorrected(0.0, 2.0, 7.0)
    assert fr == pytest.approx(-math.pi * CS * 2.0, rel=1e-15)
    assert ft == 0.0
    # ... and the correction removes it (continuity at the centre for λ > 0)
    assert all(v == 0.0 for v in film_forces(0.0, 2.0, 7.0, MU, R_S, L, C, LAM, EPS0))
    # ε → 1: huge but finite
    for eps in (1 - 1e-12, 1 - 1e-15, np.nextafter(1.0, 0.0)):
        for ed in (0.0, 1.0, -1.0):
            fr, ft = film_forces(eps, ed, 10.0, MU, R_S, L, C, LAM, EPS0)
            assert math.isfinite(fr) and math.isfinite(ft)
    # extreme rates stay finite (hypot, no squares of ε̇)
    for ed in (1e200, -1e200, 1e-320):
        assert all(math.isfinite(v) for v in film_forces(0.5, ed, 1e3, MU, R_S, L, C, LAM, EPS0))


@given(eps=st.floats(0.0, 0.999), ed=st.floats(-1e6, 1e6), ew=st.floats(-1e6, 1e6))
@settings(max_examples=500, deadline=None)
def test_film_finite_everywhere(eps, ed, ew):
    fr, ft = film_forces_eps_w(eps, ed, ew, MU, R_S, L, C, LAM, EPS0)
    assert math.isfinite(fr) and math.isfinite(ft)


def test_small_eccentricity_limit_is_half_film_squeeze():
    # As ε → 0 (k → ∞ for w = 0), P–S gives the π-film squeeze −π C ε̇: half of the 2π film.
    for eps in (1e-4, 1e-6):
        fr, _ = uncorrected(eps, 1.0, 0.0)
        # first-order term (4ε T/(2+ε²) + 1.5π ε ...) is O(ε) relative
        assert fr == pytest.approx(-math.pi * CS, rel=10 * eps)


@given(eps=st.floats(0.0, 0.999), lam=st.floats(0.0, 3.0), eps0=st.floats(0.01, 1.0))
@settings(max_examples=300, deadline=None)
def test_small_eccentricity_factor(eps, lam, eps0):
    f = small_eccentricity_factor(eps, lam, eps0)
    assert 0.0 <= f <= 1.0
    if eps >= eps0:
        assert f == 1.0
    else:
        assert f == pytest.approx((eps / eps0) ** lam, rel=1e-14)


def test_correction_continuous_at_eps0_and_inactive_above():
    ed, w = 5.0, 20.0
    below = np.array(film_forces(EPS0 * (1 - 1e-12), ed, w, MU, R_S, L, C, LAM, EPS0))
    above = np.array(film_forces(EPS0 * (1 + 1e-12), ed, w, MU, R_S, L, C, LAM, EPS0))
    # continuous: relative change O(1e-12) from the factor and the argument
    assert np.allclose(below, above, rtol=1e-10, atol=0)
    for eps in (0.2, 0.5, 0.95):
        assert film_forces(eps, ed, w, MU, R_S, L, C, 2.5, EPS0) == uncorrected(eps, ed, w)


def test_attitude_angle_of_half_sommerfeld():
    # Classical long-bearing half-Sommerfeld attitude angle: tan φ = π sqrt(1−ε²) / (2ε)
    # (angle between the load line and the line of centres). Here −F_t/F_r for w > 0.
    for eps in (0.1, 0.5, 0.9):
        fr, ft = half_sommerfeld_steady(eps, 10.0, MU, R_S, L, C)
        assert ft / -fr == pytest.approx(math.pi * math.sqrt(1 - eps**2) / (2 * eps), rel=1e-14)


@given(eps=eps_pos, ed=rate_st, w=w_st, mu=st.floats(1e-3, 1.0))
@settings(max_examples=200, deadline=None)
def test_linear_in_viscosity_and_mirror_symmetry(eps, ed, w, mu):
    # Reynolds is linear in μ; reflecting the plane (t → −t: w → −w) flips F_t and keeps F_r.
    fr, ft = film_forces(eps, ed, w, mu, R_S, L, C, LAM, EPS0)
    f1r, f1t = film_forces(eps, ed, w, 1.0, R_S, L, C, LAM, EPS0)
    assert fr == pytest.approx(mu * f1r, rel=1e-13, abs=1e-300)
    assert ft == pytest.approx(mu * f1t, rel=1e-13, abs=1e-300)
    mr, mt = film_forces(eps, ed, -w, mu, R_S, L, C, LAM, EPS0)
    assert mr == fr and mt == -ft
