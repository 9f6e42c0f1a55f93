"""Contact-onset location and the history state, shared by every compiled kernel.

History ``hist[k]`` is the impact speed δ̇⁻ (m/s) of contact joint k, captured at its located
onset, and 0 while the joint is out of contact. A trial step that ends with a joint in contact
that was not in contact at its start, with a penetration above ``onset_tol`` (m), is rejected
and retried with the step that the secant of the gap puts at ``onset_tol / 2`` inside the
contact; repeated until the step ends within ``(0, onset_tol]``. Only then is δ̇⁻ recorded:
taking it at the end of an arbitrary first step in contact would bias the LN damping
(docs/reference.md, "Numerical character").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..forces.params import P_FLOOR
from ..mechanics.problem import gaps, make_workspace, n_contacts, rhs_into, violation_from

# Layout of the float64 statistics vector every kernel returns.
S_STEPS, S_RHS, S_REJECTED, S_ONSET_REJECTED, S_IMPACTS, S_JAC, S_LU, S_VIOL_POS, S_VIOL_VEL, \
    S_STATUS = range(10)
N_STATS = 10
STATUS_OK, STATUS_MAX_STEPS, STATUS_STEP_UNDERFLOW, STATUS_NONFINITE, STATUS_NEWTON, \
    STATUS_STOPPED = range(6)
STATUS_TEXT = ("ok", "maximum number of steps reached", "step size underflow",
               "non-finite state", "Newton iteration failed to converge", "stopped on request")
# The control vector every kernel takes (int64, length 2): CTL_DONE is written by the kernel,
# the number of output instants stored so far; CTL_STOP by the caller, from another thread
# (the kernels run without the GIL): non-zero asks the kernel to stop at its next step.
CTL_DONE, CTL_STOP = range(2)
# A step below H_UNDERFLOW·max(1, |t|) s ends a run ("step size underflow"). An automatic
# starting step is never below H_START_FLOOR·max(1, |t|): Hairer's first estimate
# 0.01‖y‖/‖f‖ (HNW I, §II.4) falls under the underflow limit when a tight atol scales
# components that are zero at the start (a mechanism at rest: 1e-14 s for the double pendulum
# at rtol 0.05, atol 1e-12), and the run stopped before its first step; from the floor the
# error test shrinks the step if the problem really needs it.
H_UNDERFLOW = 1e-14
H_START_FLOOR = 1e3 * H_UNDERFLOW


@njit(cache=True)
def contact_floors(sys):
    """Impact-speed floor (m/s) of each contact joint, in ``hist`` order."""
    out = np.zeros(n_contacts(sys))
    for k in range(sys.cl_hist.shape[0]):
        h = sys.cl_hist[k]
        if h >= 0:
            out[h] = sys.cl_p[k, P_FLOOR]
    return out


@njit(cache=True)
def onset_fraction(g0, g1, hist, onset_tol):
    """Fraction of the trial step that brings the earliest new contact to ``onset_tol / 2``
    penetration, or 1.0 when no new contact overshoots ``onset_tol``."""
    theta = 1.0
    for k in range(g1.shape[0]):
        if hist[k] == 0.0 and g1[k] > onset_tol and g0[k] <= 0.0:
            # secant of the gap over the step; g1 > onset_tol >= onset_tol/2 > g0
            f = (0.5 * onset_tol - g0[k]) / (g1[k] - g0[k])
            if f < theta:
                theta = f
    if theta < 1.0:
        theta = min(max(theta, 1e-3), 0.999)
    return theta


@njit(cache=True)
def update_history(t, y, hist, floors, sys, stats):
    """Capture δ̇⁻ at a (located) onset and reset at separation. Returns True if hist changed."""
    if hist.shape[0] == 0:
        return False
    g, gd = gaps(t, y, sys)
    return update_history_from(g, gd, hist, floors, stats)


@njit(cache=True)
def update_history_from(g, gd, hist, floors, stats):
    """:func:`update_history` with the gaps and gap rates at the step's end already known."""
    changed = False
    for k in range(g.shape[0]):
        if hist[k] == 0.0 and g[k] > 0.0:
            hist[k] = max(gd[k], floors[k])
            stats[S_IMPACTS] += 1.0
            changed = True
        elif hist[k] != 0.0 and g[k] <= 0.0:
            hist[k] = 0.0
            changed = True
    return changed


