"""Integrators behind one interface.

Subclass contract (after :class:`scipy.integrate.OdeSolver`)
-------------------------------------------------------------
A subclass of :class:`Integrator`

* sets the class attributes ``name`` (the scene's ``solver.integrator`` value), ``stiff``
  (bool), ``adaptive`` (bool) and ``defaults`` (a dict of the settings it uses: some of
  ``step``, ``rtol``, ``atol``);
* implements ``_advance(system, t0, y0, hist, t_out, ctl, log_from, n_dense) -> (Y, YD, hist,
  stats, t, y, log, H)`` which integrates the right-hand side of :mod:`mechrel.mechanics.dynamics`
  (compiled kernels: ``rhs_into`` with one ``make_workspace``) from ``(t0, y0)`` over the
  increasing output instants ``t_out`` (all ≥ t0), returning the state ``Y`` and its
  derivative ``YD`` at each instant, the history state after the last instant, the statistics
  vector of :mod:`mechrel.integrate.events`, the final time and state, and the solution log:
  for every accepted step that ends after ``log_from`` (s; ``inf``: no log), rows
  ``(t, y, dy/dt, hist)`` at ``n_dense`` equally spaced points of the step's continuous
  extension inside it (those at or after ``log_from``) and at its end
  (:func:`~mechrel.integrate.events.log_row`), and the history state at each output
  instant ``H`` (the one its derivative was evaluated with); neither changes anything else; it
  keeps
  ``ctl[events.CTL_DONE]`` (``ctl``: a two-element int64 array) at the number of output
  instants stored so far, stops with ``STATUS_STOPPED`` at its next step after another thread
  sets ``ctl[events.CTL_STOP]`` and with ``STATUS_MAX_STEPS`` after ``self.max_steps`` steps
  (so a wrapped library solver must be stepped by the subclass, as
  :mod:`mechrel.integrate.scipy_ivp` does, not run to the end by a driver such as
  ``solve_ivp``);
* may split the Python around its kernel off ``_advance``: ``_before(system, t0, y0, hist,
  t_out) -> prep`` (the base's returns None) runs before it and its result, when not None, is
  passed to ``_advance(..., prep=prep)``, and ``_after(prep, out, t_out, ctl) -> out`` (the
  base's returns ``out``) runs after it, on what ``_advance`` returned:
  :meth:`Integrator.integrate_steps` runs them as steps of their own, so that a batch of runs
  can take each step for all its runs in turn (``radau`` prepares and expands its reduced
  equations there);
* may integrate other equations than the absolute ones, as long as what ``_advance`` returns
  is in the absolute layout (``radau`` integrates the clearance joints' eccentricities where
  that applies and expands its outputs); it then records the formulation it ran in the
  statistics vector (``stats[events.S_FORMULATION]``, an index in ``events.FORMULATION_TEXT``:
  :class:`SolverStats` reports it) and overrides ``formulation_for(system)``, which answers the
  same before a run;
* locates contact onsets before capturing the impact speed (use
  :func:`~mechrel.integrate.events.onset_fraction` and
  :func:`~mechrel.integrate.events.update_history`), and never returns non-finite values
  silently: it stops with a status code instead.

:meth:`Integrator.integrate` calls ``_advance`` once over the whole output grid (as the one
pause of :meth:`Integrator.integrate_steps`, a generator of the integration's steps that
:func:`run_steps` runs in order) and raises
:class:`~mechrel.errors.SimulationError` for a failed status. With a progress bar it runs
``_advance`` in a worker thread and advances the bar from ``ctl[CTL_DONE]`` every 0.1 s: the
compiled kernels release the GIL, so the display costs the integration nothing and, unlike
splitting the grid into chunks (each a restart of the step-size and Jacobian history), does not
change the result: with and without a progress bar the numbers are bitwise the same. Ctrl-C
while it waits sets ``ctl[CTL_STOP]``; the kernel stops at its next step and the
``KeyboardInterrupt`` goes on, with a note of how far the integration got. Without a progress
bar the kernel runs on the caller's thread; on the main thread a signal (Ctrl-C, or SIGTERM,
which the command line turns into :class:`~mechrel.errors.Interrupted`) sets ``ctl[CTL_STOP]``
through :class:`_SignalWatcher`, with the same effect.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import threading
import time
from collections.abc import Callable, Generator
from dataclasses import dataclass, fields
from functools import partial
from typing import Any, ClassVar

import numpy as np

from ..errors import SimulationError
from ..scene.model import MAX_STEPS_LIMIT
from . import events as ev


def run_steps(steps: Generator[Callable[[], Any], Any, Any]):
    """Run the steps of one computation in order (:meth:`Integrator.integrate_steps`,
    :func:`mechrel.simulation.sample_steps`): each callable the generator yields is called and
    its result sent back, or what it raised thrown in.

    Parameters
    ----------
    steps : generator
        Yields callables without arguments; returns the result.

    Returns
    -------
    object
        What the generator returns.

    Examples
    --------
    >>> def steps():
    ...     x = yield lambda: 2
    ...     return 10 * x
    >>> run_steps(steps())
    20
    """
    try:
        work = steps.send(None)
        while True:
            try:
                out = work()
            except BaseException as exc:  # an interrupt too: the steps' own handlers see it
                work = steps.throw(exc)
            else:
                work = steps.send(out)
    except StopIteration as done:
        return done.value


def _timed(fn, *args, **kwargs):
    """``(fn(*args, **kwargs), its wall time in s)``."""
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


@dataclass(frozen=True)
class SolverStats:
    """Statistics of one integration.

    Parameters
    ----------
    integrator : str
        Name of the integrator.
    settings : dict
        The step/tolerances actually used.
    n_steps, n_rhs, n_rejected : int
        Accepted steps, right-hand-side evaluations, rejected trial steps (by the error test,
        or because an implicit method's Newton iteration did not converge).
    n_onset_rejections : int
        Trial steps rejected to locate a contact onset.
    n_impacts : int
        Located contact onsets (impacts).
    n_jacobians, n_lu : int
        Jacobian evaluations and LU factorisations (implicit methods).
    n_newton_rejected : int
        Of ``n_rejected``, the trial steps whose Newton iteration did not converge (``radau``;
        0 for explicit methods and SciPy's solvers, which do not report it).
    max_position_violation : float
        Largest |Φ| at accepted steps (m or rad).
    max_velocity_violation : float
        Largest |Φ_q q̇ + Φ_t| at accepted steps (m/s or rad/s).
    wall_time : float
        Seconds, including compilation on a cold cache.
    status : str
        ``"ok"`` or why the run stopped (``events.STATUS_TEXT``).
    formulation : str
        The equations integrated: ``"absolute"`` (all bodies' coordinates with Lagrange
        multipliers, :mod:`mechrel.mechanics.dynamics`) or ``"reduced"`` (the clearance
        joints' eccentricities, :mod:`mechrel.mechanics.reduced`; ``radau`` only).

    Examples
    --------
    Every :class:`IntegrationResult` carries one: the double pendulum released from rest,
    0.1 s with DOPRI5 (six stages per step, the last reused as the next step's first):

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("double-pendulum"))
    >>> q, v = assemble(c.assembly, c.q_guess)
    >>> stats = DOPRI5(rtol=1e-10, atol=1e-12).integrate(
    ...     c.dynamic, np.concatenate([q, v, np.zeros(2)]), np.zeros(0), [0.0, 0.1]).stats
    >>> stats.status, stats.n_steps, stats.n_impacts, stats.max_position_violation < 1e-9
    ('ok', 38, 0, True)
    """

    integrator: str
    settings: dict
    n_steps: int
    n_rhs: int
    n_rejected: int
    n_onset_rejections: int
    n_impacts: int
    n_jacobians: int
    n_lu: int
    n_newton_rejected: int
    max_position_violation: float
    max_velocity_violation: float
    wall_time: float
    status: str
    formulation: str = "absolute"

    def as_dict(self) -> dict:
        """The statistics as a plain dictionary (for provenance files and tables).

        Returns
        -------
        dict
            ``{field name: value}``.

        Examples
        --------
        >>> from mechrel.mechanics.kinematics import assemble
        >>> from mechrel.mechanics.system import compile_scene
        >>> from mechrel.scene import load_scene
        >>> c = compile_scene(load_scene("double-pendulum"))
        >>> q, v = assemble(c.assembly, c.q_guess)
        >>> res = RK4(step=1e-3).integrate(c.dynamic, np.concatenate([q, v, np.zeros(2)]),
        ...                                np.zeros(0), [0.0, 0.1])
        >>> d = res.stats.as_dict()
        >>> list(d)[:4], d["settings"], d["n_steps"], d["n_rhs"]   # 4 evaluations per step
        (['integrator', 'settings', 'n_steps', 'n_rhs'], {'step': 0.001}, 100, 401)
        """
        # shallow (``dataclasses.asdict`` deep-copies recursively): only ``settings`` holds
        # a container, copied so that the dictionary does not alias the run's own
        out = {name: getattr(self, name) for name in _STATS_FIELDS}
        out["settings"] = dict(self.settings)
        return out


_STATS_FIELDS = tuple(f.name for f in fields(SolverStats))  # as_dict's keys


@dataclass(frozen=True)
class IntegrationResult:
    """The states of one integration at its output instants.

    Parameters
    ----------
    t : numpy.ndarray
        Output instants (s).
    y, ydot : numpy.ndarray
        State and its time derivative at each output instant (one row each).
    hist : numpy.ndarray
        History state after the last instant (m/s).
    stats : SolverStats
        Statistics of the run.
    log : numpy.ndarray, optional
        The solution log (rows ``(t, y, dy/dt, hist)``), None unless asked for with
        ``log_from``.
    hist_out : numpy.ndarray, optional
        History state at each output instant.

    Examples
    --------
    :meth:`Integrator.integrate` returns one:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("double-pendulum"))
    >>> q, v = assemble(c.assembly, c.q_guess)
    >>> res = DOPRI5().integrate(c.dynamic, np.concatenate([q, v, np.zeros(2)]), np.zeros(0),
    ...                          [0.0, 0.05, 0.1])
    >>> res.y.shape, res.log is None, res.stats.status
    ((3, 14), True, 'ok')
    """

    t: np.ndarray
    y: np.ndarray
    ydot: np.ndarray
    hist: np.ndarray
    stats: SolverStats
    log: np.ndarray | None = None
    hist_out: np.ndarray | None = None


def _film_only_models(system) -> list:
    """The film-only clearance models (table of models) among the system's joints."""
    from ..forces.models import MODELS
    from ..forces.params import P_MODEL
    codes = set(system.cl_p[:, P_MODEL].astype(int).tolist())
    return [m for m in MODELS.values() if m.film_only and m.code in codes]


#: A film joint's journal nearer its bearing centre than this fraction of ε0 (its
#: small-eccentricity correction's threshold) is *at* the centre for a failed run's advice:
#: there the film force's direction is undefined and, with λ < 2, the force not smooth.
CENTRE_FRACTION = 1e-3


def _journal_at_centre(system, t, y):
    """``(c, ε, ε0, λ)`` of a film joint whose journal is at its bearing centre in the state
    ``y`` at ``t`` (ε < :data:`CENTRE_FRACTION` ε0) with a correction exponent λ < 2, the
    one of smallest ε; None if there is none (or no finite state)."""
    from ..forces.models import MODELS
    from ..forces.params import P_C, P_EPS0, P_LAMBDA, P_MODEL
    from ..mechanics.post import post_process

    if t is None or y is None or not np.all(np.isfinite(y)):
        return None
    EX, EY, _, _, _ = post_process(np.array([float(t)]), np.ascontiguousarray(y)[None, :],
                                   system)
    film = {m.code for m in MODELS.values() if m.has_film}
    found = None
    for k in range(system.cl_p.shape[0]):
        p = system.cl_p[k]
        if int(p[P_MODEL]) not in film or not p[P_LAMBDA] < 2.0:
            continue
        eps = math.hypot(EX[0, k], EY[0, k]) / p[P_C]
        if eps < CENTRE_FRACTION * p[P_EPS0] and (found is None or eps < found[1]):
            found = (float(p[P_C]), eps, float(p[P_EPS0]), float(p[P_LAMBDA]))
    return found


class _SignalWatcher:
    """Stops the running kernel when a signal arrives while it runs on the main thread.

    Python runs its signal handlers (Ctrl-C's ``KeyboardInterrupt``, the command line's SIGTERM
    handler) only between bytecodes of the main thread, never inside a compiled kernel; but
    the C-level handler writes the signal's number to the "wakeup fd"
    (:func:`signal.set_wakeup_fd`) at once. During a kernel call that fd is a pipe read by
    this daemon thread (one per process, started on first use), which sets the kernel's
    ``ctl[CTL_STOP]``: the kernel stops at its next step, returns, and the signal's own
    handler runs right after the call (raising ``KeyboardInterrupt``). The kernel keeps the
    main thread (no hand-over to another thread, which cost 5-15 ms per integration on a
    loaded machine); the caller's own wakeup fd (asyncio's) is restored after the call."""

    def __init__(self):
        self._read, self._write = os.pipe()
        os.set_blocking(self._write, False)
        self.ctl = None  # the control vector of the kernel running now, if any
        self._session = None  # (handlers replaced, signals recorded) while installed
        threading.Thread(target=self._watch, name="mechrel-signal-watch", daemon=True).start()

    def _watch(self):
        while True:
            if os.read(self._read, 512) and self.ctl is not None:
                self.ctl[ev.CTL_STOP] = 1

    @contextlib.contextmanager
    def watching(self, ctl):
        """For the ``with`` block: the wakeup fd is this watcher's pipe, and the Python
        handlers of SIGINT and SIGTERM (if Python-level) are replaced by one that only records
        the signal: run inside a callback of the compiled code (numba calls Python to unpickle
        constants), a raising handler made numba's dispatcher fail with ``SystemError``. The
        recorded signal's own handler is called after the block (raising there). Inside
        :meth:`session` nothing is installed again: the block only names its ``ctl``."""
        with self.session():  # re-entrant: inside a session it installs nothing
            self.ctl = ctl
            try:
                yield
            finally:
                self.ctl = None
            self._raise_pending()

    @contextlib.contextmanager
    def session(self):
        """For the ``with`` block: the handlers and the wakeup fd of :meth:`watching`,
        installed once for the kernels run inside it (a batch of samples: installing them
        costs ~0.1 ms a run). A signal while no kernel runs calls its own handler at once, as
        outside the block; one during a kernel stops it and is raised when it returns.
        Re-entrant; off the main thread it installs nothing."""
        if self._session is not None:
            yield
            return
        try:
            old_fd = signal.set_wakeup_fd(self._write, warn_on_full_buffer=False)
        except ValueError:  # not the main thread of the main interpreter
            yield
            return
        saved = {}
        pending = []  # the signals recorded during a kernel

        def defer(signum, frame):
            if self.ctl is None:  # no kernel is running: the signal's own handler, now
                saved[signum](signum, frame)
                return
            pending.append(signum)
            self.ctl[ev.CTL_STOP] = 1

        for sig in (signal.SIGINT, signal.SIGTERM):
            handler = signal.getsignal(sig)
            if callable(handler):
                saved[sig] = handler
                signal.signal(sig, defer)
        self._session = (saved, pending)
        try:
            yield
        finally:
            self._session = None
            self.ctl = None
            for sig, handler in saved.items():
                signal.signal(sig, handler)
            signal.set_wakeup_fd(old_fd)

    def _raise_pending(self):
        """The handler of a signal recorded during the kernel that just returned, called."""
        if self._session is None:
            return
        saved, pending = self._session
        if pending:
            signum = pending[0]
            pending.clear()
            saved[signum](signum, None)


def signal_session():
    """A context manager under which the kernels run by :meth:`Integrator.integrate` on the
    main thread share one installation of the signal watcher (its handlers and wakeup fd),
    instead of one per run: for a loop of many short runs (a batch of samples). Ctrl-C and
    SIGTERM behave as without it: a kernel stops at its next step and the signal's handler
    raises after it, and between kernels the handler runs at once.

    Returns
    -------
    contextlib.AbstractContextManager
        The session: installed on entering the ``with`` block (re-entrant; nothing off the
        main thread), what it replaced restored on leaving it.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> from mechrel.simulation import simulate
    >>> with signal_session():
    ...     runs = [simulate(load_scene("slider-crank-lubricated")) for _ in range(2)]
    >>> runs[0].stats["status"], bool((runs[0].q == runs[1].q).all())
    ('ok', True)
    """
    return _signal_watcher().session()


_WATCHER: _SignalWatcher | None = None


def _signal_watcher() -> _SignalWatcher:
    global _WATCHER
    if _WATCHER is None:
        _WATCHER = _SignalWatcher()
    return _WATCHER


class Integrator:
    """Base class; see the module docstring for the subclass contract.

    Parameters
    ----------
    step : float, optional
        Fixed step (s) for fixed-step methods; initial step for adaptive ones (default: chosen
        automatically).
    rtol, atol : float, optional
        Relative and absolute tolerances (adaptive methods).
    max_steps : int
        Upper bound on attempted steps.
    onset_tolerance : float
        Largest penetration (m) at which a contact onset counts as located.

    Raises
    ------
    SimulationError
        A setting that is not a number > 0, ``rtol >= 1``, a step budget outside
        [1, 2**53], or a fixed-step method without a step.

    Examples
    --------
    The registered subclasses are instantiated by name (:func:`mechrel.integrate.get_integrator`,
    or from a scene by :func:`mechrel.simulation.make_integrator`):

    >>> from mechrel.integrate import get_integrator
    >>> solver = get_integrator("dopri5", rtol=1e-9, atol=1e-12)
    >>> solver.name, solver.adaptive, solver.stiff, solver.rtol
    ('dopri5', True, False, 1e-09)
    >>> get_integrator("rk4")
    Traceback (most recent call last):
    ...
    mechrel.errors.SimulationError: solver.step: the fixed-step integrator 'rk4' needs a step (s)
    """

    name: ClassVar[str] = ""
    stiff: ClassVar[bool] = False
    adaptive: ClassVar[bool] = True
    defaults: ClassVar[dict] = {}

    def __init__(self, *, step=None, rtol=None, atol=None, max_steps=10_000_000,
                 onset_tolerance=1e-9):
        given = {"step": step, "rtol": rtol, "atol": atol}
        for field, value in given.items():
            if value is None:
                value = self.defaults.get(field)
            elif isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
                raise SimulationError(f"solver.{field}: expected a number, got {value!r}")
            if value is not None and not value > 0:
                raise SimulationError(f"solver.{field}: must be > 0, got {value!r}")
            setattr(self, field, None if value is None else float(value))
        self.max_steps = int(max_steps)
        self.onset_tolerance = float(onset_tolerance)
        if self.rtol is not None and not self.rtol < 1:
            raise SimulationError(f"solver.rtol: must be < 1 (a relative tolerance of 1 asks "
                                  f"for no accuracy), got {self.rtol!r}")
        if not 0 < self.max_steps <= MAX_STEPS_LIMIT:
            raise SimulationError(f"solver.max_steps: must be in [1, 2**53], got "
                                  f"{self.max_steps!r}")
        if not self.adaptive and self.step is None:
            raise SimulationError(f"solver.step: the fixed-step integrator {self.name!r} needs "
                                  "a step (s)")

    @property
    def settings(self) -> dict:
        """The settings this integrator uses: its step, or its tolerances.

        Returns
        -------
        dict
            ``{"step": h}`` for a fixed-step method, ``{"rtol": ..., "atol": ...}`` otherwise.

        Examples
        --------
        >>> RK4(step=1e-4).settings, DOPRI5().settings
        ({'step': 0.0001}, {'rtol': 1e-08, 'atol': 1e-10})
        """
        keys = ("step",) if not self.adaptive else ("rtol", "atol")
        return {k: getattr(self, k) for k in keys}

    def formulation_for(self, system) -> str:
        """The formulation ``_advance`` will integrate ``system`` in, before a run (a run
        reports the one it ran in :class:`SolverStats`): ``"absolute"`` unless a subclass
        integrates other equations.

        Parameters
        ----------
        system : mechrel.mechanics.system.System
            The compiled mechanism.

        Returns
        -------
        str
            ``"absolute"`` or ``"reduced"``.

        Examples
        --------
        >>> from mechrel.mechanics.system import compile_scene
        >>> from mechrel.scene import load_scene
        >>> DOPRI5().formulation_for(compile_scene(load_scene("slider-crank-dry")).dynamic)
        'absolute'
        """
        return "absolute"

    def _before(self, system, t0, y0, hist, t_out):
        """What ``_advance`` is given as ``prep`` (the Python before the kernel; module
        docstring): nothing here."""
        return None

    def _advance(self, system, t0, y0, hist, t_out, ctl, log_from=math.inf,
                 n_dense=0):  # pragma: no cover - abstract
        raise NotImplementedError

    def _after(self, prep, out, t_out, ctl):
        """What ``_advance`` returned, completed by the Python after the kernel (module
        docstring): as it is here."""
        return out

    def _advice(self, status, system, t=None, y=None) -> str:
        """What to try after a failed run, by its status, the scene's effects and the state
        ``y`` at ``t`` where it stopped (absolute layout)."""
        film_only = _film_only_models(system)
        centre = _journal_at_centre(system, t, y)
        if centre is not None:
            c, eps, eps0, lam = centre
            how = "leaves it discontinuous" if lam == 0 else "makes it continuous, not smooth"
            atol = getattr(self, "atol", None)
            return (f"the journal of the clearance joint of c = {c:g} m is at its bearing centre "
                    f"(ε = {eps:.2g}, far below ε0 = {eps0:g}), where the film force is not "
                    f"smooth (its direction is undefined there; the correction (ε/ε0)^λ with "
                    f"λ = {lam:g} {how}), and the tolerance cannot be met across it: "
                    + (f"loosen solver.atol (now {atol:g}), or " if isinstance(atol, float)
                       else "")
                    + "set the joint's lubricant.lam = 3 (a correction smooth at the centre)")
        if film_only:
            from ..forces.models import MODELS
            contact = ", ".join(f"'{m.name}'" for m in MODELS.values()
                                if m.has_film and m.has_contact)
            return (f"if a {film_only[0].name} joint's film cannot carry the load it drives "
                    f"ε → 1: use model = {contact} (adds metal contact) or check the load and "
                    "viscosity")
        if status == ev.STATUS_MAX_STEPS:
            return (f"raise solver.max_steps (now {self.max_steps}), or use "
                    + ("an explicit integrator (solver.integrator = 'dopri5'), which resolves "
                       "dry impacts in fewer, cheaper steps" if self.stiff else
                       "a stiff integrator (solver.integrator = 'radau') if the scene is stiff"))
        return ("try a smaller step or tolerance"
                + ("" if self.stiff else
                   ", or a stiff integrator (solver.integrator = 'radau')"))

    def _run(self, system, t, y, hist, t_out, progress, log_from, n_dense, ctl, prep):
        """``_advance`` over ``t_out``. With a progress bar, in a worker thread while this one
        feeds the bar from the control vector and passes Ctrl-C on as a stop request. Without
        one, on this thread; on the main thread under :class:`_SignalWatcher`, so that Ctrl-C
        and SIGTERM stop the kernel at its next step (a compiled kernel does not look at
        Python's signals: before, it ran to its end first)."""
        extra = {} if prep is None else {"prep": prep}  # an _advance without _before: none
        if progress is None:
            if threading.current_thread() is not threading.main_thread():
                # no signal is handled on this thread: nothing to watch
                return self._advance(system, t, y, hist, t_out, ctl, log_from, n_dense, **extra)
            try:
                with _signal_watcher().watching(ctl):
                    return self._advance(system, t, y, hist, t_out, ctl, log_from, n_dense,
                                         **extra)
            except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (mechrel.errors.Interrupted)
                exc.add_note(f"{self.name}: integration stopped after "
                             f"{int(ctl[ev.CTL_DONE])} of {t_out.size} output instants")
                raise
        box = {}

        def work():
            try:
                box["out"] = self._advance(system, t, y, hist, t_out, ctl, log_from, n_dense,
                                           **extra)
            except BaseException as exc:  # handed to the caller's thread below
                box["exc"] = exc

        worker = threading.Thread(target=work, name="mechrel-integrate", daemon=True)
        worker.start()
        shown = 0
        try:
            alive = True
            while alive:  # the count is read once more after the worker has ended, so a run
                worker.join(0.1)  # shorter than the first poll still fills the bar
                alive = worker.is_alive()
                k = int(ctl[ev.CTL_DONE])
                if k > shown:
                    progress.update(k - shown)
                    shown = k
        except KeyboardInterrupt as exc:
            ctl[ev.CTL_STOP] = 1  # the kernel stops at its next step
            worker.join()
            exc.add_note(f"{self.name}: integration stopped after {int(ctl[ev.CTL_DONE])} of "
                         f"{t_out.size} output instants")
            raise
        if "exc" in box:
            raise box["exc"]
        return box["out"]

    def integrate(self, system, y0, hist0, t_out, *, t0=None, progress=None, log_from=None,
                  dense_points=0) -> IntegrationResult:
        """Integrate from ``(t0, y0)`` (default ``t0 = t_out[0]``) over ``t_out``.

        Parameters
        ----------
        system : mechrel.mechanics.system.System
            The compiled mechanism.
        y0 : array_like
            Initial state ``[q, q̇, W]`` (m, rad, m/s, rad/s, J).
        hist0 : array_like
            Initial history state (m/s), one entry per contact joint.
        t_out : array_like
            Output instants (s), non-empty and increasing.
        t0 : float, optional
            Start time (s), default ``t_out[0]``.
        progress : object, optional
            A tqdm-like object with ``update(n)``, advanced as output instants are stored
            (polled every 0.1 s; module docstring). It does not change the result.
        log_from : float, optional
            Keep the solution log (module docstring) from this instant on (s); ``None``: no
            log. The log does not change the result either.
        dense_points : int, default 0
            Points logged inside each step (≥ 0).

        Returns
        -------
        IntegrationResult
            States at the output instants and the run's statistics.

        Raises
        ------
        mechrel.errors.SimulationError
            Bad output instants or ``dense_points``, or the run failed (its status, with
            advice), or the state diverged.

        Examples
        --------
        The double pendulum released from rest for 0.1 s; the first link's centre stays on
        its 0.25 m circle about the pivot:

        >>> from mechrel.mechanics.kinematics import assemble
        >>> from mechrel.mechanics.system import compile_scene
        >>> from mechrel.scene import load_scene
        >>> c = compile_scene(load_scene("double-pendulum"))
        >>> q, v = assemble(c.assembly, c.q_guess)
        >>> y0 = np.concatenate([q, v, np.zeros(2)])
        >>> res = DOPRI5(rtol=1e-10, atol=1e-12).integrate(c.dynamic, y0, np.zeros(0), [0.0, 0.1])
        >>> res.stats.n_steps, round(math.hypot(*res.y[-1, :2]), 9)
        (38, 0.25)
        >>> DOPRI5().integrate(c.dynamic, y0, np.zeros(0), [0.1, 0.0])
        Traceback (most recent call last):
        ...
        mechrel.errors.SimulationError: output instants must be a non-empty increasing sequence
        """
        return run_steps(self.integrate_steps(system, y0, hist0, t_out, t0=t0,
                                              progress=progress, log_from=log_from,
                                              dense_points=dense_points))

    def integrate_steps(self, system, y0, hist0, t_out, *, t0=None, progress=None,
                        log_from=None, dense_points=0
                        ) -> Generator[Callable[[], Any], Any, IntegrationResult]:
        """:meth:`integrate` as its steps: a generator that pauses where the kernel runs.

        It yields once a callable without arguments, the kernel's run (``_advance``: the
        compiled kernel, on a worker thread with a progress bar), after the checks and
        the Python before it (``_before``); its caller calls it and sends back what it
        returned (or throws in what it raised), and the generator goes on with the Python
        after it (``_after``), the statistics and the status's checks. :func:`run_steps`
        runs the steps of one integration (that is :meth:`integrate`); a batch of samples runs
        each step for several samples in turn, so that the Python of each step runs back to
        back and not once after each kernel, which evicts it from the processor's caches
        (:meth:`mechrel.uq.problem.mechanism.MechanismModel.evaluate_batch`). The result is
        :meth:`integrate`'s, bitwise, in any order of the steps of several integrations; its
        ``wall_time`` is this integration's own steps' time.

        Parameters
        ----------
        system, y0, hist0, t_out, t0, progress, log_from, dense_points
            As for :meth:`integrate`.

        Returns
        -------
        generator
            Yields the kernel's run; returns the :class:`IntegrationResult`.

        Raises
        ------
        mechrel.errors.SimulationError
            As :meth:`integrate`, from the step that finds it.

        Examples
        --------
        The double pendulum of :meth:`integrate`'s example, its kernel run by hand:

        >>> from mechrel.mechanics import kinematics, system
        >>> from mechrel.scene import load_scene
        >>> c = system.compile_scene(load_scene("double-pendulum"))
        >>> y0 = np.concatenate([*kinematics.assemble(c.assembly, c.q_guess), np.zeros(2)])
        >>> steps = DOPRI5(rtol=1e-10, atol=1e-12).integrate_steps(c.dynamic, y0, np.zeros(0),
        ...                                                        [0.0, 0.1])
        >>> kernel = next(steps)  # the checks have run
        >>> try:
        ...     steps.send(kernel())
        ... except StopIteration as done:
        ...     res = done.value
        >>> res.stats.n_steps, round(math.hypot(*res.y[-1, :2]), 9)
        (38, 0.25)
        """
        if log_from is None:
            log_from = math.inf
        dense_points = int(dense_points)
        if dense_points < 0:
            raise SimulationError(f"dense_points = {dense_points}: must be >= 0; allowed: an "
                                  "integer >= 0 (points logged inside each step)")
        t_out = np.ascontiguousarray(t_out, dtype=float)
        if t_out.ndim != 1 or t_out.size == 0 or np.count_nonzero(t_out[1:] <= t_out[:-1]):
            raise SimulationError("output instants must be a non-empty increasing sequence")
        t = float(t_out[0] if t0 is None else t0)
        y = np.ascontiguousarray(y0, dtype=float).copy()
        hist = np.ascontiguousarray(hist0, dtype=float).copy()
        start = time.perf_counter()
        ctl = np.zeros(2, dtype=np.int64)
        try:
            prep = self._before(system, t, y, hist, t_out)
            paused = time.perf_counter()
            out, took = yield partial(_timed, self._run, system, t, y, hist, t_out, progress,
                                      float(log_from), dense_points, ctl, prep)
            start += time.perf_counter() - paused - took  # not other runs' steps' time
            Y, YD, hist, total, t, y, log, H = self._after(prep, out, t_out, ctl)
        except (np.linalg.LinAlgError, ZeroDivisionError) as exc:
            # the compiled Cholesky of the Schur complement raises LinAlgError when the state
            # has diverged (e.g. RK4 with too large a step through dry impacts), and numba's
            # compiled float division raises ZeroDivisionError (Python's error model) when a
            # state has overflowed to a zero denominator (e.g. a film of viscosity 1e200): a
            # failed run, not a bug, so that `mechrel accuracy` and the UQ executor record it
            raise SimulationError(
                f"{self.name} diverged between t = {t:.6g} s and {t_out[-1]:.6g} s "
                f"({type(exc).__name__}: {exc}); use a smaller step or tighter tolerances, "
                "and check the scene's parameters for extreme values") from None
        wall = time.perf_counter() - start
        status = int(total[ev.S_STATUS])
        result_stats = SolverStats(
            integrator=self.name, settings=self.settings,
            n_steps=int(total[ev.S_STEPS]), n_rhs=int(total[ev.S_RHS]),
            n_rejected=int(total[ev.S_REJECTED]),
            n_onset_rejections=int(total[ev.S_ONSET_REJECTED]),
            n_impacts=int(total[ev.S_IMPACTS]), n_jacobians=int(total[ev.S_JAC]),
            n_lu=int(total[ev.S_LU]), n_newton_rejected=int(total[ev.S_NEWTON_REJECTED]),
            max_position_violation=float(total[ev.S_VIOL_POS]),
            max_velocity_violation=float(total[ev.S_VIOL_VEL]), wall_time=wall,
            status=ev.STATUS_TEXT[status],
            formulation=ev.FORMULATION_TEXT[int(total[ev.S_FORMULATION])])
        if status != ev.STATUS_OK or not np.all(np.isfinite(Y)):
            raise SimulationError(
                f"integrator {self.name!r} stopped at t = {t:.6g} s: {ev.STATUS_TEXT[status]} "
                f"after {result_stats.n_steps} steps ({self.settings}); "
                + self._advice(status, system, t, y))
        return IntegrationResult(t=t_out, y=Y, ydot=YD, hist=hist, stats=result_stats,
                                 log=log if math.isfinite(log_from) else None, hist_out=H)


class RK4(Integrator):
    """Classical fourth-order Runge–Kutta at a fixed step (the paper's method).

    Steps never cross an output instant: a step longer than the output spacing is shortened
    to land on it, and a step is cut to locate a contact onset.

    Parameters
    ----------
    step : float
        The step (s), required.
    rtol, atol, max_steps, onset_tolerance
        As for :class:`Integrator` (the tolerances are not used).

    Examples
    --------
    >>> RK4(step=1e-4).settings
    {'step': 0.0001}
    """

    name = "rk4"
    adaptive = False
    defaults = {"step": None}

    def _advance(self, system, t0, y0, hist, t_out, ctl, log_from=math.inf, n_dense=0):
        from .explicit import rk4_kernel
        return rk4_kernel(system, t0, y0, hist, t_out, self.step, self.max_steps,
                          self.onset_tolerance, ctl, log_from, n_dense)


class DOPRI5(Integrator):
    """Adaptive Dormand–Prince 5(4) with PI step control and dense output.

    Parameters
    ----------
    step : float, optional
        Initial step (s), default automatic.
    rtol, atol : float, optional
        Tolerances, default 1e-8 and 1e-10.
    max_steps, onset_tolerance
        As for :class:`Integrator`.

    Examples
    --------
    >>> DOPRI5(rtol=1e-6).settings
    {'rtol': 1e-06, 'atol': 1e-10}
    """

    name = "dopri5"
    defaults = {"rtol": 1e-8, "atol": 1e-10}

    def _advance(self, system, t0, y0, hist, t_out, ctl, log_from=math.inf, n_dense=0):
        from .explicit import dopri5_kernel
        return dopri5_kernel(system, t0, y0, hist, t_out, self.step or 0.0, self.rtol,
                             self.atol, self.max_steps, self.onset_tolerance, ctl, log_from,
                             n_dense)
