"""The applied generalised forces: gravity and the clearance joints' forces.

Owns ``Q`` of the equations of motion (:mod:`mechrel.mechanics.dynamics`): gravity ``m g`` on
each body and, per clearance joint, the force law's force and moments
(:func:`~mechrel.forces.joint.clearance_force`) carried to the two bodies' coordinates through
the lever arms (``Q_θ += r × F + M``), with the power the joints absorb and their elastic
contact energy; the contact gaps of the same evaluation are left for the integrators' onset
check. :func:`applied_forces_trig` is the right-hand side's (inlined) form, with the bodies'
cosines and sines given; :func:`applied_forces` the form for other callers. All
``@njit(cache=True)``.

Source: the generalised forces of a force applied at a body-fixed point (Nikravesh 1988,
*Computer-Aided Analysis of Mechanical Systems*, ch. 6); how a clearance joint's force and
moments reach its two bodies, docs/mechanics.md ("Clearance joints"); the force laws,
docs/forces.md.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..forces.joint import clearance_force
from ..forces.params import P_C
from .joints import body_trig, gap_of, joint_state, n_contacts


@njit(cache=True, inline='always')
def applied_forces_trig(t, q, v, hist, sys, Q, cs, sn, gap, gaprate):
    """Add gravity and clearance-joint forces to Q (N, N·m).

    The penetration δ = |e| − c (m) and its rate (m/s) of the contact-capable joints go to
    ``gap`` and ``gaprate`` (as :func:`~mechrel.mechanics.joints.gaps_into` computes them),
    so that a kernel that evaluates the right-hand side at a step's end has the gaps for its
    onset check.

    Parameters
    ----------
    t : float
        Time (s).
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s;
        :func:`~mechrel.mechanics.joints.n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    Q : ndarray, shape (n,)
        Generalised forces (N, N, N·m), added to.
    cs, sn : ndarray, shape (nb,)
        cos θ and sin θ of every body (:func:`~mechrel.mechanics.joints.body_trig`).
    gap, gaprate : ndarray, shape (nh,)
        Receive the penetration δ (m) and its rate (m/s) of the contact-capable joints.

    Returns
    -------
    tuple of float
        ``(clearance power (W), elastic contact energy (J))``.

    Examples
    --------
    At the centred start the film carries nothing: Q is gravity, ``−m g`` on each body:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> cs, sn = np.empty(3), np.empty(3)
    >>> body_trig(q, cs, sn)
    >>> Q = np.zeros(9)
    >>> p, e = applied_forces_trig(0.0, q, v, np.zeros(0), dyn, Q, cs, sn, np.empty(0),
    ...                            np.empty(0))
    >>> round(float(Q[1]), 6), round(-0.3 * 9.81, 6)
    (-2.943, -2.943)
    """
    nb = q.shape[0] // 3
    cl_b = sys.cl_b
    cl_hist = sys.cl_hist
    cl_j = sys.cl_j
    cl_p = sys.cl_p
    cl_sb = sys.cl_sb
    cl_sj = sys.cl_sj
    gravity = sys.gravity
    mass = sys.mass
    for b in range(nb):
        Q[3 * b] += mass[3 * b] * gravity[0]
        Q[3 * b + 1] += mass[3 * b] * gravity[1]
    power = 0.0
    elastic = 0.0
    for k in range(cl_b.shape[0]):
        b = cl_b[k]
        j = cl_j[k]
        ex, ey, evx, evy, wb, wj, rjx, rjy, rbx, rby = joint_state(
            q, v, b, j, cl_sb[k, 0], cl_sb[k, 1], cl_sj[k, 0], cl_sj[k, 1], cs, sn)
        h = cl_hist[k]
        impact = hist[h] if h >= 0 else 0.0
        if h >= 0:
            gap[h], gaprate[h] = gap_of(ex, ey, evx, evy, cl_p[k, P_C])
        fx, fy, ms, mb, eel = clearance_force(ex, ey, evx, evy, wb, wj, impact, cl_p[k])
        power += fx * evx + fy * evy + ms * wj + mb * wb
        elastic += eel
        if j >= 0:
            Q[3 * j] += fx
            Q[3 * j + 1] += fy
            Q[3 * j + 2] += rjx * fy - rjy * fx + ms
        if b >= 0:
            Q[3 * b] -= fx
            Q[3 * b + 1] -= fy
            Q[3 * b + 2] += -(rbx * fy - rby * fx) + mb
    return power, elastic


@njit(cache=True)
def applied_forces(t, q, v, hist, sys, Q):
    """:func:`applied_forces_trig` for callers outside the right-hand side.

    Parameters
    ----------
    t : float
        Time (s).
    q : ndarray, shape (n,)
        Coordinates ``(x, y, θ)`` of each body (m, m, rad).
    v : ndarray, shape (n,)
        Their velocities (m/s, m/s, rad/s).
    hist : ndarray, shape (nh,)
        History of the contact-capable joints (impact speed, m/s;
        :func:`~mechrel.mechanics.joints.n_contacts`).
    sys : System
        The mechanism (:class:`~mechrel.mechanics.system.System`).
    Q : ndarray, shape (n,)
        Generalised forces (N, N, N·m), added to.

    Returns
    -------
    tuple of float
        ``(clearance power (W), elastic contact energy (J))``.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> Q = np.zeros(9)
    >>> p, e = applied_forces(0.0, q, v, np.zeros(0), dyn, Q)
    >>> round(float(Q[4]), 6), e
    (-2.0601, 0.0)
    """
    nb = q.shape[0] // 3
    cs = np.empty(nb)
    sn = np.empty(nb)
    body_trig(q, cs, sn)
    nh = n_contacts(sys)
    return applied_forces_trig(t, q, v, hist, sys, Q, cs, sn, np.empty(nh), np.empty(nh))
