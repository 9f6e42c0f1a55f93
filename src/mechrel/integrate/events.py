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
from ..mechanics.dynamics import make_workspace, rhs_into  # noqa: F401  (docstring examples)
from ..mechanics.formulation import (contact_system, evaluate, make_work, output_width,
                                     violation, write_output)
from ..mechanics.joints import gaps, n_contacts

# Layout of the float64 statistics vector every kernel returns.
# S_NEWTON_REJECTED counts the part of S_REJECTED whose Newton iteration did not converge
# (implicit kernels; the rest failed the error test). S_FORMULATION is the index in
# FORMULATION_TEXT of the equations integrated: the kernels leave it 0 (absolute); a caller
# that ran them on other equations records it (radau's reduced ones).
S_STEPS, S_RHS, S_REJECTED, S_ONSET_REJECTED, S_IMPACTS, S_JAC, S_LU, S_VIOL_POS, S_VIOL_VEL, \
    S_STATUS, S_NEWTON_REJECTED, S_FORMULATION = range(12)
N_STATS = 12
FORMULATION_TEXT = ("absolute", "reduced")
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
    """Impact-speed floor (m/s) of each contact joint, in ``hist`` order.

    Parameters
    ----------
    sys : mechrel.mechanics.system.System
        A compiled mechanism.

    Returns
    -------
    numpy.ndarray
        One floor per contact joint (m/s).

    Examples
    --------
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> contact_floors(compile_scene(load_scene("slider-crank-dry")).dynamic)
    array([0.001])
    """
    out = np.zeros(n_contacts(sys))
    for k in range(sys.cl_hist.shape[0]):
        h = sys.cl_hist[k]
        if h >= 0:
            out[h] = sys.cl_p[k, P_FLOOR]
    return out


@njit(cache=True)
def onset_fraction(g0, g1, hist, onset_tol):
    """Fraction of the trial step that brings the earliest new contact to ``onset_tol / 2``
    penetration, or 1.0 when no new contact overshoots ``onset_tol``.

    Parameters
    ----------
    g0, g1 : numpy.ndarray
        Penetrations δ of the contact joints at the step's start and end (m).
    hist : numpy.ndarray
        History state (m/s): 0 for a joint not in contact at the step's start.
    onset_tol : float
        Largest penetration at which an onset counts as located (m).

    Returns
    -------
    float
        The fraction, in [0.001, 0.999] when the step must be cut, else 1.0.

    Examples
    --------
    The secant of the gap from −1 nm to 3 nm reaches 0.5 nm at 3/8 of the step:

    >>> onset_fraction(np.array([-1e-9]), np.array([3e-9]), np.zeros(1), 1e-9)
    0.375
    >>> onset_fraction(np.array([-1e-9]), np.array([0.8e-9]), np.zeros(1), 1e-9)   # located
    1.0
    """
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
    """Capture δ̇⁻ at a (located) onset and reset at separation.

    Parameters
    ----------
    t : float
        Time (s).
    y : numpy.ndarray
        State at the step's end.
    hist : numpy.ndarray
        History state (m/s), updated in place.
    floors : numpy.ndarray
        Impact-speed floors (m/s, :func:`contact_floors`).
    sys : mechrel.mechanics.system.System
        The compiled mechanism.
    stats : numpy.ndarray
        Statistics vector; ``stats[S_IMPACTS]`` counts the onsets.

    Returns
    -------
    bool
        True if ``hist`` changed.

    Examples
    --------
    The slider-crank's dry joint assembled centred: no contact, nothing to capture:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank-dry"))
    >>> q, v = assemble(c.assembly, c.q_guess)
    >>> y = np.concatenate([q, v, np.zeros(2)])
    >>> update_history(0.0, y, np.zeros(1), contact_floors(c.dynamic), c.dynamic, np.zeros(N_STATS))
    False
    """
    if hist.shape[0] == 0:
        return False
    g, gd = gaps(t, y, sys)
    return update_history_from(g, gd, hist, floors, stats)


