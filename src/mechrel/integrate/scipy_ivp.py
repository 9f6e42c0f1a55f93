"""SciPy's implicit solvers (Radau, BDF, LSODA) around the compiled right-hand side.

A reference and fallback: every right-hand-side call crosses from Python into compiled code
(tens of µs per call), so the compiled kernels are faster. Contact onsets are located by
``solve_ivp`` events (plain functions of ``(t, y)``, terminal, direction +1) placed at half
the onset tolerance inside the contact; separations (direction −1) reset the history. The
integration restarts after each event with the updated history.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from ..mechanics.problem import constraint_violation, gaps, rhs
from . import events as ev
from .base import Integrator


class ScipyIVP(Integrator):
    """Base of the SciPy wrappers; ``method`` is the ``solve_ivp`` method name."""

    method = ""
    stiff = True
    defaults = {"rtol": 1e-6, "atol": 1e-9}

    def _advance(self, system, t0, y0, hist, t_out, ctl):
        hist = hist.copy()
        floors = ev.contact_floors(system)
        stats = np.zeros(ev.N_STATS)
        tol = self.onset_tolerance
        ny = y0.shape[0]
        Y = np.full((t_out.size, ny), np.nan)
        YD = np.full((t_out.size, ny), np.nan)
        t, y = float(t0), y0.copy()
        k = 0
        while k < t_out.size and t_out[k] <= t:
            Y[k], YD[k] = y, rhs(t, y, hist, system)
            k += 1
        tend = float(t_out[-1])
        first_step = self.step
        while t < tend:
            if ctl[ev.CTL_STOP]:  # checked between events (SciPy's loop is not ours)
                stats[ev.S_STATUS] = ev.STATUS_STOPPED
                break

            def fun(tt, yy, _h=hist):
                # SciPy's finite-difference Jacobians (BDF, Radau) pass columns of a matrix,
                # i.e. non-contiguous views: copying keeps rhs on its one compiled (C-layout)
                # signature instead of compiling (~25 s) and running an 'A'-layout variant.
                return rhs(tt, np.ascontiguousarray(yy), _h, system)

            evs = []
            for c in range(hist.size):
                if hist[c] == 0.0:
                    def onset(tt, yy, _c=c):
                        return gaps(tt, yy, system)[0][_c] - 0.5 * tol
                    onset.terminal, onset.direction = True, 1.0
                    evs.append(onset)
                else:
                    def separation(tt, yy, _c=c):
                        return gaps(tt, yy, system)[0][_c]
                    separation.terminal, separation.direction = True, -1.0
                    evs.append(separation)
            sol = solve_ivp(fun, (t, tend), y, method=self.method, rtol=self.rtol,
                            atol=self.atol, dense_output=True, events=evs or None,
                            first_step=first_step)
            stats[ev.S_STEPS] += sol.t.size - 1
            stats[ev.S_RHS] += sol.nfev
            stats[ev.S_JAC] += sol.njev
            stats[ev.S_LU] += sol.nlu
            for col in range(sol.y.shape[1]):
                p, v = constraint_violation(sol.t[col], sol.y[:, col], system)
                stats[ev.S_VIOL_POS] = max(stats[ev.S_VIOL_POS], p)
                stats[ev.S_VIOL_VEL] = max(stats[ev.S_VIOL_VEL], v)
            if sol.status == -1:
                stats[ev.S_STATUS] = ev.STATUS_STEP_UNDERFLOW
                break
            t_stop = float(sol.t[-1])
            while k < t_out.size and t_out[k] <= t_stop:
                Y[k] = sol.sol(t_out[k])
                YD[k] = rhs(t_out[k], Y[k], hist, system)
                k += 1
            ctl[ev.CTL_DONE] = k
            t, y = t_stop, sol.y[:, -1].copy()
            if not np.all(np.isfinite(y)):
                stats[ev.S_STATUS] = ev.STATUS_NONFINITE
                break
            if sol.status == 1:  # an event: update the history and restart
                if not ev.update_history(t, y, hist, floors, system, stats):
                    # a separation event at g = 0 exactly: reset explicitly
                    g, _ = gaps(t, y, system)
                    hist[(hist != 0.0) & (g <= 0.0)] = 0.0
            first_step = None
        return Y, YD, hist, stats, t, y


class ScipyRadau(ScipyIVP):
    """SciPy's Radau IIA (order 5) around the compiled right-hand side."""

    name = "scipy-radau"
    method = "Radau"


class ScipyBDF(ScipyIVP):
    """SciPy's variable-order BDF around the compiled right-hand side."""

    name = "bdf"
    method = "BDF"


class ScipyLSODA(ScipyIVP):
    """SciPy's LSODA (automatic stiffness switching) around the compiled right-hand side."""

    name = "lsoda"
    method = "LSODA"
