"""What the cycle extremes cost: simulate(scene) against simulate(scene, extremes=True) on the
same scene, interleaved in one process (A, B, A, B, ...), medians of the wall time, and the
right-hand-side evaluations of each (deterministic).

    python benchmarks/bench_extremes.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from _common import git_state

from mechrel.scene import load_scene
from mechrel.simulation import simulate

CASES = (("four-bar", {}), ("four-bar", {"joints.B.model": "ideal"}),
         ("slider-crank-dry", {}), ("slider-crank-lubricated", {}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    print(f"git {git_state()}, load average {os.getloadavg()[0]:.1f}")
    print("scene | rhs without | rhs with (dense 3) | points logged | wall ratio (median)")
    for name, overrides in CASES:
        scene = load_scene(name, overrides=overrides)
        simulate(scene)
        simulate(scene, extremes=True)  # compile and warm
        walls = {False: [], True: []}
        for _ in range(args.repeats):
            for flag in (False, True):
                t = time.perf_counter()
                res = simulate(scene, extremes=flag)
                walls[flag].append(time.perf_counter() - t)
                if flag:
                    with_rhs, points = res.stats["n_rhs"], res.stats["n_extreme_points"]
                else:
                    without_rhs = res.stats["n_rhs"]
        ratio = statistics.median(walls[True]) / statistics.median(walls[False])
        label = name + "".join(f" {k}={v}" for k, v in overrides.items())
        print(f"{label} | {without_rhs} | {with_rhs} | {points} | {ratio:.2f} "
              f"({statistics.median(walls[False]) * 1e3:.0f} ms without)")


if __name__ == "__main__":
    main()
