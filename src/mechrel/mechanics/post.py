"""Quantities of stored states for results: constraint violation, energies, eccentricities.

Owns what a result reports about the states an integration returned, outside the kernels:
:func:`constraint_violation` of one state, :func:`mechanical_energy` (kinetic
``½ q̇ᵀ M q̇`` and gravitational ``−Σ m g·r``) and :func:`post_process` (per output instant, the
clearance joints' eccentricities and the kinetic, gravitational and elastic contact energies,
in one compiled call). All ``@njit(cache=True)``.

Source: the kinetic energy with the diagonal mass matrix and the potential of uniform gravity
of planar rigid bodies, and the energy balance they enter, docs/mechanics.md; the elastic
contact energy is the force law's (docs/forces.md).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .applied import applied_forces
from .constraints import constraint_terms, violation_from
from .dynamics import make_workspace
from .joints import body_trig, joint_state, n_contacts


@njit(cache=True)
def constraint_violation(t, y, sys):
    """Max |Φ| (m or rad) and max |Φ_q q̇ + Φ_t| (m/s or rad/s) of the state ``y``.

    Parameters
    ----------
    t : float
        Time (s).
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of float
        max |Φ|, max |Φ̇|.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> pos, vel = constraint_violation(0.0, y, dyn)
    >>> pos, bool(vel < 1e-11)
    (0.0, True)
    """
    n = sys.mass.shape[0]
    ws = make_workspace(sys)
    constraint_terms(t, y[:n], y[n:2 * n], sys, ws)
    return violation_from(ws)


@njit(cache=True)
def mechanical_energy(y, sys):
    """Kinetic energy ½ q̇ᵀ M q̇ and gravitational potential −Σ m g·r (J).

    Parameters
    ----------
    y : ndarray, shape (2 n + 2,)
        The state ``(q, q̇, W_in, W_cl)``: coordinates (m, rad), velocities (m/s, rad/s), input
        and clearance work (J).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of float
        ``(T, V)`` (J).

    Examples
    --------
    All bodies at y = 0, so V = 0; T is ½ q̇ᵀ M q̇:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> T, V = mechanical_energy(y, dyn)
    >>> round(T, 6), round(float(0.5 * (dyn.mass * v**2).sum()), 6), V
    (63.350904, 63.350904, 0.0)
    """
    n = sys.mass.shape[0]
    T = 0.0
    V = 0.0
    for k in range(n):
        T += 0.5 * sys.mass[k] * y[n + k] ** 2
    for b in range(n // 3):
        V -= sys.mass[3 * b] * (sys.gravity[0] * y[3 * b] + sys.gravity[1] * y[3 * b + 1])
    return T, V


@njit(cache=True)
def post_process(times, Y, sys):
    """Per output instant, the clearance joints' eccentricities and the energies.

    In one compiled call: the eccentricity (e_x, e_y) (m) of every clearance joint, kinetic
    and gravitational energy and the elastic contact energy (J). The elastic energy is metal
    contact's: where no clearance joint can touch (lubricated joints only) it is 0 and no force
    law is evaluated for it.

    Parameters
    ----------
    times : ndarray, shape (N,)
        The output instants (s).
    Y : ndarray, shape (N, 2 n + 2)
        The states at those instants.
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).

    Returns
    -------
    tuple of ndarray
        ``(EX, EY, T, V, E)``: EX, EY of shape (N, n_clearance) (m), T, V, E of shape (N,)
        (J).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> EX, EY, T, V, E = post_process(np.zeros(1), y[None], dyn)
    >>> EX.shape, round(float(T[0]), 6), float(E[0])
    ((1, 1), 63.350904, 0.0)
    """
    N = Y.shape[0]
    n = sys.mass.shape[0]
    nc = sys.cl_b.shape[0]
    EX = np.empty((N, nc))
    EY = np.empty((N, nc))
    T = np.empty(N)
    V = np.empty(N)
    E = np.empty(N)
    nh = n_contacts(sys)
    no_hist = np.zeros(nh)  # the stored elastic energy does not depend on history
    cl_b = sys.cl_b
    cl_j = sys.cl_j
    cl_sb = sys.cl_sb
    cl_sj = sys.cl_sj
    Q = np.zeros(n)
    cs = np.empty(n // 3)
    sn = np.empty(n // 3)
    for r in range(N):
        y = Y[r]
        q = y[:n]
        v = y[n:2 * n]
        body_trig(q, cs, sn)
        for k in range(nc):
            EX[r, k], EY[r, k], _, _, _, _, _, _, _, _ = joint_state(
                q, v, cl_b[k], cl_j[k], cl_sb[k, 0], cl_sb[k, 1], cl_sj[k, 0], cl_sj[k, 1],
                cs, sn)
        T[r], V[r] = mechanical_energy(y, sys)
        if nh == 0:  # no joint that can touch: every force law's elastic energy is 0.0
            E[r] = 0.0
        else:
            Q[:] = 0.0
            _, E[r] = applied_forces(times[r], q, v, no_hist, sys, Q)
    return EX, EY, T, V, E
