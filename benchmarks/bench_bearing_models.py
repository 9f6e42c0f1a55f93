"""Cost of the film models on the lubricated nine-bar: long, short and finite-length bearing.

One cycle of ``nine-bar-lubricated`` (C1, C2 lubricated, 100 cP, L/D = 1.38) with
``lubricant.bearing`` = long (the paper's), short and finite, each with the scene's default
integrator (compiled Radau, rtol 1e-7). The three are run in turn, ``--rounds`` times, in one
process (interleaved, so that the load of a shared machine hits all alike); reported: the
median wall time per simulation, the rhs evaluations, and the ratio of the medians to the long
bearing's. The issue's budget is finite / long <= 1.5 per cycle.

The different films give different orbits, so the integrator takes different numbers of steps:
the ratio per rhs evaluation (median time / n_rhs) isolates the cost of the film law itself.

Run::

    python benchmarks/bench_bearing_models.py --rounds 15
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402

from mechrel.forces import pack_params  # noqa: E402
from mechrel.forces.joint import clearance_force  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402


@numba.njit(cache=True)
def _law_loop(states, p):
    acc = 0.0
    for k in range(states.shape[0]):
        s = states[k]
        F = clearance_force(s[0], s[1], s[2], s[3], s[4], s[5], 0.0, p)
        acc += F[0] + F[1]
    return acc


def law_cost(rounds: int) -> dict:
    """Median time (ns) of one clearance_force evaluation per film, on 1e5 random states of
    the nine-bar's joint (|e| < c, speeds of the running mechanism), interleaved."""
    rng = np.random.default_rng(1)
    c, RB, L = 5e-4, 0.015, 0.04
    r = c * np.sqrt(rng.uniform(0, 0.98, 100_000))
    a = rng.uniform(-np.pi, np.pi, r.size)
    states = np.column_stack([r * np.cos(a), r * np.sin(a), rng.normal(0, 0.05, r.size),
                              rng.normal(0, 0.05, r.size), rng.normal(0, 10, r.size),
                              rng.normal(0, 10, r.size)])
    ps = {b: pack_params(model="lubricated", clearance=c, bearing_radius=RB, length=L,
                         stiffness=1e10, restitution=0.9, viscosity=0.1, bearing=b)
          for b in BEARINGS}
    for p in ps.values():
        _law_loop(states[:10], p)
    t = {b: [] for b in BEARINGS}
    for _ in range(rounds):
        for b, p in ps.items():
            t0 = time.perf_counter()
            _law_loop(states, p)
            t[b].append((time.perf_counter() - t0) / states.shape[0] * 1e9)
    return {b: statistics.median(v) for b, v in t.items()}

BEARINGS = ("long", "short", "finite")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    args = ap.parse_args(argv)
    scenes = {b: load_scene("nine-bar-lubricated", overrides={
        "joints.C1.lubricant.bearing": b, "joints.C2.lubricant.bearing": b}) for b in BEARINGS}
    n_rhs = {}
    for b, sc in scenes.items():  # warm the Numba cache, count evaluations
        n_rhs[b] = simulate(sc).stats["n_rhs"]
    times = {b: [] for b in BEARINGS}
    for _ in range(args.rounds):
        for b, sc in scenes.items():
            t = time.perf_counter()
            simulate(sc)
            times[b].append(time.perf_counter() - t)
    med = {b: statistics.median(v) for b, v in times.items()}
    print(f"nine-bar-lubricated, one cycle, {args.rounds} interleaved rounds, git {git_state()}, "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'bearing':8s} {'median s':>9s} {'min s':>8s} {'n_rhs':>7s} {'/long':>6s} "
          f"{'per rhs /long':>14s}")
    for b in BEARINGS:
        print(f"{b:8s} {med[b]:9.4f} {min(times[b]):8.4f} {n_rhs[b]:7d} "
              f"{med[b] / med['long']:6.2f} "
              f"{(med[b] / n_rhs[b]) / (med['long'] / n_rhs['long']):14.2f}")
    ns = law_cost(args.rounds)
    print("clearance_force alone (ns per evaluation, median of interleaved rounds): "
          + ", ".join(f"{b} {ns[b]:.0f} ({ns[b] / ns['long']:.2f}x)" for b in BEARINGS))


if __name__ == "__main__":
    main()
