"""Argument types and error reporting shared by the ``mechrel`` subcommands and the study
scripts (``studies/*.py``)."""

from __future__ import annotations

import argparse
import sys

from .._checks import Checker
from ..errors import MechrelError, StudyError


_TYPE_DOC = """Argparse type: {what} (:meth:`mechrel._checks.Checker.{rule}`).

The text is parsed as a number, then checked by the validation toolkit's rule, so that the
option breaks the same rule with the same message as the study file and the Python argument.

Parameters
----------
text : str
    The option's text.

Returns
-------
int or float
    The value.

Raises
------
argparse.ArgumentTypeError
    The value breaks the rule (argparse shows the message and exits with code 2).

Examples
--------
>>> {name}({good!r})
{value}
>>> {name}({bad!r})
Traceback (most recent call last):
...
argparse.ArgumentTypeError: {message}
"""


def _rule(check, parse, *, name: str, what: str, good: str, bad: str, rule: str | None = None):
    """An argparse type: ``parse`` the text (kept as the text when it does not parse), then
    apply the validation toolkit's rule ``check`` (a :class:`mechrel._checks.Checker` method),
    so that the option breaks the same rule with the same message as the study file and the
    Python argument. ``name``, ``what``, a ``good`` and a ``bad`` text and the ``Checker``
    method's name ``rule`` (default: ``check``'s) make its docstring, whose example runs as a
    doctest."""

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
    try:
        check("", parse(bad))
    except MechrelError as exc:
        message = str(exc)
    else:  # pragma: no cover - a wrong example is a bug of this module
        raise AssertionError(f"{bad!r} passes the rule {check.__name__}")
    convert.__doc__ = _TYPE_DOC.format(what=what, rule=rule or check.__name__, name=name,
                                       good=good, value=repr(convert(good)), bad=bad,
                                       message=message)
    return convert


_CLI = Checker(error=StudyError)


def _number(text: str) -> int | float:
    """``text`` as an int if it is one, else as a float (a non-integer count then breaks the
    integer rule with the rule's message rather than a parse error)."""
    try:
        return int(text)
    except ValueError:
        return float(text)


sample_count = _rule(_CLI.sample_count, _number, name="sample_count", what="a number of samples",
                     good="1000", bad="1")
jobs = _rule(_CLI.jobs, _number, name="jobs", what="a number of parallel workers", good="-1",
             bad="0")
seed = _rule(_CLI.seed, _number, name="seed", what="a random seed", good="42", bad="-3")
fraction = _rule(_CLI.fraction, _number, name="fraction", what="a number in [0, 1]",
                 good="0.25", bad="1.5")


def _probability(path, value):
    return _CLI.fraction(path, value, open_lo=True, open_hi=True)


probability = _rule(_probability, _number, name="probability",
                    what="a probability in (0, 1), e.g. a target reliability", good="0.999",
                    bad="1", rule="fraction")


def _positive_integer(path, value):
    return _CLI.integer(path, value, ge=1)


positive_integer = _rule(_positive_integer, _number, name="positive_integer",
                         what="an integer >= 1 (a count that is not a sample count: a stride, "
                              "a number of points)", good="5", bad="0", rule="integer")


MIN_DPI, MAX_DPI = 10, 1200
"""The resolutions ``mechrel draw`` accepts: below 10 dots per inch FreeType cannot render the
labels; at 1200 a drawing (7 × 6 in) is 8400 × 7200 pixels, about 250 MB of memory."""
MAX_FPS = 100
"""The frame rate ``mechrel animate`` accepts at most: a GIF stores each frame's duration in
hundredths of a second."""


def _dpi(path, value):
    return _CLI.integer(path, value, ge=MIN_DPI, le=MAX_DPI, what="dots per inch")


def _fps(path, value):
    return _CLI.integer(path, value, ge=1, le=MAX_FPS, what="frames per second")


def _frames(path, value):
    return _CLI.integer(path, value, ge=2, what="a number of frames")


def _positive(path, value):
    return _CLI.number(path, value, gt=0)


def _finite(path, value):
    return _CLI.number(path, value)


dpi = _rule(_dpi, _number, name="dpi", what="a resolution of a figure", good="120", bad="0",
            rule="integer")
fps = _rule(_fps, _number, name="fps", what="a frame rate of an animation", good="20",
            bad="1000000000", rule="integer")
frames = _rule(_frames, _number, name="frames", what="a number of frames", good="120", bad="1",
               rule="integer")
positive = _rule(_positive, _number, name="positive", what="a finite number > 0", good="8",
                 bad="-1", rule="number")
finite = _rule(_finite, _number, name="finite", what="a finite number", good="0.01",
               bad="inf", rule="number")


def report_errors(run, args, prog: str) -> int:
    """``run(args)`` for a study script; a :class:`~mechrel.errors.MechrelError` (a wrong
    argument or input) is one line ``PROG: error: ...`` on stderr and exit code 2.

    Parameters
    ----------
    run : callable
        The script's work, ``run(args) -> int``.
    args : argparse.Namespace
        The parsed arguments.
    prog : str
        The script's name for the message.

    Returns
    -------
    int
        ``run``'s exit code, or 2 after a ``MechrelError``.

    Examples
    --------
    >>> def run(args):
    ...     raise StudyError("n = 1: must be >= 2; allowed: an integer >= 2")
    >>> import contextlib, io
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:
    ...     code = report_errors(run, argparse.Namespace(), "study.py")
    >>> code, err.getvalue()
    (2, 'study.py: error: n = 1: must be >= 2; allowed: an integer >= 2\\n')
    """
    from .terminal import printable

    try:
        return run(args)
    except MechrelError as exc:
        print(printable(f"{prog}: error: {exc}"), file=sys.stderr)
        return 2


def add_set_option(p: argparse.ArgumentParser, help_text: str) -> None:
    """``--set PATH=VALUE`` (repeatable) into ``args.overrides``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The (sub)command's parser.
    help_text : str
        The option's help.

    Examples
    --------
    >>> p = argparse.ArgumentParser()
    >>> add_set_option(p, "override a scene value")
    >>> p.parse_args(["--set", "joints.C.clearance=1e-4", "--set", "gravity=[0, 0]"]).overrides
    ['joints.C.clearance=1e-4', 'gravity=[0, 0]']
    """
    p.add_argument("--set", dest="overrides", action="append", default=[],
                   metavar="PATH=VALUE", help=help_text)
