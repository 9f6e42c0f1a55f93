"""Radau's Newton tolerance κ and step-growth limit against error and time, lubricated scenes.

RADAU5 stops its simplified Newton iteration when the predicted distance to the collocation
solution is below ``κ`` times the error scale, with ``κ = max(10 u / r, min(0.03, √r))`` for
the transformed tolerance ``r = 0.1 rtol^(2/3)``, and lets a step grow at most eightfold
(``FACR = 1/8``) (Hairer & Wanner, *Solving Ordinary Differential Equations II*, 2nd ed.,
Springer 1996, §IV.8; mechrel's kernel uses both as they are). On the lubricated nine-bar about
40 % of Radau's trial steps are rejected because the Newton iteration diverged after the step
had grown (docs/performance.md, "Cost per cycle against the floor"). A looser ``κ`` means
fewer iterations per step and fewer divergent ones, but less converged stages; a smaller
growth limit means fewer divergent iterations, but more steps. Is there time to be had at the
same accuracy?

For each scene and ``rtol`` (atol = 1e-3 rtol) this runs, interleaved, the shipped Radau and
variants compiled from its source by asserted edits (so they cannot drift from it):
``κ = min(0.03, 3 √r)``, ``min(0.03, 10 √r)``, the constant ``0.03``, growth limits of
4× and 2×, the Newton-aware cap of ``bench_floor.py``, the Jacobian taken a quarter step
ahead (on the previous collocation polynomial), Newton iterating on past RADAU5's early
"too slow" prediction (shrinking only when it misses κ by 10×, or never) and an unedited
copy. Each run is scored by
the largest error of the slider's displacement, velocity and acceleration error curves
against a radau rtol 1e-11 reference, divided by the reference curve's range (the pointwise
measure of ``mechrel accuracy``); time is the median kernel wall time of ``--repeats`` warm
runs. Compare settings on the error–time frontier, not at equal
``rtol``: a variant that is faster at one ``rtol`` but less accurate may only have moved along
the frontier.

The earlier measurements were on the absolute equations; ``--formulation auto`` runs each
variant as the shipped Radau runs, i.e. on the reduced equations wherever they apply.

``--variants`` picks some of them; ``copy`` (a fresh copy of the shipped kernel, no edit) is
the fair baseline, since a fresh copy runs 5–7 % faster than the cached shipped kernel, and
``θ cap 0.2`` is ``bench_floor.py``'s Newton-aware step cap.

Run (≈ 8–10 min, of which ≈ 5–7 compiling the variants)::

    python benchmarks/bench_radau_controls.py --repeats 5 --json bench_radau_controls.json
    python benchmarks/bench_radau_controls.py --repeats 5 --formulation auto
    python benchmarks/bench_radau_controls.py --repeats 5 --formulation auto \
        --scenes nine-bar-lubricated --variants copy "θ cap 0.2" \
        --rtols 3e-2 1e-2 3e-3 1e-3 3e-4 1e-4 3e-5 1e-5 1e-6 1e-7
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402
from bench_floor import _CONTROLLER_EDITS, _Swap, radau_variant  # noqa: E402

import mechrel.integrate.radau as radau  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

SHIPPED = "    fnewt = max(10.0 * UROUND / rtol, min(0.03, math.sqrt(rtol)))\n"
_LINE = "    fnewt = max(10.0 * UROUND / rtol, {})\n"
_GROWTH = "FACR = 0.125  # h_new ≤ h / FACR\n"
_SHRINK = ("                if dyth >= 1.0 and not fixed:  # no convergence in NIT iterations: "
           "shrink\n")
_JACOBIAN_POINT_EDITS = [
    ("""        if need_jac:
            n_partial = _update_jacobian(t, y, f0, hist, sys, sys_smooth, ws, J, JS, Jsm,""",
     """        if need_jac:
            if use_partial and not first:
                _dense_output(0.25 * h / hold, y, cont1, cont2, cont3, ypj)
                tj = t + 0.25 * h
            else:
                for i in range(ny):
                    ypj[i] = y[i]
                tj = t
            n_partial = _update_jacobian(tj, ypj, f0, hist, sys, sys_smooth, ws, J, JS, Jsm,"""),
    ("    yp = np.zeros(ny)\n", "    yp = np.zeros(ny)\n    ypj = np.zeros(ny)\n"),
]
VARIANTS = {  # label: the edits of the shipped source
    "κ = min(0.03, 3 √r)": [(SHIPPED, _LINE.format("min(0.03, 3.0 * math.sqrt(rtol))"))],
    "κ = min(0.03, 10 √r)": [(SHIPPED, _LINE.format("min(0.03, 10.0 * math.sqrt(rtol))"))],
    "κ = 0.03": [(SHIPPED, _LINE.format("0.03"))],
    "growth ≤ 4×": [(_GROWTH, "FACR = 0.25\n")],
    "growth ≤ 2×": [(_GROWTH, "FACR = 0.5\n")],
    # bench_floor.py's Newton-aware cap: after an accepted step with contraction θ the next
    # step is at most h · 0.2/θ (the cap doubles after a step that converged at once)
    "θ cap 0.2": _CONTROLLER_EDITS,
    # the Jacobian (and so Newton's matrices and the error filter) taken at the previous
    # collocation polynomial extrapolated a quarter of the new step ahead, instead of at the
    # step's start (partial updates only: the reduced and absolute lubricated scenes)
    "J at t + h/4": _JACOBIAN_POINT_EDITS,
    # RADAU5 shrinks the step as soon as the contraction predicts that NIT iterations will not
    # reach κ (``dyth ≥ 1``); these iterate on unless the prediction misses by 10× (or never
    # shrink early: only divergence or NIT iterations end the iteration)
    "shrink at 10×": [(_SHRINK, _SHRINK.replace("dyth >= 1.0", "dyth >= 10.0"))],
    "no early shrink": [(_SHRINK, _SHRINK.replace("dyth >= 1.0", "dyth >= 1e300"))],
    # no edit: a fresh copy of the shipped kernel, which runs 5–7 % faster than the cached
    # shipped one (docs/performance.md), the fair baseline of the variants
    "copy": [],
}
RTOLS = (3e-4, 1e-4, 3e-5, 1e-5, 1e-6, 1e-7)
REF_RTOL, REF_ATOL = 1e-11, 1e-14
QUANTITIES = ("displacement", "velocity", "acceleration")


def curve_error(res, ref) -> float:
    """The largest |e − e_ref| / range(e_ref) over the slider's three error curves e."""
    worst = 0.0
    for q in QUANTITIES:
        e, er = res.error("slider", q), ref.error("slider", q)
        worst = max(worst, float(np.max(np.abs(e - er)) / (er.max() - er.min())))
    return worst


def frontier(rows, levels=(3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6)) -> str:
    """The error–time frontier as a markdown table: per scene and error level, each variant's
    kernel time (ms) at its fastest setting whose error is at most the level (its rtol in
    brackets; "–" where no setting reaches it), and the ratio to the baseline (``copy`` if it
    ran, else the shipped kernel)."""
    variants = list(dict.fromkeys(r["variant"] for r in rows))
    base = "copy" if "copy" in variants else "shipped"
    others = [v for v in variants if v != base]
    out = ["", f"| scene | error ≤ | {base} | " + " | ".join(f"{v} | ratio" for v in others)
           + " |", "|---|---:|---:|" + "---:|---:|" * len(others)]
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for level in levels:
            best = {}
            for v in variants:
                ok = [(r["kernel_ms"], r["rtol"]) for r in rows
                      if r["scene"] == scene and r["variant"] == v and r["error"] <= level]
                best[v] = min(ok) if ok else None
            cells = [f"{best[base][0]:.2f} ({best[base][1]:g})" if best[base] else "–"]
            for v in others:
                b = best[v]
                cells.append(f"{b[0]:.2f} ({b[1]:g})" if b else "–")
                cells.append(f"{b[0] / best[base][0]:.2f}" if b and best[base] else "–")
            out.append(f"| {scene} | {level:g} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scenes", nargs="+",
                    default=["nine-bar-lubricated", "slider-crank-lubricated"])
    ap.add_argument("--json", default=None)
    ap.add_argument("--rtols", nargs="+", type=float, default=list(RTOLS))
    ap.add_argument("--formulation", choices=["absolute", "auto"], default="absolute",
                    help="the equations every variant integrates (auto: as the shipped Radau)")
    ap.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS),
                    help="the variants run beside the shipped kernel (default: all)")
    args = ap.parse_args(argv)
    kernels = {"shipped": radau.Radau._advance}
    for i, (label, edits) in enumerate((k, VARIANTS[k]) for k in args.variants):
        kernels[label] = radau_variant(edits, f"radau_controls_{i}",
                                       formulations=args.formulation == "auto")
    rows = []
    for name in args.scenes:
        scene = load_scene(name)
        ref = simulate(scene, integrator="radau", rtol=REF_RTOL, atol=REF_ATOL)
        for rtol in args.rtols:
            kw = {"integrator": "radau", "rtol": rtol, "atol": 1e-3 * rtol,
                  "formulation": args.formulation}
            times = {k: [] for k in kernels}
            last = {}
            order = list(kernels.items())
            for k in range(args.repeats):  # the order rotated every round: the first run of
                # a round is slower (measured ~5 % for two identical kernels)
                for label, advance in order[k % len(order):] + order[:k % len(order)]:
                    with _Swap(advance):
                        r = simulate(scene, **kw)
                    times[label].append(r.stats["wall_time"])
                    last[label] = r
            for label, r in last.items():
                row = {"scene": name, "rtol": rtol, "variant": label,
                       "formulation": r.stats["formulation"],
                       "kernel_ms": 1e3 * statistics.median(times[label]),
                       "steps": r.stats["n_steps"], "rejected": r.stats["n_rejected"],
                       "rhs": r.stats["n_rhs"], "error": curve_error(r, ref)}
                rows.append(row)
                print(f"{name} rtol {rtol:g} {label:20s} {row['kernel_ms']:7.2f} ms  "
                      f"steps {row['steps']:4d} rejected {row['rejected']:4d} rhs "
                      f"{row['rhs']:5d}  error {row['error']:.2e}", flush=True)
    print("\n| scene | rtol | Radau | kernel (ms) | steps | rejected | error / range |")
    print("|---|---:|---|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['scene']} | {r['rtol']:g} | {r['variant']} | {r['kernel_ms']:.2f} | "
              f"{r['steps']} | {r['rejected']} | {r['error']:.2g} |")
    print(frontier(rows))
    print(git_state())
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "git": git_state()}, indent=1))


if __name__ == "__main__":
    main()
