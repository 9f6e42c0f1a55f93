"""``mechrel reliability`` and ``mechrel sensitivity``."""

from __future__ import annotations

import argparse
import math
import sys

from ..errors import MechrelError


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    if not (text.isdigit() and int(text) >= 1):
        raise argparse.ArgumentTypeError(f"{text!r}: not a positive integer; allowed: 1, 2, ...")
    return int(text)


def seed_int(text: str) -> int:
    """argparse type: an integer >= 0."""
    if not text.isdigit():
        raise argparse.ArgumentTypeError(f"{text!r}: not a non-negative integer; allowed: 0, 1, "
                                         "2, ...")
    return int(text)


def jobs_int(text: str) -> int:
    """argparse type: an integer >= 1, or -1 (all cores)."""
    if not (text == "-1" or text.isdigit() and int(text) >= 1):
        raise argparse.ArgumentTypeError(f"{text!r}: not a number of workers; allowed: 1, 2, "
                                         "... or -1 (all cores)")
    return int(text)


def fraction(text: str) -> float:
    """argparse type: a number in [0, 1]."""
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


def _study_args(p, section):
    p.add_argument("study", nargs="?", default="nine-bar-lubricated", metavar="STUDY",
                   help="embedded study name or path to a study .toml "
                        "(default: nine-bar-lubricated)")
    p.add_argument("--scene", metavar="SCENE",
                   help="embedded scene name or scene file to use instead of the study's "
                        "scene (a file the study names must be in the study file's folder)")
    p.add_argument("--n", type=positive_int, help="number of samples (default: the study's)")
    p.add_argument("--jobs", type=jobs_int, default=2,
                   help="parallel workers, -1 for all cores (default 2)")
    p.add_argument("--seed", type=seed_int, help="random seed, >= 0 (default: the study's)")
    p.add_argument("--max-failure-fraction", type=fraction, metavar="F",
                   help="refuse to estimate when more than this fraction of the samples failed "
                        f"(default: the study's {section}.max_failure_fraction); the failed "
                        "samples are written to OUT either way")
    p.add_argument("--out", default="results", metavar="DIR",
                   help="output folder (default: results/)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-cache", action="store_true",
                   help="do not read or write OUT/evaluations.sqlite (e.g. when it is damaged "
                        "and you want to keep it)")


def _cmd_reliability(args) -> int:
    from .runner import run_reliability
    from .study import load_study

    study = load_study(args.study, overrides={"scene": args.scene} if args.scene else None)
    methods = None if args.method is None else (args.method,)
    lines, _ = run_reliability(study, methods=methods, n=args.n, n_jobs=args.jobs,
                               seed=args.seed, out=args.out, progress=not args.no_progress,
                               max_failure_fraction=args.max_failure_fraction,
                               cache=not args.no_cache)
    print("\n".join(lines))
    return 0


def _cmd_sensitivity(args) -> int:
    from .runner import run_sensitivity
    from .study import load_study

    study = load_study(args.study, overrides={"scene": args.scene} if args.scene else None)
    lines, _ = run_sensitivity(study, n=args.n, n_jobs=args.jobs, seed=args.seed, out=args.out,
                               progress=not args.no_progress,
                               max_failure_fraction=args.max_failure_fraction,
                               cache=not args.no_cache)
    print("\n".join(lines))
    return 0


def _cmd_accuracy(args) -> int:
    from ..scene import load_scene
    from .accuracy import run_accuracy

    scene = load_scene(args.scene, overrides=args.overrides)
    lines, _ = run_accuracy(scene, target=args.target, quick=args.quick, out=args.out,
                            progress=not args.no_progress, ensemble=args.ensemble,
                            seed=args.seed)
    print("\n".join(lines))
    return 0


def register_commands(sub) -> None:
    p = sub.add_parser(
        "reliability", help="accuracy reliability of a study (FOSM, Monte Carlo, PCE)",
        description="Reliability of the output errors staying within their allowables, per "
                    "crank angle and over the whole cycle, by FOSM (the paper's method), Monte "
                    "Carlo and polynomial chaos. Finished model evaluations are cached in "
                    "OUT/evaluations.sqlite, so an interrupted run resumes where it stopped. "
                    "Failed samples are written to OUT/failures.csv.")
    _study_args(p, "reliability")
    p.add_argument("--method", choices=("fosm", "mc", "pce", "all"),
                   help="estimator (default: the study's reliability.methods)")
    p.set_defaults(func=_cmd_reliability)

    p = sub.add_parser(
        "sensitivity", help="Sobol sensitivity indices of a study's error measures",
        description="First- and total-order Sobol indices (SALib, Saltelli design with N base "
                    "samples: N (d + 2) model runs) of the peak |error| over the cycle of each "
                    "quantity with respect to the study's uncertain inputs. Failed samples are "
                    "written to OUT/sensitivity_failures.csv.")
    _study_args(p, "sensitivity")
    p.set_defaults(func=_cmd_sensitivity)

    p = sub.add_parser(
        "accuracy", help="error against wall time of integrator settings on a scene",
        description="Runs the scene with RK4 step sizes, adaptive and stiff tolerances, "
                    "measures each against a tight-tolerance reference (pointwise errors, or, "
                    "for chaotic dry-contact scenes, the ensemble means of the error curves' "
                    "statistics over R perturbed initial states, with their statistical floor), "
                    "prints a table, saves a plot and recommends the fastest setting that "
                    "meets the target — or says that the target is below the floor at this R.")
    p.add_argument("scene", metavar="SCENE", help="embedded scene name or .toml path")
    p.add_argument("--set", dest="overrides", action="append", default=[],
                   metavar="PATH=VALUE", help="override a scene value (repeatable)")
    p.add_argument("--target", type=float, default=0.01,
                   help="relative error to meet (default 0.01)")
    p.add_argument("--quick", action="store_true", help="fewer settings")
    p.add_argument("--ensemble", type=int, metavar="R",
                   help="dry/transition scenes: perturbed initial states per setting, >= 2 "
                        "(default 8; the floor falls as 1/sqrt(R), the run time grows R-fold)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the ensemble's perturbations (default 0)")
    p.add_argument("--out", default="results/accuracy", metavar="DIR")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=_cmd_accuracy)
