"""Compile the simulation kernels a scene needs on a cold cache, announced, before a run.

On a cold numba cache (a fresh install, or after :mod:`mechrel._kernel_cache` cleared it
because the kernels' sources changed) the first run compiles the kernels it needs: minutes on
two cores. :func:`warm_up` finds which compiled entry points a scene needs and whether numba
has them (:func:`cold_entries`, :func:`is_compiled`); if not, it prints "compiling simulation
kernels, once — about N s" with a bar of the elapsed time while a two-instant run of the scene
compiles them, the stiff kernel's callees in two processes at once (:func:`split_compile`).
``mechrel simulate``, ``draw``, ``animate``, ``reliability`` and ``sensitivity`` call it before
anything else, so Monte Carlo workers load the kernels from the cache. The numbers of later
runs do not depend on it: the same functions are compiled for the same types.

This module sits above :mod:`mechrel.simulation` and :mod:`mechrel.uq` (it runs a simulation
and starts its helper process as the UQ executor starts workers).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

__all__ = ["warm_up", "cold_entries", "is_compiled", "DEFAULT_COMPILE_SECONDS"]

_PACKAGE = Path(__file__).resolve().parent


# The compiled entry points a simulation calls from Python: the integrators' kernels (which
# inline the right-hand side, the force laws and the event handling) and the kinematic
# analysis (the ideal counterpart, and ideal scenes). Compiling them is the one-off cost of a
# cold cache: minutes on two cores.
_ENTRY_POINTS = {
    "rk4": ("mechrel.integrate.explicit", "rk4_kernel"),
    "dopri5": ("mechrel.integrate.explicit", "dopri5_kernel"),
    "radau": ("mechrel.integrate.radau", "radau5_kernel"),
    "kinematics": ("mechrel.mechanics.construction", "_construct"),
    "kinematics-newton": ("mechrel.mechanics.kinematics", "_kinematics"),
}
_TIMES = "kernel-compile-seconds.json"
DEFAULT_COMPILE_SECONDS = {"rk4": 55.0, "dopri5": 55.0, "radau": 36.0, "kinematics": 8.0,
                           "kinematics-newton": 10.0}
"""First-compilation times (s) on two idle cores, used until this machine has measured its own
(stored beside the cache). The kinematic analysis takes about 8 s of CPU in closed form
(:mod:`mechrel.mechanics.construction`: 7.2–7.4 s measured in a fresh cache, after the
assembly's own compilation) and about 10 s by Newton–Raphson, for mechanisms not built of
class-II groups (numba's compile events,
benchmarks/bench_cold_start.py); the dry slider-crank's first run (DOPRI5 and the kinematic
analysis, one process) took 65 s in a fresh checkout. A cold Radau warm-up runs in two processes
(:func:`split_compile`): about 45 s of CPU in this one and 29 s in the helper on the default
study (benchmarks/bench_cold_start.py, load ≈ 1.3), against 78 s in one process, so about 45 s
on two free cores (45.4 s measured, median of three). The load moves these numbers by a factor
of two or more either way."""


def is_compiled(entry: str, formulation: str | None = None) -> bool:
    """Whether a compiled entry point will not compile from scratch when called.

    That is: compiled in this process, or with a fresh index in numba's on-disk cache. Each
    formulation (:mod:`mechrel.mechanics.formulation`) is its own compiled overload, so a
    user whose first stiff run integrated the absolute equations still has the reduced
    kernel to compile.

    Parameters
    ----------
    entry : str
        ``"rk4"``, ``"dopri5"``, ``"radau"``, ``"kinematics"`` or ``"kinematics-newton"``.
    formulation : str, optional
        ``"absolute"`` or ``"reduced"``: for a kernel that integrates either, whether it is
        compiled for that one (default: for any).

    Returns
    -------
    bool

    Examples
    --------
    The ideal slider-crank, placed in closed form, needs the kinematic analysis only (whether
    ``"dopri5"`` is compiled depends on what ran before):

    >>> from mechrel.scene import load_scene
    >>> spent = warm_up(load_scene("slider-crank"), progress=False)
    >>> is_compiled("kinematics")
    True
    """
    import importlib

    from .mechanics.reduced import ReducedSystem

    module, name = _ENTRY_POINTS[entry]
    dispatcher = getattr(importlib.import_module(module), name)

    def wanted(args) -> bool:  # an overload's argument types: the system comes first
        if formulation is None:
            return True
        reduced = getattr(args[0], "instance_class", None) is ReducedSystem if args else False
        return reduced == (formulation == "reduced")

    if any(wanted(sig) for sig in dispatcher.signatures):
        return True
    try:  # numba's cache: the index of the function's cached overloads ({} when stale)
        index = dispatcher._cache._cache_file._load_index()
    except AttributeError:  # another numba layout: assume cached rather than announce wrongly
        return True
    return any(wanted(key[0]) for key in index)


def cold_entries(scene) -> list[str]:
    """The compiled entry points ``scene`` needs that are not compiled yet.

    Parameters
    ----------
    scene : Scene
        The scene a run will simulate (its solver settings choose the integrator).

    Returns
    -------
    list of str
        Keys as :func:`is_compiled` takes them; empty on a warm cache.

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> spent = warm_up(scene, progress=False)
    >>> cold_entries(scene)
    []
    """
    from .mechanics.construction import construction
    from .mechanics.system import compile_scene
    from .simulation import make_integrator

    compiled = compile_scene(scene)
    ideal = compiled.ideal
    need = []
    if ideal.n_constraints == ideal.n_coordinates:  # a fully driven ideal mechanism
        need.append("kinematics" if construction(ideal) is not None else "kinematics-newton")
    cold = [e for e in need if not is_compiled(e)]
    if scene.clearance_joints or not scene.drivers:
        integrator = make_integrator(scene)
        formulation = integrator.formulation_for(compiled.dynamic)
        if integrator.name in _ENTRY_POINTS and not is_compiled(integrator.name, formulation):
            cold.append(integrator.name)
    return cold


def _times_file() -> Path:
    return _PACKAGE / "__pycache__" / _TIMES


def _expected_seconds(entries) -> float:
    import json

    try:
        known = json.loads(_times_file().read_text())
    except (OSError, ValueError):
        known = {}
    return sum(float(known.get(e, DEFAULT_COMPILE_SECONDS[e])) for e in entries)


def _record_seconds(entries, seconds: float) -> None:
    import json

    try:
        known = json.loads(_times_file().read_text())
    except (OSError, ValueError):
        known = {}
    # the time of the whole warm-up, shared out in proportion to the defaults
    total = sum(DEFAULT_COMPILE_SECONDS[e] for e in entries)
    for e in entries:
        known[e] = round(seconds * DEFAULT_COMPILE_SECONDS[e] / total, 1)
    try:
        _times_file().parent.mkdir(exist_ok=True)
        _times_file().write_text(json.dumps(known))
    except OSError:  # read-only installation
        pass


def warm_up(scene, *, integrator: str | None = None, progress: bool = True,
            file=None) -> float:
    """Compile the kernels ``scene`` needs if the cache is cold, announcing it.

    On a cold cache: prints "compiling simulation kernels, once — about N s" (N: this
    machine's last measured compile time, or :data:`DEFAULT_COMPILE_SECONDS`) and a bar of the
    elapsed time against N while a short run of ``scene`` compiles them (the numbers of later
    runs do not depend on it); past N the bar says it is taking longer and keeps counting.
    Worker processes then load the kernels from the on-disk cache.

    Parameters
    ----------
    scene : Scene
        The scene a run will simulate.
    integrator : str, optional
        The integrator the run will use in place of ``scene.solver.integrator``
        (``simulate(scene, integrator=...)``, ``mechrel simulate --integrator``): its kernel
        is the one checked and compiled.
    progress : bool
        Show the bar (else one line).
    file : file-like, optional
        Where to announce it (default ``sys.stderr``).

    Returns
    -------
    float
        The seconds spent (0 on a warm cache, without output).

    Examples
    --------
    >>> from mechrel.scene import load_scene
    >>> scene = load_scene("slider-crank")
    >>> spent = warm_up(scene, progress=False)
    >>> warm_up(scene, progress=False)  # warm now: nothing to do
    0.0
    """
    import math
    import sys
    import threading
    import time

    from .scene import with_overrides
    from .simulation import make_integrator, simulate

    if integrator is not None:
        make_integrator(scene, integrator)  # a wrong name refused as simulate refuses it
        scene = with_overrides(scene, {"solver.integrator": integrator})
    cold = cold_entries(scene)
    if not cold:
        return 0.0

    expected = _expected_seconds(cold)
    out = file or sys.stderr
    # two output instants: the kernels compile on their first call, whatever its length
    a = scene.analysis
    speed = abs(scene.drivers[a.cycle_driver].speed) if a.cycle_driver else 0.0
    step = a.sample_step if a.sample_step is not None else (
        a.sample_step_angle / speed if speed else 1e-3)
    short = with_overrides(scene, {"analysis.duration": step})
    box = {}

    def work():
        try:
            if "radau" in cold:
                split_compile(short)
            simulate(short)
        except BaseException as exc:  # a scene that fails to run fails in its real run too
            box["exc"] = exc

    start = time.perf_counter()
    worker = threading.Thread(target=work, name="mechrel-compile", daemon=True)
    worker.start()
    label = f"compiling simulation kernels, once — about {expected:.0f} s"
    if progress:
        from tqdm.auto import tqdm

        with tqdm(total=round(expected), desc=label, unit="s", file=out,
                  bar_format="{desc}: {bar} {n:.0f}/{total:.0f} s") as bar:
            while worker.is_alive():
                worker.join(0.5)
                elapsed = time.perf_counter() - start
                if elapsed > bar.total:  # past the estimate: say so and keep counting
                    if bar.total == round(expected):
                        bar.set_description(f"{label}, taking longer (a busy machine?)",
                                            refresh=False)
                    bar.total = math.ceil(elapsed)
                bar.n = elapsed
                bar.refresh()
            bar.n = bar.total
            bar.refresh()
    else:
        print(label, file=out, flush=True)
        worker.join()
    spent = time.perf_counter() - start
    if "exc" not in box:
        _record_seconds(cold, spent)
    return spent


# ----------------------------------------------------------------------------- two processes

# The stiff integrator's kernel calls compiled functions that numba compiles (and caches) each
# on its own: the right-hand side inside ``events.start`` (inlined there, in the stages of the
# Radau Newton iteration ``radau._solve_collocation`` and in the finite-difference Jacobian:
# three copies), the Newton iteration, the clearance Jacobian, the finite-difference Jacobian
# and the kernel's smaller helpers; the simulation also needs the kinematic analysis and the
# post-processing. A cold compilation did them one after another on one core. numba loads a
# callee from the on-disk cache when another process has put it there first, so a second
# process compiles part of them while this one compiles the rest: ``Shares.helper`` in a helper
# process, in this order; ``Shares.own`` here, each after the helper's jobs it calls
# (``Shares.needs``, else it would compile them a second time); then this process waits for
# the helper's jobs that the kernel needs (``Shares.wait_for``) and compiles the kernel itself
# (its step loop and small helpers), loading them. On two idle cores the critical path is the
# longer of the two shares, plus the kernel's own body, so the shares are balanced by their compile
# times (numba's self times on an idle machine, ``benchmarks/profile_compile.py``: the Newton
# iteration 12.0 s, the kernel's body 11.8 s, the finite-difference Jacobian 9.8 s, the
# right-hand side 9.8 s, the clearance Jacobian 5.9 s, the kinematic analysis ≈ 5 s, the
# post-processing ≈ 3.5 s, each with smaller callees). The post-processing, needed only after
# the integration, ends the helper's share while the kernel compiles here. Measured
# (``benchmarks/bench_cold_start.py --modes two-previous two``): 45 s against 55 s with the
# kinematic analysis in the helper's share (docs/performance.md, "The one-off compilation").
# Where the scene's Radau integrates the reduced equations (the default study), the jobs
# compile their versions (mechrel.mechanics.formulation), whose shares differ: the kernel's
# body 16.0 s, the reduced right-hand side 6.6 s, the expansion of the outputs 6.3 s, the
# fast Jacobian 4.8 s, the Newton iteration 3.8 s (profile_compile.py, 2026-11-26), and
# every job calls the reduced right-hand side: ``SHARES["reduced"]`` compiles it first, in the
# helper, and the expansion, run after the kernel, joins the helper's share.
class Shares(NamedTuple):
    """How the jobs are split between the helper process and this one, for one formulation.

    ``helper``: the helper's jobs, in order; ``own``: this process's, in order, each after
    the helper's jobs it ``needs`` (``{own job: helper jobs}``: numba would compile a callee a
    second time otherwise); ``wait_for``: the helper's jobs the kernel needs."""

    helper: tuple
    own: tuple
    needs: dict
    wait_for: tuple


