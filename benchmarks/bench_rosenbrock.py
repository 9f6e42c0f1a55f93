"""Rosenbrock methods on the reduced equations against radau (issue 14 §1 and §3): a measured
lever that was not adopted.

Radau spends most of a cycle of the lubricated nine-bar in its simplified Newton iteration
(about three iterations per trial step, 85–90 trial steps per cycle rejected because Newton
would not converge; docs/performance.md, "Why Newton rejects steps on the reduced
equations"). A Rosenbrock method is linearly implicit: one Jacobian and one LU per step, a
fixed number of right-hand sides per step and no iteration that can fail. This script runs two
of them with radau's contract (the same outputs, onsets and statistics; no step log) on the
reduced equations:

* **RODAS** (Hairer & Wanner's ``rodas.f``, HW II §VI.4: order 4(3), six stages, L-stable,
  stiffly accurate, dense output of order 3; ``bench_floor.py`` runs the same method in NumPy
  on the absolute equations, as a bound on the fewest steps, and its coefficients are used
  here);
* **Rodas5P** (Steinebach, "Construction of Rosenbrock–Wanner method Rodas5P and numerical
  benchmarks within the Julia Differential Equations package", BIT 63 (2023) 27: order 5(4),
  eight stages, built to keep its order on the Prothero–Robinson problem, i.e. on stiff
  components).

Each step solves ``(I/(γh) − J) k_i = f(t + c_i h, y + Σ a_ij k_j) + Σ (C_ij/h) k_j
+ d_i h ∂f/∂t`` (the formulation of ``rodas.f``), condensed to the coordinates as radau does
(``mechrel.integrate.radau._solve_condensed``). ``J`` is radau's Jacobian at the step's start
(smooth rest + fast clearance part, :func:`mechrel.integrate.radau._update_jacobian`, the
fast part refreshed every step); ``∂f/∂t`` by one forward difference. The error estimate is
the last stage (``k_s``), in the scaled RMS norm with ``atol + rtol max(|y₀|, |y₁|)``;
step control as in RODAS (factor ``err^(−1/p)``, Gustafsson's predictive controller, bounds
[h/6, 5h]); tolerances untransformed (radau transforms them, module docstring of
``mechrel.integrate.radau``): compare at equal accuracy, not equal rtol.

Measured on ``nine-bar-lubricated`` (one cycle, 361 outputs), against the same radau
(``radau``, a fresh copy of the shipped kernel compiled in this process, so that neither side
carries the cached kernel's 5–7 %; docs/performance.md): for every setting (rtol, atol = 1e-3
rtol) the steps, rejected steps, right-hand sides and the accuracy against radau rtol 1e-11 by
the two criteria of ``bench_lubricated_ninebar.py`` (the peak of the slider's acceleration
error over θ ≥ 1°, and the largest deviation of the acceleration error curve, both relative
to the reference peak), then the integrator's wall time, median of ``--repeats`` runs per
round and of the rounds' medians, the methods interleaved.

A second table says which state components set the Rosenbrock step: Rodas5P with the error
norm taken over a subset of the state (all; all but the two work integrals; the
eccentricities only; the eccentricities' rates and the work integrals).
A third says whether the Jacobian's smooth rest, which is kept for up to 30 steps while the
fast part is refreshed every step, costs RODAS steps: the same runs with a full Jacobian at
every step.

Run (≈ 2–3 min, of which ≈ 1 compiling)::

    python benchmarks/bench_rosenbrock.py --rounds 5
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state, radau_copy  # noqa: E402
from bench_floor import _RA, _RC, _RCT, _RD, _RG, _RH  # noqa: E402
from bench_lubricated_ninebar import accuracy  # noqa: E402

import mechrel.integrate.radau as radau  # noqa: E402
from mechrel.mechanics.borrow import borrowed, keep_alive  # noqa: E402
from mechrel.integrate.events import (CTL_DONE, H_START_FLOOR, S_LU,  # noqa: E402
                                      S_ONSET_REJECTED, S_REJECTED, S_RHS, S_STATUS, S_STEPS,
                                      STATUS_NEWTON, STATUS_NONFINITE, all_finite, new_log,
                                      onset_fraction, out_of_budget, record_violation, start,
                                      update_history_from)
from mechrel.integrate.radau import (UROUND, _rms, _solve_condensed,  # noqa: E402
                                     _update_jacobian, lu_factor)
from mechrel.mechanics.formulation import (evaluate, evaluate_inline, gaps,  # noqa: E402
                                           has_fast_part, n_coordinates, output_width,
                                           write_output)
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

SAFE = 0.9
FAC_UP = 6.0  # h_new ≤ 6 h (RODAS: FAC2 = 6)
FAC_DOWN = 0.2  # h_new ≥ h/5 (RODAS: FAC1 = 0.2)
SQRT_UROUND = math.sqrt(UROUND)


def rodas4():
    """RODAS (``rodas.f``, METH = 1; the coefficients of ``bench_floor.py``'s NumPy RODAS): A,
    C, c, d, dense-output rows H, γ, order of the error estimate's exponent."""
    A = np.zeros((6, 6))
    C = np.zeros((6, 6))
    for i, row in enumerate(_RA, start=1):
        A[i, :i] = row
    A[5, :4] = A[4, :4]
    A[5, 4] = 1.0  # stiffly accurate: stage 6 starts from y + Σ a_5j k_j + k_5
    for i, row in enumerate(_RC, start=1):
        C[i, :i] = row
    H = np.zeros((2, 6))
    H[:, :5] = _RH
    return A, C, np.array(_RCT), np.array(_RD), H, _RG, 4.0


def rodas5p():
    """Rodas5P (Steinebach 2023; the tableau as published in Julia's OrdinaryDiffEq): A, C,
    c, d, dense-output rows H, γ, order of the error estimate's exponent."""
    A = np.zeros((8, 8))
    C = np.zeros((8, 8))
    A[1, 0] = 3.0
    A[2, :2] = 2.849394379747939, 0.45842242204463923
    A[3, :3] = -6.954028509809101, 2.489845061869568, -10.358996098473584
    A[4, :4] = 2.8029986275628964, 0.5072464736228206, -0.3988312541770524, -0.04721187230404641
    A[5, :5] = (-7.502846399306121, 2.561846144803919, -11.627539656261098,
                -0.18268767659942256, 0.030198172008377946)
    A[6, :5] = A[5, :5]
    A[6, 5] = 1.0
    A[7, :6] = A[6, :6]
    A[7, 6] = 1.0
    C[1, 0] = -14.155112264123755
    C[2, :2] = -17.97296035885952, -2.859693295451294
    C[3, :3] = 147.12150275711716, -1.41221402718213, 71.68940251302358
    C[4, :4] = 165.43517024871676, -0.4592823456491126, 42.90938336958603, -5.961986721573306
    C[5, :5] = (24.854864614690072, -3.0009227002832186, 47.4931110020768, 5.5814197821558125,
                -0.6610691825249471)
    C[6, :6] = (30.91273214028599, -3.1208243349937974, 77.79954646070892, 34.28646028294783,
                -19.097331116725623, -28.087943162872662)
    C[7, :7] = (37.80277123390563, -3.2571969029072276, 112.26918849496327, 66.9347231244047,
                -40.06618937091002, -54.66780262877968, -9.48861652309627)
    c = np.array([0.0, 0.6358126895828704, 0.4095798393397535, 0.9769306725060716,
                  0.4288403609558664, 1.0, 1.0, 1.0])
    d = np.array([0.21193756319429014, -0.42387512638858027, -0.3384627126235924,
                  1.8046452872882734, 2.325825639765069, 0.0, 0.0, 0.0])
    H = np.array([
        [25.948786856663858, -2.5579724845846235, 10.433815404888879, -2.3679251022685204,
         0.524948541321073, 1.1241088310450404, 0.4272876194431874, -0.17202221070155493],
        [-9.91568850695171, -0.9689944594115154, 3.0438037242978453, -24.495224566215796,
         20.176138334709044, 15.98066361424651, -6.789040303419874, -6.710236069923372],
        [11.419903575922262, 2.8879645146136994, 72.92137995996029, 80.12511834622643,
         -52.072871366152654, -59.78993625266729, -0.15582684282751913, 4.883087185713722]])
    return A, C, c, d, H, 0.21193756319429014, 5.0


@njit(cache=False, nogil=True)
def rosenbrock_kernel(TA, TC, Tc, Td, TH, gam, order, err_lo, err_hi, full_jacobian, sys,
                      sys_smooth, t0, y0, hist, t_out, h0, rtol, atol, max_steps, onset_tol, ctl):
    """A Rosenbrock method given by its tableau, with ``radau5_kernel``'s arguments and
    return values (no log; module docstring). The error norm runs over the state components
    ``err_lo … err_hi − 1``; with ``full_jacobian`` every step's Jacobian is a full one (the
    smooth rest differenced again), not only a fresh fast part."""
    ns = TA.shape[0]
    nd = TH.shape[0]
    nout = t_out.shape[0]
    ny = y0.shape[0]
    nq = n_coordinates(sys)
    jac_floor = atol / rtol
    expo = 1.0 / order
    Y, YD, stats, floors, y, f0, k, tend, ws = start(sys, t0, y0, hist, t_out)
    H = np.zeros((nout, hist.shape[0]))
    for i in range(k):
        H[i] = hist
    ctl[CTL_DONE] = k
    t = t0
    scal = np.empty(ny)
    for i in range(ny):
        scal[i] = atol + rtol * abs(y[i])
    h = h0
    if h <= 0.0:  # Hairer's starting step, as in radau5_kernel
        d0 = _rms(y, scal)
        d1 = _rms(f0, scal)
        h = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h = max(h, H_START_FLOOR * max(1.0, abs(t)))
    if k < nout:
        h = min(h, tend - t)
    J = np.zeros((ny, ny))
    JS = np.zeros((ny, ny))
    Jsm = np.zeros((ny - nq, 2 * nq))
    E = np.zeros((nq, nq))
    piv = np.zeros(nq, dtype=np.int64)
    work = np.zeros(nq)
    K = np.zeros((ns, ny))
    D = np.zeros((nd, ny))
    yt = np.zeros(ny)
    ft = np.zeros(ny)
    dfdt = np.zeros(ny)
    ynew = np.zeros(ny)
    yold = np.zeros(ny)
    fa = np.zeros(ny)
    fb = np.zeros(ny)
    yp = np.zeros(ny)
    ydense = np.zeros(ny)
    fdense = np.zeros(ny)
    use_partial = has_fast_part(sys)
    partial = np.bool_(False)
    n_partial = np.int64(0)
    need_jac = True
    first = True
    reject = False
    hacc = h
    erracc = 1e-2
    n_sing = 0
    nh = hist.shape[0]
    contacts = nh > 0
    g0 = np.empty(nh)
    g1 = np.empty(nh)
    gd1 = np.empty(nh)
    if contacts:
        gaps(t, y, sys, g0, gd1)
    log, nlog = new_log(math.inf, output_width(sys), nh)
    owner = ws  # sys, sys_smooth and ws borrowed as radau5_kernel does (mechanics/borrow.py)
    sys, sys_smooth, ws = borrowed((sys, sys_smooth, owner))
    while k < nout:
        if need_jac:  # J and ∂f/∂t at the step's start
            n_partial = _update_jacobian(t, y, f0, hist, sys, sys_smooth, ws, J, JS, Jsm,
                                         partial, n_partial, use_partial, jac_floor, yp, fa, fb,
                                         stats)
            dt = SQRT_UROUND * max(abs(t), 1e-3)
            evaluate(t + dt, y, hist, sys, ws, ft)
            stats[S_RHS] += 1
            for i in range(ny):
                dfdt[i] = (ft[i] - f0[i]) / dt
            need_jac = False
        if out_of_budget(stats, h, t, max_steps, ctl):
            break
        g = 1.0 / (gam * h)
        for i in range(nq):  # the condensed matrix g² I − g A_v − A_q
            for j in range(nq):
                E[i, j] = -g * J[nq + i, nq + j] - J[nq + i, j]
            E[i, i] += g * g
        ok = lu_factor(E, piv)
        stats[S_LU] += 1
        if not ok:
            n_sing += 1
            if n_sing >= 5:
                stats[S_STATUS] = STATUS_NEWTON
                break
            h *= 0.5
            reject = True
            continue
        tph = t + h
        for st in range(ns):
            if st == 0:
                for i in range(ny):
                    ft[i] = f0[i]
            else:
                for i in range(ny):
                    s = y[i]
                    for j in range(st):
                        s += TA[st, j] * K[j, i]
                    yt[i] = s
                evaluate_inline(t + Tc[st] * h, yt, hist, sys, ws, ft)
                stats[S_RHS] += 1
            kk = K[st]
            for i in range(ny):
                s = ft[i] + h * Td[st] * dfdt[i]
                for j in range(st):
                    s += TC[st, j] * K[j, i] / h
                kk[i] = s
            _solve_condensed(E, piv, J, g, kk, work)
        err = 0.0
        for i in range(ny):
            ynew[i] = yt[i] + K[ns - 1, i]
        for i in range(err_lo, err_hi):
            sk = atol + rtol * max(abs(y[i]), abs(ynew[i]))
            err += (K[ns - 1, i] / sk) ** 2
        err = math.sqrt(err / (err_hi - err_lo))
        if not err == err:  # a non-finite stage: reject as a large error
            err = 1e10
        quot = max(1.0 / FAC_UP, min(1.0 / FAC_DOWN, err ** expo / SAFE))
        hnew = h / quot
        if err <= 1.0:
            if contacts:
                gaps(tph, ynew, sys, g1, gd1)
                th_on = onset_fraction(g0, g1, hist, onset_tol)
                if th_on < 1.0:
                    stats[S_ONSET_REJECTED] += 1
                    h *= th_on
                    continue
            if not first:  # Gustafsson's predictive controller
                facgus = (hacc / h) * (err * err / erracc) ** expo / SAFE
                facgus = max(1.0 / FAC_UP, min(1.0 / FAC_DOWN, facgus))
                quot = max(quot, facgus)
                hnew = h / quot
            first = False
            hacc = h
            erracc = max(1e-2, err)
            told = t
            t = tph
            for i in range(ny):
                yold[i] = y[i]
                y[i] = ynew[i]
                for r in range(nd):
                    s = 0.0
                    for j in range(ns):
                        s += TH[r, j] * K[j, i]
                    D[r, i] = s
            stats[S_STEPS] += 1
            while k < nout and t_out[k] <= t:
                if t_out[k] == t:
                    ydense[:] = y
                else:  # y(s) = (1 − s) y₀ + s (y₁ + (1 − s)(D₀ + s D₁ + s² D₂ …))
                    sv = (t_out[k] - told) / h
                    s1 = 1.0 - sv
                    for i in range(ny):
                        p = D[nd - 1, i]
                        for r in range(nd - 2, -1, -1):
                            p = D[r, i] + sv * p
                        ydense[i] = yold[i] * s1 + sv * (y[i] + s1 * p)
                evaluate(t_out[k], ydense, hist, sys, ws, fdense)
                write_output(sys, ws, ydense, fdense, Y[k], YD[k])
                H[k] = hist
                stats[S_RHS] += 1
                k += 1
            ctl[CTL_DONE] = k
            if not all_finite(y):
                stats[S_STATUS] = STATUS_NONFINITE
                break
            changed = False
            if contacts:
                g0, g1 = g1, g0
                changed = update_history_from(g0, gd1, hist, floors, stats)
            evaluate(t, y, hist, sys, ws, f0)
            record_violation(ws, stats)
            stats[S_RHS] += 1
            for i in range(ny):
                scal[i] = atol + rtol * abs(y[i])
            if reject:
                hnew = min(hnew, h)
            reject = False
            n_sing = 0
            if k >= nout:
                break
            if t + hnew * (1.0 + 1e-6) >= tend:
                h = tend - t
            else:
                h = hnew
            need_jac = True
            partial = use_partial and not changed and not full_jacobian
        else:
            stats[S_REJECTED] += 1
            reject = True
            h = 0.1 * h if first else hnew
    keep_alive(owner)
    return Y, YD, hist, stats, t, y, log[:nlog], H


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    scene = load_scene("nine-bar-lubricated")
    ref = simulate(scene, rtol=1e-11, atol=1e-14)
    e_ref = ref.error("slider", "acceleration")
    copy = radau_copy([], "radau_copy_rosenbrock")
    shipped_kernel = radau.radau5_kernel

    def rosenbrock(tab, lo=0, hi=0, full=False):
        A, C, c, d, Hd, gam, order = tab

        def kernel(sys_, smooth, t0, y0, hist, t_out, h0, rtol, atol, max_steps, onset_tol,
                   fixed, ctl, log_from, n_dense):
            return rosenbrock_kernel(A, C, c, d, Hd, gam, order, lo, y0.shape[0] - hi, full,
                                     sys_, smooth, t0, y0, hist, t_out, h0, rtol, atol,
                                     max_steps, onset_tol, ctl)
        return kernel

    methods = {"radau": (copy.radau5_kernel, [3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5, 1e-7]),
               "RODAS": (rosenbrock(rodas4()), [3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5, 1e-6]),
               "Rodas5P": (rosenbrock(rodas5p()),
                           [3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5, 1e-6])}

    def run(kernel, tol):
        radau.radau5_kernel = kernel  # _advance_reduced calls the kernel by module global
        try:
            return simulate(scene, rtol=tol, atol=tol * 1e-3)
        finally:
            radau.radau5_kernel = shipped_kernel

    rows = {}
    for name, (kernel, tols) in methods.items():
        for tol in tols:
            r = run(kernel, tol)
            a = accuracy(r.error("slider", "acceleration"), e_ref)
            s = r.stats
            rows[name, tol] = {
                "steps": s["n_steps"], "rejected": s["n_rejected"], "rhs": s["n_rhs"],
                "peak": a["peak_rel_dev"], "curve": a["curve_rel_dev"], "times": []}
    for rnd in range(args.rounds):
        order = list(methods.items())
        if rnd % 2:
            order.reverse()
        for name, (kernel, tols) in order:
            for tol in tols:
                walls = [run(kernel, tol).stats["wall_time"] for _ in range(args.repeats)]
                rows[name, tol]["times"].append(float(np.median(walls)))
    print("| method | rtol | steps (rejected) | rhs | peak dev. | curve dev. | integrator (ms) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for (name, tol), r in rows.items():
        print(f"| {name} | {tol:g} | {r['steps']} ({r['rejected']}) | {r['rhs']} | "
              f"{r['peak']:.1e} | {r['curve']:.1e} | {np.median(r['times']) * 1e3:.2f} |")
    print("\nThe fastest setting of each method meeting each level of the curve deviation:\n")
    print("| curve dev. ≤ | " + " | ".join(methods) + " |")
    print("|---:|" + "---:|" * len(methods))
    for level in (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5):
        cells = []
        for name in methods:
            ok = [(np.median(r["times"]) * 1e3, tol) for (m, tol), r in rows.items()
                  if m == name and r["curve"] <= level]
            cells.append(f"{min(ok)[0]:.2f} ({min(ok)[1]:g})" if ok else "–")
        print(f"| {level:g} | " + " | ".join(cells) + " |")

    print("\nRodas5P, the error norm over a subset of the state (nz = 4 eccentricity "
          "components, their rates, two work integrals):\n")
    print("| error norm over | rtol | steps (rejected) | curve dev. |\n|---|---:|---:|---:|")
    for label, lo, hi in (("the whole state", 0, 0), ("all but the work integrals", 0, 2),
                          ("the eccentricities", 0, 6), ("the rates and work integrals", 4, 0)):
        for tol in (1e-4, 1e-5, 1e-6):
            r = run(rosenbrock(rodas5p(), lo, hi), tol)
            curve = accuracy(r.error("slider", "acceleration"), e_ref)["curve_rel_dev"]
            print(f"| {label} | {tol:g} | {r.stats['n_steps']} ({r.stats['n_rejected']}) | "
                  f"{curve:.1e} |")
    print("\nRODAS with a full Jacobian at every step against the fast part refreshed (the "
          "smooth rest kept up to 30 steps):\n")
    print("| rtol | steps (rejected), fast part | steps (rejected), full |\n|---:|---:|---:|")
    for tol in (1e-2, 1e-3, 1e-4, 1e-5):
        a, b = (run(rosenbrock(rodas4(), full=f), tol).stats for f in (False, True))
        print(f"| {tol:g} | {a['n_steps']} ({a['n_rejected']}) | {b['n_steps']} "
              f"({b['n_rejected']}) |")
    print(f"\ngit {git_state()}, load average {os.getloadavg()[0]:.2f}, {args.rounds} rounds "
          f"of {args.repeats}")


if __name__ == "__main__":
    main()
