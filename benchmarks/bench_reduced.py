"""Issue 14 §1: the reduced formulation (only the clearance joints' eccentricities integrated)
against the absolute one (all body coordinates, Lagrange multipliers), side by side.

1. Lubricated nine-bar at the 1 % peak criterion of ``bench_lubricated_ninebar.py``: the slider
   acceleration error e(θ) (clearance − ideal) against the reference (absolute radau, rtol
   1e-10), peak excluding θ = 0, |P − P_ref| ≤ 1 % P_ref. Each formulation's rtol scan
   (atol = 1e-3 rtol) picks its fastest passing setting (one timing each); the chosen pair is
   then timed ``--repeats`` times interleaved (absolute, reduced, absolute, ...) and the
   medians compared.
2. Dry slider-crank and dry nine-bar with radau at the same rtol for both formulations (the
   dry scenes' recommended settings are dopri5, which integrates the absolute formulation
   only; see docs/performance.md): interleaved medians, with steps and evaluations.
3. Cost per cycle against a floor: the cost of one right-hand side of each formulation
   (interleaved in one compiled loop over states of a run) times the fewest evaluations an
   L-stable three-stage method needs, 3 × (accepted steps of the loosest passing setting),
   one Newton iteration per stage and no rejected step or Jacobian.

Run (≈ 2–4 min warm)::

    python benchmarks/bench_reduced.py --repeats 7 --json /tmp/bench_reduced.json

Numba's cache is warmed first (one untimed run of each). BLAS/numba threads are limited to 1.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

from mechrel.mechanics import problem  # noqa: E402
from mechrel.mechanics.kinematics import assemble  # noqa: E402
from mechrel.mechanics.reduced import (make_reduced_workspace, reduced_rhs_into,  # noqa: E402
                                       reduced_system)
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

LUB = "nine-bar-lubricated"
RTOLS = {"absolute": [1e-3, 3e-4, 1e-4, 3e-5], "reduced": [1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 1e-4]}


def peak(e):
    return float(np.max(np.abs(e[1:])))


def run(scene, form, rtol, atol=None):
    t0 = time.perf_counter()
    r = simulate(scene, integrator="radau", formulation=form, rtol=rtol,
                 atol=rtol * 1e-3 if atol is None else atol)
    wall = time.perf_counter() - t0
    s = r.stats
    return r, {"wall": wall, "integration": s["wall_time"], "steps": s["n_steps"],
               "rejected": s["n_rejected"], "rhs": s["n_rhs"], "jac": s["n_jacobians"],
               "lu": s["n_lu"]}


def interleave(cases, repeats):
    """Median and min wall (s) of each (label, thunk), run in turn ``repeats`` times."""
    walls = {k: [] for k, _ in cases}
    ints = {k: [] for k, _ in cases}
    for _ in range(repeats):
        for k, f in cases:
            st = f()
            walls[k].append(st["wall"])
            ints[k].append(st["integration"])
    return {k: {"median": statistics.median(walls[k]), "min": min(walls[k]),
                "integration_median": statistics.median(ints[k])} for k in walls}


@njit(cache=True)
def _abs_loop(sys, Y, T, reps):
    ws = problem.make_workspace(sys)
    out = np.empty(Y.shape[1])
    h = np.zeros(problem.n_contacts(sys))
    for _ in range(reps):
        for r in range(Y.shape[0]):
            problem.rhs_into(T[r], Y[r], h, sys, ws, out)
    return out


@njit(cache=True)
def _red_loop(rs, X, T, reps):
    rw = make_reduced_workspace(rs)
    out = np.empty(X.shape[1])
    h = np.zeros(problem.n_contacts(rs.dyn))
    for _ in range(reps):
        for r in range(X.shape[0]):
            reduced_rhs_into(T[r], X[r], h, rs, rw, out)
    return out


def rhs_costs(name, repeats=5, reps=20):
    """µs per right-hand side of each formulation over the states of a run's output grid
    (consecutive instants 1° apart: the reduced solve's predictor is from the previous one)."""
    scene = load_scene(name)
    r, _ = run(scene, "absolute", 1e-6)
    compiled = compile_scene(scene)
    q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0)
    qa, _ = assemble(compiled.assembly, q0, 0.0)
    rs = reduced_system(scene, compiled, qa)
    Y = np.ascontiguousarray(np.column_stack([r.q, r.v, np.zeros((r.q.shape[0], 2))]))
    T = np.ascontiguousarray(r.time)
    ex = np.column_stack([r.orbits[k]["ex"] for k in compiled.clearance_names])
    ey = np.column_stack([r.orbits[k]["ey"] for k in compiled.clearance_names])
    z = np.empty((ex.shape[0], 2 * ex.shape[1]))
    z[:, 0::2], z[:, 1::2] = ex, ey
    zd = np.gradient(z, T, axis=0)
    X = np.ascontiguousarray(np.column_stack([z, zd, np.zeros((z.shape[0], 2))]))
    _abs_loop(compiled.dynamic, Y, T, 1)
    _red_loop(rs, X, T, 1)
    ta, tr = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        _abs_loop(compiled.dynamic, Y, T, reps)
        ta.append((time.perf_counter() - t0) / (reps * len(T)))
        t0 = time.perf_counter()
        _red_loop(rs, X, T, reps)
        tr.append((time.perf_counter() - t0) / (reps * len(T)))
    return statistics.median(ta), statistics.median(tr)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    out = {"git": git_state(), "load": os.getloadavg()}

    def log(*a):
        print(*a, flush=True)

    # 1. lubricated nine-bar at the 1 % peak criterion
    scene = load_scene(LUB)
    ref, _ = run(scene, "absolute", 1e-10, 1e-13)
    e_ref = ref.error("slider", "acceleration")
    P = peak(e_ref)
    rows = []
    for form, rtols in RTOLS.items():
        run(scene, form, rtols[0])  # warm
        for rtol in rtols:
            try:
                r, st = run(scene, form, rtol)
                dev = abs(peak(r.error("slider", "acceleration")) - P) / P
                rows.append({"formulation": form, "rtol": rtol, "peak_rel_dev": dev, **st})
            except Exception as exc:  # a failed loose setting is a result
                rows.append({"formulation": form, "rtol": rtol, "failed": str(exc)[:120]})
            log(rows[-1])
    best = {}
    for form in RTOLS:
        ok = [r for r in rows if r["formulation"] == form and "failed" not in r
              and r["peak_rel_dev"] <= 0.01]
        best[form] = min(ok, key=lambda r: r["wall"])
    timing = interleave([(f, lambda f=f: run(scene, f, best[f]["rtol"])[1]) for f in best],
                        args.repeats)
    out["lubricated"] = {"scan": rows, "chosen": best, "timing": timing,
                         "speedup": timing["absolute"]["median"] / timing["reduced"]["median"]}
    log("lubricated nine-bar:", json.dumps(out["lubricated"]["timing"]),
        f"speed-up {out['lubricated']['speedup']:.2f}")

    # 2. dry scenes, radau at the same rtol
    out["dry"] = {}
    for name in ("slider-crank-dry", "nine-bar-dry"):
        sc = load_scene(name)
        stats = {f: run(sc, f, 1e-6, 1e-9)[1] for f in ("absolute", "reduced")}
        timing = interleave([(f, lambda f=f: run(sc, f, 1e-6, 1e-9)[1])
                             for f in ("absolute", "reduced")], max(3, args.repeats // 2))
        out["dry"][name] = {"stats": stats, "timing": timing,
                            "speedup": timing["absolute"]["median"]
                            / timing["reduced"]["median"]}
        log(name, json.dumps(out["dry"][name]))

    # 3. floor
    ta, tr = rhs_costs(LUB)
    steps = min(best[f]["steps"] for f in best)
    out["floor"] = {"rhs_us": {"absolute": 1e6 * ta, "reduced": 1e6 * tr},
                    "fewest_steps": steps,
                    "floor_ms": {"absolute": 1e3 * 3 * steps * ta,
                                 "reduced": 1e3 * 3 * steps * tr}}
    log("floor:", json.dumps(out["floor"]))
    if args.json:
        args.json.write_text(json.dumps(out, indent=1, default=str))


if __name__ == "__main__":
    main()
