"""Dry contact of a journal in its bearing: stiffness and the Lankarani–Nikravesh normal force.

Sources
-------
- Chen, Wang & Gao (2022), Arch. Appl. Mech., eqs. (4)–(6), with the corrections of
  ``docs/reference.md``: c_e (not c_r) in eq. (5), and the conformal radius
  combination R_B R_S / (R_B − R_S) in eq. (6).
- Lankarani, H.M. & Nikravesh, P.E. (1990), "A contact force model with hysteresis damping for
  impact analysis of multibody systems", J. Mech. Des. 112, 369–376; and (1994), "Continuous
  contact force models for impact analysis in multibody systems", Nonlinear Dyn. 5, 193–207.
- Flores, P., Ambrósio, J., Claro, J.C.P. & Lankarani, H.M. (2004/2006), clearance-joint papers
  (e.g. "Dynamic behaviour of planar rigid multi-body systems including revolute joints with
  clearance", Proc. IMechE K 221 (2007); "Kinematics and dynamics of multibody systems with
  imperfect joints", Springer 2008) for the conformal journal–bearing stiffness.
"""

from __future__ import annotations

import math

import numba

from mechrel.errors import SceneError
from mechrel.forces.params import _real  # the one finite-number check of parameters

__all__ = ["contact_stiffness", "ln_normal_force", "contact_energy"]


def contact_stiffness(R_B, R_S, E_B, nu_B, E_S, nu_S, conformal=True):
    """Contact stiffness K (N/m^1.5) of a journal (pin) in a bearing (hole), eq. (6).

    .. math::

        K = \\frac{4}{3(\\sigma_B + \\sigma_S)} \\sqrt{R^*}, \\qquad
        \\sigma_k = \\frac{1 - \\nu_k^2}{E_k},

    with :math:`R^* = R_B R_S / (R_B - R_S)` for ``conformal=True`` (journal inside a bearing,
    internal contact; Flores et al. 2004/2006 after Lankarani & Nikravesh 1990) or
    :math:`R^* = R_B R_S / (R_B + R_S)` for ``conformal=False`` (the formula as printed in the
    paper, which is the one for two convex cylinders). For the paper's joint (R_B = 15 mm,
    c = 0.5 mm) the two differ by
    :math:`\\sqrt{(R_B + R_S)/(R_B - R_S)} = \\sqrt{59} \\approx 7.68`.

    Parameters
    ----------
    R_B, R_S : float
        Bearing and journal radii (m), R_B > R_S > 0.
    E_B, E_S : float
        Young's moduli (Pa), > 0.
    nu_B, nu_S : float
        Poisson's ratios (-), in (-1, 0.5) (the scene's rule for ``poisson_bearing`` and
        ``poisson_journal``).
    conformal : bool, default True
        Conformal (difference of radii, default) or the paper's literal sum of radii.

    Returns
    -------
    float
        K in N/m^1.5.

    Raises
    ------
    mechrel.errors.SceneError
        An argument is outside its range (the message names it).

    Examples
    --------
    The paper's joint (bearing radius 15 mm, clearance 0.5 mm, steel on steel):

    >>> K = contact_stiffness(15e-3, 14.5e-3, 206e9, 0.3, 206e9, 0.3)
    >>> f"{K:.4e}"
    '9.9536e+10'
    >>> K_printed = contact_stiffness(15e-3, 14.5e-3, 206e9, 0.3, 206e9, 0.3, conformal=False)
    >>> round((K / K_printed) ** 2, 9)   # (R_B + R_S) / (R_B - R_S)
    59.0
    >>> contact_stiffness(15e-3, 15e-3, 206e9, 0.3, 206e9, 0.3)
    Traceback (most recent call last):
    ...
    mechrel.errors.SceneError: R_B = 0.015 is invalid: allowed > R_S = 0.015 (m)
    """
    R_B, R_S, E_B, nu_B, E_S, nu_S = (_real(name, v) for name, v in (
        ("R_B", R_B), ("R_S", R_S), ("E_B", E_B), ("nu_B", nu_B), ("E_S", E_S), ("nu_S", nu_S)))
    if not R_S > 0.0:
        raise SceneError(f"R_S = {R_S!r} is invalid: allowed > 0 (m)", path="R_S")
    if not R_B > R_S:
        raise SceneError(f"R_B = {R_B!r} is invalid: allowed > R_S = {R_S!r} (m)", path="R_B")
    for name, E in (("E_B", E_B), ("E_S", E_S)):
        if not E > 0.0:
            raise SceneError(f"{name} = {E!r} is invalid: allowed > 0 (Pa)", path=name)
    for name, nu in (("nu_B", nu_B), ("nu_S", nu_S)):
        if not -1.0 < nu < 0.5:
            raise SceneError(f"{name} = {nu!r} is invalid: allowed in (-1, 0.5)", path=name)
    sigma = (1.0 - nu_B * nu_B) / E_B + (1.0 - nu_S * nu_S) / E_S
    if conformal:
        r_star = R_B * R_S / (R_B - R_S)
    else:
        r_star = R_B * R_S / (R_B + R_S)
    return 4.0 / (3.0 * sigma) * math.sqrt(r_star)


