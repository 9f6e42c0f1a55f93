"""Exceptions a user can cause. Everything else is a bug."""

from __future__ import annotations


class MechrelError(Exception):
    """Base class of every error caused by user input or by a model that cannot be evaluated."""


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
    """

    def __init__(self, message: str, *, source: str | None = None, path: str | None = None):
        self.source = source
        self.path = path
        prefix = f"{source}: " if source else ""
        super().__init__(prefix + message)


class SceneError(InputError):
    """A scene file or scene value is invalid.

    The message names the file (when there is one), the field path, the offending value and
    what is allowed.
    """


class AssemblyError(MechrelError, RuntimeError):
    """The mechanism cannot be assembled: position constraints stay violated."""


class SimulationError(MechrelError, RuntimeError):
    """A simulation failed (non-finite state, step size underflow, too many steps)."""


class StudyError(InputError):
    """A study file or estimator argument is invalid."""


class CacheError(StudyError):
    """An evaluation cache cannot be used: not a mechrel cache, damaged, or not writable.

    The message names the file and what to do (delete it, or run without the cache)."""


class OutputError(StudyError):
    """An output folder or file cannot be used: not writable, or held by another run."""


class Interrupted(KeyboardInterrupt):
    """A run stopped by a signal (SIGTERM; Ctrl-C raises :class:`KeyboardInterrupt`): raised
    on the main thread by the command line's signal handler, handled as Ctrl-C is."""

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(signum)


class MechrelWarning(UserWarning):
    """Base class of mechrel's warnings."""


class EstimateWarning(MechrelWarning):
    """An estimate that may not be trustworthy: its assumptions are not met, its numerical
    basis is degenerate, or it disagrees with an independent estimate. The result carries the
    same text in its ``warnings`` field (and the study runners in the console and
    ``summary.json``), so that a report never states such a number without its caveat."""


def interrupt_of(exc: BaseException) -> KeyboardInterrupt | None:
    """The :class:`KeyboardInterrupt` (Ctrl-C, or :class:`Interrupted` for SIGTERM) behind
    ``exc``, or None.

    Python runs a signal handler between bytecodes of the main thread, also inside a callback
    that compiled numba code makes into Python (it unpickles constants on a function's first
    call in a process); a handler that raises there reaches the caller as a ``SystemError``
    whose cause is the interrupt. Such an error is an interrupt, not a failure: the callers
    that handle interrupts (the evaluation loop, the command line) look through it."""
    seen: set[int] = set()
    link: BaseException | None = exc
    while link is not None and id(link) not in seen:
        if isinstance(link, KeyboardInterrupt):
            return link
        seen.add(id(link))
        link = link.__cause__ or link.__context__
    return None
