"""Integrator benchmark (not a test): wall time, steps, right-hand-side evaluations and error of
each integrator on the ideal slider-crank and nine-bar (forward dynamics against the kinematic
analysis) and on the lubricated nine-bar (one cycle; against a tight-tolerance reference).

    python benchmarks/bench_integrators.py [--repeats 5] [--out bench_integrators.md]
                                           [--skip-ideal] [--skip-lubricated]

Times are the median of ``--repeats`` warm runs (every kernel is compiled and cached by a first
run that is not timed), wall time of ``simulate`` in one process on one core
(``NUMBA_NUM_THREADS=1`` is set below). Errors:

* ideal scenes: max over the cycle of |x − x_kin| / |x_kin| (slider displacement) and of
  |a − a_kin| / max|a_kin| (slider acceleration), with ``x_kin``, ``a_kin`` from the kinematic
  analysis (exact to round-off for a fully driven mechanism);
* lubricated nine-bar: relative error of the peak |slider acceleration| over the cycle and the
  max pointwise acceleration error relative to that peak, against DOPRI5 at
  rtol = 1e-11, atol = 1e-14 (which agrees with Radau at the same tolerances to ~1e-9 relative
  on the peak; checked by ``--check-reference``).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

IDEAL_RUNS = [  # (integrator, settings); rk4's step is a fraction of the output interval
    ("rk4", {"step_fraction": 1.0}),
    ("dopri5", {"rtol": 1e-9, "atol": 1e-12}),
    ("radau", {"rtol": 1e-9, "atol": 1e-12}),
    ("scipy-radau", {"rtol": 1e-9, "atol": 1e-12}),
    ("bdf", {"rtol": 1e-9, "atol": 1e-12}),
    ("lsoda", {"rtol": 1e-9, "atol": 1e-12}),
]
LUBRICATED_RUNS = [
    ("radau", {"rtol": 1e-5, "atol": 1e-8}),
    ("radau", {"rtol": 1e-6, "atol": 1e-9}),
    ("radau", {"rtol": 1e-7, "atol": 1e-10}),
    ("radau", {"rtol": 1e-8, "atol": 1e-11}),
    ("lsoda", {"rtol": 1e-6, "atol": 1e-9}),
    ("lsoda", {"rtol": 1e-7, "atol": 1e-10}),
    ("dopri5", {"rtol": 1e-7, "atol": 1e-10}),
]
REFERENCE = ("dopri5", {"rtol": 1e-11, "atol": 1e-14})


def _settings(scene, integrator, settings):
    s = dict(settings)
    if "step_fraction" in s:
        s["step"] = s.pop("step_fraction") * scene.analysis_sample_step
    return s


def timed(scene, repeats, **kw):
    """(result, median wall time of simulate, median wall time of the integration alone,
    median CPU time of simulate) over ``repeats`` warm runs."""
    simulate(scene, **kw)  # compile / warm the cache
    walls, integ, cpus, res = [], [], [], None
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        res = simulate(scene, **kw)
        walls.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
        integ.append(res.stats["wall_time"])
    return res, statistics.median(walls), statistics.median(integ), statistics.median(cpus)


def _fmt_settings(s):
    return ", ".join(f"{k}={v:.3g}" for k, v in s.items())


def bench_ideal(name, repeats):
    scene = load_scene(name)
    kin = simulate(scene)
    x_k = kin.outputs["slider"]["displacement"]
    a_k = kin.outputs["slider"]["acceleration"]
    rows = []
    for integ, settings in IDEAL_RUNS:
        s = _settings(scene, integ, settings)
        res, wall, wall_int, cpu = timed(scene, repeats, method="dynamics", integrator=integ,
                                         **s)
        x = res.outputs["slider"]["displacement"]
        a = res.outputs["slider"]["acceleration"]
        st = res.stats
        rows.append((integ, _fmt_settings(s), st["n_steps"], st["n_rhs"], st["n_rejected"],
                     wall_int, cpu, float(np.max(np.abs(x - x_k) / np.abs(x_k))),
                     float(np.max(np.abs(a - a_k)) / np.max(np.abs(a_k))),
                     st["max_position_violation"]))
        print(name, rows[-1], flush=True)
    return rows


def bench_lubricated(repeats, check_reference=False):
    scene = load_scene("nine-bar-lubricated")
    integ, s = REFERENCE
    ref = simulate(scene, integrator=integ, **s)
    a_ref = ref.outputs["slider"]["acceleration"]
    peak_ref = float(np.max(np.abs(a_ref)))
    if check_reference:
        other = simulate(scene, integrator="radau", **s)
        peak_o = float(np.max(np.abs(other.outputs["slider"]["acceleration"])))
        print(f"reference check: dopri5 peak {peak_ref:.12g}, radau peak {peak_o:.12g}, "
              f"relative difference {abs(peak_o - peak_ref) / peak_ref:.2e}")
    rows = []
    for integ, s in LUBRICATED_RUNS:
        res, wall, wall_int, cpu = timed(scene, repeats, integrator=integ, **s)
        a = res.outputs["slider"]["acceleration"]
        st = res.stats
        rows.append((integ, _fmt_settings(s), st["n_steps"], st["n_rhs"], st["n_rejected"],
                     st["n_jacobians"], st["n_lu"], wall_int, wall, cpu,
                     abs(float(np.max(np.abs(a))) - peak_ref) / peak_ref,
                     float(np.max(np.abs(a - a_ref))) / peak_ref,
                     max(d["eps"].max() for d in res.orbits.values())))
        print("nine-bar-lubricated", rows[-1], flush=True)
    return rows, peak_ref, ref.stats["n_steps"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default="bench_integrators.md")
    ap.add_argument("--skip-ideal", action="store_true")
    ap.add_argument("--skip-lubricated", action="store_true")
    ap.add_argument("--check-reference", action="store_true")
    args = ap.parse_args(argv)

    import numba
    import scipy

    lines = [f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
             f"(NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}); Python "
             f"{platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
             f"numba {numba.__version__}. Times: median of {args.repeats} warm runs; "
             "'integration' is the integrator alone (`stats['wall_time']`), 'simulate' the "
             "whole call (compiling the scene, the ideal counterpart's kinematic analysis, "
             "orbits, energies). Load average at the start: "
             f"{os.getloadavg()[0]:.2f}.", ""]
    if not args.skip_ideal:
        for name in ("slider-crank", "nine-bar"):
            rows = bench_ideal(name, args.repeats)
            lines += [f"### {name} (ideal), forward dynamics vs kinematic analysis, one cycle", "",
                      "| integrator | settings | steps | rhs evals | rejected | integration (s) | "
                      "simulate CPU (s) | max rel. pos. error | max acc. error / max abs(acc) | "
                      "max abs(Φ) |",
                      "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
            for r in rows:
                lines.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]} | {r[5]:.4f} | "
                             f"{r[6]:.4f} | {r[7]:.1e} | {r[8]:.1e} | {r[9]:.1e} |")
            lines.append("")
    if not args.skip_lubricated:
        rows, peak, nref = bench_lubricated(args.repeats, args.check_reference)
        lines += ["### nine-bar-lubricated, one cycle (2/3 s)", "",
                  f"Reference: DOPRI5 rtol = 1e-11, atol = 1e-14 ({nref} steps); peak |slider "
                  f"acceleration| = {peak:.6f} m/s².", "",
                  "| integrator | settings | steps | rhs evals | rejected | Jacobians | LU | "
                  "integration (s) | simulate (s) | simulate CPU (s) | peak acc. rel. error | "
                  "max acc. error / peak | max ε |",
                  "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in rows:
            lines.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]} | {r[5]} | {r[6]} | "
                         f"{r[7]:.3f} | {r[8]:.3f} | {r[9]:.3f} | {r[10]:.1e} | {r[11]:.1e} | "
                         f"{r[12]:.4f} |")
        lines.append("")
    text = "\n".join(lines)
    with open(args.out, "w", encoding="utf-8") as fh:
        fh.write(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
