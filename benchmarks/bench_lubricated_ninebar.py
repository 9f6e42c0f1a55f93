"""Targets 1 and 2: the lubricated nine-bar, mechrel against the straightforward NumPy/SciPy
baseline (``benchmarks/baseline_numpy.py``), both at the loosest setting that is accurate.

Scene ``nine-bar-lubricated``: C1 and C2 lubricated (0.5 mm, 100 cP), ω1 = −3π, ω2 = +3π rad/s,
one cycle (2/3 s), output every degree of crank 1 (361 instants).

Accuracy criterion
------------------
e(θ) is the slider acceleration error (with clearances − ideal) at the output instants. The
reference e_ref is mechrel's compiled Radau at rtol 1e-10, atol 1e-13, cross-checked against
the independent NumPy baseline with SciPy LSODA at the same tolerances.

* The sample at θ = 0 is excluded from the peak: there the journal starts centred at rest and
  the acceleration is fixed by the initial state alone (−8.14 m/s², the same for every
  integrator), so the literal whole-cycle peak would be met by any run. The peak is
  P = max_{θ ≥ 1°} |e(θ)| (3.59 m/s² at θ ≈ 178°).
* "peak" criterion (the issue's): |P − P_ref| ≤ 1 % P_ref.
* "curve" criterion (stricter, reported too): max_θ |e(θ) − e_ref(θ)| ≤ 1 % P_ref; it implies
  the peak criterion.

A setting is a (integrator, rtol) pair with atol = 1e-3 rtol. Every setting is run once for
accuracy (deterministic); every setting meeting a criterion is then timed ``--repeats`` times
(mechrel) or ``--baseline-repeats`` times (baseline), the runs interleaved so that the load of
the shared machine hits all settings alike, and the setting with the smallest median wall time
is chosen per code and criterion (median and minimum reported). The
speed-up is median(baseline) / median(mechrel), total wall time of one simulation each
(set-up, assembly, ideal kinematics, integration, outputs; mechrel's ``simulate`` also computes
energies and orbits), and the integration alone is reported separately.

Run (≈ 5–10 min, the baseline scan dominates)::

    python benchmarks/bench_lubricated_ninebar.py --json /tmp/bench_lub.json

Numba's cache is warmed first (one untimed simulation). BLAS/OpenMP/numba threads are limited to
1 (one core); ``--cpu K`` also pins the process to core K.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import baseline_numpy  # noqa: E402

from mechrel.integrate import INTEGRATORS  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

SCENE = "nine-bar-lubricated"
REF_RTOL, REF_ATOL = 1e-10, 1e-13
ATOL_RATIO = 1e-3


from _common import git_state  # noqa: E402  (benchmarks/ is sys.path[0])

def peak(e):
    """Peak |error| excluding θ = 0 (fixed by the initial state)."""
    return float(np.max(np.abs(e[1:])))


def accuracy(e, e_ref):
    P_ref = peak(e_ref)
    return {"peak": peak(e), "peak_rel_dev": abs(peak(e) - P_ref) / P_ref,
            "curve_rel_dev": float(np.max(np.abs(e - e_ref))) / P_ref}


def run_mechrel(scene, integrator, rtol):
    t0 = time.perf_counter()
    r = simulate(scene, integrator=integrator, rtol=rtol, atol=rtol * ATOL_RATIO)
    wall = time.perf_counter() - t0
    s = r.stats
    return r.error("slider", "acceleration"), {
        "wall": wall, "integration": s["wall_time"], "steps": s["n_steps"], "rhs": s["n_rhs"],
        "jac": s["n_jacobians"], "lu": s["n_lu"], "rejected": s["n_rejected"]}


def run_baseline(method, rtol, solve="augmented"):
    r = baseline_numpy.simulate(SCENE, method=method, rtol=rtol, atol=rtol * ATOL_RATIO,
                                solve=solve)
    s = r.stats
    return r.error, {"wall": s.wall, "integration": s.extra["integration_wall"],
                     "steps": s.nsteps, "rhs": s.nfev, "jac": s.njev, "lu": s.nlu,
                     "rejected": None}


def scan(label, settings, runner, e_ref, log):
    rows = []
    for name, rtol in settings:
        try:
            e, st = runner(name, rtol)
            acc = accuracy(e, e_ref)
            row = {"code": label, "integrator": name, "rtol": rtol, **st, **acc}
        except Exception as exc:  # a failed coarse setting is a result, not a crash
            row = {"code": label, "integrator": name, "rtol": rtol, "failed": str(exc)[:200]}
        rows.append(row)
        log(row)
    return rows


def passing(rows, key):
    return [r for r in rows if "failed" not in r and r[key] <= 0.01]


def time_candidates(cands, n_repeats, log):
    """Time every candidate ``n_repeats`` times, interleaved (one run of each per round), so
    that a change of the machine's load hits all of them alike."""
    walls = {id(c): [] for c in cands}
    ints = {id(c): [] for c in cands}
    for k in range(n_repeats):
        for c in cands:
            if c["code"] == "mechrel":
                _, st = run_mechrel(c["_scene"], c["integrator"], c["rtol"])
            else:
                _, st = run_baseline(c["integrator"], c["rtol"])
            walls[id(c)].append(st["wall"])
            ints[id(c)].append(st["integration"])
        log(f"timing round {k + 1}/{n_repeats} done")
    for c in cands:
        w, i = walls[id(c)], ints[id(c)]
        c["timing"] = {"median": statistics.median(w), "min": min(w), "all": w,
                       "integration_median": statistics.median(i), "integration_min": min(i)}


