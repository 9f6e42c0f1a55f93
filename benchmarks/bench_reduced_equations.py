"""One evaluation of the equations of motion in the clearance joints' eccentricities against one
of the absolute equations.

The reduced equations (:mod:`mechrel.mechanics.reduced`) have 4 nc + 2 states (10 for the
nine-bar) instead of 2 n + 2 (50), hold the constraints exactly and need no Baumgarte terms.
This measures ``reduced_rhs_into`` against the absolute ``rhs_into`` at the same mid-cycle
state, each in a compiled loop of ``--calls`` evaluations, interleaved over ``--repeats``
rounds, medians (µs). What a whole cycle costs in either formulation, at equal accuracy, is
``bench_formulations.py``'s question (the compiled Radau on both); an earlier version of this
script counted SciPy's Radau steps on the reduced equations before that integrator existed
(docs/performance.md, "The equations of motion in the eccentricities").

Run (≈ 30 s)::

    python benchmarks/bench_reduced_equations.py --json /tmp/bench_reduced.json
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

from mechrel.mechanics.construction import construction  # noqa: E402
from mechrel.mechanics.dynamics import N_WORK, make_workspace, rhs_into  # noqa: E402
from mechrel.mechanics.kinematics import assemble  # noqa: E402
from mechrel.mechanics.reduced import (make_reduced_work,  # noqa: E402
                                       reduced_coordinates, reduced_rhs_into)
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

SCENES = ("nine-bar-lubricated", "slider-crank-lubricated", "nine-bar-dry")


@njit(cache=True)
def _loop_reduced(k, t, y, hist, sys, con, rw, out):
    s = 0.0
    for _ in range(k):
        y[0] += 1e-18  # a new state each call, as in an integration
        reduced_rhs_into(t, y, hist, sys, con, rw, out)
        s += out[-1]
    return s


@njit(cache=True)
def _loop_absolute(k, t, y, hist, sys, ws, out):
    s = 0.0
    for _ in range(k):
        y[0] += 1e-18
        rhs_into(t, y, hist, sys, ws, out)
        s += out[-1]
    return s


def evaluation_cost(name, calls, repeats):
    """µs per evaluation, reduced and absolute, at the state the simulation reaches at
    mid-cycle (medians of interleaved rounds)."""
    scene = load_scene(name)
    compiled = compile_scene(scene)
    system = compiled.dynamic
    res = simulate(scene, integrator="radau", rtol=1e-7, atol=1e-10)
    mid = len(res.time) // 2
    y_abs = np.concatenate([res.q[mid], res.v[mid], np.zeros(N_WORK)])
    n = res.q.shape[1]
    q0, _ = assemble(compiled.assembly, compiled.q_guess, 0.0)
    con = construction(system)
    rw = make_reduced_work(system, con, q0)
    y_red = reduced_coordinates(system, con, res.q[mid], res.v[mid])
    t = float(res.time[mid])
    hist = np.zeros(system.n_contacts)
    ws = make_workspace(system)
    out_r = np.empty(y_red.size)
    out_a = np.empty(y_abs.size)
    _loop_reduced(10, t, y_red.copy(), hist, system, con, rw, out_r)  # compile
    _loop_absolute(10, t, y_abs.copy(), hist, system, ws, out_a)
    tr, ta = [], []
    for _ in range(repeats):
        yr, ya = y_red.copy(), y_abs.copy()
        t0 = time.perf_counter()
        _loop_reduced(calls, t, yr, hist, system, con, rw, out_r)
        t1 = time.perf_counter()
        _loop_absolute(calls, t, ya, hist, system, ws, out_a)
        t2 = time.perf_counter()
        tr.append((t1 - t0) / calls * 1e6)
        ta.append((t2 - t1) / calls * 1e6)
    return {"scene": name, "states_reduced": int(y_red.size),
            "states_absolute": int(2 * n + N_WORK),
            "us_reduced": float(np.median(tr)), "us_absolute": float(np.median(ta))}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=200_000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    costs = []
    for name in SCENES:
        costs.append(evaluation_cost(name, args.calls, args.repeats))
        print(json.dumps(costs[-1]), flush=True)
    print("\n| scene | states, reduced / absolute | µs per evaluation, reduced | absolute | "
          "ratio |")
    print("|---|---|---:|---:|---:|")
    for c in costs:
        print(f"| {c['scene']} | {c['states_reduced']} / {c['states_absolute']} "
              f"| {c['us_reduced']:.2f} | {c['us_absolute']:.2f} "
              f"| {c['us_reduced'] / c['us_absolute']:.2f} |")
    print(git_state())
    if args.json:
        Path(args.json).write_text(json.dumps({"costs": costs, "git": git_state()}, indent=1))


if __name__ == "__main__":
    main()