SHARES = {
    # the absolute formulation: the Newton iteration and the finite-difference Jacobian each
    # inline their own copy of the right-hand side; the clearance Jacobian calls rhs_into
    "absolute": Shares(helper=("rhs", "newton", "post_process"),
                       own=("fd_jacobian", "kinematics", "clearance_jacobian"),
                       needs={"clearance_jacobian": ("rhs",)}, wait_for=("rhs", "newton")),
    # the reduced formulation: everything calls reduced_rhs_into ("rhs"), so that comes
    # first; the kernels' start (with the reduced work arrays) follows in the helper while
    # this process compiles the Newton iteration and the Jacobians (self times, one process:
    # right-hand side 11.4 s, start 10.6 s, kinematic analysis 9.3–13 s, Newton 5.7 s,
    # expansion 5.0 s, post-processing 3.5 s, fast Jacobian 3.3 s, finite differences 2.5 s,
    # the kernel's body 21 s; /tmp-cache runs of _compile_job, 2026-11-26)
    "reduced": Shares(helper=("rhs", "start", "expand", "post_process"),
                      own=("kinematics", "newton", "fd_jacobian", "clearance_jacobian"),
                      needs={"newton": ("rhs",), "fd_jacobian": ("rhs",),
                             "clearance_jacobian": ("rhs",)},
                      wait_for=("rhs", "start")),
}


