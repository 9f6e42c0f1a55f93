"""Radau's complex LU: pivots by |Re| + |Im| (LAPACK's rule) against the modulus, side by side.

Radau IIA's Newton iteration factorises a real and a complex condensed iteration matrix
(``radau.lu_factor``) each time the step size or the Jacobian changes. Its pivot search used
the modulus |a| of each candidate, which for a complex entry is a ``hypot``; it now uses
|Re| + |Im| as LAPACK's zgetrf does (izamax with dcabs1), which picks the same pivot for a
real matrix and, for a complex one, a pivot within a factor √2 of the largest modulus (the
same stability bound up to that factor). This measures, in one process, interleaved:

* µs per factorisation of the real and of the complex condensed matrix of the lubricated
  nine-bar (Jacobian at mid-cycle, the step size of its cycle at rtol 1e-5), shipped and with
  the modulus (a copy of the Radau module built from the shipped source by one asserted edit,
  ``bench_floor.radau_variant``);
* the whole ``simulate`` of the lubricated scenes at the settings that matter (the 1 % peak
  criterion, the main study's), ms per cycle, medians of ``--repeats``; the solver counts of
  both, and the largest difference of the slider's error curves between them over each
  curve's range (a different pivot changes round-off, which the step-size control may turn
  into a different sequence of steps: then the difference is of the size of the integration
  error, not of round-off).

Run (≈ 1 min warm, the first run also compiles the variant, ≈ 1 min)::

    python benchmarks/bench_lu_pivot.py --repeats 9
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
from bench_floor import _per_call, _Swap, full_jacobian, radau_variant  # noqa: E402

import mechrel.integrate.radau as radau  # noqa: E402
from mechrel.mechanics.dynamics import N_WORK  # noqa: E402
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

SHIPPED = ("        v = A[k, k]\n        amax = abs(v.real) + abs(v.imag)\n"
           "        for i in range(k + 1, n):\n            v = A[i, k]\n"
           "            a = abs(v.real) + abs(v.imag)\n")
MODULUS = ("        amax = abs(A[k, k])\n        for i in range(k + 1, n):\n"
           "            a = abs(A[i, k])\n")
SETTINGS = [("nine-bar-lubricated", 3e-4, "1 % peak criterion"),
            ("nine-bar-lubricated", 1e-5, "the main study's setting"),
            ("slider-crank-lubricated", 1e-5, "the accuracy report's recommendation")]
QUANTITIES = ("displacement", "velocity", "acceleration")


@njit(cache=False)
def _factor_loop(factor, E0, reps):
    n = E0.shape[0]
    piv = np.zeros(n, dtype=np.int64)
    s = 0.0
    for _ in range(reps):
        E = E0.copy()
        factor(E, piv)
        s += abs(E[0, 0])
    return s


def matrices():
    """The real and complex condensed iteration matrices of the lubricated nine-bar at
    mid-cycle (its Jacobian from a radau run at rtol 1e-5), at the mean step of that run."""
    scene = load_scene("nine-bar-lubricated")
    r = simulate(scene, integrator="radau", rtol=1e-5, atol=1e-8)
    h = scene.analysis_duration / max(r.stats["n_steps"], 1)
    sys_ = compile_scene(scene).dynamic
    k = r.time.size // 2
    y = np.concatenate([r.q[k], r.v[k], np.zeros(N_WORK)])
    J = full_jacobian(float(r.time[k]), y, np.zeros(sys_.n_contacts), sys_)
    n = (J.shape[0] - N_WORK) // 2
    E1 = np.zeros((n, n))
    E2 = np.zeros((n, n), dtype=np.complex128)
    radau._build_matrices(J, h, E1, E2)
    return E1, E2


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    variant = radau_variant([(SHIPPED, MODULUS)], "radau_modulus_pivot")
    modulus_factor = variant.module.lu_factor
    E1, E2 = matrices()
    lu = {}
    for label, E in (("real", E1), ("complex", E2)):
        t_new, t_old = [], []
        for _ in range(3):
            t_new.append(_per_call(_factor_loop, (radau.lu_factor, E, 0), 1))
            t_old.append(_per_call(_factor_loop, (modulus_factor, E, 0), 1))
        lu[label] = {"shipped_us": min(t_new), "modulus_us": min(t_old)}
        print(label, json.dumps(lu[label]), flush=True)
    rows = []
    for name, rtol, why in SETTINGS:
        scene = load_scene(name)
        kw = {"integrator": "radau", "rtol": rtol, "atol": rtol * 1e-3}
        cycles = scene.analysis.cycles or 1.0
        a, b = simulate(scene, **kw), None
        with _Swap(variant):
            b = simulate(scene, **kw)
        diff = {}
        for q in QUANTITIES:
            ea, eb = a.error("slider", q), b.error("slider", q)
            diff[q] = float(np.max(np.abs(ea - eb)) / (ea.max() - ea.min()))
        t_new, t_old = [], []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            simulate(scene, **kw)
            t_new.append((time.perf_counter() - t0) / cycles * 1e3)
            with _Swap(variant):
                t0 = time.perf_counter()
                simulate(scene, **kw)
                t_old.append((time.perf_counter() - t0) / cycles * 1e3)
        row = {"scene": name, "rtol": rtol, "why": why,
               "shipped_ms": statistics.median(t_new), "modulus_ms": statistics.median(t_old),
               "counts_shipped": [a.stats[k] for k in ("n_steps", "n_rejected", "n_lu")],
               "counts_modulus": [b.stats[k] for k in ("n_steps", "n_rejected", "n_lu")],
               "max_rel_diff": diff}
        rows.append(row)
        print(json.dumps(row), flush=True)
    print("\n| factorisation (n = 24) | modulus pivots (µs) | |Re| + |Im| pivots (µs) |")
    print("|---|---:|---:|")
    for label, d in lu.items():
        print(f"| {label} | {d['modulus_us']:.2f} | {d['shipped_us']:.2f} |")
    print("\n| scene | radau rtol | modulus pivots (ms per cycle) | |Re| + |Im| (ms per cycle) "
          "| speed-up | steps, rejected, LU pairs (modulus → shipped) | largest difference of "
          "the error curves (d, v, a; of their range) |")
    print("|---|---:|---:|---:|---:|---|---|")
    for r_ in rows:
        c0 = ", ".join(map(str, r_["counts_modulus"]))
        c1 = ", ".join(map(str, r_["counts_shipped"]))
        d = ", ".join(f"{v:.1e}" for v in r_["max_rel_diff"].values())
        print(f"| {r_['scene']} | {r_['rtol']:g} | {r_['modulus_ms']:.2f} | "
              f"{r_['shipped_ms']:.2f} | {r_['modulus_ms'] / r_['shipped_ms']:.2f}× | "
              f"{c0} → {c1} | {d} |")
    print(git_state())
    if args.json:
        Path(args.json).write_text(json.dumps({"lu": lu, "rows": rows, "git": git_state()},
                                              indent=1))


if __name__ == "__main__":
    main()
