"""Cost per simulated cycle against the physical floor (issue 14 §3).

For each scene and integrator setting this measures, in one process with the runs interleaved:

* the **cost per cycle**: median wall time of ``simulate`` (warm), and of the integrator alone;
* the **right-hand-side cost** ``t_f``: one evaluation of the equations Radau integrates (the
  kernels' allocation-free form, ``mechrel.mechanics.formulation.evaluate_inline``, inlined
  as in Radau's Newton iteration: the reduced equations where radau runs them, the absolute
  ones otherwise) in a compiled loop over the states of the cycle, µs;
* for implicit settings, one **LU pair** (the real and the complex condensed iteration matrices
  of Radau, built from its full Jacobian of the same equations at a state of the cycle), µs;
* the **fewest steps** ``N`` an L-stable method needs at the setting's accuracy, bounded from
  above by three measurements: the accepted steps of mechrel's Radau; the accepted steps of the
  same Radau with its Newton iteration made as good as it gets (fresh Jacobian at every
  iteration, up to 50 iterations, no step reduction for predicted slow convergence: a variant
  built from the shipped kernel's source by asserted edits, so that it cannot drift from it);
  and the accepted steps of RODAS (Hairer & Wanner's Rosenbrock method of order 4, L-stable,
  stiffly accurate: no Newton iteration at all), written here in NumPy at the tolerance that
  meets the same accuracy;
* the **floor** ``s · N · t_f`` with ``s = 3`` stage evaluations per step (Radau IIA's
  collocation needs the right-hand side at its three stages at least once), and a floor that
  includes one LU pair per step, ``N (3 t_f + t_LU)``.

Accuracy is the 1 % peak criterion of ``bench_lubricated_ninebar.py`` (peak slider
acceleration error within 1 % of a radau rtol 1e-10 reference) for the lubricated scenes;
the dry scenes are chaotic (docs/performance.md, "Which tolerance") and are reported at
their default setting, whose floor is its own steps × stages × t_f.

``--formulation`` chooses the equations radau integrates (default ``auto``, what the shipped
Radau does: the reduced ones on the lubricated scenes); the criterion setting of the nine-bar
is the loosest that meets the 1 % peak criterion in that formulation (rtol 3e-2 reduced, 3e-4
absolute: ``bench_formulations.py``).

Run (≈ 3–5 min warm; the first run compiles the loops and the Radau variants, ≈ 2 min)::

    python benchmarks/bench_floor.py --repeats 7 --json bench_floor.json
    python benchmarks/bench_floor.py --repeats 7 --formulation absolute
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.linalg as sla  # noqa: E402
from numba import njit  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state, radau_copy  # noqa: E402

import mechrel.integrate.radau as radau  # noqa: E402
from mechrel.integrate.events import (N_STATS, S_JAC, S_LU, S_REJECTED, S_RHS, S_STEPS,  # noqa: E402
                                     new_log, start)
from mechrel.integrate.base import Integrator  # noqa: E402
from mechrel.integrate.radau import reduced_system  # noqa: E402
from mechrel.mechanics.borrow import borrowed, keep_alive  # noqa: E402
from mechrel.mechanics.dynamics import N_WORK, make_workspace, rhs_into  # noqa: E402
from mechrel.mechanics.formulation import evaluate, evaluate_inline, make_work  # noqa: E402
from mechrel.mechanics.reduced import reduced_coordinates  # noqa: E402
from mechrel.mechanics.system import compile_scene, without_clearance_forces  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

REF_RTOL, REF_ATOL = 1e-10, 1e-13
ATOL_RATIO = 1e-3
STAGES = 3


# ---------------------------------------------------------------------------- compiled timings
# Not cached: a cached caller keeps its own copy of its callees (bench_effects.py says why).
@njit(cache=False)
def _lu_loop(J, h, reps):
    n = (J.shape[0] - N_WORK) // 2
    E1 = np.zeros((n, n))
    E2 = np.zeros((n, n), dtype=np.complex128)
    p1 = np.zeros(n, dtype=np.int64)
    p2 = np.zeros(n, dtype=np.int64)
    s = 0.0
    for _ in range(reps):
        radau._build_matrices(J, h, E1, E2)
        radau.lu_factor(E1, p1)
        radau.lu_factor(E2, p2)
        s += E1[0, 0]
    return s


@njit(cache=False)
def _eval_loop(T, Y, hist, sys, reps):
    """``evaluate_inline`` (the kernels' allocation-free right-hand side of ``sys``'s
    formulation, inlined as in Radau's Newton iteration) at every state ``reps`` times; returns
    a checksum (keeps the calls)."""
    s = 0.0
    owner = make_work(sys)
    sys, ws = borrowed((sys, owner))  # as the kernels pass them (mechanics/borrow.py)
    out = np.empty(Y.shape[1])
    for _ in range(reps):
        for k in range(Y.shape[0]):
            evaluate_inline(T[k], Y[k], hist, sys, ws, out)
            s += out[0]
    keep_alive(owner)
    return s


@njit(cache=False)
def _jacobian(t, y, hist, sys, floor):
    """The finite-difference Jacobian of ``sys``'s equations at ``(t, y)``
    (``mechrel.integrate.radau.fd_jacobian``): for the LU timings, which depend on the
    matrices' size and pivots, not on how their entries were obtained."""
    ny = y.shape[0]
    J = np.zeros((ny, ny))
    f0 = np.zeros(ny)
    ws = make_work(sys)
    evaluate(t, y, hist, sys, ws, f0)
    radau.fd_jacobian(t, y, f0, hist, sys, ws, J, floor, np.zeros(ny), np.zeros(ny))
    return J


def full_jacobian(t, y, hist, sys):
    """Radau's full Jacobian of the absolute equations at ``(t, y)`` (RODAS, below): the
    kernel's own update (``mechrel.integrate.radau._update_jacobian``, not partial), smooth
    part by differences of the force-free mechanism plus the semi-analytic fast part, with the
    increments' floor ``atol/rtol`` of this benchmark's settings (``ATOL_RATIO``)."""
    ny = y.size
    nq = sys.mass.shape[0]
    J = np.zeros((ny, ny))
    radau._update_jacobian(t, y, np.zeros(ny), hist, sys, without_clearance_forces(sys),
                           make_workspace(sys), J, np.zeros((ny, ny)),
                           np.zeros((ny - nq, 2 * nq)), np.bool_(False), np.int64(0),
                           np.bool_(True), ATOL_RATIO, np.zeros(ny),
                           np.zeros(ny), np.zeros(ny), np.zeros(N_STATS))
    return J


def _per_call(fn, args, calls_per_rep, seconds=0.3):
    """µs per call of a compiled loop, calibrated to ``seconds`` per chunk; best of 3 chunks."""
    fn(*args[:-1], 1)
    reps = 1
    while True:
        t0 = time.perf_counter()
        fn(*args[:-1], reps)
        if time.perf_counter() - t0 > seconds / 2:
            break
        reps *= 2
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        fn(*args[:-1], reps)
        best = min(best, (time.perf_counter() - t0) / (reps * calls_per_rep) * 1e6)
    return best


# ---------------------------------------------------------------------------- RODAS (NumPy)
# Hairer & Wanner, Solving ODEs II, §IV.7, and the Fortran code rodas.f (coefficients METH = 1:
# γ = 0.25, order 4 with an embedded order-3 solution whose difference is the last stage,
# dense output of order 3). Written in the form of rodas.f: stage values U_i = y + Σ a_ij k_j,
# (I/(hγ) − J) k_i = f(t + c_i h, U_i) + h d_i f_t + Σ C_ij k_j / h.
_RA = ((1.544,), (0.9466785280815826, 0.2557011698983284),
       (3.314825187068521, 2.896124015972201, 0.9986419139977817),
       (1.221224509226641, 6.019134481288629, 12.53708332932087, -0.6878860361058950))
_RC = ((-5.6688,), (-2.430093356833875, -0.2063599157091915),
       (-0.1073529058151375, -9.594562251023355, -20.47028614809616),
       (7.496443313967647, -10.24680431464352, -33.99990352819905, 11.70890893206160),
       (8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136,
        -6.058818238834054))
_RCT = (0.0, 0.386, 0.21, 0.63, 1.0, 1.0)
_RD = (0.25, -0.1043, 0.1035, -0.3620000000000023e-01, 0.0, 0.0)  # rodas.f's D1 … D4
_RH = ((10.12623508344586, -7.487995877610167, -34.80091861555747, -7.992771707568823,
        1.025137723295662),
       (-0.6762803392801253, 6.087714651680015, 16.43084320892478, 24.76722511418386,
        -6.594389125716872))
_RG = 0.25


def rodas_advance(self, sys, t0, y0, hist, t_out, ctl, log_from=math.inf, n_dense=0):
    """RODAS over ``t_out`` with the ``Integrator._advance`` contract (no contacts, no log):
    a fresh Jacobian at every step (a Rosenbrock method's order needs the exact one), the
    standard controller ``h_new = h · min(6, max(0.2, 0.9 err^(−1/4)))``."""
    Y, YD, stats, _floors, y, _f0, k, tend, ws = start(sys, t0, y0, hist, t_out)
    rtol, atol = self.rtol, self.atol
    ny = y.size
    t, h = t0, 1e-5

    def f(tt, yy):
        o = np.empty(ny)
        rhs_into(tt, yy, hist, sys, ws, o)
        return o

    eye = np.eye(ny)
    n_rhs = n_rej = n_acc = 0
    while k < t_out.size:
        h = min(h, tend - t)
        fy = f(t, y)
        J = full_jacobian(t, y, hist, sys)
        n_rhs += 1 + 2 * sys.mass.shape[0] + 8  # its cost, in right-hand sides (about)
        dt = 1e-8 * max(abs(t), 1.0)
        ft = (f(t + dt, y) - fy) / dt
        n_rhs += 1
        while True:
            lu = sla.lu_factor(eye / (h * _RG) - J)
            ks = []
            u = y
            for i in range(6):
                if i == 0:
                    rhs_i = fy + h * _RD[0] * ft
                else:
                    if i < 5:
                        u = y + sum(a * kj for a, kj in zip(_RA[i - 1], ks))
                    else:
                        u = u + ks[4]
                    rhs_i = f(t + _RCT[i] * h, u) + h * _RD[i] * ft \
                        + sum(c * kj for c, kj in zip(_RC[i - 1], ks)) / h
                    n_rhs += 1
                ks.append(sla.lu_solve(lu, rhs_i))
            y1 = u + ks[5]
            sk = atol + rtol * np.maximum(np.abs(y), np.abs(y1))
            err = math.sqrt(float(np.mean((ks[5] / sk) ** 2)))
            if not math.isfinite(err):
                err = 1e10
            hnew = h / max(0.2, min(6.0, err ** 0.25 / 0.9))
            if err <= 1.0:
                break
            n_rej += 1
            h = hnew
            if h < 1e-14:
                raise RuntimeError("RODAS: step size underflow")
        kd1 = sum(c * kj for c, kj in zip(_RH[0], ks))
        kd2 = sum(c * kj for c, kj in zip(_RH[1], ks))
        while k < t_out.size and t_out[k] <= t + h:
            th = (t_out[k] - t) / h
            Y[k] = (1 - th) * y + th * (y1 + (1 - th) * (kd1 + th * kd2))
            YD[k] = f(t_out[k], Y[k])
            k += 1
        t, y = t + h, y1
        n_acc += 1
        h = hnew
    stats[S_STEPS], stats[S_RHS], stats[S_REJECTED] = n_acc, n_rhs, n_rej
    stats[S_JAC] = stats[S_LU] = n_acc + n_rej
    log, _ = new_log(math.inf, ny, hist.size)
    return Y, YD, hist, stats, t, y, log[:0], np.zeros((t_out.size, hist.size))


# ---------------------------------------------------------------------------- Newton made exact
NIT_EXACT = 50

# Asserted edits of the shipped kernel's source (mechrel/integrate/radau.py): the Jacobian is
# brought up to date (in full) at the current end-stage value before every Newton iteration
# but the first and the matrices refactorised, up to NIT_EXACT iterations, and no step
# reduction for a predicted slow convergence (only divergence, θ ≥ 0.99, still halves the
# step). Each edit must apply exactly once, so a change of the kernel fails here loudly.
_LOOP_TOP = ("    while True:\n        if newt >= nit:\n            status = NEWTON_FAILED\n"
             "            break\n")
_CALL_END = ("            faccon, nit, fixed, z1, z2, z3, w1, w2, w3, F3, ystage, r1, rc, work1, "
             "work2, ")
_EDITS = [
    ("                       rc, work1, work2, stats):\n",
     "                       rc, work1, work2, stats, sys_smooth, JS, Jsm, jac_floor, yp,\n"
     "                       use_partial):\n"),
    (_LOOP_TOP,
     _LOOP_TOP
     + "        if newt >= 1:\n"
     "            for i in range(ny):\n"
     "                ystage[i] = y[i] + z3[i]\n"
     "            _update_jacobian(tph, ystage, fa, hist, sys, sys_smooth, ws, J, JS, Jsm, False,\n"
     "                             0, use_partial, jac_floor, yp, fa, fb, stats)\n"
     "            _factor_matrices(J, h, E1, E2, piv1, piv2)\n"
     "            stats[S_LU] += 1\n"),
    ("                if dyth >= 1.0 and not fixed:", "                if False:"),
    (_CALL_END + "stats)\n",
     _CALL_END + "stats,\n            sys_smooth, JS, Jsm, jac_floor, yp, use_partial)\n"),
    ("    nit = NIT_FIXED if fixed else NIT\n", "    nit = NIT_FIXED if fixed else NIT_EXACT\n"),
    ("from mechrel.integrate.base import Integrator\n",
     f"from mechrel.integrate.base import Integrator\nNIT_EXACT = {NIT_EXACT}\n"),
]


# A Newton-aware step-size cap (tried for "step-size control that does not throw away 40 % of
# its steps"): the simplified Newton iteration's contraction θ grows about in proportion to the
# step (measured on the lubricated nine-bar: 4× the step, 4× θ), so after an accepted step
# with a measured θ the next step is capped at h·θ_T/θ, θ_T = 0.2, and after a step that
# converged at once (no θ) the cap doubles.
THETA_TARGET = 0.2
_CONTROLLER_EDITS = [
    ("    hnew = h\n", "    hnew = h\n    hcap = 1e300\n"),
    ("            hacc = h\n",
     "            if newt > 1:\n"
     "                hcap = h * THETA_TARGET / max(theta, 1e-4)\n"
     "            else:\n"
     "                hcap = 2.0 * max(hcap, h)\n"
     "            hnew = min(hnew, hcap)\n"
     "            hacc = h\n"),
    ("from mechrel.integrate.base import Integrator\n",
     f"from mechrel.integrate.base import Integrator\nTHETA_TARGET = {THETA_TARGET!r}\n"),
]


def radau_variant(edits, name, formulations=False):
    """The ``_advance`` of Radau compiled from a copy of the shipped kernel's source with
    ``edits`` applied (each must match exactly once), in a temporary module ``name``; the
    copy's relative imports are made absolute first, so edits anchor on the absolute ones.
    The variant integrates the absolute equations; with ``formulations`` it is the copy's own
    ``Radau._advance``, which integrates the reduced ones wherever the shipped one does."""
    mod = radau_copy(edits, name)
    if formulations:
        advance = mod.Radau._advance
        advance.module = mod
        advance.around = (mod.Radau._before, mod.Radau._after)  # its Python around the kernel
        return advance

    def advance(self, system, t0, y0, hist, t_out, ctl, log_from=math.inf, n_dense=0):
        return mod.radau5_kernel(system, without_clearance_forces(system), t0, y0, hist, t_out,
                                 self.step or 0.0, self.rtol, self.atol, self.max_steps,
                                 self.onset_tolerance, self.fixed_step, ctl, log_from, n_dense)
    advance.module = mod  # the variant's other functions, for callers that time them
    return advance


# ---------------------------------------------------------------------------- measurements
def peak_dev(r, e_ref):
    """|peak − peak_ref| / peak_ref of the slider acceleration error, θ = 0 excluded (fixed by
    the initial state; bench_lubricated_ninebar.py)."""
    e = r.error("slider", "acceleration")
    p_ref = float(np.max(np.abs(e_ref[1:])))
    return abs(float(np.max(np.abs(e[1:]))) - p_ref) / p_ref


class _Swap:
    """Run ``simulate`` with another ``Radau._advance`` (the variant kernel or RODAS), and the
    Python around it that goes with it (``advance.around``: ``(_before, _after)``; none, the
    base ``Integrator``'s, for an ``_advance`` that integrates the absolute equations itself)."""

    def __init__(self, advance):
        self.advance, self.saved = advance, None
        self.around = getattr(advance, "around", (Integrator._before, Integrator._after))

    def __enter__(self):
        self.saved = (radau.Radau._before, radau.Radau._advance, radau.Radau._after)
        radau.Radau._before, radau.Radau._after = self.around
        radau.Radau._advance = self.advance

    def __exit__(self, *exc):
        radau.Radau._before, radau.Radau._advance, radau.Radau._after = self.saved


def rhs_cost(scene, res, formulation):
    """µs per evaluation over the states of the run ``res``, in ``formulation``
    (``"absolute"`` or ``"reduced"``); also the system and states it used."""
    system = compile_scene(scene).dynamic
    T = np.ascontiguousarray(res.time)
    Y = np.concatenate([res.q, res.v, np.zeros((T.size, N_WORK))], axis=1)
    sys_ = system
    if formulation == "reduced":
        sys_ = reduced_system(system, Y[0], required=True)
        Y = np.array([reduced_coordinates(system, sys_.con, q, v) for q, v in zip(res.q, res.v)])
    Y = np.ascontiguousarray(Y)
    hist = np.zeros(system.n_contacts)
    return _per_call(_eval_loop, (T, Y, hist, sys_, 0), T.size), sys_, T, Y


def lu_cost(sys_, T, Y, h):
    """µs per LU pair of Radau's condensed iteration matrices at mid-cycle, step ``h``, from
    its full Jacobian there (increments' floor ``atol/rtol`` of this benchmark's settings)."""
    k = T.size // 2
    system = getattr(sys_, "sys", sys_)  # the reduced system's own mechanism
    J = _jacobian(T[k], Y[k].copy(), np.zeros(system.n_contacts), sys_, ATOL_RATIO)
    return _per_call(_lu_loop, (J, h, 0), 1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=7, help="timed, interleaved runs per setting")
    ap.add_argument("--json", default=None, help="write all results here")
    ap.add_argument("--out", default=None, help="write the markdown table here")
    ap.add_argument("--formulation", default="auto", choices=("auto", "absolute", "reduced"),
                    help="the equations radau integrates (default: the shipped choice)")
    args = ap.parse_args(argv)
    # the variants run as the shipped Radau does, in the formulation of the instance
    variant = radau_variant(_EDITS, "radau_exact_newton", formulations=True)
    capped = radau_variant(_CONTROLLER_EDITS, "radau_theta_cap", formulations=True)
    form = {} if args.formulation == "auto" else {"formulation": args.formulation}
    criterion = 3e-4 if args.formulation == "absolute" else 3e-2
    rows = []
    lub = [("nine-bar-lubricated", criterion, "1 % peak criterion (bench_formulations.py)"),
           ("nine-bar-lubricated", 1e-5, "the main study's setting"),
           ("nine-bar-lubricated", 1e-7, "the scene's default"),
           ("slider-crank-lubricated", 1e-5, "the accuracy report's recommendation")]
    refs = {}
    for name, rtol, why in lub:
        scene = load_scene(name)
        if name not in refs:
            ref = simulate(scene, integrator="radau", rtol=REF_RTOL, atol=REF_ATOL)
            refs[name] = (ref.error("slider", "acceleration"), ref)
        e_ref, ref = refs[name]
        kw = {"integrator": "radau", "rtol": rtol, "atol": rtol * ATOL_RATIO, **form}
        r = simulate(scene, **kw)
        formulation = r.stats["formulation"]
        row = {"scene": name, "setting": f"radau ({formulation}) rtol {rtol:g}", "why": why,
               "rtol": rtol, "formulation": formulation,
               "kind": "implicit", "steps": r.stats["n_steps"], "rejected": r.stats["n_rejected"],
               "rhs": r.stats["n_rhs"], "jac": r.stats["n_jacobians"], "lu": r.stats["n_lu"],
               "peak_dev": peak_dev(r, e_ref), "cycles": scene.analysis.cycles,
               "kw": kw, "scene_obj": scene}
        with _Swap(variant):
            rv = simulate(scene, **kw)
        row["variant_steps"] = rv.stats["n_steps"]
        row["variant_peak_dev"] = peak_dev(rv, e_ref)
        row["t_f"], sys_, T, Y = rhs_cost(scene, ref, formulation)
        row["t_lu"] = lu_cost(sys_, T, Y, scene.analysis_duration / max(row["steps"], 1))
        rows.append(row)
    # RODAS at the 1 % criterion: the loosest tolerance that meets it
    e_ref = refs["nine-bar-lubricated"][0]
    scene = load_scene("nine-bar-lubricated")
    rodas = None
    for rt in (1e-3, 3e-4, 1e-4, 3e-5, 1e-5):
        with _Swap(rodas_advance):
            rr = simulate(scene, integrator="radau", rtol=rt, atol=rt * ATOL_RATIO)
        dev = peak_dev(rr, e_ref)
        print(f"RODAS rtol {rt:g}: {rr.stats['n_steps']} steps, {rr.stats['n_rejected']} "
              f"rejected, peak deviation {dev:.2e}", flush=True)
        if dev <= 0.01:
            rodas = {"rtol": rt, "steps": rr.stats["n_steps"],
                     "rejected": rr.stats["n_rejected"], "peak_dev": dev}
            break
    rows[0]["rodas"] = rodas
    for name in ("nine-bar-dry", "slider-crank-dry"):
        scene = load_scene(name)
        r = simulate(scene)
        t_f, *_ = rhs_cost(scene, r, "absolute")  # DOPRI5 integrates the absolute ones
        rows.append({"scene": name, "setting": f"{r.stats['integrator']} (default)",
                     "why": "the scene's default (chaotic: no 1 % setting exists)",
                     "kind": "explicit", "steps": r.stats["n_steps"],
                     "rejected": r.stats["n_rejected"], "rhs": r.stats["n_rhs"],
                     "cycles": scene.analysis.cycles, "t_f": t_f, "kw": {},
                     "scene_obj": scene})
    # the step-size controller: RADAU5's against the Newton-aware cap, lubricated nine-bar
    ctl_rows = []
    scene = load_scene("nine-bar-lubricated")
    e_ref = refs["nine-bar-lubricated"][0]
    for rt in (3e-3, 1e-3, 3e-4, 1e-5, 1e-7):
        for label, adv in (("RADAU5 (shipped)", None), (f"θ cap {THETA_TARGET}", capped)):
            kw = {"integrator": "radau", "rtol": rt, "atol": rt * ATOL_RATIO, **form}
            if adv is None:
                r = simulate(scene, **kw)
            else:
                with _Swap(adv):
                    r = simulate(scene, **kw)
            st = r.stats
            ctl_rows.append({"scene": "nine-bar-lubricated", "setting": f"rtol {rt:g}",
                             "controller": label, "steps": st["n_steps"],
                             "rejected": st["n_rejected"],
                             "newton_rejected": st.get("n_newton_rejected"),
                             "rhs": st["n_rhs"], "peak_dev": peak_dev(r, e_ref), "kw": kw,
                             "advance": adv, "cycles": scene.analysis.cycles,
                             "scene_obj": scene})
    # interleaved timing
    timed = rows + ctl_rows
    for row in timed:
        row["walls"], row["kernel"] = [], []
    for _ in range(args.repeats):
        for row in timed:
            t0 = time.perf_counter()
            if row.get("advance") is None:
                r = simulate(row["scene_obj"], **row["kw"])
            else:
                with _Swap(row["advance"]):
                    r = simulate(row["scene_obj"], **row["kw"])
            row["walls"].append((time.perf_counter() - t0) / row["cycles"])
            row["kernel"].append(r.stats["wall_time"] / row["cycles"])
    lines = table(rows) + [""] + ctl_table(ctl_rows)
    print("\n".join(lines))
    meta = {"git": git_state(), "date": time.strftime("%Y-%m-%d %H:%M"),
            "load": os.getloadavg(), "python": platform.python_version(),
            "repeats": args.repeats}
    print(f"git {meta['git']}, load average {meta['load'][0]:.2f}", flush=True)
    if args.out:
        Path(args.out).write_text("\n".join(lines) + "\n")
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"meta": meta, "rows": [_plain(row) for row in rows],
             "controller": [_plain(row) for row in ctl_rows]}, indent=1, default=float))


