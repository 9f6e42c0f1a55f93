"""``mechrel draw`` and ``mechrel animate``: pictures of a scene (:mod:`mechrel.io.drawing`).

Every argument and the output file are checked before anything is assembled or simulated
(a wrong ``--fps`` must not surface after a minute of rendering), and the picture is written as
a set of one file (:func:`mechrel.io.results.result_set`): an interrupt, a full disk or a
read-only folder leaves the previous file as it was, never a truncated GIF that looks valid.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import OutputError
from .args import add_set_option, dpi, finite, fps, frames, positive

_SET_HELP = "override a scene value by its dotted path, e.g. joints.C1.clearance=0.3e-3 " \
            "(repeatable)"
DRAWING_FORMATS = (".png", ".pdf", ".svg")
"""The file types of ``mechrel draw``."""


def _checked_out(text: str, suffixes) -> Path:
    """``--out`` as a file of one of ``suffixes`` in a folder that exists or can be created,
    is writable and holds no folder of that name; before anything runs."""
    from ..io.results import check_folder

    out = Path(text)
    if out.suffix.lower() not in suffixes:
        raise OutputError(f"--out = {text!r}: unknown file type {out.suffix or '(none)'!r}; "
                          f"allowed: {', '.join(suffixes)}")
    check_folder(out.parent, [out.name], what="--out")
    return out


def _cmd_draw(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io import save_figure
    from ..io.drawing import draw_scene
    from ..io.results import result_set
    from ..scene import load_scene
    from .terminal import say

    scene = load_scene(args.scene, overrides=args.overrides)
    out = _checked_out(args.out, DRAWING_FORMATS)
    fig = draw_scene(scene, t=args.time)
    try:
        with result_set(out.parent, out.name, what="--out", manifest=False) as stage:
            save_figure(fig, stage / out.name, dpi=args.dpi)
    finally:
        plt.close(fig)
    say(f"wrote {out}")
    return 0


def _cmd_animate(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    from ..warmup import warm_up
    from ..io.drawing import (ANIMATION_FORMATS, animate, animation_output,
                              check_animation_path, save_animation)
    from ..io.results import result_set
    from ..scene import load_scene
    from ..simulation import simulate
    from .simulate import _summary_lines
    from .terminal import say

    scene = load_scene(args.scene, overrides=args.overrides)
    # before the simulation, not after it: the file type (and ffmpeg for MP4), the folder,
    # the output and its quantity
    out = _checked_out(args.out, ANIMATION_FORMATS)
    check_animation_path(out)
    animation_output(scene, args.output, args.quantity)
    warm_up(scene, progress=not args.no_progress)  # announces a cold cache's compilation
    result = simulate(scene, progress=not args.no_progress)
    say(*_summary_lines(result))
    anim = animate(result, output=args.output, quantity=args.quantity, frames=args.frames,
                   magnify=args.magnify)
    with result_set(out.parent, out.name, what="--out", manifest=False) as stage:
        save_animation(anim, stage / out.name, fps=args.fps)
    say(f"wrote {out}")
    return 0


def register_draw(sub) -> None:
    """Add the ``mechrel draw`` subcommand to ``sub``, the parser's subparsers action
    (one entry of :data:`mechrel.cli.main.COMMANDS`).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="mechrel")
    >>> register_draw(parser.add_subparsers(dest="command"))
    >>> parser.parse_args(["draw", "slider-crank", "--out", "crank.png"]).command
    'draw'
    """
    p = sub.add_parser(
        "draw", help="draw a scene's assembled configuration",
        description="Assemble a scene at time --time and draw it (bodies, joints, clearance "
                    "joints in red, slider guides, ground, labels) into --out.")
    p.add_argument("scene", metavar="SCENE", help="embedded scene name or path to a .toml file")
    add_set_option(p, _SET_HELP)
    p.add_argument("--out", required=True, metavar="FIG.png|.pdf|.svg", help="figure file")
    p.add_argument("--time", type=finite, default=0.0, help="time (s) the drivers are set to "
                                                            "(default 0)")
    p.add_argument("--dpi", type=dpi, default=120,
                   help="resolution of a .png, 10 to 1200 dots per inch (default 120)")
    p.set_defaults(func=_cmd_draw)


def register_animate(sub) -> None:
    """Add the ``mechrel animate`` subcommand to ``sub``, the parser's subparsers action
    (one entry of :data:`mechrel.cli.main.COMMANDS`).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="mechrel")
    >>> register_animate(parser.add_subparsers(dest="command"))
    >>> parser.parse_args(["animate", "slider-crank", "--out", "crank.gif"]).command
    'animate'
    """
    p = sub.add_parser(
        "animate", help="simulate a scene and animate it",
        description="Simulate a scene and animate it: the mechanism, its ideal counterpart as a "
                    "ghost, the journal orbits magnified inside each clearance circle, and an "
                    "output's error traced beside it. GIF (Pillow), HTML (self-contained page) "
                    "or MP4 (needs ffmpeg), by the suffix of --out.")
    p.add_argument("scene", metavar="SCENE", help="embedded scene name or path to a .toml file")
    add_set_option(p, _SET_HELP)
    p.add_argument("--out", required=True, metavar="ANIM.gif|.html|.mp4", help="animation file")
    p.add_argument("--frames", type=frames, default=120,
                   help="number of frames, >= 2 (default 120)")
    p.add_argument("--fps", type=fps, default=20,
                   help="frames per second, 1 to 100 (default 20)")
    p.add_argument("--output", help="output whose error is traced (default: the first)")
    p.add_argument("--quantity",
                   help="which error of the output: one of its kind's quantities (a point's "
                        "displacement, velocity, acceleration; a body's angle, ...; default: "
                        "the first)")
    p.add_argument("--magnify", type=positive, help="draw a clearance circle of radius c with "
                                                 "radius MAGNIFY·c (default: 8 %% of the "
                                                 "mechanism's size)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_animate)
