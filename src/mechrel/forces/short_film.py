"""Hydrodynamic film forces of a short (Ocvirk) journal bearing, rotation and squeeze.

Same conventions as :mod:`mechrel.forces.film`: ``F_r`` is the film force on the JOURNAL along
n = e/|e|, ``F_t`` along t (n rotated by +90°), ε = |e|/c, ε̇ = dε/dt and w = ω_S + ω_B − 2γ̇ the
wedge speed (rad/s), entered as the product ε·w which stays bounded at the bearing centre.

Derivation (restated in docs/forces.md, "Short bearing")
--------------------------------------------------------
θ is measured from n toward t, so the film thickness is h = c (1 − ε cos θ) (thinnest at
θ = 0). In the frame turning with the line of centres both surfaces move at R·(ω − γ̇), so
Reynolds' equation reads

    ∂/∂x(h³ ∂p/∂x) + ∂/∂z(h³ ∂p/∂z) = 6 μ R w ∂h/∂x + 12 μ ∂h/∂t,   x = R θ,

with ∂h/∂x = c ε sin θ / R and ∂h/∂t = −c ε̇ cos θ, i.e. a right-hand side −12 μ c G(θ),
G(θ) = ε̇ cos θ − (ε w / 2) sin θ. The short-bearing approximation (Ocvirk 1952) drops the
circumferential flow term (valid for L/D → 0); with p = 0 at both ends z = ±L/2,

    p = 6 μ c G(θ) (L²/4 − z²) / h³,   ∫ p dz = μ c L³ G(θ) / h³.

Half-Sommerfeld (Gümbel) cavitation keeps the positive part: the half circle where
G = A cos(θ + φ) > 0, A = hypot(ε̇, εw/2), φ = atan2(εw/2, ε̇), i.e. θ ∈ (−π/2 − φ, π/2 − φ);
this region turns with the squeeze direction exactly as the long bearing's Gümbel film of
:mod:`mechrel.forces.film`. The force on the journal is F = −R ∫ P(θ) (cos θ n + sin θ t) dθ:

    F_r = −(μ R L³ / c²) [ε̇ A_cc − (εw/2) A_sc],   F_t = −(μ R L³ / c²) [ε̇ A_sc − (εw/2) A_ss],

A_cc, A_sc, A_ss the integrals of cos²θ, sin θ cos θ, sin²θ times (1 − ε cos θ)^−3 over the
region. With the Sommerfeld substitution 1 − ε cos θ = β²/(1 + ε cos ψ), β = sqrt(1 − ε²),
they become integrals of trigonometric polynomials with closed forms:

    A_cc = ∫(cos ψ + ε)² dψ / β⁵,   A_sc = ∫ sin ψ (cos ψ + ε) dψ / β⁴,   A_ss = ∫ sin²ψ dψ / β³,

over the image (ψ_a, ψ_b) of the region, ψ = atan2(β sin θ, cos θ − ε). The integrands are
trigonometric polynomials, integrated by a 12-point Gauss–Legendre rule (error < 1e-11; their
closed forms, differences of O(1) primitives, lose all accuracy on the thick-film side as
ε → 1, where the integral is O(β⁴) before the division by β⁵). Nothing divides by ε or ε̇; the
only singularity is the physical one, β → 0 as ε → 1.

Steady rotation (ε̇ = 0) gives Ocvirk's classical result F_r = −μ R L³ ε² w / (c² (1 − ε²)²),
F_t = π μ R L³ ε w / (4 c² (1 − ε²)^{3/2}) (Hamrock, Schmid & Jacobson
2004, ch. 10).

Sources
-------
- Ocvirk, F.W. (1952), "Short-bearing approximation for full journal bearings", NACA TN 2808.
- Hamrock, B.J., Schmid, S.R. & Jacobson, B.O. (2004), Fundamentals of Fluid Film Lubrication,
  2nd ed., Marcel Dekker, ch. 10 (short-bearing theory) and ch. 17 (dynamically loaded
  bearings).
- Sommerfeld, A. (1904) substitution, as in Pinkus & Sternlicht (1961), ch. 3.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mechrel.forces.film import small_eccentricity_factor

__all__ = ["short_film_forces", "ocvirk_steady"]

_TWO_PI = 2.0 * math.pi
_SUBNORMAL = 5e-324  # smallest positive float64


_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)
_GL_HALF = _GL_X.size // 2  # nodes _GL_HALF.. are the positive ones (ascending order)
"""12-point Gauss–Legendre nodes and weights on [−1, 1]. The ψ-integrands are trigonometric
polynomials of degree 2 on an arc of length ≤ 2π: the rule's error is below 1e-11 relative
(entire integrand, Bernstein ellipse ρ = 8: e^{π(ρ − 1/ρ)} ρ^{−24} ≈ 1e-11)."""


@numba.njit(cache=True, fastmath=False)
def _region_integrals(psi_a, psi_b, eps):
    """∫(cos ψ + ε)², ∫sin ψ (cos ψ + ε), ∫sin²ψ over (ψ_a, ψ_b) by Gauss–Legendre.

    The closed forms (ψ/2 + sin 2ψ/4 + 2ε sin ψ + ε²ψ, ...) are differences of O(1)
    primitives; on an arc of the thick film (ψ near ±π, ε → 1) the integral is O(β⁴) small and
    the difference would lose everything once divided by β⁵. The quadrature sums the
    (non-negative, for the first and last) integrand directly and keeps full relative accuracy.
    """
    m = 0.5 * (psi_a + psi_b)
    h = 0.5 * (psi_b - psi_a)
    cm = math.cos(m)
    sm = math.sin(m)
    I_cc = 0.0
    I_sc = 0.0
    I_ss = 0.0
    # the nodes come in pairs ±x: ψ = m ± h x shares cos(h x) and sin(h x)
    for k in range(_GL_HALF, _GL_X.size):
        cx = math.cos(h * _GL_X[k])
        sx = math.sin(h * _GL_X[k])
        wk = _GL_W[k]
        for sgn in (1.0, -1.0):
            s = sm * cx + sgn * cm * sx
            ce = cm * cx - sgn * sm * sx + eps
            I_cc += wk * ce * ce
            I_sc += wk * s * ce
            I_ss += wk * s * s
    return h * I_cc, h * I_sc, h * I_ss


@numba.njit(cache=True, fastmath=False)
def short_film_forces(eps, eps_dot, eps_w, mu, R_S, L, c, lam, eps0):
    """Short-bearing (Ocvirk) film forces with half-Sommerfeld cavitation, rotation + squeeze.

    See the module docstring for the derivation; the result is multiplied by the same
    small-eccentricity factor as the long bearing
    (:func:`mechrel.forces.film.small_eccentricity_factor`) so that the force is continuous at
    the bearing centre.

    Parameters
    ----------
    eps : float
        ε = |e|/c (-), 0 ≤ ε < 1 (the caller caps it).
    eps_dot : float
        ε̇ (1/s), > 0 when the journal moves away from the centre.
    eps_w : float
        ε·w (rad/s), w = ω_S + ω_B − 2γ̇.
    mu : float
        Dynamic viscosity (Pa s).
    R_S : float
        Journal radius (m).
    L : float
        Bearing length (m).
    c : float
        Radial clearance (m).
    lam, eps0 : float
        Small-eccentricity correction (see :func:`mechrel.forces.film.small_eccentricity_factor`).

    Returns
    -------
    (float, float)
        (F_r, F_t) in N: force on the journal along n and along t.

    Examples
    --------
    Without squeeze and correction it is Ocvirk's steady force (:func:`ocvirk_steady`):

    >>> F = short_film_forces(0.5, 0.0, 0.5 * 100.0, 0.01, 9.5e-3, 20e-3, 0.5e-3, 0.0, 0.1)
    >>> S = ocvirk_steady(0.5, 100.0, 0.01, 9.5e-3, 20e-3, 0.5e-3)
    >>> [round(f, 12) for f in F] == [round(s, 12) for s in S]
    True
    """
    a = 0.5 * eps_w          # ε w / 2
    # start of the region θ_a = −π/2 − φ with cos φ = ε̇/A, sin φ = a/A, A = hypot(ε̇, a):
    # cos θ_a = −a/A, sin θ_a = −ε̇/A, exact on the axes (no rounding of π). Both are scaled
    # by m = max(|a|, |ε̇|) first, so that subnormal rates keep full precision; then the hypot
    # is ≥ 1 unless ε̇ = a = 0, where the force is 0 anyway (it is linear in ε̇ and a) and the
    # floor 1 gives cos θ_a = sin θ_a = 0 instead of 0/0.
    m = max(max(abs(a), abs(eps_dot)), _SUBNORMAL)
    am = a / m
    em = eps_dot / m
    A = max(math.hypot(am, em), 1.0)
    ca = -am / A
    sa = -em / A
    om = (1.0 - eps) * (1.0 + eps)
    beta = math.sqrt(om)
    psi_a = math.atan2(beta * sa, ca - eps)
    # θ_b = θ_a + π: cos θ_b = −cos θ_a, sin θ_b = −sin θ_a
    psi_b = math.atan2(-beta * sa, -ca - eps)
    d = psi_b - psi_a
    if d <= 0.0:
        d += _TWO_PI
    psi_b = psi_a + d
    I_cc, I_sc, I_ss = _region_integrals(psi_a, psi_b, eps)
    b2 = om
    b3 = b2 * beta
    A_cc = I_cc / (b3 * b2)
    A_sc = I_sc / (b2 * b2)
    A_ss = I_ss / b3
    k = small_eccentricity_factor(eps, lam, eps0) * mu * R_S * L * L * L / (c * c)
    Fr = -k * (eps_dot * A_cc - a * A_sc)
    Ft = -k * (eps_dot * A_sc - a * A_ss)
    return Fr, Ft


@numba.njit(cache=True, fastmath=False)
def ocvirk_steady(eps, w, mu, R_S, L, c):
    """Ocvirk's steady (ε̇ = 0) short-bearing forces, half-Sommerfeld (N).

    .. math::

        F_r = -\\frac{\\mu R_S L^3}{c^2} \\frac{\\varepsilon^2 |w|}{(1-\\varepsilon^2)^2},
        \\qquad
        F_t = \\frac{\\pi \\mu R_S L^3}{4 c^2} \\frac{\\varepsilon w}{(1-\\varepsilon^2)^{3/2}}.

    No small-eccentricity correction. Source: Ocvirk (1952); Hamrock, Schmid & Jacobson
    (2004), ch. 10, with the surface speed U = R w.

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
        (F_r, F_t) in N: force on the journal along n and along t.

    Examples
    --------
    A 1 cP film, R_S = 9.5 mm, L = 20 mm, c = 0.5 mm at ε = 0.5 and w = 100 rad/s:

    >>> Fr, Ft = ocvirk_steady(0.5, 100.0, 0.01, 9.5e-3, 20e-3, 0.5e-3)
    >>> f"{Fr:.6f} N, {Ft:.6f} N"
    '-0.135111 N, 0.183798 N'
    """
    om = (1.0 - eps) * (1.0 + eps)
    k = mu * R_S * L * L * L / (c * c)
    return -k * eps * eps * abs(w) / (om * om), 0.25 * math.pi * k * eps * w / (om * math.sqrt(om))
