"""Why a fresh copy of Radau's kernel runs faster than the shipped one: which functions must be
compiled in the running process rather than loaded from numba's cache.

Earlier measurements (docs/performance.md, "Radau's Newton tolerance and step-growth limit")
found a fresh copy of the shipped kernel (compiled from its source in the benchmark's process)
5–7 % faster than the shipped kernel loaded from numba's on-disk cache, with the same steps and
evaluations, and the benchmarks of kernel variants compare against such a copy for that
reason. This script locates the difference. Each mode runs in a process of its own, which
first compiles the named functions of ``mechrel.integrate.radau`` in that process (numba's
cache switched off for them, ``NullCache``) and loads everything else from the cache; then it
times the shipped kernel against a fresh copy of the module, interleaved (medians of 9 runs per
round, 7 rounds, the order alternating), on the lubricated nine-bar at the main study's
setting (rtol 1e-5, atol 1e-8, one cycle; integrator wall time).

Modes: ``cached`` (nothing compiled here), ``kernel`` (``radau5_kernel``), ``kernel+newton``
(and ``_solve_collocation``), ``all`` (every compiled function of the module: the kernel, the
Newton iteration, the LU factorisation and solve, the condensed solve, the matrices, the
finite-difference Jacobian, the RMS norm).

Run (≈ 6 min: each mode compiles the copy, some also the kernel)::

    python benchmarks/bench_cache_load.py
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state, radau_copy  # noqa: E402

MODES = {
    "cached": (),
    "kernel": ("radau5_kernel",),
    "kernel+newton": ("radau5_kernel", "_solve_collocation"),
    "all": ("radau5_kernel", "_solve_collocation", "lu_factor", "lu_solve", "fd_jacobian",
            "_build_matrices", "_solve_condensed", "_rms"),
}


def measure(fresh, rounds=7, reps=9) -> dict:
    """In this process: compile ``fresh`` (names in ``mechrel.integrate.radau``) here, then
    time the shipped kernel against a fresh copy (ms, medians)."""
    from numba.core.caching import NullCache

    import mechrel.integrate.radau as radau
    from mechrel.scene import load_scene
    from mechrel.simulation import simulate

    for name in fresh:
        getattr(radau, name)._cache = NullCache()
    scene = load_scene("nine-bar-lubricated")
    kw = {"rtol": 1e-5, "atol": 1e-8}
    shipped = radau.Radau._advance
    simulate(scene, **kw)
    copy = radau_copy([], "radau_cache_load_copy").Radau._advance
    times = {"shipped": [], "copy": []}
    try:
        radau.Radau._advance = copy
        counts = {"copy": simulate(scene, **kw).stats["n_rhs"]}
        for rnd in range(rounds):
            pair = [("shipped", shipped), ("copy", copy)]
            for label, advance in pair if rnd % 2 == 0 else pair[::-1]:
                radau.Radau._advance = advance
                walls = [simulate(scene, **kw).stats["wall_time"] for _ in range(reps)]
                times[label].append(float(np.median(walls)))
        radau.Radau._advance = shipped
        counts["shipped"] = simulate(scene, **kw).stats["n_rhs"]
    finally:
        radau.Radau._advance = shipped
    return {k: 1e3 * float(np.median(v)) for k, v in times.items()} | {"rhs": counts}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--modes", nargs="+", choices=list(MODES), default=list(MODES))
    ap.add_argument("--child", choices=list(MODES), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(measure(MODES[args.child])))
        return
    print("| compiled in the process | shipped (ms) | fresh copy (ms) | shipped / copy |")
    print("|---|---:|---:|---:|")
    for mode in args.modes:
        out = subprocess.run([sys.executable, __file__, "--child", mode], check=True,
                             capture_output=True, text=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        assert r["rhs"]["shipped"] == r["rhs"]["copy"]  # the same run, evaluation for evaluation
        names = ", ".join(MODES[mode]) or "nothing (all loaded from the cache)"
        print(f"| {mode}: {names} | {r['shipped']:.2f} | {r['copy']:.2f} | "
              f"{r['shipped'] / r['copy']:.3f} |", flush=True)
    print(f"git {git_state()}, load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
