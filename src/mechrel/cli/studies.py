"""``mechrel reliability``, ``mechrel sensitivity`` and ``mechrel design``: a study file run by
the estimators of :mod:`mechrel.uq` (:mod:`mechrel.study.runner`,
:mod:`mechrel.study.design`)."""

from __future__ import annotations

import contextlib
import warnings

from ..errors import StudyError
from .args import add_set_option, fraction, jobs, probability, sample_count, seed
from .terminal import say

SET_HELP = ("override a value (repeatable): a study field by its dotted path "
            "(reliability.n=512, inputs.clearance.std=2e-5, allowable.velocity.mean=0.2, "
            "reference=same-geometry) or, for any other path, a scene value "
            "(joints.C1.model=dry), applied after the study's scene_overrides")


def split_overrides(texts) -> tuple[dict, dict]:
    """Split ``PATH=VALUE`` strings into study-field overrides and scene overrides.

    A path whose first part is a field of a study file (``reliability``, ``inputs``,
    ``allowable``, ``angle_step``, ...; docs/studies.md) sets that field; any other path is a
    scene path, checked against the scene when the study's model is built.

    Parameters
    ----------
    texts : iterable of str
        The ``--set`` values, ``PATH=VALUE`` each (values in SI units).

    Returns
    -------
    study : dict
        ``{path: value}`` of the study fields.
    scene : dict
        ``{path: value}`` of the scene values.

    Raises
    ------
    StudyError
        If a path starts with ``scene_overrides`` (a scene value is set by its own path).
    SceneError
        If a text is not ``PATH=VALUE``.

    Examples
    --------
    >>> split_overrides(["reliability.n=512", "joints.C1.model=dry"])
    ({'reliability.n': 512}, {'joints.C1.model': 'dry'})
    """
    from ..scene.loader import parse_override
    from ..study.study import study_fields

    study, scene = {}, {}
    fields = study_fields()
    for text in texts:
        path, value = parse_override(text)
        head = path.split(".", 1)[0]
        if head == "scene_overrides":
            raise StudyError(f"--set {text}: 'scene_overrides' is set by giving the scene path "
                             "itself; allowed: e.g. --set joints.C1.model=dry")
        (study if head in fields else scene)[path] = value
    return study, scene


SCHEDULER_TIMEOUT = 10.0
"""Seconds ``--scheduler`` waits for a Dask scheduler's answer before it gives up."""
_ALLOWED_SCHEDULER = ("allowed: the address of a running Dask scheduler, e.g. "
                      "tcp://127.0.0.1:8786 (port 8786; 8787 is its dashboard's)")


def _identify(address: str, timeout: float) -> dict:
    """The reply of whatever listens at ``address`` to Dask's ``identity`` request, within
    ``timeout`` s (distributed's own connect waits for ever for a server that accepts and
    never answers, and reads a web server's reply as a message of exabytes)."""
    import asyncio

    from distributed.comm import connect

    async def ask():
        comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
        try:
            await asyncio.wait_for(comm.write({"op": "identity", "reply": True}), timeout)
            return await asyncio.wait_for(comm.read(), timeout)
        finally:
            comm.abort()

    return asyncio.run(ask())


@contextlib.contextmanager
def dask_backend(address: str | None, *, timeout: float = SCHEDULER_TIMEOUT):
    """The executor backend for ``--scheduler``, as a context manager.

    Parameters
    ----------
    address : str or None
        The address of a running Dask scheduler (e.g. ``tcp://10.0.0.5:8786``), or None.
    timeout : float, default SCHEDULER_TIMEOUT
        Seconds to wait for the scheduler's answer.

    Yields
    ------
    str
        ``"loky"`` without an address; with one, ``"dask"``, a :class:`distributed.Client`
        connected to the scheduler for the duration.

    Raises
    ------
    StudyError
        If dask.distributed is not installed, nothing accepts a connection at ``address``,
        what answers is not a Dask scheduler (its dashboard, a worker, another server), or
        nothing answers within ``timeout`` s.

    Examples
    --------
    >>> with dask_backend(None) as backend:
    ...     backend
    'loky'
    """
    if address is None:
        yield "loky"
        return
    try:
        from distributed import Client
    except ImportError:
        raise StudyError(f"--scheduler = {address!r}: dask.distributed is not installed; "
                         "allowed: pip install 'mechrel[dask]', or leave out --scheduler") from None
    where = f"--scheduler = {address!r}"
    try:
        reply = _identify(address, timeout)
    except TimeoutError:
        raise StudyError(f"{where}: no answer within {timeout:g} s; {_ALLOWED_SCHEDULER}") from None
    except OSError as exc:  # refused, unreachable (distributed's CommClosedError included)
        raise StudyError(f"{where}: cannot connect to a Dask scheduler there "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())}); "
                         f"{_ALLOWED_SCHEDULER}") from None
    except Exception as exc:  # noqa: BLE001 - any other failure to speak Dask's protocol
        raise StudyError(f"{where}: what answers there does not speak Dask's protocol (a web "
                         f"page, e.g. the dashboard, or another server: {type(exc).__name__}); "
                         f"{_ALLOWED_SCHEDULER}") from None
    kind = reply.get("type") if isinstance(reply, dict) else None
    if kind != "Scheduler":
        raise StudyError(f"{where}: a Dask {kind or 'server'} answers there, not a scheduler; "
                         f"{_ALLOWED_SCHEDULER}")
    try:
        client = Client(address, timeout=f"{timeout}s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise StudyError(f"{where}: cannot connect to a Dask scheduler there "
                         f"({type(exc).__name__}: {' '.join(str(exc).split())}); "
                         f"{_ALLOWED_SCHEDULER}") from None
    try:
        yield "dask"
    finally:
        client.close()


