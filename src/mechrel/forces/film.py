"""Hydrodynamic film forces of a lubricated journal bearing (long-bearing theory).

Sign and frame conventions (all functions here)
-----------------------------------------------
``F_r`` is the film force on the JOURNAL along n = e/|e| (e = journal centre − bearing centre);
``F_t`` its component along t = n rotated by +90°. ``F_r < 0`` pushes the journal back toward
the bearing centre. ε = |e|/c, ε̇ = dε/dt, and w = ω_S + ω_B − 2γ̇ is the wedge speed (rad/s)
with ω_S, ω_B the absolute angular velocities of the journal's and bearing's bodies and
γ = atan2(e_y, e_x). All functions require 0 ≤ ε < 1: the caller clamps ε (the clearance joint
uses min(ε, ε_max)).

Sources
-------
- Chen, Wang & Gao (2022), Arch. Appl. Mech., eqs. (10)–(18), with the corrections of
  ``docs/reference.md``: wedge speed w = ω_S + ω_B − 2γ̇ (frame invariant), sign of
  eq. (13), and k of eq. (15) never divided by ε̇.
- Pinkus, O. & Sternlicht, B. (1961), Theory of Hydrodynamic Lubrication, McGraw-Hill
  (dynamically loaded long bearing, Gumbel / π-film conditions).
- Flores, P., Ambrósio, J., Claro, J.C.P., Lankarani, H.M. & Koshy, C.S. (2009), "Lubricated
  revolute joints in rigid multibody systems", Nonlinear Dyn. 56, 277–295 (use of the
  Pinkus–Sternlicht forces in multibody codes).
"""

from __future__ import annotations

import math

import numba

__all__ = [
    "film_forces", "film_forces_eps_w", "small_eccentricity_factor",
    "half_sommerfeld_steady", "full_film_squeeze",
]

_TINY = 2.2250738585072014e-308  # smallest normal float64


@numba.njit(cache=True, fastmath=False)
def small_eccentricity_factor(eps, lam, eps0):
    """Small-eccentricity correction factor (min(ε, ε0)/ε0)^λ (-), paper eqs. (16)–(17).

    The paper prints ε^λ for ε ≤ ε0 and 1 above, which jumps by the factor ε0^λ at ε0 unless
    ε0 = 1. We normalise by ε0 so that the factor is continuous (it equals the printed form for
    ε0 = 1). It goes to 0 as ε → 0 for λ > 0, which makes the film force continuous at the
    bearing centre, where the direction n of the uncorrected force is undefined.

    Parameters
    ----------
    eps : float
        Eccentricity ratio ε (-), ≥ 0.
    lam : float
        Exponent λ (-), ≥ 0 (λ = 0 switches the correction off).
    eps0 : float
        Threshold ε0 (-), in (0, 1].

    Returns
    -------
    float
        Factor in [0, 1].

    Examples
    --------
    >>> small_eccentricity_factor(0.05, 1.0, 0.1), small_eccentricity_factor(0.5, 1.0, 0.1)
    (0.5, 1.0)
    """
    return (min(eps, eps0) / eps0) ** lam