@njit(cache=True)
def update_history_from(g, gd, hist, floors, stats):
    """:func:`update_history` with the gaps and gap rates at the step's end already known.

    Parameters
    ----------
    g, gd : numpy.ndarray
        Penetration δ (m) and its rate δ̇ (m/s) of each contact joint.
    hist : numpy.ndarray
        History state (m/s), updated in place.
    floors : numpy.ndarray
        Impact-speed floors (m/s).
    stats : numpy.ndarray
        Statistics vector; ``stats[S_IMPACTS]`` counts the onsets.

    Returns
    -------
    bool
        True if ``hist`` changed.

    Examples
    --------
    A joint entering contact at 0.3 m/s, then separating:

    >>> hist, stats = np.zeros(1), np.zeros(N_STATS)
    >>> update_history_from(np.array([1e-10]), np.array([0.3]), hist, np.array([1e-3]), stats)
    True
    >>> hist, float(stats[S_IMPACTS])
    (array([0.3]), 1.0)
    >>> update_history_from(np.array([-1e-10]), np.array([-0.2]), hist, np.array([1e-3]), stats)
    True
    >>> hist
    array([0.])
    """
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
    """Track in ``stats`` the largest position and velocity constraint violation.

    Of the state whose right-hand side (or constraint terms) was evaluated last in ``ws``. The
    kernels call it right after an evaluation at every accepted state, so it costs nothing
    extra.

    Parameters
    ----------
    ws : mechrel.mechanics.dynamics.Workspace or mechrel.mechanics.reduced.ReducedWork
        The right-hand side's work arrays (a reduced evaluation satisfies the constraints by
        construction and records nothing).
    stats : numpy.ndarray
        Statistics vector; ``stats[S_VIOL_POS]`` (m or rad) and ``stats[S_VIOL_VEL]``
        (m/s or rad/s) are raised to the violation found.

    Examples
    --------
    An assembled double pendulum satisfies its constraints to rounding:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("double-pendulum"))
    >>> q, v = assemble(c.assembly, c.q_guess)
    >>> ws, stats = make_workspace(c.dynamic), np.zeros(N_STATS)
    >>> rhs_into(0.0, np.concatenate([q, v, np.zeros(2)]), np.zeros(0), c.dynamic, ws, np.empty(14))
    >>> record_violation(ws, stats)
    >>> bool(stats[S_VIOL_POS] < 1e-12 and stats[S_VIOL_VEL] < 1e-12)
    True
    """
    p, v = violation(ws)
    if p > stats[S_VIOL_POS]:
        stats[S_VIOL_POS] = p
    if v > stats[S_VIOL_VEL]:
        stats[S_VIOL_VEL] = v


@njit(cache=True)
def all_finite(y):
    """Whether every entry of a state vector is finite (no NaN, no ±inf).

    Parameters
    ----------
    y : numpy.ndarray
        A one-dimensional array.

    Returns
    -------
    bool
        True if all entries are finite.

    Examples
    --------
    >>> all_finite(np.array([0.0, 1e300])), all_finite(np.array([0.0, np.nan]))
    (True, False)
    """
    for k in range(y.shape[0]):
        if not math.isfinite(y[k]):
            return False
    return True


