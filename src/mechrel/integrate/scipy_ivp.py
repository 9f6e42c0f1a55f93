"""SciPy's implicit solvers (Radau, BDF, LSODA) around the compiled right-hand side.

A reference and fallback: every right-hand-side call crosses from Python into compiled code
(tens of µs per call), so the compiled kernels are faster.

The wrapper drives SciPy's :class:`~scipy.integrate.OdeSolver` classes one step at a time, as
``solve_ivp`` does, so that ``max_steps`` and a stop request apply at every step (inside
``solve_ivp`` they could not: a BDF run through dry impacts took minutes per millisecond with no
way to stop it). Contact onsets are located like ``solve_ivp`` events (terminal, direction +1)
placed at half the onset tolerance inside the contact; separations (direction −1) reset the
history. Detection and root finding are ``solve_ivp``'s (a sign change of the event function
between the step's ends; Brent's method on the step's dense output, ``xtol = rtol = 4 eps``), so
results are those of ``solve_ivp`` with events, with one exception: when the dense output does
not bracket the sign change that the step's end states show (a grazing restart, where the
interpolant and the state differ by round-off in the sign of a gap of ~0), ``solve_ivp`` raises
"f(a) and f(b) must have different signs"; here the event is placed at the step's end, whose
state does satisfy it. The solver restarts after each event with the updated history.
"""

from __future__ import annotations

import numpy as np
from scipy import integrate
from scipy.optimize import brentq

from ..mechanics.dynamics import rhs
from ..mechanics.joints import gaps
from ..mechanics.post import constraint_violation
from . import events as ev
from .base import Integrator

_EPS = np.finfo(float).eps


def _event_time(event_values, sol, c, t_old, t_new):
    """Where event ``c`` crosses zero on the step's dense output ``sol`` (``solve_ivp``'s
    Brent root); the step's end when the dense output does not bracket it (module docstring)."""
    def g_c(tt):
        return event_values(tt, sol(tt))[0][c]
    g_new = g_c(t_new)
    if g_c(t_old) * g_new > 0.0:
        return t_new
    root = brentq(g_c, t_old, t_new, xtol=4 * _EPS, rtol=4 * _EPS)
    # The restart acts on the state at the root, so it must be past the crossing (the sign of
    # g_new, or 0). Brent's root can sit on the near side within its tolerance, and where the
    # dense output is flat at that resolution (a gap of 1e-17 m closing at 4 m/s) the restart
    # saw the same crossing again at the same instant, 16 000 times over 0.2 ms of a dry
    # slider-crank. Stepping forward by doubling steps from 4 eps reaches the far side (t_new
    # is on it) within the tolerance's order.
    h = 4 * _EPS * max(abs(root), abs(t_new - t_old))
    while root < t_new and g_c(root) * g_new < 0.0:
        root = min(root + h, t_new)
        h *= 2.0
    return root