@contextlib.contextmanager
def _warnings_in_summary():
    """The estimates' :class:`~mechrel.errors.EstimateWarning` are lines of the printed summary
    (and of its JSON), not also Python warnings on stderr."""
    from ..errors import EstimateWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EstimateWarning)
        yield


def _load(args):
    from ..study.study import load_study

    study_fields, scene = split_overrides(args.overrides)
    if args.scene:  # given on the command line: not confined to the study file's folder
        study_fields["scene"] = args.scene
    study = load_study(args.study, overrides=study_fields, scene_overrides=scene)
    study.model()  # every scene path and input checked here, before anything runs
    return study


def _target(text: str):
    """``--target-reliability``: a probability in (0, 1), or ``none`` (False: the study's
    ``inverse.target`` is not asked)."""
    return False if text.strip().lower() == "none" else probability(text)


_target.__name__ = "probability"  # argparse names the type in its messages


def _jobs(args) -> int:
    if args.jobs is not None:
        return args.jobs
    return -1 if args.scheduler else 2


def _cmd_reliability(args) -> int:
    from ..study.runner import run_reliability

    study = _load(args)
    methods = None if args.method is None else tuple(args.method)
    with dask_backend(args.scheduler) as backend, _warnings_in_summary():
        lines, _ = run_reliability(study, methods=methods, n=args.n, n_jobs=_jobs(args),
                                   seed=args.seed, out=args.out, backend=backend,
                                   progress=not args.no_progress,
                                   max_failure_fraction=args.max_failure_fraction,
                                   cache=not args.no_cache,
                                   target_reliability=args.target_reliability)
    say(*lines)
    return 0


def _cmd_sensitivity(args) -> int:
    from ..study.runner import run_sensitivity

    study = _load(args)
    with dask_backend(args.scheduler) as backend, _warnings_in_summary():
        lines, _ = run_sensitivity(study, n=args.n, n_jobs=_jobs(args), seed=args.seed,
                                   out=args.out, backend=backend, progress=not args.no_progress,
                                   max_failure_fraction=args.max_failure_fraction,
                                   cache=not args.no_cache)
    say(*lines)
    return 0


def _cmd_design(args) -> int:
    from ..study.design import run_design

    study = _load(args)
    with dask_backend(args.scheduler) as backend, _warnings_in_summary():
        lines, _ = run_design(study, method=args.method, n_jobs=_jobs(args), seed=args.seed,
                              out=args.out, backend=backend, progress=not args.no_progress,
                              max_failure_fraction=args.max_failure_fraction,
                              cache=not args.no_cache)
    say(*lines)
    return 0


def _study_args(p, section, n=True, default="nine-bar-lubricated"):
    p.add_argument("study", nargs="?", default=default, metavar="STUDY",
                   help=f"embedded study name or path to a study .toml (default: {default})")
    p.add_argument("--scene", metavar="SCENE",
                   help="embedded scene name or scene file to use instead of the study's "
                        "scene (a file the study names must be in the study file's folder)")
    add_set_option(p, SET_HELP)
    if n:
        p.add_argument("--n", type=sample_count,
                       help="number of samples (default: the study's)")
    p.add_argument("--jobs", type=jobs, default=None,
                   help="parallel workers (default 2; with --scheduler: all the cluster's)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the model evaluations on the Dask cluster whose scheduler is at "
                        "ADDRESS (e.g. tcp://10.0.0.5:8786); needs dask.distributed")
    p.add_argument("--seed", type=seed, help="random seed (default: the study's)")
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


