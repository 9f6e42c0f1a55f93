"""Dry scenes: DOPRI5 (their default, absolute equations) against Radau (the reduced equations,
where it applies), one run per cycle, interleaved.

Issue 14 asks for the dry nine-bar and slider-crank several times faster. Their default is
DOPRI5 at rtol 1e-8, which spends 84–87 % of its time in right-hand sides
(docs/dev/performance-log.md, "Cost per cycle against the floor"); ``radau`` integrates them in
the clearance joints' eccentricities. Both are chaotic (the accuracy report's ensemble measure
resolves no 1 % setting on them), so no equal-accuracy comparison is possible: this prints, per
scene and setting, the median wall time of the whole ``simulate`` over ``--repeats`` interleaved
rounds, the integrator's counts and the number of impacts, which is what either integrator must
resolve.

A second table says where DOPRI5's steps go at its default setting (one untimed run with the
solution log kept): the share of the run during which a joint is in contact (penetration
δ > 0 at a step's end), the steps taken then, and the median step in contact and in free
flight. Steps of about the same length in both mean that the step is set by the tolerance
along the whole motion, not by the contact stiffness (an explicit method's stability limit
there) or by the impacts alone.

Run (≈ 1 min warm)::

    python benchmarks/bench_dry_radau.py --repeats 5
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

import numpy as np  # noqa: E402

from mechrel.mechanics.joints import gaps_into  # noqa: E402
from mechrel.mechanics.kinematics import assemble  # noqa: E402
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import make_integrator, output_times, simulate  # noqa: E402

SETTINGS = (("dopri5", 1e-8), ("radau", 1e-5), ("radau", 1e-7), ("radau", 1e-9))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scenes", nargs="+", default=["slider-crank-dry", "nine-bar-dry"])
    args = ap.parse_args(argv)
    print(f"git {git_state()}, load {os.getloadavg()[0]:.2f}, medians of {args.repeats}")
    print("| scene | integrator | rtol | formulation | ms per cycle | steps (rejected) | rhs "
          "| impacts |")
    print("|---|---|---:|---|---:|---:|---:|---:|")
    for name in args.scenes:
        scene = load_scene(name)
        cycles = scene.analysis.cycles or 1
        last, walls = {}, {s: [] for s in SETTINGS}
        for s in SETTINGS:  # warm-up
            simulate(scene, integrator=s[0], rtol=s[1], atol=s[1] * 1e-3)
        for _ in range(args.repeats):
            for s in SETTINGS:
                t = time.perf_counter()
                last[s] = simulate(scene, integrator=s[0], rtol=s[1], atol=s[1] * 1e-3)
                walls[s].append((time.perf_counter() - t) / cycles)
        for s in SETTINGS:
            st = last[s].stats
            print(f"| {name} | {s[0]} | {s[1]:.0e} | {st['formulation']} | "
                  f"{1e3 * statistics.median(walls[s]):.1f} | {st['n_steps']} "
                  f"({st['n_rejected']}) | {st['n_rhs']} | {st['n_impacts']} |", flush=True)
    print("\nWhere DOPRI5's steps go (default setting, one run):\n")
    print("| scene | steps | time in contact | steps in contact | median step in contact (s) "
          "| median step in free flight (s) |")
    print("|---|---:|---:|---:|---:|---:|")
    for name in args.scenes:
        print(steps_in_contact(load_scene(name)), flush=True)


def steps_in_contact(scene) -> str:
    """One table row: the default integrator's accepted steps of ``scene`` split by whether
    any clearance joint is in contact at the step's end (from the solution log)."""
    c = compile_scene(scene)
    sys_ = c.dynamic
    q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    q, v = assemble(c.assembly, q0, 0.0)
    n = q.size
    res = make_integrator(scene).integrate(sys_, np.concatenate([q, v, np.zeros(2)]),
                                           np.zeros(sys_.n_contacts), output_times(scene, c),
                                           log_from=0.0)
    t = res.log[:, 0]
    h = np.diff(t)
    g = np.empty(sys_.n_contacts)
    gd = np.empty(sys_.n_contacts)
    contact = np.empty(t.size, dtype=bool)
    for i in range(t.size):
        gaps_into(t[i], res.log[i, 1:2 * n + 3], sys_, g, gd)
        contact[i] = bool(np.any(g > 0.0))
    inside = contact[1:]  # a step in contact: in contact at its end
    return (f"| {scene.name} | {h.size} | {100 * h[inside].sum() / (t[-1] - t[0]):.1f} % | "
            f"{int(inside.sum())} | {np.median(h[inside]):.2e} | {np.median(h[~inside]):.2e} |")


if __name__ == "__main__":
    main()
