"""The ``mechrel`` command (also ``python -m mechrel``).

Every subcommand is a module of this package with a ``register(subparsers)`` function, listed
in :data:`COMMANDS`: adding a command is one module plus one line there. Nothing is imported
conditionally, so a command that cannot be imported is an error, not a command that silently
disappears from the help.
"""

from __future__ import annotations

import argparse
import sys

from ..errors import MechrelError
from . import accuracy, pictures, scenes, simulate, studies
from .simulate import EPILOG

COMMANDS = (
    scenes.register,
    simulate.register,
    pictures.register_draw,
    pictures.register_animate,
    studies.register_reliability,
    studies.register_sensitivity,
    accuracy.register,
)
"""The subcommands' registration functions, in the order of the help."""


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="mechrel",
        description="Dynamic response errors and accuracy reliability of planar mechanisms "
                    "with clearance joints (dry contact, lubricated journal bearings).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"mechrel {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in COMMANDS:
        register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return args.func(args)
    except MechrelError as exc:
        print(f"mechrel: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mechrel: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
