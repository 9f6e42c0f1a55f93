"""What the equations of motion in the clearance joints' eccentricities would cost per cycle:
their right-hand side against the absolute one, and the steps and evaluations an implicit
method needs on them at the 1 % criterion.

The reduced equations (:mod:`mechrel.mechanics.reduced`) have 4 nc states (8 for the nine-bar)
instead of 2 n + 2 (50), hold the constraints exactly and need no Baumgarte terms; no compiled
integrator uses them yet. Two measurements decide whether one should:

* **cost of one evaluation**: ``reduced_rhs_into`` against the absolute ``rhs_into`` at the
  same mid-cycle state, each in a compiled loop of ``--calls`` evaluations, interleaved over
  ``--repeats`` rounds, medians (µs);
* **evaluations per cycle**: SciPy's Radau (``solve_ivp``) on the reduced equations of the
  lubricated nine-bar, one cycle, rtol 1e-2 … 1e-5 with the eccentricities' atol = rtol ×
  clearance and the rates' atol = rtol × clearance × 10 /s, once with SciPy's own
  finite-difference Jacobian (its evaluations counted) and once with the same differences
  given as ``jac`` (not counted: what an analytic Jacobian would leave). SciPy steps in
  Python, so its wall time is not the question; its counts are: right-hand-side
  evaluations, Jacobians and LU factorisations. The
  accuracy criterion is the one of ``bench_lubricated_ninebar.py``: the slider acceleration
  error's peak (θ ≥ 1°) within 1 % of the reference's, the reference being mechrel's compiled
  absolute Radau at rtol 1e-10.

The product of the two, against the compiled absolute path's counts at its own 1 % setting
(radau rtol 3e-4: ``bench_floor.py``), is the floor a compiled reduced integrator would start
from. Run (≈ 1 min)::

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
from scipy.integrate import solve_ivp  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

from mechrel.forces.params import P_C  # noqa: E402
from mechrel.mechanics.construction import construction  # noqa: E402
from mechrel.mechanics.dynamics import N_WORK, make_workspace, rhs_into  # noqa: E402
from mechrel.mechanics.kinematics import assemble, kinematic_analysis  # noqa: E402
from mechrel.mechanics.reduced import (expand, make_reduced_work,  # noqa: E402
                                       reduced_coordinates, reduced_rhs_into)
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

SCENES = ("nine-bar-lubricated", "slider-crank-lubricated", "nine-bar-dry")
SLIDER_Y = 22  # the nine-bar slider's y coordinate in q (body 8)


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


def evaluations_per_cycle(rtols, vscale):
    """SciPy Radau's counts on the reduced nine-bar, and the peak criterion."""
    scene = load_scene("nine-bar-lubricated")
    compiled = compile_scene(scene)
    system = compiled.dynamic
    ref = simulate(scene, integrator="radau", rtol=1e-10, atol=1e-13)
    T = ref.time
    e_ref = ref.error("slider", "acceleration")
    p_ref = float(np.max(np.abs(e_ref[1:])))
    q0, v0 = assemble(compiled.assembly, compiled.q_guess, 0.0)
    qi, _ = assemble(compiled.ideal, compiled.q_guess, 0.0)
    _, _, Ai, _ = kinematic_analysis(compiled.ideal, qi, T)
    con = construction(system)
    rw = make_reduced_work(system, con, q0)
    y0 = reduced_coordinates(system, con, q0, v0)
    hist = np.zeros(0)
    out = np.empty(y0.size)
    nz = y0.size // 2
    clearance = np.repeat(system.cl_p[:, P_C], 2)

    def f(t, y):
        reduced_rhs_into(t, y, hist, system, con, rw, out)
        return out.copy()

    def jac(t, y):
        """Forward differences as SciPy makes them, but not counted in ``nfev``: the count of
        the evaluations a run needs besides its Jacobians (what an analytic Jacobian leaves)."""
        f0 = f(t, y)
        J = np.empty((y.size, y.size))
        for j in range(y.size):
            h = 1e-8 * max(abs(y[j]), clearance[j % nz] * (1.0 if j < nz else vscale))
            yj = y.copy()
            yj[j] += h
            J[:, j] = (f(t, yj) - f0) / h
        return J

    rows = []
    for rtol, jacobian in [(r, how) for r in rtols for how in ("finite differences", "given")]:
        atol = rtol * np.concatenate([clearance, clearance * vscale])
        sol = solve_ivp(f, (T[0], T[-1]), y0, method="Radau", t_eval=T, rtol=rtol, atol=atol,
                        jac=jac if jacobian == "given" else None)
        if not sol.success:
            rows.append({"rtol": rtol, "jacobian": jacobian, "failed": sol.message})
            continue
        e = np.empty(T.size)
        for k, t in enumerate(T):
            reduced_rhs_into(t, sol.y[:, k], hist, system, con, rw, out)
            _, _, a = expand(t, sol.y[:, k], out[nz:], system, con, rw)
            e[k] = a[SLIDER_Y] - Ai[k, SLIDER_Y]
        peak = float(np.max(np.abs(e[1:])))
        rows.append({"rtol": rtol, "jacobian": jacobian, "nfev": int(sol.nfev),
                     "njev": int(sol.njev),
                     "nlu": int(sol.nlu), "peak_rel_dev": abs(peak - p_ref) / p_ref,
                     "curve_rel_dev": float(np.max(np.abs(e - e_ref))) / p_ref})
        print(json.dumps(rows[-1]), flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=200_000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--vscale", type=float, default=10.0,
                    help="atol of the rates / atol of the eccentricities (1/s)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    costs = []
    for name in SCENES:
        costs.append(evaluation_cost(name, args.calls, args.repeats))
        print(json.dumps(costs[-1]), flush=True)
    counts = evaluations_per_cycle([1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5], args.vscale)
    print("\n| scene | states, reduced / absolute | µs per evaluation, reduced | absolute | "
          "ratio |")
    print("|---|---|---:|---:|---:|")
    for c in costs:
        print(f"| {c['scene']} | {c['states_reduced']} / {c['states_absolute']} "
              f"| {c['us_reduced']:.2f} | {c['us_absolute']:.2f} "
              f"| {c['us_reduced'] / c['us_absolute']:.2f} |")
    nine = costs[0]
    print("\n| SciPy Radau on the reduced nine-bar, rtol | Jacobian | evaluations | Jacobians "
          "| LU | peak dev | curve dev | evaluations × reduced µs (ms) |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|")
    for r in counts:
        if "failed" in r:
            print(f"| {r['rtol']:g} | {r['jacobian']} | failed: {r['failed']} | | | | | |")
            continue
        print(f"| {r['rtol']:g} | {r['jacobian']} | {r['nfev']} | {r['njev']} | {r['nlu']} "
              f"| {100 * r['peak_rel_dev']:.3f} % | {100 * r['curve_rel_dev']:.2f} % "
              f"| {r['nfev'] * nine['us_reduced'] / 1e3:.2f} |")
    print(git_state())
    if args.json:
        Path(args.json).write_text(json.dumps({"costs": costs, "counts": counts,
                                               "vscale": args.vscale, "git": git_state()},
                                              indent=1))


if __name__ == "__main__":
    main()
