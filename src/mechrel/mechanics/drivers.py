"""Driven coordinates: the angle, speed and acceleration a driver prescribes.

Owns the driver laws of a :class:`~mechrel.mechanics.system.System` (``dr_law``, ``dr_par``:
constant speed, constant acceleration, harmonic, smooth start) as functions of time:
:func:`driver_law` for one instant (called by the constraints, :mod:`mechrel.mechanics.constraints`)
and :func:`driver_angles` for an output grid (the crank angle of a result). All
``@njit(cache=True)``.

Source: the laws are those of the scene format (docs/scenes.md, ``[drivers.NAME]``); the smooth
start follows the speed ``ω s(t/T)`` with ``s`` the quintic smoothstep ``10τ³ − 15τ⁴ + 6τ⁵``,
whose derivative vanishes at both ends of the ramp, so the driver's acceleration is continuous.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .system import (D_ACCEL, D_AMPLITUDE, D_ANGLE0, D_FREQUENCY, D_PHASE, D_RAMP, D_SPEED,
                     LAW_CONSTANT_ACCELERATION, LAW_CONSTANT_SPEED, LAW_HARMONIC)


@njit(cache=True)
def driver_law(law, par, t):
    """Angle (rad), angular velocity (rad/s) and angular acceleration (rad/s²) of a driver.

    Parameters
    ----------
    law : int
        The driver law code (``System.dr_law``: constant speed, constant acceleration, harmonic).
    par : ndarray
        Its parameters (a row of ``System.dr_par``: rad, rad/s, rad/s², Hz, s).
    t : float
        Time (s).

    Returns
    -------
    tuple of float
        ``(θ, θ̇, θ̈)`` at ``t``.

    Examples
    --------
    The slider-crank's crank turns at a constant 5000 rpm = 523.599 rad/s:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> th, om, al = driver_law(dyn.dr_law[0], dyn.dr_par[0], 0.1)
    >>> round(th, 4), round(om, 4), al
    (52.3599, 523.5988, 0.0)
    """
    th0 = par[D_ANGLE0]
    w = par[D_SPEED]
    if law == LAW_CONSTANT_SPEED:
        return th0 + w * t, w, 0.0
    if law == LAW_CONSTANT_ACCELERATION:
        a = par[D_ACCEL]
        return th0 + w * t + 0.5 * a * t * t, w + a * t, a
    if law == LAW_HARMONIC:
        amp = par[D_AMPLITUDE]
        om = par[D_FREQUENCY]
        ph = om * t + par[D_PHASE]
        return th0 + amp * math.sin(ph), amp * om * math.cos(ph), -amp * om * om * math.sin(ph)
    # smooth start: the speed follows w * s(t/T), s the quintic smoothstep 10τ³ − 15τ⁴ + 6τ⁵,
    # so the acceleration is zero at both ends of the ramp.
    T = par[D_RAMP]
    if t >= T:
        return th0 + w * (t - 0.5 * T), w, 0.0
    tau = t / T
    t2 = tau * tau
    t3 = t2 * tau
    S = t2 * t2 * (2.5 - 3.0 * tau + t2)  # ∫ s dτ
    s = t3 * (10.0 - 15.0 * tau + 6.0 * t2)
    ds = 30.0 * t2 * (1.0 - 2.0 * tau + t2)
    return th0 + w * T * S, w * s, w * ds / T


@njit(cache=True)
def driver_angles(law, par, times):
    """Angle (rad) of one driver at each instant.

    Parameters
    ----------
    law : int
        The driver law code (``System.dr_law``: constant speed, constant acceleration, harmonic).
    par : ndarray
        Its parameters (a row of ``System.dr_par``: rad, rad/s, rad/s², Hz, s).
    times : ndarray, shape (N,)
        The instants (s).

    Returns
    -------
    ndarray, shape (N,)
        θ (rad).

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-lubricated"))
    >>> q, v = assemble(c.assembly, c.q_guess, 0.0)
    >>> dyn, y = c.dynamic, np.concatenate([q, v, np.zeros(2)])
    >>> driver_angles(dyn.dr_law[0], dyn.dr_par[0], np.array([0.0, 0.01])).round(6).tolist()
    [0.0, 5.235988]
    """
    out = np.empty(times.shape[0])
    for r in range(times.shape[0]):
        out[r] = driver_law(law, par, times[r])[0]
    return out
