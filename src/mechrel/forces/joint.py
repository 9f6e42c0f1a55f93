"""The revolute clearance-joint element: dry, lubricated and transition force laws.

Geometry and sign conventions
-----------------------------
e = r_S − r_B (journal centre minus bearing centre, m), n = e/|e|, t = n rotated by +90°
(t = (−n_y, n_x)), δ = |e| − c (penetration, contact while δ > 0), δ̇ = v·n with v = de/dt,
γ̇ = (v·t)/|e|, ε = |e|/c, ε̇ = δ̇/c. The slip velocity of the journal's contact point relative
to the bearing's is v_T = v·t + ω_S R_S − ω_B R_B.

The returned force (Fx, Fy) acts on the JOURNAL at the journal centre; the bearing body gets
(−Fx, −Fy) at the bearing centre. M_S is the moment on the journal body about the journal
centre (R_S F_T), M_B the moment on the bearing body about the bearing centre (−R_B F_T).
Dry: F = −F_N n + F_T t (the normal force pushes the journal back toward the bearing centre;
friction opposes the slip). Lubricated: F = F_r n + F_t t (eq. 18; F_r < 0 when ε̇ > 0: the
squeeze film resists the approach). The film's viscous shear torques (:func:`film_shear_torques`)
are applied only when p[P_SHEAR] is set (lubricant.shear_torque; off by default, as in the
paper).

Power of the joint on the mechanism: P = F·v + M_S ω_S + M_B ω_B (the caller integrates it).
For a dry joint, P + dE_el/dt = −(F_N − K δ^n) δ̇ + F_T v_T ≤ 0 (dissipation).

Sources
-------
Chen, Wang & Gao (2022), eqs. (1)–(19) as corrected in docs/reference.md;
Lankarani & Nikravesh (1990/1994); Ambrósio (2002); Pinkus & Sternlicht (1961);
Flores et al. (2009, transition model).
"""

from __future__ import annotations

import math

import numba

from mechrel.forces.contact import ln_normal_force
from mechrel.forces.film import film_forces_eps_w
from mechrel.forces.finite_film import finite_film_forces
from mechrel.forces.friction import friction_force
from mechrel.forces.short_film import short_film_forces
from mechrel.forces.params import (
    BEARING_LONG, BEARING_SHORT, MODEL_DRY, MODEL_LUBRICATED, MODEL_TRANSITION, P_BEARING, P_C,
    P_CAVITATION, P_SHEAR, P_CE, P_CF, P_E1, P_EPS0, P_EPSMAX,
    P_FLOOR, P_K, P_L, P_LAMBDA, P_MODEL, P_MU, P_N, P_RB, P_RS, P_V0, P_V1,
)

__all__ = ["clearance_force", "transition_weight", "transition_energy", "film_shear_torques"]

_TINY = 2.2250738585072014e-308  # smallest normal float64
EPS_GUARD = 1.0 - 1e-9
"""Numerical cap of ε in the lubricated model's film (-): not a modelling clamp (see
:func:`clearance_force`); at ε = 1 − 1e-9 the squeeze factor (1 − ε²)^−1.5 is ~1e13."""


@numba.njit(cache=True, fastmath=False)
def transition_weight(delta, e1):
    """Weight s of the dry force in the transition model, eq. (19) (-).

    s = clip((|e| − c)/e1, 0, 1) = clip(δ/e1, 0, 1); the force is s F_Dry + (1 − s) F_Lub, which
    is F_Lub for |e| < c, F_Dry for |e| > c + e1 and the paper's linear blend between.
    Source: Flores et al. (2009); paper eq. (19).

    Parameters
    ----------
    delta : float
        Penetration δ = |e| − c (m); negative inside the clearance.
    e1 : float
        Width of the transition band (m), > 0.

    Returns
    -------
    float
        s = clip(δ/e1, 0, 1) (-).

    Examples
    --------
    >>> transition_weight(-1e-4, 1e-5), transition_weight(5e-6, 1e-5), transition_weight(1e-4, 1e-5)
    (0.0, 0.5, 1.0)
    """
    return min(1.0, max(0.0, delta / e1))