def _plain(row):
    return {k: v for k, v in row.items() if k not in ("scene_obj", "advance")}


def ctl_table(rows):
    out = ["| scene | setting | controller | steps | rejected (by Newton) | rhs | "
           "simulate per cycle (ms, median) | peak deviation |",
           "|---|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['scene']} | {r['setting']} | {r['controller']} | {r['steps']} | "
                   f"{r['rejected']} ({r['newton_rejected']}) | {r['rhs']} | "
                   f"{statistics.median(r['walls']) * 1e3:.2f} | {r['peak_dev']:.1e} |")
    return out


def table(rows):
    out = ["| scene | setting | cost per cycle, simulate (ms) | integrator (ms) | steps (rejected) "
           "| rhs | t_f (µs) | t_LU pair (µs) | fewest steps N (how) | floor s·N·t_f (ms) "
           "| floor with one LU per step (ms) | cost / floor |",
           "|---|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|"]
    for r in rows:
        cyc = r["cycles"]
        wall = statistics.median(r["walls"]) * 1e3
        kern = statistics.median(r["kernel"]) * 1e3
        if r["kind"] == "implicit":
            cands = [(r["steps"] / cyc, "radau's accepted steps"),
                     (r["variant_steps"] / cyc,
                      f"radau, Newton made exact (peak dev. {r['variant_peak_dev']:.1e})")]
            if r.get("rodas"):
                cands.append((r["rodas"]["steps"] / cyc,
                              f"RODAS rtol {r['rodas']['rtol']:g}"))
            n, how = min(cands)
            floor = STAGES * n * r["t_f"] * 1e-3
            floor_lu = n * (STAGES * r["t_f"] + r["t_lu"]) * 1e-3
            out.append(f"| {r['scene']} | {r['setting']} ({r['why']}; peak dev. "
                       f"{r['peak_dev']:.1e}) | {wall:.2f} | {kern:.2f} | "
                       f"{r['steps'] / cyc:.0f} ({r['rejected'] / cyc:.0f}) | "
                       f"{r['rhs'] / cyc:.0f} | {r['t_f']:.2f} | {r['t_lu']:.1f} | "
                       f"{n:.0f} ({how}) | {floor:.2f} | {floor_lu:.2f} | "
                       f"{wall / floor:.0f}× ({wall / floor_lu:.0f}×) |")
        else:
            floor = 6 * r["steps"] / cyc * r["t_f"] * 1e-3  # DOPRI5: 6 new stages per step
            out.append(f"| {r['scene']} | {r['setting']} ({r['why']}) | {wall:.2f} | "
                       f"{kern:.2f} | {r['steps'] / cyc:.0f} ({r['rejected'] / cyc:.0f}) | "
                       f"{r['rhs'] / cyc:.0f} | {r['t_f']:.2f} | – | {r['steps'] / cyc:.0f} "
                       f"(its own steps; explicit, 6 stages) | {floor:.2f} | – | "
                       f"{wall / floor:.1f}× |")
    return out


if __name__ == "__main__":
    main()
