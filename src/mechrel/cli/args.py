"""Argument types and error reporting shared by the ``mechrel`` subcommands and the study
scripts (``paper/*.py``)."""

from __future__ import annotations

import argparse
import sys

from .._checks import Checker
from ..errors import MechrelError, StudyError


def _rule(check, parse):
    """An argparse type: ``parse`` the text (kept as the text when it does not parse), then
    apply the validation toolkit's rule ``check`` (a :class:`mechrel._checks.Checker` method),
    so that the option breaks the same rule with the same message as the study file and the
    Python argument."""

    def convert(text: str):
        try:
            value = parse(text)
        except ValueError:
            value = text
        try:
            return check("", value)
        except MechrelError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = check.__name__  # argparse names the type in its messages
    convert.__doc__ = (f"Argparse type: the text parsed, then checked by the rule "
                       f"``{check.__name__}`` of :class:`mechrel._checks.Checker`.")
    return convert


_CLI = Checker(error=StudyError)


def _number(text: str) -> int | float:
    """``text`` as an int if it is one, else as a float (a non-integer count then breaks the
    integer rule with the rule's message rather than a parse error)."""
    try:
        return int(text)
    except ValueError:
        return float(text)


sample_count = _rule(_CLI.sample_count, _number)
"""Argparse type: a number of samples (:meth:`mechrel._checks.Checker.sample_count`)."""
jobs = _rule(_CLI.jobs, _number)
"""Argparse type: a number of parallel workers (:meth:`mechrel._checks.Checker.jobs`)."""
seed = _rule(_CLI.seed, _number)
"""Argparse type: a random seed (:meth:`mechrel._checks.Checker.seed`)."""
fraction = _rule(_CLI.fraction, _number)
"""Argparse type: a number in [0, 1] (:meth:`mechrel._checks.Checker.fraction`)."""


def _positive_integer(path, value):
    return _CLI.integer(path, value, ge=1)


positive_integer = _rule(_positive_integer, _number)
"""Argparse type: an integer >= 1 (a count that is not a sample count: a stride, a number of
points) (:meth:`mechrel._checks.Checker.integer`)."""


def report_errors(run, args, prog: str) -> int:
    """``run(args)`` for a study script; a :class:`~mechrel.errors.MechrelError` (a wrong
    argument or input) is one line ``PROG: error: ...`` on stderr and exit code 2."""
    try:
        return run(args)
    except MechrelError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2


def add_set_option(p: argparse.ArgumentParser, help_text: str) -> None:
    """``--set PATH=VALUE`` (repeatable) into ``args.overrides``."""
    p.add_argument("--set", dest="overrides", action="append", default=[],
                   metavar="PATH=VALUE", help=help_text)
