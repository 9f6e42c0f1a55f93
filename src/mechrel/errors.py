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


class MechrelWarning(UserWarning):
    """Base class of mechrel's warnings."""


class EstimateWarning(MechrelWarning):
    """An estimate that may not be trustworthy: its assumptions are not met, its numerical
    basis is degenerate, or it disagrees with an independent estimate. The result carries the
    same text in its ``warnings`` field (and the study runners in the console and
    ``summary.json``), so that a report never states such a number without its caveat."""
