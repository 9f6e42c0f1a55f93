"""Exceptions a user can cause. Everything else is a bug."""

from __future__ import annotations


class MechrelError(Exception):
    """Base class of every error caused by user input or by a model that cannot be evaluated.

    Catch it to handle every error mechrel reports about its input; anything else is a bug.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> try:
    ...     load_scene("no-such-scene")
    ... except MechrelError as err:
    ...     print(type(err).__name__)
    SceneError
    """


class InputError(MechrelError, ValueError):
    """A value given by the user is invalid (the base of :class:`SceneError` and
    :class:`StudyError`, the errors :class:`mechrel._checks.Checker` raises).

    Parameters
    ----------
    message : str
        ``PATH = VALUE: PROBLEM; allowed: WHAT``.
    source : str, optional
        The file (or ``"<mapping>"``) the value comes from; it prefixes the message.
    path : str, optional
        The dotted path of the field.

    Examples
    --------
    >>> err = InputError("n = 1: must be >= 2; allowed: an integer >= 2", source="study.toml",
    ...                  path="n")
    >>> str(err), err.path, isinstance(err, ValueError)
    ('study.toml: n = 1: must be >= 2; allowed: an integer >= 2', 'n', True)
    """

    # set by the force-law parameter check (mechrel.forces.params) on the errors it raises, for
    # the scene loader's message; absent otherwise
    value: object
    allowed: str

    def __init__(self, message: str, *, source: str | None = None, path: str | None = None):
        self.source = source
        self.path = path
        prefix = f"{source}: " if source else ""
        super().__init__(prefix + message)


class SceneError(InputError):
    """A scene file or scene value is invalid.

    The message names the file (when there is one), the field path, the offending value and
    what is allowed.

    Parameters
    ----------
    message : str
        ``PATH = VALUE: PROBLEM; allowed: WHAT``.
    source : str, optional
        The file the value comes from; it prefixes the message.
    path : str, optional
        The dotted path of the field.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> try:
    ...     load_scene("slider-crank", overrides=["joints.C.clearance=-1e-3"])
    ... except SceneError as err:
    ...     print(err.path)
    joints.C.clearance
    """


class AssemblyError(MechrelError, RuntimeError):
    """The mechanism cannot be assembled: position constraints stay violated.

    Examples
    --------
    A slider-crank whose rod (0.03 m) is shorter than its crank (0.05 m): a quarter turn
    after t = 0 the crank pin is 0.05 m above the slider's line, out of the rod's reach:

    >>> from mechrel.mechanics.kinematics import assemble
    >>> from mechrel.mechanics.system import compile_scene
    >>> from mechrel.scene import load_scene
    >>> c = compile_scene(load_scene("slider-crank", overrides=["bodies.rod.length(A,B)=0.03"]))
    >>> try:
    ...     assemble(c.ideal, c.q_guess, 0.003, labels=c.labels["ideal"])
    ... except AssemblyError as err:
    ...     print(str(err)[:75])
    the mechanism cannot be assembled at t = 0.003 s: constraints stay violated
    """


class SimulationError(MechrelError, RuntimeError):
    """A simulation failed (non-finite state, step size underflow, too many steps).

    Examples
    --------
    >>> from mechrel.integrate import get_integrator
    >>> try:
    ...     get_integrator("dopri5", rtol=2.0)
    ... except SimulationError as err:
    ...     print(err)
    solver.rtol: must be < 1 (a relative tolerance of 1 asks for no accuracy), got 2.0
    """


class StudyError(InputError):
    """A study file or estimator argument is invalid.

    Parameters
    ----------
    message : str
        ``PATH = VALUE: PROBLEM; allowed: WHAT``.
    source : str, optional
        The file the value comes from; it prefixes the message.
    path : str, optional
        The dotted path of the field.

    Examples
    --------
    >>> from mechrel._checks import ARGS
    >>> try:
    ...     ARGS.sample_count("n", 1)
    ... except StudyError as err:
    ...     print(err)
    n = 1: must be >= 2; allowed: an integer >= 2 (a sample count)
    """


class CacheError(StudyError):
    """An evaluation cache cannot be used: not a mechrel cache, damaged, or not writable.

    The message names the file and what to do (delete it, or run without the cache).

    Parameters
    ----------
    message : str
        What is wrong and what to do.
    source : str, optional
        The cache file; it prefixes the message.
    path : str, optional
        Not used (a cache is a whole file).

    Examples
    --------
    >>> err = CacheError("not a mechrel cache; delete it or run without --cache",
    ...                  source="cache.sqlite")
    >>> isinstance(err, StudyError), str(err)
    (True, 'cache.sqlite: not a mechrel cache; delete it or run without --cache')
    """


