"""``mechrel accuracy``: error against wall time of integrator settings on a scene."""

from __future__ import annotations

from .args import add_set_option, positive, seed
from .terminal import say


def _cmd_accuracy(args) -> int:
    from ..scene import load_scene
    from ..study.accuracy import run_accuracy

    scene = load_scene(args.scene, overrides=args.overrides)
    lines, _ = run_accuracy(scene, target=args.target, quick=args.quick, out=args.out,
                            progress=not args.no_progress, ensemble=args.ensemble,
                            seed=args.seed)
    say(*lines)
    return 0


def register(sub) -> None:
    """Add the ``mechrel accuracy`` subcommand to ``sub``, the parser's subparsers action
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
    >>> parser.parse_args(["accuracy", "slider-crank"]).command
    'accuracy'
    """
    p = sub.add_parser(
        "accuracy", help="error against wall time of integrator settings on a scene",
        description="Runs the scene with RK4 step sizes, adaptive and stiff tolerances, "
                    "measures each against a tight-tolerance reference (pointwise errors, or, "
                    "for chaotic dry-contact scenes, the ensemble means of the error curves' "
                    "statistics over R perturbed initial states, with their statistical floor), "
                    "prints a table, saves a plot and recommends the fastest setting that "
                    "meets the target — or says that the target is below the floor at this R.")
    p.add_argument("scene", metavar="SCENE", help="embedded scene name or .toml path")
    add_set_option(p, "override a scene value (repeatable)")
    p.add_argument("--target", type=positive, default=0.01,
                   help="relative error to meet (default 0.01)")
    p.add_argument("--quick", action="store_true", help="fewer settings")
    p.add_argument("--ensemble", type=int, metavar="R",
                   help="dry/transition scenes: perturbed initial states per setting, >= 2 "
                        "(default 8; the floor falls as 1/sqrt(R), the run time grows R-fold)")
    p.add_argument("--seed", type=seed, default=0,
                   help="seed of the ensemble's perturbations (default 0)")
    p.add_argument("--out", default="results/accuracy", metavar="DIR")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=_cmd_accuracy)