def _shares(scene) -> Shares:
    """The split of :data:`SHARES` for the formulation ``scene``'s Radau integrates."""
    from .mechanics.system import compile_scene
    from .simulation import make_integrator

    return SHARES[make_integrator(scene).formulation_for(compile_scene(scene).dynamic)]


def _compile_job(name: str, scene) -> None:
    """Compile (or load from the cache) the dispatcher of job ``name`` for the argument types
    a simulation of ``scene`` passes it (numba types of arrays made as the kernels make them:
    C-contiguous float64, the scene's System and Workspace, or ReducedSystem and ReducedWork
    where its Radau integrates the reduced equations), without running it; the
    kinematic analysis is run on the scene's first two output instants, as ``simulate`` runs
    it."""
    import numba
    import numpy as np

    from .mechanics.dynamics import N_WORK, make_workspace
    from .mechanics.kinematics import assemble_positions, kinematic_analysis
    from .mechanics.system import compile_scene

    compiled = compile_scene(scene)
    if name == "kinematics":
        from .simulation import output_times

        tol = scene.solver.assembly_tolerance
        q0 = assemble_positions(compiled.ideal, compiled.q_guess, 0.0, tol=tol)
        kinematic_analysis(compiled.ideal, q0, output_times(scene, compiled)[:2], tol=tol)
        return
    sys_ = compiled.dynamic
    ny = 2 * compiled.q_guess.size + N_WORK
    vec = numba.typeof(np.zeros(ny))
    mat = numba.typeof(np.zeros((ny, ny)))
    hist = numba.typeof(np.zeros(sys_.n_contacts))
    sys_t = numba.typeof(sys_)
    f64 = numba.float64
    if name == "post_process":
        from .mechanics.post import post_process

        post_process.compile((vec, mat, sys_t))
        return
    # the integrator's jobs: for the formulation the scene's Radau will integrate
    # (mechrel.mechanics.formulation), with the types of its system and work arrays
    from .integrate.radau import reduced_system
    from .simulation import make_integrator

    integrator = make_integrator(scene)
    nq = compiled.q_guess.size
    reduced = integrator.formulation_for(sys_) == "reduced"
    if reduced:
        from .mechanics.reduced import make_reduced_work

        # the types only: the first guess has the assembled configuration's (assembling
        # here would compile the Newton assembly in both processes)
        red = reduced_system(sys_, np.concatenate([compiled.q_guess, np.zeros(nq + N_WORK)]))
        nq = 2 * red.con.cl_nodes.shape[0]
        ny = 2 * nq + N_WORK
        vec = numba.typeof(np.zeros(ny))
        mat = numba.typeof(np.zeros((ny, ny)))
        # the work arrays' type from the function's Python body: calling the compiled one
        # here would compile it in both processes (the helper's "rhs" job compiles it)
        rw = make_reduced_work.py_func(sys_, red.con, red.q_ref)
        ws = numba.typeof(rw)
        if name == "expand":  # the reduced state before the kernel, the expansion after it
            from .integrate.radau import _finish_reduced
            from .mechanics.reduced import _reduced_state

            q = numba.typeof(compiled.q_guess)
            absolute = numba.typeof(np.zeros((2, 2 * compiled.q_guess.size + N_WORK)))
            con = numba.typeof(red.con)
            _reduced_state.compile((sys_t, con, q, q, f64, f64))
            _finish_reduced.compile((absolute, numba.typeof(np.zeros(2)), numba.int64, f64,
                                     vec, sys_t, con, numba.typeof(red.q_ref)))
            return
        if name == "clearance_jacobian":  # the reduced equations' own fast part
            from .mechanics.reduced import reduced_fast_jacobian

            reduced_fast_jacobian.compile((f64, vec, hist, sys_t, numba.typeof(red.con), ws,
                                           vec, mat))
            return
        sys_t = numba.typeof(red)
    else:
        if name == "expand":  # the absolute formulation's outputs need no expansion
            return
        ws = numba.typeof(make_workspace(sys_))
    if name == "rhs" and reduced:  # the reduced right-hand side alone: "start" follows here
        from .mechanics.reduced import reduced_rhs_into

        reduced_rhs_into.compile((f64, vec, hist, numba.typeof(sys_), numba.typeof(red.con),
                                  ws, vec))
    elif name == "start" and not reduced:  # "rhs" compiles it with the right-hand side
        return
    elif name in ("rhs", "start"):
        from .integrate.events import start

        start.compile((sys_t, f64, vec, hist, vec))
    elif name == "clearance_jacobian":
        from .mechanics.jacobian import clearance_jacobian

        clearance_jacobian.compile((f64, vec, hist, sys_t, ws, vec, mat))
    elif name == "fd_jacobian":
        from .integrate.radau import fd_jacobian

        fd_jacobian.compile((f64, vec, vec, hist, sys_t, ws, mat, f64, vec, vec))
    elif name == "newton":  # Radau's Newton iteration: the stages' inlined right-hand side
        from .integrate.radau import _solve_collocation

        qmat = numba.typeof(np.zeros((nq, nq)))
        cmat = numba.typeof(np.zeros((nq, nq), dtype=np.complex128))
        ivec = numba.typeof(np.zeros(nq, dtype=np.int64))
        qvec = numba.typeof(np.zeros(nq))
        cqvec = numba.typeof(np.zeros(nq, dtype=np.complex128))
        cvec = numba.typeof(np.zeros(ny, dtype=np.complex128))
        F3 = numba.typeof(np.zeros((3, ny)))
        _solve_collocation.compile(
            (f64, f64, f64, vec, hist, sys_t, ws, mat, qmat, ivec, cmat, ivec, f64, f64, f64,
             vec, f64, f64, numba.int64, numba.boolean) + (vec,) * 6
            + (F3, vec, vec, cvec, qvec, cqvec, vec))
    else:
        raise ValueError(f"unknown compile job {name!r}")


