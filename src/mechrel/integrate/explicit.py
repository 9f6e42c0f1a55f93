"""Compiled explicit kernels: classical RK4 at a fixed step, and Dormand–Prince 5(4) with
step-size control and its 4th-order continuous extension.

Both integrate ``mechrel.mechanics.dynamics.rhs`` on the output grid ``t_out`` and return the
state and its derivative at each output instant, the history state, and the statistics vector
(:mod:`mechrel.integrate.events`). No Python is called inside the step loop.

References
----------
Hairer, Nørsett & Wanner, *Solving Ordinary Differential Equations I*, 2nd ed., Springer 1993:
§II.1 (RK4), §II.5 (DOPRI5 coefficients, Table 5.2), §II.6 (dense output, eq. 6.12 and the
coefficients of the ``dopri5`` code), §II.4 (step-size control with PI stabilisation, eq. 4.13).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..mechanics.borrow import borrowed
from ..mechanics.dynamics import rhs_inline, rhs_into
from .events import (CTL_DONE, H_START_FLOOR, S_ONSET_REJECTED, S_REJECTED, S_RHS, S_STATUS,
                     S_STEPS, STATUS_NONFINITE, all_finite, log_row, new_log,
                     onset_fraction, out_of_budget, record_violation, start,
                     update_history_from)


@njit(cache=True)
def _rk4_step(t, y, h, hist, sys, ws, K, tmp, out):
    """One classical RK4 step from ``(t, y)`` with ``K[0] = f(t, y)`` into ``out``, and
    ``K[4] = f(t + h, out)``, the next step's first stage (so ``ws`` holds the constraint
    terms and contact gaps of ``out`` on return). Stage states are built in ``tmp`` by loops;
    the four evaluations share one (inlined) right-hand-side call site. Allocates nothing.
    The arrays are used borrowed (:func:`~mechrel.mechanics.borrow.borrowed`): the caller
    owns them for the duration of the call."""
    y, hist, sys, ws, K, tmp, out = borrowed((y, hist, sys, ws, K, tmp, out))
    n = y.shape[0]
    for stage in range(1, 5):
        if stage == 4:
            ts = t + h
            h6 = h / 6.0
            for i in range(n):
                tmp[i] = y[i] + h6 * (K[0, i] + 2.0 * (K[1, i] + K[2, i]) + K[3, i])
                out[i] = tmp[i]
        elif stage == 3:
            ts = t + h
            for i in range(n):
                tmp[i] = y[i] + h * K[2, i]
        else:
            ts = t + 0.5 * h
            for i in range(n):
                tmp[i] = y[i] + 0.5 * h * K[stage - 1, i]
        rhs_inline(ts, tmp, hist, sys, ws, K[stage])


@njit(cache=True, nogil=True)
def rk4_kernel(sys, t0, y0, hist, t_out, h, max_steps, onset_tol, ctl, log_from, n_dense):
    """Classical RK4 with step ``h`` (s).

    Steps are shortened to land on every output instant and to locate contact onsets. RK4 has
    no continuous extension of its own, so the points of the solution log inside a step come
    from the cubic Hermite interpolant of the step's end values and derivatives (third order,
    below the method's fourth).

    Each step ends with the right-hand side at its end state, which is the next step's first
    stage, the derivative stored at an output instant, and the source of the contact gaps
    (onset check) and of the constraint violation recorded for every accepted state: four
    evaluations per step and nothing else, except a re-evaluation when the history changes.

    Parameters
    ----------
    sys : mechrel.mechanics.system.System
        The compiled mechanism.
    t0 : float
        Start time (s).
    y0 : numpy.ndarray
        Initial state ``[q, q̇, W]``.
    hist : numpy.ndarray
        Initial history state (m/s).
    t_out : numpy.ndarray
        Output instants (s), increasing.
    h : float
        Step (s).
    max_steps : int
        Steps allowed.
    onset_tol : float
        Largest penetration at which a contact onset counts as located (m).
    ctl : numpy.ndarray
        The control vector of :mod:`~mechrel.integrate.events` (outputs stored, for a
        progress display in another thread; a stop request, checked once per step).
    log_from : float
        Start of the solution log (s; :func:`~mechrel.integrate.events.log_row`; inf: none).
    n_dense : int
        Points logged inside each step.

    Returns
    -------
    tuple
        ``(Y, YD, hist, stats, t, y, log, H)``: states and derivatives at the output instants,
        the final history, the statistics vector, the final time and state, the log and the
        history state at each output instant.

    Examples
    --------
    The double pendulum released from rest, 0.1 s at a 1 ms step; the first link's centre
    stays on its 0.25 m circle about the pivot:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("double-pendulum"))
    >>> q, v = assemble(c.assembly, c.q_guess)
    >>> y0 = np.concatenate([q, v, np.zeros(2)])
    >>> ctl = np.zeros(2, np.int64)
    >>> Y, YD, hist, stats, t, y, log, H = rk4_kernel(c.dynamic, 0.0, y0, np.zeros(0),
    ...                                               np.array([0.0, 0.1]), 1e-3, 10**6, 1e-9,
    ...                                               ctl, math.inf, 0)
    >>> float(stats[S_STEPS]), float(stats[S_STATUS]), int(ctl[CTL_DONE])
    (100.0, 0.0, 2)
    >>> round(math.hypot(*Y[1, :2]), 9)
    0.25
    """
    nout = t_out.shape[0]
    Y, YD, stats, floors, y, f, k, _, ws = start(sys, t0, y0, hist, t_out)
    H = np.zeros((nout, hist.shape[0]))  # the history state at each output instant
    for i in range(k):
        H[i] = hist
    ctl[CTL_DONE] = k
    t = t0
    ny = y.shape[0]
    K = np.empty((5, ny))
    for i in range(ny):
        K[0, i] = f[i]
    tmp = np.empty(ny)
    ynew = np.empty(ny)
    nh = hist.shape[0]
    contacts = nh > 0
    g0 = np.empty(nh)
    g1 = np.empty(nh)
    gd1 = np.empty(nh)
    for i in range(nh):
        g0[i] = ws.gap[i]  # start() evaluated f(t0, y0)
    log, nlog = new_log(log_from, ny, nh)
    ylog = np.empty(ny)
    flog = np.empty(ny)
    while k < nout:
        if out_of_budget(stats, h, t, max_steps, ctl):
            break
        hk = min(h, t_out[k] - t)
        _rk4_step(t, y, hk, hist, sys, ws, K, tmp, ynew)
        stats[S_RHS] += 4
        if contacts:
            theta = onset_fraction(g0, ws.gap, hist, onset_tol)
            while theta < 1.0 and hk * theta > 1e-15 * max(1.0, abs(t)):
                hk *= theta
                _rk4_step(t, y, hk, hist, sys, ws, K, tmp, ynew)
                stats[S_RHS] += 4
                stats[S_ONSET_REJECTED] += 1
                theta = onset_fraction(g0, ws.gap, hist, onset_tol)
            for i in range(nh):
                g1[i] = ws.gap[i]
                gd1[i] = ws.gaprate[i]
        if not all_finite(ynew):
            stats[S_STATUS] = STATUS_NONFINITE
            break
        # land exactly on the output instant (hk was computed as its difference)
        told = t
        t = t_out[k] if hk == t_out[k] - t else t + hk
        y, ynew = ynew, y
        stats[S_STEPS] += 1
        record_violation(ws, stats)  # ws holds the terms of the new state (K[4])
        if t > log_from:  # the solution log: Hermite points inside the step, then its end
            hs = t - told  # the step went from (told, ynew, K[0]) to (t, y, K[4])
            for j in range(1, n_dense + 1):
                th = j / (n_dense + 1.0)
                tj = told + th * hs
                if tj >= log_from:
                    h00 = (1.0 + 2.0 * th) * (1.0 - th) ** 2
                    h10 = th * (1.0 - th) ** 2
                    h01 = th * th * (3.0 - 2.0 * th)
                    h11 = th * th * (th - 1.0)
                    for i in range(ny):
                        ylog[i] = (h00 * ynew[i] + h01 * y[i]
                                   + hs * (h10 * K[0, i] + h11 * K[4, i]))
                    rhs_into(tj, ylog, hist, sys, ws, flog)
                    stats[S_RHS] += 1
                    log, nlog = log_row(log, nlog, tj, ylog, flog, hist)
            log, nlog = log_row(log, nlog, t, y, K[4], hist)
        for i in range(ny):
            K[0, i] = K[4, i]
        if contacts:
            g0, g1 = g1, g0
            if update_history_from(g0, gd1, hist, floors, stats):
                rhs_into(t, y, hist, sys, ws, K[0])  # the right-hand side changed with hist
                stats[S_RHS] += 1
        while k < nout and t_out[k] <= t:
            Y[k] = y
            YD[k] = K[0]
            H[k] = hist
            k += 1
        ctl[CTL_DONE] = k
    return Y, YD, hist, stats, t, y, log[:nlog], H


# Dormand–Prince 5(4) tableau (Hairer, Nørsett & Wanner, Table II.5.2).
C2, C3, C4, C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0,
                           -5103.0 / 18656.0)
A71, A73, A74, A75, A76 = (35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0,
                           11.0 / 84.0)
E1, E3, E4, E5, E6, E7 = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0,
                          22.0 / 525.0, -1.0 / 40.0)
# Dense output (coefficients of Hairer's dopri5 code, contd5).
D1, D3, D4, D5, D6, D7 = (-12715105075.0 / 11282082432.0, 87487479700.0 / 32700410799.0,
                          -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0,
                          -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0)


# The tableau as arrays for the stage loop (rows: stages 2…7; the 7th is the solution, FSAL).
_C = np.array([0.0, C2, C3, C4, C5, 1.0, 1.0])
_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [A21, 0.0, 0.0, 0.0, 0.0, 0.0],
    [A31, A32, 0.0, 0.0, 0.0, 0.0],
    [A41, A42, A43, 0.0, 0.0, 0.0],
    [A51, A52, A53, A54, 0.0, 0.0],
    [A61, A62, A63, A64, A65, 0.0],
    [A71, 0.0, A73, A74, A75, A76],
])


@njit(cache=True)
def _dopri_stages(t, y, h, hist, sys, ws, K, ytmp, ynew, err, dense):
    """One Dormand–Prince step from ``(t, y)`` with ``K[0] = f(t, y)`` (FSAL): stages into the
    rows of ``K`` (7 × ny), the 5th-order solution into ``ynew``, the error estimate into
    ``err`` and the dense-output coefficient into ``dense``; ``K[6] = f(t + h, ynew)``, so
    ``ws`` holds the constraint terms of ``ynew`` on return. Loops, no temporaries; the six
    evaluations share one (inlined) right-hand-side call site."""
    y, hist, sys, ws, K, ytmp, ynew, err, dense = borrowed((y, hist, sys, ws, K, ytmp, ynew, err,
                                                             dense))
    ny = y.shape[0]
    for s in range(1, 7):
        for i in range(ny):
            acc = 0.0
            for j in range(s):
                acc += _A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        if s == 6:
            for i in range(ny):
                ynew[i] = ytmp[i]
        rhs_inline(t + _C[s] * h, ytmp, hist, sys, ws, K[s])
    for i in range(ny):
        err[i] = h * (E1 * K[0, i] + E3 * K[2, i] + E4 * K[3, i] + E5 * K[4, i] + E6 * K[5, i]
                      + E7 * K[6, i])
        dense[i] = h * (D1 * K[0, i] + D3 * K[2, i] + D4 * K[3, i] + D5 * K[4, i]
                        + D6 * K[5, i] + D7 * K[6, i])


@njit(cache=True)
def _error_norm(err, y, ynew, rtol, atol):
    s = 0.0
    for i in range(y.shape[0]):
        sc = atol + rtol * max(abs(y[i]), abs(ynew[i]))
        s += (err[i] / sc) ** 2
    return math.sqrt(s / y.shape[0])


@njit(cache=True, nogil=True)
def dopri5_kernel(sys, t0, y0, hist, t_out, h0, rtol, atol, max_steps, onset_tol, ctl,
                  log_from, n_dense):
    """Adaptive Dormand–Prince 5(4) with PI step control and dense output.

    Parameters
    ----------
    sys : mechrel.mechanics.system.System
        The compiled mechanism.
    t0 : float
        Start time (s).
    y0 : numpy.ndarray
        Initial state ``[q, q̇, W]``.
    hist : numpy.ndarray
        Initial history state (m/s).
    t_out : numpy.ndarray
        Output instants (s), increasing.
    h0 : float
        Initial step (s); ≤ 0 picks it automatically.
    rtol, atol : float
        Relative and absolute tolerances.
    max_steps : int
        Attempted steps allowed.
    onset_tol : float
        Largest penetration at which a contact onset counts as located (m).
    ctl, log_from, n_dense
        As in :func:`rk4_kernel` (the points inside a step from the continuous extension).

    Returns
    -------
    tuple
        ``(Y, YD, hist, stats, t, y, log, H)`` as in :func:`rk4_kernel`.

    Examples
    --------
    The double pendulum of :func:`rk4_kernel`'s example: the two methods agree to eight digits
    after 0.1 s, DOPRI5 in 38 steps instead of 100:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("double-pendulum"))
    >>> q, v = assemble(c.assembly, c.q_guess)
    >>> y0, ctl = np.concatenate([q, v, np.zeros(2)]), np.zeros(2, np.int64)
    >>> t_out = np.array([0.0, 0.1])
    >>> Y, *_ = rk4_kernel(c.dynamic, 0.0, y0, np.zeros(0), t_out, 1e-3, 10**6, 1e-9, ctl,
    ...                    math.inf, 0)
    >>> Z, _, _, stats, *_ = dopri5_kernel(c.dynamic, 0.0, y0, np.zeros(0), t_out, 0.0, 1e-10,
    ...                                    1e-12, 10**6, 1e-9, ctl, math.inf, 0)
    >>> float(stats[S_STEPS]), bool(np.abs(Y[1, :6] - Z[1, :6]).max() < 1e-8)
    (38.0, True)
    """
    nout = t_out.shape[0]
    ny = y0.shape[0]
    Y, YD, stats, floors, y, f, k, tend, ws = start(sys, t0, y0, hist, t_out)
    H = np.zeros((nout, hist.shape[0]))  # the history state at each output instant
    for i in range(k):
        H[i] = hist
    ctl[CTL_DONE] = k
    K = np.empty((7, ny))
    K[0] = f
    ytmp = np.empty(ny)
    ynew = np.empty(ny)
    err = np.empty(ny)
    dense = np.empty(ny)
    t = t0
    h = h0
    if h <= 0.0:  # Hairer's starting-step heuristic (HNW I, §II.4)
        d0 = 0.0
        d1 = 0.0
        for i in range(ny):
            sc = atol + rtol * abs(y[i])
            d0 += (y[i] / sc) ** 2
            d1 += (f[i] / sc) ** 2
        d0 = math.sqrt(d0 / ny)
        d1 = math.sqrt(d1 / ny)
        h = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h = max(h, H_START_FLOOR * max(1.0, abs(t)))
        h = min(h, max(tend - t, 1e-12))
    errold = 1e-4
    rejected_last = False
    nh = hist.shape[0]
    contacts = nh > 0
    g0 = np.empty(nh)
    g1 = np.empty(nh)
    gd1 = np.empty(nh)
    for i in range(nh):  # from start()'s f(t0, y0); then the end of one step is the next's start
        g0[i] = ws.gap[i]
    log, nlog = new_log(log_from, ny, nh)
    ylog = np.empty(ny)
    flog = np.empty(ny)
    while k < nout:
        if out_of_budget(stats, h, t, max_steps, ctl):
            break
        h = min(h, tend - t)
        _dopri_stages(t, y, h, hist, sys, ws, K, ytmp, ynew, err, dense)
        stats[S_RHS] += 6
        en = _error_norm(err, y, ynew, rtol, atol)
        if not math.isfinite(en):
            en = 1e10
        if en > 1.0:
            stats[S_REJECTED] += 1
            h *= max(0.2, 0.9 * en ** -0.2)
            rejected_last = True
            continue
        if contacts:
            for i in range(nh):  # K[6] = f(t + h, ynew) left the gaps of ynew in ws
                g1[i] = ws.gap[i]
                gd1[i] = ws.gaprate[i]
            theta = onset_fraction(g0, g1, hist, onset_tol)
            if theta < 1.0:
                stats[S_ONSET_REJECTED] += 1
                h *= theta
                continue
        # accepted: ws holds the terms of ynew (K[6] was its last evaluation)
        record_violation(ws, stats)
        told = t
        t = t + h
        stats[S_STEPS] += 1
        # outputs inside (told, t] from the continuous extension
        while k < nout and t_out[k] <= t:
            th = (t_out[k] - told) / h
            th1 = 1.0 - th
            for i in range(ny):
                r2 = ynew[i] - y[i]
                r3 = h * K[0, i] - r2
                r4 = r2 - h * K[6, i] - r3
                Y[k, i] = y[i] + th * (r2 + th1 * (r3 + th * (r4 + th1 * dense[i])))
            rhs_into(t_out[k], Y[k], hist, sys, ws, YD[k])
            H[k] = hist
            stats[S_RHS] += 1
            k += 1
        ctl[CTL_DONE] = k
        if t > log_from:  # the solution log: points of the continuous extension, then the end
            for j in range(1, n_dense + 1):
                th = j / (n_dense + 1.0)
                tj = told + th * h
                if tj >= log_from:
                    th1 = 1.0 - th
                    for i in range(ny):
                        r2 = ynew[i] - y[i]
                        r3 = h * K[0, i] - r2
                        r4 = r2 - h * K[6, i] - r3
                        ylog[i] = y[i] + th * (r2 + th1 * (r3 + th * (r4 + th1 * dense[i])))
                    rhs_into(tj, ylog, hist, sys, ws, flog)
                    stats[S_RHS] += 1
                    log, nlog = log_row(log, nlog, tj, ylog, flog, hist)
            log, nlog = log_row(log, nlog, t, ynew, K[6], hist)
        y, ynew = ynew, y
        for i in range(ny):
            K[0, i] = K[6, i]
        if not all_finite(y):
            stats[S_STATUS] = STATUS_NONFINITE
            break
        if contacts:
            g0, g1 = g1, g0
            if update_history_from(g0, gd1, hist, floors, stats):
                rhs_into(t, y, hist, sys, ws, K[0])  # the right-hand side changed with the history
                stats[S_RHS] += 1
        # PI step-size control (HNW I, eq. II.4.13 with beta = 0.04)
        fac = 0.9 * en ** -0.17 * errold ** 0.04 if en > 0.0 else 10.0
        fac = min(max(fac, 0.2), 1.0 if rejected_last else 10.0)
        errold = max(en, 1e-4)
        h *= fac
        rejected_last = False
    return Y, YD, hist, stats, t, y, log[:nlog], H