@njit(cache=True)
def start(sys, t0, y0, hist, t_out):
    """What every kernel does first.

    Allocate the outputs (NaN until written; rows in the absolute layout ``(q, q̇, W)``,
    :func:`~mechrel.mechanics.formulation.write_output`), the statistics, the contact floors
    and the right-hand-side workspace; evaluate f(t0, y0); record the output instants at t0
    and the initial constraint violation.

    Parameters
    ----------
    sys : mechrel.mechanics.system.System or mechrel.mechanics.reduced.ReducedSystem
        The compiled mechanism, in either formulation (:mod:`mechrel.mechanics.formulation`).
    t0 : float
        Start time (s).
    y0 : numpy.ndarray
        Initial state ``[q, q̇, W]`` (or ``[z, ż, W]``).
    hist : numpy.ndarray
        Initial history state (m/s).
    t_out : numpy.ndarray
        Output instants (s), increasing.

    Returns
    -------
    tuple
        ``(Y, YD, stats, floors, y, f, k, tend, ws)``: outputs and their derivatives, the
        statistics vector, the floors, the current state and derivative, ``k`` the next
        output index, the last output instant and the workspace.

    Examples
    --------
    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("double-pendulum"))
    >>> q, v = assemble(c.assembly, c.q_guess)
    >>> y0 = np.concatenate([q, v, np.zeros(2)])
    >>> Y, YD, stats, floors, y, f, k, tend, ws = start(c.dynamic, 0.0, y0, np.zeros(0),
    ...                                                 np.array([0.0, 0.1]))
    >>> bool((Y[0] == y0).all()), bool(np.isnan(Y[1]).all()), k, tend, float(stats[S_RHS])
    (True, True, 1, 0.1, 1.0)
    """
    nout = t_out.shape[0]
    ny = y0.shape[0]
    Y = np.full((nout, output_width(sys)), np.nan)
    YD = np.full((nout, output_width(sys)), np.nan)
    stats = np.zeros(N_STATS)
    floors = contact_floors(contact_system(sys))
    ws = make_work(sys)
    y = y0.copy()
    f = np.empty(ny)
    evaluate(t0, y, hist, sys, ws, f)
    stats[S_RHS] += 1
    record_violation(ws, stats)
    k = 0
    while k < nout and t_out[k] <= t0:
        write_output(sys, ws, y, f, Y[k], YD[k])
        k += 1
    tend = t_out[nout - 1] if nout > 0 else t0
    return Y, YD, stats, floors, y, f, k, tend, ws


@njit(cache=True)
def out_of_budget(stats, h, t, max_steps, ctl):
    """Whether an adaptive kernel must stop, with the status set in ``stats``.

    It must stop after ``max_steps`` attempted steps, at a step below ``H_UNDERFLOW`` of the
    time scale, or at a stop request in ``ctl``.

    Parameters
    ----------
    stats : numpy.ndarray
        Statistics vector; ``stats[S_STATUS]`` is set when the kernel must stop.
    h : float
        Next step (s).
    t : float
        Time (s).
    max_steps : int
        Attempted steps allowed.
    ctl : numpy.ndarray
        Control vector (``ctl[CTL_STOP]`` non-zero: stop requested).

    Returns
    -------
    bool
        True if the kernel must stop.

    Examples
    --------
    >>> stats, ctl = np.zeros(N_STATS), np.zeros(2, np.int64)
    >>> out_of_budget(stats, 1e-3, 0.5, 100, ctl), out_of_budget(stats, 1e-15, 0.5, 100, ctl)
    (False, True)
    >>> STATUS_TEXT[int(stats[S_STATUS])]
    'step size underflow'
    """
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
    """An empty solution log and its row count.

    Parameters
    ----------
    log_from : float
        Start of the log (s); inf: no log asked for (0 rows allocated).
    ny, nh : int
        Lengths of the state and of the history state.

    Returns
    -------
    (numpy.ndarray, int)
        The log, ``LOG_START_ROWS`` rows of ``1 + 2 ny + nh`` (or none), and 0 rows used.

    Examples
    --------
    >>> new_log(math.inf, 14, 0)[0].shape, new_log(0.0, 14, 0)[0].shape
    ((0, 29), (256, 29))
    """
    rows = 0 if math.isinf(log_from) else LOG_START_ROWS
    return np.empty((rows, 1 + 2 * ny + nh)), 0


@njit(cache=True)
def log_row(log, n, t, y, yd, hist):
    """Append (t, y, yd, hist) as row ``n`` of ``log``, doubling it when full.

    Parameters
    ----------
    log : numpy.ndarray
        The log (:func:`new_log`).
    n : int
        Rows used.
    t : float
        Time (s).
    y, yd : numpy.ndarray
        State and its derivative.
    hist : numpy.ndarray
        History state (m/s).

    Returns
    -------
    (numpy.ndarray, int)
        The log (a larger copy when it was full) and ``n + 1``.

    Examples
    --------
    >>> log, n = new_log(0.0, 2, 1)
    >>> log, n = log_row(log, n, 0.5, np.array([1.0, 2.0]), np.array([3.0, 4.0]), np.zeros(1))
    >>> n, log[0].tolist()
    (1, [0.5, 1.0, 2.0, 3.0, 4.0, 0.0])
    """
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
