"""Compiled explicit kernels: classical RK4 at a fixed step, and Dormand–Prince 5(4) with
step-size control and its 4th-order continuous extension.

Both integrate ``mechrel.mechanics.problem.rhs`` on the output grid ``t_out`` and return the
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

from ..mechanics.problem import gaps, rhs
from .events import (S_H, S_ONSET_REJECTED, S_REJECTED, S_RHS, S_STATUS, S_STEPS,
                     STATUS_MAX_STEPS, STATUS_NONFINITE, all_finite,
                     onset_fraction, out_of_budget, record_violation, start,
                     update_history_from)


@njit(cache=True)
def _rk4_step(t, y, h, hist, sys, tmp, out):
    """One classical RK4 step into ``out``; stage states are built in ``tmp`` by loops (array
    expressions would allocate a temporary per operation, a measurable share of a step)."""
    n = y.shape[0]
    k1 = rhs(t, y, hist, sys)
    for i in range(n):
        tmp[i] = y[i] + 0.5 * h * k1[i]
    k2 = rhs(t + 0.5 * h, tmp, hist, sys)
    for i in range(n):
        tmp[i] = y[i] + 0.5 * h * k2[i]
    k3 = rhs(t + 0.5 * h, tmp, hist, sys)
    for i in range(n):
        tmp[i] = y[i] + h * k3[i]
    k4 = rhs(t + h, tmp, hist, sys)
    h6 = h / 6.0
    for i in range(n):
        out[i] = y[i] + h6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])


@njit(cache=True)
def rk4_kernel(sys, t0, y0, hist, t_out, h, max_steps, onset_tol):
    """Classical RK4 with step ``h`` (s); steps are shortened to land on every output instant
    and to locate contact onsets. Returns (Y, YD, hist, stats, t, y)."""
    nout = t_out.shape[0]
    Y, YD, stats, floors, y, _, k, _ = start(sys, t0, y0, hist, t_out)
    t = t0
    tmp = np.empty_like(y)
    ynew = np.empty_like(y)
    contacts = hist.shape[0] > 0
    if contacts:
        g0, _ = gaps(t, y, sys)
    while k < nout:
        if stats[S_STEPS] >= max_steps:
            stats[S_STATUS] = STATUS_MAX_STEPS
            break
        hk = min(h, t_out[k] - t)
        _rk4_step(t, y, hk, hist, sys, tmp, ynew)
        stats[S_RHS] += 4
        if contacts:
            g1, gd1 = gaps(t + hk, ynew, sys)
            theta = onset_fraction(g0, g1, hist, onset_tol)
            while theta < 1.0 and hk * theta > 1e-15 * max(1.0, abs(t)):
                hk *= theta
                _rk4_step(t, y, hk, hist, sys, tmp, ynew)
                stats[S_RHS] += 4
                stats[S_ONSET_REJECTED] += 1
                g1, gd1 = gaps(t + hk, ynew, sys)
                theta = onset_fraction(g0, g1, hist, onset_tol)
        if not all_finite(ynew):
            stats[S_STATUS] = STATUS_NONFINITE
            break
        # land exactly on the output instant (hk was computed as its difference)
        t = t_out[k] if hk == t_out[k] - t else t + hk
        y, ynew = ynew, y
        stats[S_STEPS] += 1
        if contacts:
            update_history_from(g1, gd1, hist, floors, stats)
            g0 = g1
        record_violation(t, y, sys, stats)
        while k < nout and t_out[k] <= t:
            Y[k] = y
            YD[k] = rhs(t, y, hist, sys)
            stats[S_RHS] += 1
            k += 1
    stats[S_H] = h
    return Y, YD, hist, stats, t, y


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


@njit(cache=True)
def _dopri_stages(t, y, h, k1, hist, sys):
    k2 = rhs(t + C2 * h, y + h * A21 * k1, hist, sys)
    k3 = rhs(t + C3 * h, y + h * (A31 * k1 + A32 * k2), hist, sys)
    k4 = rhs(t + C4 * h, y + h * (A41 * k1 + A42 * k2 + A43 * k3), hist, sys)
    k5 = rhs(t + C5 * h, y + h * (A51 * k1 + A52 * k2 + A53 * k3 + A54 * k4), hist, sys)
    k6 = rhs(t + h, y + h * (A61 * k1 + A62 * k2 + A63 * k3 + A64 * k4 + A65 * k5), hist, sys)
    ynew = y + h * (A71 * k1 + A73 * k3 + A74 * k4 + A75 * k5 + A76 * k6)
    k7 = rhs(t + h, ynew, hist, sys)
    err = h * (E1 * k1 + E3 * k3 + E4 * k4 + E5 * k5 + E6 * k6 + E7 * k7)
    dense = h * (D1 * k1 + D3 * k3 + D4 * k4 + D5 * k5 + D6 * k6 + D7 * k7)
    return ynew, k7, err, dense


@njit(cache=True)
def _error_norm(err, y, ynew, rtol, atol):
    s = 0.0
    for i in range(y.shape[0]):
        sc = atol + rtol * max(abs(y[i]), abs(ynew[i]))
        s += (err[i] / sc) ** 2
    return math.sqrt(s / y.shape[0])


@njit(cache=True)
def dopri5_kernel(sys, t0, y0, hist, t_out, h0, rtol, atol, max_steps, onset_tol):
    """Adaptive Dormand–Prince 5(4). ``h0`` ≤ 0 picks the initial step automatically.
    Returns (Y, YD, hist, stats, t, y); ``stats[S_H]`` is the step to continue with."""
    nout = t_out.shape[0]
    ny = y0.shape[0]
    Y, YD, stats, floors, y, f, k, tend = start(sys, t0, y0, hist, t_out)
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
        h = min(h, max(tend - t, 1e-12))
    errold = 1e-4
    rejected_last = False
    contacts = hist.shape[0] > 0
    if contacts:
        g0, _ = gaps(t, y, sys)  # kept from step to step: the end of one is the next's start
    while k < nout:
        if out_of_budget(stats, h, t, max_steps):
            break
        h = min(h, tend - t)
        ynew, fnew, err, dense = _dopri_stages(t, y, h, f, hist, sys)
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
            g1, gd1 = gaps(t + h, ynew, sys)
            theta = onset_fraction(g0, g1, hist, onset_tol)
            if theta < 1.0:
                stats[S_ONSET_REJECTED] += 1
                h *= theta
                continue
        # accepted
        told = t
        t = t + h
        stats[S_STEPS] += 1
        # outputs inside (told, t] from the continuous extension
        while k < nout and t_out[k] <= t:
            th = (t_out[k] - told) / h
            th1 = 1.0 - th
            r2 = ynew - y
            r3 = h * f - r2
            r4 = r2 - h * fnew - r3
            Y[k] = y + th * (r2 + th1 * (r3 + th * (r4 + th1 * dense)))
            YD[k] = rhs(t_out[k], Y[k], hist, sys)
            stats[S_RHS] += 1
            k += 1
        y = ynew
        f = fnew
        if not all_finite(y):
            stats[S_STATUS] = STATUS_NONFINITE
            break
        if contacts:
            g0 = g1
            if update_history_from(g1, gd1, hist, floors, stats):
                f = rhs(t, y, hist, sys)  # the right-hand side changed with the history
                stats[S_RHS] += 1
        record_violation(t, y, sys, stats)
        # PI step-size control (HNW I, eq. II.4.13 with beta = 0.04)
        fac = 0.9 * en ** -0.17 * errold ** 0.04 if en > 0.0 else 10.0
        fac = min(max(fac, 0.2), 1.0 if rejected_last else 10.0)
        errold = max(en, 1e-4)
        h *= fac
        rejected_last = False
    stats[S_H] = h
    return Y, YD, hist, stats, t, y