class OutputError(StudyError):
    """An output folder or file cannot be used: not writable, or held by another run.

    Parameters
    ----------
    message : str
        What is wrong and what to do.
    source : str, optional
        The folder or file; it prefixes the message.
    path : str, optional
        The dotted path of the field that named it, if any.

    Examples
    --------
    >>> from mechrel.io.tables import check_table_path
    >>> try:
    ...     check_table_path("results/table.xlsx")
    ... except OutputError as err:
    ...     print(type(err).__name__)
    OutputError
    """


class WorkerError(MechrelError, RuntimeError):
    """A worker process of a parallel run ended without its result: killed by the system (out
    of memory) or from outside (``kill -9``). The finished chunks are cached; a rerun resumes.

    Examples
    --------
    >>> err = WorkerError("a worker process ended without a word (SIGKILL)")
    >>> isinstance(err, MechrelError), isinstance(err, RuntimeError)
    (True, True)
    """


class Interrupted(KeyboardInterrupt):
    """A run stopped by a signal (SIGTERM; Ctrl-C raises :class:`KeyboardInterrupt`).

    Raised on the main thread by the command line's signal handler, handled as Ctrl-C is.

    Parameters
    ----------
    signum : int
        The signal's number.

    Examples
    --------
    >>> import signal
    >>> err = Interrupted(signal.SIGTERM)
    >>> isinstance(err, KeyboardInterrupt), err.signum == signal.SIGTERM
    (True, True)
    """

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(signum)


class MechrelWarning(UserWarning):
    """Base class of mechrel's warnings.

    Examples
    --------
    Turn them into errors, e.g. in a test:

    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("error", MechrelWarning)
    ...     try:
    ...         warnings.warn("check this", EstimateWarning)
    ...     except MechrelWarning as w:
    ...         print(w)
    check this
    """


class EstimateWarning(MechrelWarning):
    """An estimate that may not be trustworthy: its assumptions are not met, its numerical
    basis is degenerate, or it disagrees with an independent estimate. The result carries the
    same text in its ``warnings`` field (and the study runners in the console and
    ``summary.json``), so that a report never states such a number without its caveat.

    Examples
    --------
    >>> issubclass(EstimateWarning, MechrelWarning), issubclass(EstimateWarning, UserWarning)
    (True, True)
    """


class SimulationWarning(MechrelWarning):
    """A simulation result whose numbers may be wrong by more than the effect it resolves:
    the run's ideal joints drifted apart by a tenth of the smallest clearance or more
    (:data:`mechrel.simulation.run.DRIFT_LIMIT`), so its errors are partly the integrator's.
    :func:`mechrel.simulation.simulate` issues it and the result carries the same text in its
    ``warnings`` field; a sample of a study (``simulate_sample``) with such a run fails with
    it as its reason instead.

    Examples
    --------
    >>> issubclass(SimulationWarning, MechrelWarning)
    True
    """


def interrupt_of(exc: BaseException) -> KeyboardInterrupt | None:
    """The :class:`KeyboardInterrupt` (Ctrl-C, or :class:`Interrupted` for SIGTERM) behind
    ``exc``, or None.

    Python runs a signal handler between bytecodes of the main thread, also inside a callback
    that compiled numba code makes into Python (it unpickles constants on a function's first
    call in a process); a handler that raises there reaches the caller as a ``SystemError``
    whose cause is the interrupt. Such an error is an interrupt, not a failure: the callers
    that handle interrupts (the evaluation loop, the command line) look through it.

    Parameters
    ----------
    exc : BaseException
        The exception caught.

    Returns
    -------
    KeyboardInterrupt or None
        The interrupt in ``exc``'s chain of causes and contexts (``exc`` itself included).

    Examples
    --------
    >>> try:
    ...     try:
    ...         raise KeyboardInterrupt
    ...     except KeyboardInterrupt as ki:
    ...         raise SystemError("error return without exception set") from ki
    ... except SystemError as err:
    ...     print(type(interrupt_of(err)).__name__, interrupt_of(ValueError()))
    KeyboardInterrupt None
    """
    seen: set[int] = set()
    link: BaseException | None = exc
    while link is not None and id(link) not in seen:
        if isinstance(link, KeyboardInterrupt):
            return link
        seen.add(id(link))
        link = link.__cause__ or link.__context__
    return None