def register_reliability(sub) -> None:
    """Add the ``mechrel reliability`` subcommand (one entry of :data:`mechrel.cli.main.COMMANDS`).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="mechrel")
    >>> register_reliability(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["reliability", "slider-crank-lubricated", "--method", "fosm"])
    >>> args.command, args.method, args.n
    ('reliability', ['fosm'], None)
    """
    from ..study.study import rare_event_methods, study_methods

    rare = ", ".join(f"{k} ({m.name})" for k, m in rare_event_methods().items())
    p = sub.add_parser(
        "reliability", help="accuracy reliability of a study (FOSM, Monte Carlo, PCE, "
                            "rare-event methods)",
        description="Reliability of the output errors staying within their allowables, per "
                    "crank angle and over the whole cycle, by FOSM (the paper's method), Monte "
                    "Carlo and polynomial chaos; the whole-cycle failure probability at rare "
                    f"levels by {rare}, with the settings of the study's table of the method's "
                    "name (e.g. --set subset.n_per_level=500). Finished model evaluations are "
                    "cached in OUT/evaluations.sqlite, so an interrupted run resumes where it "
                    "stopped. Failed samples are written to OUT/failures.csv.")
    _study_args(p, "reliability")
    p.add_argument("--method", choices=tuple(study_methods()) + ("all",), action="append",
                   help="estimator, repeatable to run and cross-check several (--method form "
                        "--method subset; default: the study's reliability.methods; all: every "
                        "method; --n sets Monte Carlo's samples only)")
    p.add_argument("--target-reliability", type=_target, metavar="R",
                   help="also answer the inverse question: the allowable of each quantity, "
                        "and the common factor on the study's allowables for the whole cycle, "
                        "at which the whole-cycle reliability is R, with its interval "
                        "(OUT/inverse.csv; methods: the study's inverse.methods, default auto: "
                        "Monte Carlo when n (1 - R) >= 10, else subset simulation); default: "
                        "the study's inverse.target; none: not asked")
    p.set_defaults(func=_cmd_reliability)


def register_sensitivity(sub) -> None:
    """Add the ``mechrel sensitivity`` subcommand (one entry of :data:`mechrel.cli.main.COMMANDS`).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="mechrel")
    >>> register_sensitivity(parser.add_subparsers(dest="command"))
    >>> parser.parse_args(["sensitivity", "--n", "64"]).n
    64
    """
    p = sub.add_parser(
        "sensitivity", help="Sobol sensitivity indices of a study's error measures",
        description="First- and total-order Sobol indices (SALib, Saltelli design with N base "
                    "samples: N (d + 2) model runs) of the peak |error| over the cycle of each "
                    "quantity with respect to the study's uncertain inputs. Failed samples are "
                    "written to OUT/sensitivity_failures.csv.")
    _study_args(p, "sensitivity")
    p.set_defaults(func=_cmd_sensitivity)


def register_design(sub) -> None:
    """Add the ``mechrel design`` subcommand (one entry of :data:`mechrel.cli.main.COMMANDS`).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="mechrel")
    >>> register_design(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["design", "my-study.toml", "--method", "mc"])
    >>> args.command, args.study, args.method
    ('design', 'my-study.toml', 'mc')
    """
    from ..uq.design import DESIGN_METHODS

    p = sub.add_parser(
        "design", help="design for reliability: the cheapest design (loosest tolerances, "
                       "largest clearance) whose whole-cycle reliability meets its target",
        description="Minimise the study's [design] cost over its design variables (an "
                    "input's mean, std or tolerance half-width, a scene value) subject to "
                    "whole-cycle (or per-angle) reliability constraints R >= target; the "
                    "optimum is verified by an independent Monte Carlo or subset simulation "
                    "run, and the trade-off curve of cost against reliability is drawn "
                    "(OUT/design*.csv, design_tradeoff.png, design.json). Methods: "
                    + ", ".join(f"{k} ({m.summary})" for k, m in DESIGN_METHODS.items())
                    + ". Simulations are cached in OUT/evaluations.sqlite.")
    _study_args(p, "design", n=False, default="nine-bar-clearance-design")
    p.add_argument("--method", choices=tuple(DESIGN_METHODS),
                   help="design method (default: the study's design.method)")
    p.set_defaults(func=_cmd_design)