@numba.njit(cache=True, fastmath=False)
def film_forces_eps_w(eps, eps_dot, eps_w, mu, R_S, L, c, lam, eps0):
    """Pinkus–Sternlicht long-bearing film forces, written in ε, ε̇ and the product ε·w.

    Same as :func:`film_forces` but takes ``eps_w = ε·w`` (rad/s) instead of w, which stays
    bounded at the bearing centre (ε → 0, where w itself diverges through γ̇ = (v·t)/|e|). This
    is the form :func:`mechrel.forces.joint.clearance_force` calls.

    With C = 6 μ R_S³ L / c², T = sqrt(1 − ε²) · hypot(ε w / 2, ε̇) (= ε |ε̇| k with k of eq. 15) and
    ρ = ε ε̇ / (T + 1.5 ε |ε̇|) (= sign(ε̇)/(k + 1.5), in [−2/3, 2/3]), g = 1 + 1.5 ρ (= (k+3)/(k+1.5)
    for ε̇ ≥ 0 and k/(k+1.5) for ε̇ < 0):

    .. math::

        F_r = -\\frac{C}{(1-\\varepsilon^2)^{3/2}}
              \\Bigl[\\frac{4 \\varepsilon T}{2 + \\varepsilon^2} + \\pi \\dot\\varepsilon g\\Bigr],
        \\qquad
        F_t = \\frac{C \\pi (\\varepsilon w) g}{(2 + \\varepsilon^2)\\sqrt{1-\\varepsilon^2}},

    both multiplied by :func:`small_eccentricity_factor`. This single expression is eqs. (11)
    and (12) for ε̇ ≥ 0 and the corrected eqs. (13) and (14) for ε̇ < 0 (docs/forces.md shows
    the algebra). It never divides by ε̇ or ε, is continuous in ε̇ (also at ε̇ = 0) and its
    ε̇ → 0 limit is the half-Sommerfeld steady force (:func:`half_sommerfeld_steady`).

    Parameters
    ----------
    eps : float
        ε = |e|/c (-), 0 ≤ ε < 1 (the caller clamps).
    eps_dot : float
        ε̇ (1/s), > 0 when the journal moves away from the centre.
    eps_w : float
        ε·w (rad/s) with w = ω_S + ω_B − 2γ̇.
    mu : float
        Dynamic viscosity (Pa s).
    R_S : float
        Journal radius (m).
    L : float
        Bearing length (m).
    c : float
        Radial clearance (m).
    lam, eps0 : float
        Small-eccentricity correction (see :func:`small_eccentricity_factor`).

    Returns
    -------
    (float, float)
        (F_r, F_t) in N: force on the journal along n and along t.

    Examples
    --------
    Without squeeze (ε̇ = 0) and correction (λ = 0) it is the half-Sommerfeld steady force:

    >>> F = film_forces_eps_w(0.5, 0.0, 0.5 * 100.0, 0.01, 9.5e-3, 20e-3, 0.5e-3, 0.0, 0.1)
    >>> S = half_sommerfeld_steady(0.5, 100.0, 0.01, 9.5e-3, 20e-3, 0.5e-3)
    >>> [round(f, 12) for f in F] == [round(s, 12) for s in S]
    True
    """
    C = 6.0 * mu * R_S * R_S * R_S * L / (c * c)
    om = (1.0 - eps) * (1.0 + eps)  # 1 - ε², accurate near ε = 1
    sq = math.sqrt(om)
    T = sq * math.hypot(0.5 * eps_w, eps_dot)
    # The denominator vanishes only when ε ε̇ = 0 as well; the ratio is bounded by 2/3 in
    # magnitude and its limit there is 0, which the floor at the smallest normal number gives.
    rho = eps * eps_dot / max(T + 1.5 * eps * abs(eps_dot), _TINY)
    g = 1.0 + 1.5 * rho
    two_e2 = 2.0 + eps * eps
    f = small_eccentricity_factor(eps, lam, eps0)
    Fr = -f * C * (4.0 * eps * T / two_e2 + math.pi * eps_dot * g) / (om * sq)
    Ft = f * C * math.pi * eps_w * g / (two_e2 * sq)
    return Fr, Ft


@numba.njit(cache=True, fastmath=False)
def film_forces(eps, eps_dot, w, mu, R_S, L, c, lam, eps0):
    """Pinkus–Sternlicht long-bearing film forces with Gumbel conditions, eqs. (11)–(17).

    Eqs. (11)–(12) (approach, ε̇ ≥ 0) and the sign-corrected eqs. (13)–(14) (separation,
    ε̇ < 0), with

    .. math::

        k = \\Bigl[(1 - \\varepsilon^2)\\Bigl(\\frac{w^2}{4 \\dot\\varepsilon^2}
            + \\frac{1}{\\varepsilon^2}\\Bigr)\\Bigr]^{1/2}   \\quad (15)

    evaluated without dividing by ε̇: ε̇ k = sign(ε̇) sqrt((1 − ε²)(w²/4 + ε̇²/ε²)),
    (k+3)/(k+1.5) = 1 + 1.5/(k+1.5), k/(k+1.5) = 1 − 1.5/(k+1.5), and multiplied by the
    small-eccentricity correction (min(ε, ε0)/ε0)^λ (eqs. 16–17, made continuous at ε0).
    See :func:`film_forces_eps_w` for the closed form actually evaluated.

    Source: Pinkus & Sternlicht (1961); Flores et al. (2009); paper eqs. (11)–(17) as
    corrected in docs/reference.md. The long-bearing (infinitely long) approximation is a modelling
    choice: the paper's bearing has L/D ≈ 1.4.

    Parameters
    ----------
    eps : float
        Eccentricity ratio ε = |e|/c (-), 0 ≤ ε < 1 (the caller clamps; ε ≥ 1 is invalid).
    eps_dot : float
        ε̇ (1/s).
    w : float
        Wedge speed ω_S + ω_B − 2γ̇ (rad/s).
    mu : float
        Dynamic viscosity μ (Pa s).
    R_S : float
        Journal radius R_S (m).
    L : float
        Bearing length L (m).
    c : float
        Radial clearance c (m).
    lam : float
        Correction exponent λ (-).
    eps0 : float
        Correction threshold ε0 (-).

    Returns
    -------
    (float, float)
        (F_r, F_t) in N: film force on the journal along n = e/|e| and along t (n rotated
        +90°). The force on the journal in the global frame is F_r n + F_t t (eq. 18).

    Examples
    --------
    Pure squeeze: approach and separation differ by the full-film squeeze force, whose
    pressure is odd in ε̇ (:func:`full_film_squeeze`):

    >>> args = (0.01, 9.5e-3, 20e-3, 0.5e-3, 0.0, 0.1)   # μ (Pa s), R_S, L, c (m), λ, ε0
    >>> dF = film_forces(0.5, 10.0, 0.0, *args)[0] - film_forces(0.5, -10.0, 0.0, *args)[0]
    >>> round(dF, 12) == round(full_film_squeeze(0.5, 10.0, *args[:4]), 12)
    True
    """
    return film_forces_eps_w(eps, eps_dot, eps * w, mu, R_S, L, c, lam, eps0)