@njit(cache=True)
def record_violation(ws, stats):
    """Track in ``stats`` the largest position and velocity constraint violation, of the state
    whose right-hand side (or constraint terms) was evaluated last in ``ws``. The kernels call
    it right after an evaluation at every accepted state, so it costs nothing extra."""
    p, v = violation_from(ws)
    if p > stats[S_VIOL_POS]:
        stats[S_VIOL_POS] = p
    if v > stats[S_VIOL_VEL]:
        stats[S_VIOL_VEL] = v


@njit(cache=True)
def all_finite(y):
    for k in range(y.shape[0]):
        if not math.isfinite(y[k]):
            return False
    return True


@njit(cache=True)
def start(sys, t0, y0, hist, t_out):
    """What every kernel does first: allocate the outputs (NaN until written), the statistics,
    the contact floors and the right-hand-side workspace; evaluate f(t0, y0); record the output
    instants at t0 and the initial constraint violation. Returns
    (Y, YD, stats, floors, y, f, k, tend, ws) with ``k`` the next output index."""
    nout = t_out.shape[0]
    ny = y0.shape[0]
    Y = np.full((nout, ny), np.nan)
    YD = np.full((nout, ny), np.nan)
    stats = np.zeros(N_STATS)
    floors = contact_floors(sys)
    ws = make_workspace(sys)
    y = y0.copy()
    f = np.empty(ny)
    rhs_into(t0, y, hist, sys, ws, f)
    stats[S_RHS] += 1
    record_violation(ws, stats)
    k = 0
    while k < nout and t_out[k] <= t0:
        Y[k] = y
        YD[k] = f
        k += 1
    tend = t_out[nout - 1] if nout > 0 else t0
    return Y, YD, stats, floors, y, f, k, tend, ws


@njit(cache=True)
def out_of_budget(stats, h, t, max_steps, ctl):
    """True (with the status set) when an adaptive kernel must stop: ``max_steps`` attempted
    steps, a step below ``H_UNDERFLOW`` of the time scale, or a stop request in ``ctl``."""
    if ctl[CTL_STOP] != 0:
        stats[S_STATUS] = STATUS_STOPPED
        return True
    if stats[S_STEPS] + stats[S_REJECTED] >= max_steps:
        stats[S_STATUS] = STATUS_MAX_STEPS
        return True
    if h < H_UNDERFLOW * max(1.0, abs(t)):
        stats[S_STATUS] = STATUS_STEP_UNDERFLOW
        return True
    return False


# The solution log (cycle extremes, docs/mechanics.md "Cycle extremes from the solution"): rows
# (t, y, dy/dt, hist) at every accepted step's end and at ``n_dense`` equally spaced points of
# the step's continuous extension inside it, for steps ending after ``log_from`` (s). A run
# that does not ask for it passes ``log_from = inf``: it then costs one comparison per step and
# changes nothing (the logged points are evaluated after everything the step needs).
LOG_START_ROWS = 256


@njit(cache=True)
def new_log(log_from, ny, nh):
    """An empty log (0 rows when ``log_from`` is inf, i.e. no log asked for)."""
    rows = 0 if math.isinf(log_from) else LOG_START_ROWS
    return np.empty((rows, 1 + 2 * ny + nh)), 0


@njit(cache=True)
def log_row(log, n, t, y, yd, hist):
    """Append (t, y, yd, hist) as row ``n`` of ``log``, doubling it when full; returns
    ``(log, n + 1)``."""
    if n == log.shape[0]:
        bigger = np.empty((max(2 * n, LOG_START_ROWS), log.shape[1]))
        bigger[:n] = log[:n]
        log = bigger
    ny = y.shape[0]
    log[n, 0] = t
    for i in range(ny):
        log[n, 1 + i] = y[i]
        log[n, 1 + ny + i] = yd[i]
    for i in range(hist.shape[0]):
        log[n, 1 + 2 * ny + i] = hist[i]
    return log, n + 1
