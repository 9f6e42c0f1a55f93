"""Argument types and error reporting shared by the ``mechrel`` subcommands and the study
scripts (``paper/*.py``)."""

from __future__ import annotations

import argparse
import math
import sys

from ..errors import MechrelError


def positive_int(text: str) -> int:
    """Argparse type: an integer >= 1."""
    if not (text.isdigit() and int(text) >= 1):
        raise argparse.ArgumentTypeError(f"{text!r}: not a positive integer; allowed: 1, 2, ...")
    return int(text)


def jobs(text: str) -> int:
    """Argparse type: a number of parallel workers, an integer >= 1 or -1 (all)."""
    if not (text.isdigit() and int(text) >= 1) and text.strip() != "-1":
        raise argparse.ArgumentTypeError(f"{text!r}: not a number of workers; allowed: 1, 2, "
                                         "... or -1 (all cores, or all the cluster's workers)")
    return int(text)


def seed(text: str) -> int:
    """Argparse type: a seed, an integer >= 0."""
    if not text.isdigit():
        raise argparse.ArgumentTypeError(f"{text!r}: not a seed; allowed: an integer >= 0")
    return int(text)


def fraction(text: str) -> float:
    """Argparse type: a number in [0, 1]."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"{text!r}: not a number in [0, 1]; allowed: a number "
                                         "in [0, 1]")
    return value


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