@numba.njit(cache=True, fastmath=False)
def half_sommerfeld_steady(eps, w, mu, R_S, L, c):
    """Steady (ε̇ = 0) long-bearing film forces with Gumbel (half-Sommerfeld) conditions (N).

    Derived independently from Reynolds' equation in docs/forces.md: the full-Sommerfeld
    pressure of the infinitely long bearing is integrated over its positive half only:

    .. math::

        F_r = -\\frac{12 \\mu R_S^3 L}{c^2} \\frac{\\varepsilon^2 |w|}
              {(2 + \\varepsilon^2)(1 - \\varepsilon^2)},
        \\qquad
        F_t = \\frac{6 \\pi \\mu R_S^3 L}{c^2} \\frac{\\varepsilon w}
              {(2 + \\varepsilon^2)\\sqrt{1 - \\varepsilon^2}}.

    No small-eccentricity correction is applied. Source: classical long-bearing theory
    (Sommerfeld 1904; Gumbel conditions), e.g. Pinkus & Sternlicht (1961), ch. 3.

    Parameters
    ----------
    eps : float
        ε (-), 0 ≤ ε < 1.
    w : float
        Wedge speed ω_S + ω_B − 2γ̇ (rad/s).
    mu, R_S, L, c : float
        Viscosity (Pa s), journal radius, length, radial clearance (m).

    Returns
    -------
    (float, float)
        (F_r, F_t), force on the journal along n and t.

    Examples
    --------
    A 1 cP film, R_S = 9.5 mm, L = 20 mm, c = 0.5 mm at ε = 0.5 and w = 100 rad/s:

    >>> Fr, Ft = half_sommerfeld_steady(0.5, 100.0, 0.01, 9.5e-3, 20e-3, 0.5e-3)
    >>> f"{Fr:.6f} N, {Ft:.6f} N"
    '-0.121938 N, 0.331756 N'
    """
    om = (1.0 - eps) * (1.0 + eps)
    k = mu * R_S * R_S * R_S * L / (c * c)
    Fr = -12.0 * k * eps * eps * abs(w) / ((2.0 + eps * eps) * om)
    Ft = 6.0 * math.pi * k * eps * w / ((2.0 + eps * eps) * math.sqrt(om))
    return Fr, Ft


@numba.njit(cache=True, fastmath=False)
def full_film_squeeze(eps, eps_dot, mu, R_S, L, c):
    """Radial squeeze-film force of the full (2π, Sommerfeld) long-bearing film (N).

    .. math::

        F_r = -\\frac{12 \\pi \\mu R_S^3 L}{c^2}
        \\frac{\\dot\\varepsilon}{(1 - \\varepsilon^2)^{3/2}}

    Pure squeeze (w = 0) with no cavitation; used to check the Gumbel forces, which must satisfy
    F_r(+ε̇) − F_r(−ε̇) = full_film_squeeze(ε, ε̇) because the full-film pressure is odd in ε̇.
    Source: classical long-bearing squeeze film, e.g. Pinkus & Sternlicht (1961).

    Parameters
    ----------
    eps : float
        ε (-), 0 ≤ ε < 1.
    eps_dot : float
        ε̇ (1/s), > 0 when the journal moves away from the centre.
    mu, R_S, L, c : float
        Viscosity (Pa s), journal radius, length, radial clearance (m).

    Returns
    -------
    float
        F_r (N), the force on the journal along n.

    Examples
    --------
    >>> f"{full_film_squeeze(0.5, 10.0, 0.01, 9.5e-3, 20e-3, 0.5e-3):.6f}"
    '-0.398107'
    >>> full_film_squeeze(0.5, 0.0, 0.01, 9.5e-3, 20e-3, 0.5e-3)   # no squeeze, no force
    -0.0
    """
    om = (1.0 - eps) * (1.0 + eps)
    return -12.0 * math.pi * mu * R_S * R_S * R_S * L * eps_dot / (c * c * om * math.sqrt(om))