@numba.njit(cache=True, fastmath=False)
def ln_normal_force(delta, delta_dot, impact_speed, K, n, c_e):
    """Lankarani–Nikravesh normal contact force F_N ≥ 0 (N), paper eq. (5) corrected.

    .. math::

        F_N = \\max\\Bigl(0,\\; K \\delta^n \\Bigl[1 + \\frac{3(1 - c_e^2)}{4}
        \\frac{\\dot\\delta}{\\dot\\delta^-}\\Bigr]\\Bigr) \\text{ for } \\delta > 0,
        \\qquad F_N = 0 \\text{ for } \\delta \\le 0.

    Source: Lankarani & Nikravesh (1990, 1994); paper eq. (5) with c_e in place of the
    misprinted c_r. The hysteresis factor 3(1 − c_e²)/4 is derived to first order in the
    dissipation, so the law's effective restitution equals c_e only for c_e near 1 (measured:
    c_e = 0.9 gives 0.913; see docs/forces.md). The ``max(0, ·)`` keeps the law from pulling
    at the end of the restitution phase.

    Parameters
    ----------
    delta : float
        Penetration δ = |e| − c (m); contact only while δ > 0.
    delta_dot : float
        Penetration rate δ̇ (m/s), > 0 while approaching.
    impact_speed : float
        Approach speed δ̇⁻ (m/s) captured at the start of the current impact, already floored
        by the caller (must be > 0 when δ > 0).
    K : float
        Contact stiffness (N/m^n).
    n : float
        Force exponent (-), 1.5 in the paper.
    c_e : float
        Coefficient of restitution (-), in (0, 1].

    Returns
    -------
    float
        F_N (N), ≥ 0; the force on the journal is −F_N along n = e/|e|.

    Examples
    --------
    1 µm penetration, K = 1e10 N/m^1.5, impact speed 0.1 m/s, c_e = 0.9:

    >>> round(ln_normal_force(1e-6, 0.0, 0.1, 1e10, 1.5, 0.9), 9)   # at rest: Hertz K δ^1.5
    10.0
    >>> round(ln_normal_force(1e-6, 0.1, 0.1, 1e10, 1.5, 0.9), 9)   # approach: 1 + 0.75(1 − 0.81)
    11.425
    >>> ln_normal_force(1e-6, -1.0, 0.1, 1e10, 1.5, 0.9)   # fast separation: never pulls
    0.0
    >>> ln_normal_force(-1e-6, 0.1, 0.1, 1e10, 1.5, 0.9)   # no penetration
    0.0
    """
    if not delta > 0.0:
        return 0.0
    f = K * delta**n * (1.0 + 0.75 * (1.0 - c_e * c_e) * delta_dot / impact_speed)
    return max(0.0, f)


@numba.njit(cache=True, fastmath=False)
def contact_energy(delta, K, n):
    """Elastic energy stored in the Hertzian spring, K δ^(n+1)/(n+1) for δ > 0, else 0 (J).

    Source: the conservative part of the Lankarani–Nikravesh law, F = K δ^n (Hertz).

    Parameters
    ----------
    delta : float
        Penetration δ (m); no energy for δ ≤ 0.
    K : float
        Contact stiffness (N/m^n).
    n : float
        Contact force exponent (-).

    Returns
    -------
    float
        Stored energy (J).

    Examples
    --------
    >>> round(contact_energy(1e-6, 1e10, 1.5), 15)   # 1e10 · (1e-6)^2.5 / 2.5
    4e-06
    >>> contact_energy(0.0, 1e10, 1.5)
    0.0
    """
    if not delta > 0.0:
        return 0.0
    return K * delta ** (n + 1.0) / (n + 1.0)