def split_compile(scene) -> set[str]:
    """Compile the stiff integrator's callees for ``scene`` in this process and a helper
    process at once (see :data:`SHARES`), leaving the kernel to the caller: on return the
    helper's jobs the kernel needs are in the on-disk cache (or the helper failed, and the
    kernel compiles them itself, as before). Results do not depend on it: the same functions
    compiled for the same types. Returns the helper's jobs done by then."""
    import json
    import subprocess
    import sys
    import threading

    from .scene.loader import thaw

    from .uq.execution._workers import PARENT_ENV

    env = dict(os.environ)
    env[PARENT_ENV] = str(os.getpid())  # the helper ends itself when this process ends
    # ``python -c`` puts the current folder first on the import path: a pickle.py or json.py
    # in the folder a user runs mechrel from would be executed by the helper (as by loky's
    # workers, uq/execution/_workers.py)
    env["PYTHONSAFEPATH"] = "1"
    env["PYTHONPATH"] = os.pathsep.join([str(_PACKAGE.parent)]
                                        + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    shares = _shares(scene)
    try:
        proc = subprocess.Popen(
            [sys.executable, "-c", "from mechrel.warmup import _helper; _helper()",
             *shares.helper], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL, env=env, text=True)
    except OSError:  # no interpreter to start (an embedded Python): one process, as before
        return set()
    done = set()
    finished = threading.Event()

    def read():
        for line in proc.stdout:
            done.add(line.strip())
        finished.set()

    threading.Thread(target=read, name="mechrel-compile-helper", daemon=True).start()
    try:
        try:
            proc.stdin.write(json.dumps(thaw(scene.raw)))
            proc.stdin.close()
        except OSError:  # the helper died at start: its jobs compile here, in the kernel
            pass
        for name in shares.own:
            _wait_for(shares.needs.get(name, ()), done, finished)
            _compile_job(name, scene)
        _wait_for(shares.wait_for, done, finished)
    finally:
        if not finished.is_set():  # the rest (post-processing) it may finish on its own
            threading.Thread(target=_reap, args=(proc,), daemon=True).start()
        else:
            proc.wait()
    return set(done)


def _wait_for(names, done: set, finished) -> None:
    """Wait until the helper has reported each job of ``names`` done (in ``done``), or has
    ended (``finished`` set: what it did not do compiles here, in the caller's job)."""
    while not finished.is_set() and not all(n in done for n in names):
        finished.wait(0.05)


def _reap(proc) -> None:
    try:
        proc.wait(timeout=600)
    except Exception:  # noqa: BLE001 - a stuck helper: stop it (it only fills the cache)
        proc.kill()


def _helper() -> None:
    """The helper process of :func:`split_compile`: the scene's raw mapping (JSON) on stdin,
    the job names as arguments; prints each job's name when it is done. It ends itself when
    the process that started it ends (interrupted, or killed), instead of compiling on for
    nobody (:func:`mechrel.uq.execution._workers.watch_parent`)."""
    from .uq.execution._workers import watch_parent

    watch_parent()  # first: its parent may be gone before the imports below are done

    import json
    import sys

    from .scene import load_scene

    scene = load_scene(json.loads(sys.stdin.read()))
    for name in sys.argv[1:]:
        _compile_job(name, scene)
        print(name, flush=True)