def fmt_row(r):
    if "failed" in r:
        return (f"| {r['code']} | {r['integrator']} | {r['rtol']:.0e} | "
                f"failed: {r['failed'][:60]} | | | | | |")
    return (f"| {r['code']} | {r['integrator']} | {r['rtol']:.0e} | {r['wall']:.3f} | "
            f"{r['integration']:.3f} | {r['steps']} | {r['rhs']} | {100 * r['peak_rel_dev']:.3f} | "
            f"{100 * r['curve_rel_dev']:.3f} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5, help="timed repeats of the chosen settings")
    ap.add_argument("--baseline-repeats", type=int, default=3)
    ap.add_argument("--cpu", type=int, default=None, help="pin the process to this core")
    ap.add_argument("--json", default=None, help="write all results here")
    ap.add_argument("--reference", default=None,
                    help="optional cache file of the reference curves (reused only when the git "
                         "state matches; by default the reference is recomputed, ~30 s)")
    ap.add_argument("--quick", action="store_true", help="smaller scans (smoke test)")
    args = ap.parse_args(argv)
    if args.cpu is not None:
        os.sched_setaffinity(0, {args.cpu})

    def log(row):
        print(fmt_row(row), flush=True)

    scene = load_scene(SCENE)
    fast_stiff = "radau" if "radau" in INTEGRATORS else "lsoda"
    t0 = time.perf_counter()
    simulate(scene, integrator=fast_stiff)  # warm numba's cache (load or compile)
    warm = time.perf_counter() - t0
    print(f"warm-up ({fast_stiff}, first call in this process): {warm:.2f} s", flush=True)

    # ---- reference
    ref_path = Path(args.reference) if args.reference else None
    z = np.load(ref_path) if ref_path is not None and ref_path.exists() else None
    if z is not None and str(z["git"]) == git_state() and not git_state().endswith("dirty"):
        e_ref, e_ref_np, ref_info = z["e_ref"], z["e_ref_np"], json.loads(str(z["info"]))
    else:
        e_ref, st = run_mechrel(scene, "radau" if "radau" in INTEGRATORS else "lsoda", REF_RTOL)
        e_ref_np, st_np = run_baseline("LSODA", REF_RTOL)
        ref_info = {"mechrel": st, "baseline": st_np}
        if ref_path is not None:
            np.savez(ref_path, e_ref=e_ref, e_ref_np=e_ref_np, info=json.dumps(ref_info),
                     git=git_state())
    P_ref = peak(e_ref)
    cross = float(np.max(np.abs(e_ref_np - e_ref))) / P_ref
    print(f"reference: mechrel radau rtol {REF_RTOL:g}: P_ref = {P_ref:.6f} m/s^2; independent "
          f"NumPy baseline LSODA rtol {REF_RTOL:g}: P = {peak(e_ref_np):.6f} m/s^2, max curve "
          f"difference {100 * cross:.4f} % of P_ref", flush=True)

    # ---- scans
    print("| code | integrator | rtol | wall (s) | integration (s) | steps | rhs evals | "
          "peak dev (%) | curve dev (%) |\n|---|---|---|---|---|---|---|---|---|")
    # radau integrates the reduced equations here (its default formulation), which meet the
    # peak criterion from rtol 3e-2 (docs/dev/performance-log.md, "Radau on the reduced equations")
    tols = ([3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6] if not args.quick
            else [1e-4, 1e-5])
    mr_settings = [("radau", t) for t in tols if "radau" in INTEGRATORS]
    mr_settings += [("lsoda", t) for t in ([1e-4, 1e-5, 1e-6] if not args.quick else [1e-5])]
    mr_settings += [("bdf", t) for t in ([1e-4, 1e-5, 1e-6] if not args.quick else [])]
    mr_rows = scan("mechrel", mr_settings, lambda n, t: run_mechrel(scene, n, t), e_ref, log)
    bl_tols = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7] if not args.quick else [1e-5]
    bl_settings = [(m, t) for m in ("LSODA", "BDF", "Radau") for t in bl_tols]
    bl_rows = scan("baseline", bl_settings, run_baseline, e_ref, log)

    # ---- timed repeats of every accurate setting, interleaved; then the fastest per code
    for r in mr_rows:
        r["_scene"] = scene
    cands = {id(r): r for crit in ("peak_rel_dev", "curve_rel_dev")
             for r in passing(mr_rows, crit) + passing(bl_rows, crit)}
    mr_c = [c for c in cands.values() if c["code"] == "mechrel"]
    bl_c = [c for c in cands.values() if c["code"] == "baseline"]
    print(f"timing {len(mr_c)} mechrel settings x {args.repeats} and {len(bl_c)} baseline "
          f"settings x {args.baseline_repeats}, interleaved", flush=True)
    time_candidates(mr_c + bl_c, args.baseline_repeats, print)
    if args.repeats > args.baseline_repeats:
        extra = {id(c): c["timing"] for c in mr_c}
        time_candidates(mr_c, args.repeats - args.baseline_repeats, print)
        for c in mr_c:  # merge the two series
            w = extra[id(c)]["all"] + c["timing"]["all"]
            c["timing"]["all"] = w
            c["timing"]["median"] = statistics.median(w)
            c["timing"]["min"] = min(w)
    for r in mr_rows:
        r.pop("_scene", None)
    results = {}
    for crit in ("peak_rel_dev", "curve_rel_dev"):
        pm, pb = passing(mr_rows, crit), passing(bl_rows, crit)
        if not pm or not pb:
            results[crit] = None
            continue
        m = min(pm, key=lambda r: r["timing"]["median"])
        b = min(pb, key=lambda r: r["timing"]["median"])
        tm, tb = m["timing"], b["timing"]
        results[crit] = {"mechrel": m, "baseline": b,
                         "speedup_median": tb["median"] / tm["median"],
                         "speedup_min": tb["min"] / tm["min"],
                         "speedup_integration": tb["integration_median"] / tm["integration_median"]}

    print("\n## Timed repeats of every accurate setting\n")
    print("| code | setting | wall median (s) | wall min (s) | integration median (s) | n |")
    print("|---|---|---|---|---|---|")
    for c in mr_c + bl_c:
        t = c["timing"]
        print(f"| {c['code']} | {c['integrator']} rtol {c['rtol']:.0e} | {t['median']:.3f} | "
              f"{t['min']:.3f} | {t['integration_median']:.3f} | {len(t['all'])} |")
    print("\n## Fastest settings meeting each criterion\n")
    print("| criterion | code | setting | wall median (s) | wall min (s) | integration median (s) "
          "| steps | rhs evals | speed-up (median) | speed-up (min) | speed-up (integration) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for crit, res in results.items():
        if res is None:
            print(f"| {crit} | no setting met it | | | | | | | | | |")
            continue
        for code in ("mechrel", "baseline"):
            r = res[code]
            tm = r["timing"]
            extra = (f"{res['speedup_median']:.1f}× | {res['speedup_min']:.1f}× | "
                     f"{res['speedup_integration']:.1f}× |" if code == "mechrel" else "| | |")
            print(f"| {crit.split('_')[0]} | {code} | {r['integrator']} rtol {r['rtol']:.0e} | "
                  f"{tm['median']:.3f} | {tm['min']:.3f} | {tm['integration_median']:.3f} | "
                  f"{r['steps']} | {r['rhs']} | {extra}")
    meta = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
            "machine": f"{platform.node()} {platform.processor() or platform.machine()}, "
                       f"{os.cpu_count()} cores, load average {os.getloadavg()}",
            "python": platform.python_version(), "warm_up": warm, "git": git_state(),
            "reference": {"P_ref": P_ref, "baseline_cross_check_curve_dev": cross, **ref_info}}
    print(f"\n{meta['date']}; {meta['machine']}; git {meta['git']}")
    if args.json:
        Path(args.json).write_text(json.dumps({"meta": meta, "mechrel": mr_rows,
                                               "baseline": bl_rows, "results": results},
                                              indent=1, default=float))


if __name__ == "__main__":
    main()