@numba.njit(cache=True, fastmath=False)
def transition_energy(delta, K, n, e1):
    """Potential energy (J) of the blended elastic force s(δ) K δ^n of the transition model.

    U(δ) = ∫_0^δ s(x) K x^n dx = K δ^(n+2) / ((n+2) e1) for 0 < δ ≤ e1 and
    K e1^(n+1)/(n+2) + K (δ^(n+1) − e1^(n+1))/(n+1) beyond; 0 for δ ≤ 0.

    Parameters
    ----------
    delta : float
        Penetration δ = |e| − c (m).
    K : float
        Contact stiffness (N/m^n).
    n : float
        Contact force exponent (-).
    e1 : float
        Width of the transition band (m), > 0.

    Returns
    -------
    float
        U(δ) (J).

    Examples
    --------
    At the end of the band, δ = e1, U = K e1^(n+1)/(n+2):

    >>> f"{transition_energy(1e-5, 1e10, 1.5, 1e-5):.6e}"
    '9.035079e-04'
    >>> transition_energy(-1e-5, 1e10, 1.5, 1e-5)
    0.0
    """
    if not delta > 0.0:
        return 0.0
    if delta <= e1:
        return K * delta ** (n + 2.0) / ((n + 2.0) * e1)
    return K * e1 ** (n + 1.0) / (n + 2.0) + K * (delta ** (n + 1.0) - e1 ** (n + 1.0)) / (n + 1.0)


@numba.njit(cache=True, fastmath=False)
def film_shear_torques(eps, F_t, omega_S, omega_B, mu, R_S, L, c):
    r"""Viscous shear torques of the film on the journal and on the bearing (N m).

    With θ from n and h = c(1 − ε cos θ), the shear stress on the journal surface is
    μ(U_S − U_B)/h + (h/2)∂p/∂x and on the bearing surface μ(U_S − U_B)/h − (h/2)∂p/∂x
    (Couette plus Poiseuille parts; U the surface speeds, x = Rθ). Integrated over the
    circumference, with the shear acting over the full film (Petroff's assumption: the
    cavitated region still transmits shear), and integrating the pressure part by parts
    (∫h ∂p/∂θ dθ = −∫p ∂h/∂θ dθ, ∂h/∂θ = cε sin θ):

    .. math::

        T_S = -\frac{2\pi\mu R^3 L (\omega_S - \omega_B)}{c\sqrt{1-\varepsilon^2}}
              - \frac{e}{2} F_t,
        \qquad
        T_B = +\frac{2\pi\mu R^3 L (\omega_S - \omega_B)}{c\sqrt{1-\varepsilon^2}}
              - \frac{e}{2} F_t,

    e = εc and F_t the film's tangential force on the journal. They satisfy the moment balance
    T_S + T_B + e F_t = 0 of the fluid ring (the film force on the journal acts at the journal
    centre, its reaction at the bearing centre). With them the film's power on the mechanism,
    F·v + T_S ω_S + T_B ω_B = c (F_r ε̇ − F_t εw/2) − T_c (ω_S − ω_B), is the sum of the
    pressure film's dissipation (≤ 0) and the Couette dissipation −T_c(ω_S − ω_B) ≤ 0, and it
    vanishes for a rigid rotation of the whole joint. At ε = 0 this is Petroff's law.
    Source: Hamrock, Schmid & Jacobson (2004), ch. 8 and 10 (friction torque of journal
    bearings); Pinkus & Sternlicht (1961), ch. 3.

    Parameters
    ----------
    eps : float
        ε = |e|/c (-), 0 ≤ ε < 1.
    F_t : float
        Tangential film force on the journal (N).
    omega_S, omega_B : float
        Absolute angular velocities of the journal body and of the bearing body (rad/s).
    mu : float
        Dynamic viscosity (Pa s).
    R_S : float
        Journal radius (m).
    L : float
        Bearing length (m).
    c : float
        Radial clearance (m).

    Returns
    -------
    (float, float)
        (T_S, T_B): torque on the journal body about its centre, on the bearing body about its
        centre (N m).

    Examples
    --------
    A centred journal (ε = 0, F_t = 0) turning at 10 rad/s: Petroff's torque
    2π μ R³ L ω / c, opposing the rotation:

    >>> T_S, T_B = film_shear_torques(0.0, 0.0, 10.0, 0.0, 0.01, 9.5e-3, 20e-3, 0.5e-3)
    >>> f"{T_S:.6e} N m", T_S == -T_B
    ('-2.154818e-05 N m', True)
    """
    om = (1.0 - eps) * (1.0 + eps)
    Tc = 2.0 * math.pi * mu * R_S * R_S * R_S * L * (omega_S - omega_B) / (c * math.sqrt(om))
    half = 0.5 * eps * c * F_t
    return -Tc - half, Tc - half