class ScipyIVP(Integrator):
    """Base of the SciPy wrappers; ``method`` is the name of the
    :class:`scipy.integrate.OdeSolver` subclass.

    Parameters
    ----------
    step : float, optional
        Initial step (s), default automatic.
    rtol, atol : float, optional
        Tolerances, default 1e-6 and 1e-9.
    max_steps, onset_tolerance
        As for :class:`~mechrel.integrate.base.Integrator`.

    Examples
    --------
    >>> [cls.method for cls in ScipyIVP.__subclasses__()]
    ['Radau', 'BDF', 'LSODA']
    """

    method = ""
    stiff = True
    defaults = {"rtol": 1e-6, "atol": 1e-9}

    def _advance(self, system, t0, y0, hist, t_out, ctl, log_from=np.inf, n_dense=0):
        hist = hist.copy()
        log = []  # the solution log's rows (Integrator's contract), for steps ending after log_from
        floors = ev.contact_floors(system)
        stats = np.zeros(ev.N_STATS)
        tol = self.onset_tolerance
        solver_class = getattr(integrate, self.method)
        Y = np.full((t_out.size, y0.shape[0]), np.nan)
        YD = np.full_like(Y, np.nan)
        H = np.zeros((t_out.size, hist.size))  # the history state at each output instant
        t, y = float(t0), y0.copy()
        k = 0
        while k < t_out.size and t_out[k] <= t:
            Y[k], YD[k], H[k] = y, rhs(t, y, hist, system), hist
            k += 1
        ctl[ev.CTL_DONE] = k
        tend = float(t_out[-1])
        first_step = self.step
        contacts = hist.size > 0  # no contact joint, no event functions to evaluate

        def fun(tt, yy):
            # SciPy's finite-difference Jacobians (BDF, Radau) pass columns of a matrix, i.e.
            # non-contiguous views: copying keeps rhs on its one compiled (C-layout) signature
            # instead of compiling (~25 s) and running an 'A'-layout variant.
            return rhs(tt, np.ascontiguousarray(yy), hist, system)

        def event_values(tt, yy):
            """Onset (gap − tol/2, rising) for joints out of contact, separation (gap,
            falling) for joints in contact; the event is a sign change in that direction."""
            g = gaps(tt, yy, system)[0]
            return np.where(hist == 0.0, g - 0.5 * tol, g), np.where(hist == 0.0, 1.0, -1.0)

        while t < tend:  # one OdeSolver per stretch between events
            solver = solver_class(fun, t, y, tend, rtol=self.rtol, atol=self.atol,
                                  first_step=first_step)
            first_step = None
            if contacts:
                g_old, direction = event_values(t, y)
            n_fev = n_jev = n_lu = 0
            event = False
            while True:
                if ctl[ev.CTL_STOP]:
                    stats[ev.S_STATUS] = ev.STATUS_STOPPED
                    break
                if stats[ev.S_STEPS] >= self.max_steps:
                    stats[ev.S_STATUS] = ev.STATUS_MAX_STEPS
                    break
                solver.step()
                stats[ev.S_RHS] += solver.nfev - n_fev
                stats[ev.S_JAC] += solver.njev - n_jev
                stats[ev.S_LU] += solver.nlu - n_lu
                n_fev, n_jev, n_lu = solver.nfev, solver.njev, solver.nlu
                if solver.status == "failed":
                    stats[ev.S_STATUS] = ev.STATUS_STEP_UNDERFLOW
                    break
                stats[ev.S_STEPS] += 1
                t_old, t_new, y_new = solver.t_old, solver.t, solver.y
                sol = solver.dense_output()
                t_stop, y_stop = t_new, y_new
                if contacts:
                    g_new, _ = event_values(t_new, y_new)
                    crossed = np.flatnonzero(
                        (g_old <= 0.0) & (g_new >= 0.0) & (direction > 0.0)
                        | (g_old >= 0.0) & (g_new <= 0.0) & (direction < 0.0))
                    g_old = g_new
                    if crossed.size:  # the earliest crossing ends the stretch
                        event = True
                        t_stop = min(_event_time(event_values, sol, c, t_old, t_new)
                                     for c in crossed)
                        if t_stop < t_new:
                            y_stop = sol(t_stop)
                p, v = constraint_violation(t_stop, y_stop, system)
                stats[ev.S_VIOL_POS] = max(stats[ev.S_VIOL_POS], p)
                stats[ev.S_VIOL_VEL] = max(stats[ev.S_VIOL_VEL], v)
                while k < t_out.size and t_out[k] <= t_stop:
                    Y[k] = sol(t_out[k])
                    YD[k] = rhs(t_out[k], Y[k], hist, system)
                    H[k] = hist
                    k += 1
                ctl[ev.CTL_DONE] = k
                if t_stop > log_from:  # points of the step's dense output, then its end
                    for j in range(1, n_dense + 1):
                        tj = t_old + j / (n_dense + 1.0) * (t_stop - t_old)
                        if tj >= log_from:
                            yj = np.asarray(sol(tj), dtype=float)
                            log.append(np.concatenate([[tj], yj, rhs(tj, yj, hist, system),
                                                       hist]))
                    ys = np.asarray(y_stop, dtype=float)
                    log.append(np.concatenate([[t_stop], ys, rhs(t_stop, ys, hist, system),
                                               hist]))
                t, y = float(t_stop), np.array(y_stop, dtype=float)
                if event or solver.status == "finished" or not np.all(np.isfinite(y)):
                    break
            if stats[ev.S_STATUS] != ev.STATUS_OK:
                break
            if not np.all(np.isfinite(y)):
                stats[ev.S_STATUS] = ev.STATUS_NONFINITE
                break
            if event and not ev.update_history(t, y, hist, floors, system, stats):
                # a separation event at g = 0 exactly: reset explicitly
                g, _ = gaps(t, y, system)
                hist[(hist != 0.0) & (g <= 0.0)] = 0.0
        width = 1 + 2 * y0.shape[0] + hist.shape[0]
        return Y, YD, hist, stats, t, y, np.array(log).reshape(-1, width), H


class ScipyRadau(ScipyIVP):
    """SciPy's Radau IIA (order 5) around the compiled right-hand side.

    Parameters
    ----------
    step, rtol, atol, max_steps, onset_tolerance
        As for :class:`ScipyIVP`.

    Examples
    --------
    >>> ScipyRadau().name, ScipyRadau().settings
    ('scipy-radau', {'rtol': 1e-06, 'atol': 1e-09})
    """

    name = "scipy-radau"
    method = "Radau"


class ScipyBDF(ScipyIVP):
    """SciPy's variable-order BDF around the compiled right-hand side.

    Parameters
    ----------
    step, rtol, atol, max_steps, onset_tolerance
        As for :class:`ScipyIVP`.

    Examples
    --------
    >>> ScipyBDF(rtol=1e-8).settings
    {'rtol': 1e-08, 'atol': 1e-09}
    """

    name = "bdf"
    method = "BDF"


class ScipyLSODA(ScipyIVP):
    """SciPy's LSODA (automatic stiffness switching) around the compiled right-hand side.

    Parameters
    ----------
    step, rtol, atol, max_steps, onset_tolerance
        As for :class:`ScipyIVP`.

    Examples
    --------
    >>> ScipyLSODA().name
    'lsoda'
    """

    name = "lsoda"
    method = "LSODA"
