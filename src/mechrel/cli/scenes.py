"""``mechrel scenes``: list the embedded scenes, or describe one."""

from __future__ import annotations


def _cmd_scenes(args) -> int:
    from ..scene import list_scenes, load_scene
    from .terminal import say

    if args.name:
        scene = load_scene(args.name)
        say(f"{scene.name}: {scene.description}",
            f"  bodies:  {', '.join(scene.bodies)}",
            "  joints:  " + ", ".join(
                f"{j.name} ({j.type}{', ' + j.model + ' clearance' if j.is_clearance else ''})"
                for j in scene.joints.values()),
            "  drivers: " + (", ".join(
                f"{d.name} ({d.law}, {d.speed:g} rad/s)" for d in scene.drivers.values())
                or "none"),
            f"  outputs: {', '.join(scene.outputs)}")
        return 0
    for name, description in list_scenes().items():
        first = description.strip().splitlines()[0] if description.strip() else ""
        say(f"{name:28s} {first}")
    return 0


def register(sub) -> None:
    """Add the ``mechrel scenes`` subcommand to ``sub``, the parser's subparsers action
    (one entry of :data:`mechrel.cli.main.COMMANDS`).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="mechrel")
    >>> register(parser.add_subparsers(dest="command"))
    >>> parser.parse_args(["scenes"]).command
    'scenes'
    """
    p = sub.add_parser("scenes", help="list the embedded scenes, or describe one",
                       description="List the embedded scenes, or describe one.")
    p.add_argument("name", nargs="?", help="scene to describe")
    p.set_defaults(func=_cmd_scenes)
