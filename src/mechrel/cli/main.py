"""The ``mechrel`` command (also ``python -m mechrel``).

Every subcommand is a module of this package with a ``register(subparsers)`` function, listed
in :data:`COMMANDS`: adding a command is one module plus one line there. Every command is
imported when the parser is built (inside :func:`main`'s interrupt handling), none
conditionally, so a command that cannot be imported is an error, not a command that silently
disappears from the help.
"""

from __future__ import annotations

# Only light modules here: the console script imports this module before main() runs, and an
# interrupt before main() installs its handlers is Python's traceback. argparse, pathlib and
# the subcommands (numpy, pandas, scipy, numba: seconds) are imported inside main()'s handlers.
import sys
import warnings

from ..errors import Interrupted, MechrelError, MechrelWarning, interrupt_of
from .terminal import printable, say

COMMANDS = (
    "scenes:register",
    "simulate:register",
    "pictures:register_draw",
    "pictures:register_animate",
    "studies:register_reliability",
    "studies:register_sensitivity",
    "studies:register_design",
    "accuracy:register",
)
"""The subcommands' registration functions as ``"module:function"`` of this package, in the
order of the help (imported by :func:`build_parser`)."""


def registrations():
    """The registration functions of :data:`COMMANDS`, importing their modules.

    Returns
    -------
    list of callable
        ``register(subparsers)`` of each subcommand, in order.

    Examples
    --------
    >>> [f.__name__ for f in registrations()][:2]
    ['register', 'register']
    """
    import importlib

    out = []
    for entry in COMMANDS:
        module, name = entry.split(":")
        out.append(getattr(importlib.import_module(f".{module}", __package__), name))
    return out


def _parser_class():
    """Argparse's parser whose error line is one line with its control characters escaped
    (argparse quotes an unrecognised argument as it was typed)."""
    import argparse

    class Parser(argparse.ArgumentParser):
        def error(self, message):
            self.print_usage(sys.stderr)
            self.exit(2, f"{self.prog}: error: {printable(message)}\n")

    return Parser


def build_parser():
    """The ``mechrel`` argument parser: every subcommand of :data:`COMMANDS`, in order.

    Returns
    -------
    argparse.ArgumentParser
        The parser; each subcommand sets ``args.func``.

    Examples
    --------
    >>> args = build_parser().parse_args(["simulate", "slider-crank", "--set", "gravity=[0, 0]"])
    >>> args.command, args.scene, args.overrides
    ('simulate', 'slider-crank', ['gravity=[0, 0]'])
    """
    import argparse

    from .. import __version__
    from .simulate import EPILOG

    parser = _parser_class()(
        prog="mechrel",
        description="Dynamic response errors and accuracy reliability of planar mechanisms "
                    "with clearance joints (dry contact, lubricated journal bearings).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"mechrel {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in registrations():
        register(sub)
    return parser


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


def _interrupted_line(exc: KeyboardInterrupt, args) -> str:
    """One line for an interrupt: by what, and what of the run is kept (the evaluation cache,
    when the run has one on disk)."""
    import signal

    name = signal.Signals(exc.signum).name if isinstance(exc, Interrupted) else "Ctrl-C"
    line = f"mechrel: interrupted ({name})"
    if args is None:  # while the arguments were parsed or the command imported
        return line
    from pathlib import Path

    out = getattr(args, "out", None)
    if args.command in ("reliability", "sensitivity") and out and not args.no_cache:
        db = Path(out) / "evaluations.sqlite"
        if db.is_file():
            line += (f"; the finished model evaluations are kept in {db}: the same command "
                     "resumes from them")
    return line


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Mechrel's own warnings as one line ``mechrel: warning: ...``; others as Python shows
    them (where, category, message; then the source line), their control characters escaped
    as well (matplotlib's "Glyph 27 (\\x1b) missing" quotes a name's escape character)."""
    out = sys.stderr if file is None else file
    if issubclass(category, MechrelWarning):
        say(f"mechrel: warning: {message}", file=out)
        return
    import linecache

    say(f"{filename}:{lineno}: {category.__name__}: {message}", file=out)
    source = (line if line is not None else linecache.getline(filename, lineno)).strip()
    if source:
        say(f"  {source}", file=out)


def main(argv=None) -> int:
    """The command line. A :class:`~mechrel.errors.MechrelError`, or an ``OSError`` about a
    file (a name too long, no permission, a full disk), is one line on stderr and exit code 2;
    Ctrl-C and SIGTERM stop the run promptly (running integrations at their next step,
    worker processes at once) with one line, exit code 128 + the signal number (130, 143) —
    also while the arguments are parsed and the command's modules imported.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 on success, 2 after a ``MechrelError`` or a file's ``OSError``, 128 +
        the signal number after an interrupt.

    Examples
    --------
    >>> import contextlib, io
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:
    ...     code = main(["scenes", "no-such-scene"])
    >>> code, err.getvalue().startswith("mechrel: error: ")
    (2, True)
    """
    import signal

    # first, before the imports of the subcommands (seconds): SIGTERM is an interrupt too
    try:
        old_term, on_main = signal.signal(signal.SIGTERM, _raise_interrupted), True
    except ValueError:  # not the main thread: no signal handlers there
        old_term, on_main = None, False
    args = None
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        if not getattr(args, "func", None):
            parser.print_help()
            return 0
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return args.func(args)
    except (KeyboardInterrupt, Exception) as exc:
        # an interrupt, or an error raised while one was handled (a SystemError from a numba
        # callback, errors.interrupt_of; a RuntimeError from joblib's abort of a worker pool
        # whose manager thread Ctrl-C caught starting): the interrupt's one line
        interrupt = interrupt_of(exc)
        if interrupt is not None:
            say(_interrupted_line(interrupt, args), file=sys.stderr)
            return 128 + (interrupt.signum if isinstance(interrupt, Interrupted)
                          else signal.SIGINT)
        if isinstance(exc, MechrelError):
            say(f"mechrel: error: {exc}", file=sys.stderr)
            return 2
        if isinstance(exc, BrokenPipeError):  # `mechrel simulate ... | head`: the reader left
            import os
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit
            return 128 + signal.SIGPIPE
        if isinstance(exc, OSError) and exc.filename is not None:
            # a path the system refuses wherever it is first touched (a name too long for the
            # file system, a folder without permission, a full disk): one line, as a bad
            # argument's
            say(f"mechrel: error: {exc.filename}: {exc.strerror or exc}; allowed: a path this "
                "system can read or write", file=sys.stderr)
            return 2
        raise
    finally:
        # the command's worker pool ends with it, its resources unregistered (a signal now is
        # held and dropped: the command's work and its lines are done)
        if "joblib" in sys.modules:
            from .._signals import signals_held
            from ..uq.execution._workers import end_pool

            with signals_held(deliver=False):
                end_pool()
        if on_main:
            signal.signal(signal.SIGTERM, old_term)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
