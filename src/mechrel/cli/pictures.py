"""``mechrel draw`` and ``mechrel animate``: pictures of a scene (:mod:`mechrel.io.drawing`)."""

from __future__ import annotations

from pathlib import Path

from ..errors import MechrelError
from .args import add_set_option

_SET_HELP = "override a scene value by its dotted path, e.g. joints.C1.clearance=0.3e-3 " \
            "(repeatable)"


def _cmd_draw(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..io.drawing import draw_scene
    from ..scene import load_scene

    scene = load_scene(args.scene, overrides=args.overrides)
    out = Path(args.out)
    if out.suffix.lower() not in (".png", ".pdf", ".svg"):
        raise MechrelError(f"draw: --out = {args.out!r}: unknown file type; allowed: .png, "
                           ".pdf, .svg")
    fig = draw_scene(scene, t=args.time)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=args.dpi)
    plt.close(fig)
    print(f"wrote {out}")
    return 0


def _cmd_animate(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    from .._kernel_cache import warm_up
    from ..io.drawing import animate, animation_output, check_animation_path, save_animation
    from ..scene import load_scene
    from ..simulation import simulate
    from .simulate import _summary_lines

    scene = load_scene(args.scene, overrides=args.overrides)
    check_animation_path(args.out)  # before the simulation, not after it
    animation_output(scene, args.output, args.quantity)
    warm_up(scene, progress=not args.no_progress)  # announces a cold cache's compilation
    result = simulate(scene, progress=not args.no_progress)
    print("\n".join(_summary_lines(result)))
    anim = animate(result, output=args.output, quantity=args.quantity, frames=args.frames,
                   magnify=args.magnify)
    print(f"wrote {save_animation(anim, args.out, fps=args.fps)}")
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
    p.add_argument("--time", type=float, default=0.0, help="time (s) the drivers are set to "
                                                           "(default 0)")
    p.add_argument("--dpi", type=int, default=120, help="resolution of a .png (default 120)")
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
    p.add_argument("--frames", type=int, default=120, help="number of frames (default 120)")
    p.add_argument("--fps", type=int, default=20, help="frames per second (default 20)")
    p.add_argument("--output", help="output whose error is traced (default: the first)")
    p.add_argument("--quantity",
                   help="which error of the output: one of its kind's quantities (a point's "
                        "displacement, velocity, acceleration; a body's angle, ...; default: "
                        "the first)")
    p.add_argument("--magnify", type=float, help="draw a clearance circle of radius c with "
                                                 "radius MAGNIFY·c (default: 8 %% of the "
                                                 "mechanism's size)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_animate)
