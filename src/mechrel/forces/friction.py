"""Modified Coulomb friction with Ambrósio's dynamic correction coefficient c_d.

Sources
-------
- Chen, Wang & Gao (2022), Arch. Appl. Mech., eqs. (7)–(8) (c_N there, c_d here).
- Ambrósio, J.A.C. (2002), "Impact of rigid and flexible multibody systems: deformation
  description and contact models", in Virtual Nonlinear Multibody Systems, NATO ASI II/103,
  Kluwer, 15–33 (the dynamic correction coefficient).
"""

from __future__ import annotations

import math

import numba

__all__ = ["dynamic_correction", "friction_force"]


@numba.njit(cache=True, fastmath=False)
def dynamic_correction(v_abs, v0, v1):
    """Ambrósio's dynamic correction coefficient c_d (-), paper eq. (8).

    .. math::

        c_d = \\begin{cases} 0 & |v_T| < v_0 \\\\
        \\dfrac{|v_T| - v_0}{v_1 - v_0} & v_0 \\le |v_T| \\le v_1 \\\\
        1 & |v_T| > v_1 \\end{cases}

    Continuous (0 at v0, exactly 1 at v1). Source: Ambrósio (2002).

    Parameters
    ----------
    v_abs : float
        Magnitude of the relative tangential (slip) velocity |v_T| (m/s), ≥ 0.
    v0, v1 : float
        Dead-band and full-friction speeds (m/s), 0 ≤ v0 < v1.

    Returns
    -------
    float
        c_d in [0, 1].

    Examples
    --------
    v0 = 0.1 mm/s, v1 = 10 mm/s (mechrel's defaults):

    >>> dynamic_correction(0.5e-4, 1e-4, 1e-2)   # below v0: no friction
    0.0
    >>> round(dynamic_correction(5.05e-3, 1e-4, 1e-2), 12)   # half-way between v0 and v1
    0.5
    >>> dynamic_correction(1.0, 1e-4, 1e-2)
    1.0
    """
    if v_abs < v0:
        return 0.0
    if v_abs > v1:
        return 1.0
    return (v_abs - v0) / (v1 - v0)


@numba.njit(cache=True, fastmath=False)
def friction_force(F_N, v_t, c_f, v0, v1):
    """Tangential friction force F_T (N), paper eq. (7): F_T = −c_f c_d F_N v_T/|v_T|.

    Written as ``-c_f * F_N * copysign(c_d(|v_T|), v_T)``: no division by |v_T|, finite for
    every v_T, and exactly zero (±0.0) for |v_T| < v0, in particular at v_T = ±0. The force
    opposes the slip: sign(F_T) = −sign(v_T) whenever c_d F_N > 0, and |F_T| ≤ c_f F_N.

    Source: Ambrósio (2002), modified Coulomb law; paper eqs. (7)–(8).

    Parameters
    ----------
    F_N : float
        Normal force magnitude (N), ≥ 0.
    v_t : float
        Relative tangential velocity of the journal's contact point with respect to the
        bearing's, along t = n rotated by +90° (m/s).
    c_f : float
        Friction coefficient (-).
    v0, v1 : float
        Speeds of :func:`dynamic_correction` (m/s).

    Returns
    -------
    float
        F_T (N), component along t of the friction force on the journal.

    Examples
    --------
    F_N = 100 N, c_f = 0.05, sliding at ±0.5 m/s (above v1): the force opposes the slip.

    >>> friction_force(100.0, 0.5, 0.05, 1e-4, 1e-2)
    -5.0
    >>> friction_force(100.0, -0.5, 0.05, 1e-4, 1e-2)
    5.0
    >>> friction_force(100.0, 0.0, 0.05, 1e-4, 1e-2)   # no slip: exactly zero, no 0/0
    -0.0
    """
    return -c_f * F_N * math.copysign(dynamic_correction(abs(v_t), v0, v1), v_t)