@numba.njit(cache=True, fastmath=False)
def clearance_force(ex, ey, vx, vy, omega_B, omega_S, impact_speed, p):
    """Force and moments of a revolute clearance joint on its two bodies.

    Parameters
    ----------
    ex, ey : float
        e = r_S − r_B, journal centre minus bearing centre (m).
    vx, vy : float
        v = de/dt (m/s).
    omega_B, omega_S : float
        Absolute angular velocities of the bearing body and of the journal body (rad/s).
    impact_speed : float
        Captured approach speed δ̇⁻ of the current impact (m/s), 0 if none is captured yet; then
        max(δ̇, p[P_FLOOR]) is used (the value the caller captures at the located onset). A
        captured value is floored by p[P_FLOOR] too.
    p : numpy.ndarray
        Parameter vector from :func:`mechrel.forces.params.pack_params`.

    Returns
    -------
    (Fx, Fy, M_S, M_B, E_el) : tuple of float
        Force on the journal at the journal centre (N; the bearing gets −F at its centre),
        moment on the journal body about its centre (N m; R_S F_T), moment on the bearing body
        about its centre (N m; −R_B F_T), and the elastic contact energy stored (J):
        K δ^(n+1)/(n+1) for the dry model, the potential of s(δ) K δ^n for the transition
        model (:func:`transition_energy`), 0 for the lubricated model.

    Notes
    -----
    - Dry (MODEL_DRY): F = −F_N n + F_T t while δ > 0, else 0. Friction is not evaluated when
      p[P_CF] == 0. No film code runs.
    - Lubricated (MODEL_LUBRICATED): F = F_r n + F_t t from the film model p[P_BEARING]
      (:func:`mechrel.forces.film.film_forces_eps_w` for the long bearing,
      :func:`mechrel.forces.short_film.short_film_forces` for the short one,
      :func:`mechrel.forces.finite_film.finite_film_forces` for the finite one) at the actual ε.
      The model has no contact: the divergence of the film force as ε → 1 (squeeze term
      ∝ ε̇/(1 − ε²)^1.5, whose impulse
      ∫ dε/(1 − ε²)^1.5 is unbounded) is the only thing that keeps the journal inside the
      bearing, so the film must not be clamped at a ε_max < 1 (a clamp at 0.99 let a 1 cP
      slider-crank journal reach ε ≈ 13, and the 0.7 mm nine-bar reach ε = 1.0005).
      ε is only capped at :data:`EPS_GUARD` = 1 − 1e-9 so that trial states at ε ≥ 1 (an
      integrator stage stepping past the singularity) give a finite, very large force that the
      error control rejects. p[P_EPSMAX] is not used by this model.
      A journal pushed to h_min = c(1 − ε) of nanometres is in contact physically: use the
      transition model for such loads.
    - Transition (MODEL_TRANSITION): s F_Dry + (1 − s) F_Lub with s = clip(δ/e1, 0, 1)
      (eq. 19), film at min(ε, ε_max). Continuous in e.
    - At e = 0 exactly, n is undefined: the code uses n = e / max(|e|, 2.2e-308) = 0, so every
      directional quantity (δ̇, γ̇|e|, F) is 0 there, which is the limit of the force for λ > 0
      (the film force vanishes like (ε/ε0)^λ at the centre; δ < 0 so no contact force).

    Examples
    --------
    A dry joint (c = 0.5 mm) with the journal at rest 1 μm into the wall: the Hertzian force
    K δ^1.5 pushes it back towards the centre (−x), and the spring stores K δ^2.5/2.5:

    >>> from mechrel.forces.params import pack_params
    >>> p = pack_params(model="dry", clearance=0.5e-3, bearing_radius=15e-3, length=20e-3,
    ...                 stiffness=9.9536e10, restitution=0.9)
    >>> Fx, Fy, M_S, M_B, E = clearance_force(0.5e-3 + 1e-6, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, p)
    >>> round(Fx, 6), Fy, f"{E:.5e} J"
    (-99.536, 0.0, '3.98144e-05 J')
    """
    model = int(p[P_MODEL])
    c = p[P_C]
    R_S = p[P_RS]
    R_B = p[P_RB]

    r = math.hypot(ex, ey)
    rs = max(r, _TINY)
    nx = ex / rs
    ny = ey / rs
    tx = -ny
    ty = nx
    vn = vx * nx + vy * ny   # δ̇
    vt = vx * tx + vy * ty   # |e| γ̇
    delta = r - c

    if model == MODEL_DRY:
        s_dry = 1.0
        s_film = 0.0
    elif model == MODEL_LUBRICATED:
        s_dry = 0.0
        s_film = 1.0
    elif model == MODEL_TRANSITION:
        s_dry = transition_weight(delta, p[P_E1])
        s_film = 1.0 - s_dry
    else:
        raise ValueError("clearance_force: unknown model code in p[P_MODEL]")

    Fx = 0.0
    Fy = 0.0
    M_S = 0.0
    M_B = 0.0
    E_el = 0.0

    if s_dry > 0.0 and delta > 0.0:
        K = p[P_K]
        n = p[P_N]
        floor = p[P_FLOOR]
        if impact_speed > 0.0:
            v_imp = max(impact_speed, floor)
        else:
            v_imp = max(vn, floor)
        F_N = ln_normal_force(delta, vn, v_imp, K, n, p[P_CE])
        F_T = 0.0
        if p[P_CF] > 0.0:
            slip = vt + omega_S * R_S - omega_B * R_B
            F_T = friction_force(F_N, slip, p[P_CF], p[P_V0], p[P_V1])
        Fx += s_dry * (-F_N * nx + F_T * tx)
        Fy += s_dry * (-F_N * ny + F_T * ty)
        M_S += s_dry * R_S * F_T
        M_B -= s_dry * R_B * F_T
        if model == MODEL_DRY:
            E_el = K * delta ** (n + 1.0) / (n + 1.0)
        else:
            E_el = transition_energy(delta, K, n, p[P_E1])

    if s_film > 0.0:
        eps = r / c
        eps_max = p[P_EPSMAX] if model == MODEL_TRANSITION else EPS_GUARD
        eps_e = min(eps, eps_max)
        # ε·w = (|e|(ω_S + ω_B) − 2 v·t)/c stays bounded at e = 0; scale it to the clamped ε.
        eps_w = (r * (omega_S + omega_B) - 2.0 * vt) / c
        eps_w_e = eps_w * (eps_max / max(eps, eps_max))
        if p[P_BEARING] == BEARING_LONG:
            F_r, F_t = film_forces_eps_w(eps_e, vn / c, eps_w_e, p[P_MU], R_S, p[P_L], c,
                                         p[P_LAMBDA], p[P_EPS0])
        elif p[P_BEARING] == BEARING_SHORT:
            F_r, F_t = short_film_forces(eps_e, vn / c, eps_w_e, p[P_MU], R_S, p[P_L], c,
                                         p[P_LAMBDA], p[P_EPS0])
        else:  # BEARING_FINITE (pack_params admits no other code)
            F_r, F_t = finite_film_forces(eps_e, vn / c, eps_w_e, p[P_MU], R_S, p[P_L], c,
                                          p[P_LAMBDA], p[P_EPS0], p[P_CAVITATION] != 0.0)
        Fx += s_film * (F_r * nx + F_t * tx)
        Fy += s_film * (F_r * ny + F_t * ty)
        if p[P_SHEAR] != 0.0:
            T_S, T_B = film_shear_torques(eps_e, F_t, omega_S, omega_B, p[P_MU], R_S,
                                          p[P_L], c)
            M_S += s_film * T_S
            M_B += s_film * T_B

    return Fx, Fy, M_S, M_B, E_el
