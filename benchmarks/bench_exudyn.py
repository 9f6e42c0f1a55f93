"""Target 3: dry-contact slider-crank at a fixed step, mechrel's compiled RK4 against Exudyn
with an equivalent Python user-function contact force.

Exudyn is an optional benchmark dependency (``pip install exudyn``; measured with 1.13.6), not
a runtime dependency of mechrel.

The mechanism (the ``slider-crank-dry`` scene): crank 0.05 m, rod 0.12 m, masses 0.30 / 0.21 /
0.14 kg, inertias 1e-4 / 2.5e-4 / 1e-4 kg m², crank at 5000 rpm, gravity −9.81 m/s² along y;
clearance joint between the rod's small end (bearing, R_B = 10 mm) and the slider (journal,
c = 0.5 mm); Lankarani–Nikravesh contact with K from eq. 6 (conformal, E = 206 GPa, ν = 0.3),
n = 1.5, c_e = 0.9, impact-speed floor 1e-4 m/s, Coulomb friction c_f = 0.01 with Ambrósio's
c_d (v0 = 1e-4, v1 = 1e-2 m/s). All contact parameters are read from mechrel's packed parameter
vector of that scene; the initial state is mechrel's assembled one (crank at 0, journal centred).

Exudyn model (redundant coordinates, as mechrel): three ``ObjectRigidBody2D`` on
``NodeRigidBody2D``; ``ObjectJointRevolute2D`` at O (ground–crank) and A (crank–rod); the
slider's y and angle held by ``ObjectConnectorCoordinate`` to the ground; the crank driven by a
velocity-level ``ObjectConnectorCoordinate`` (θ̇ = ω, no user function); gravity by
``LoadMassProportional``. The clearance joint is an ``ObjectGenericODE2`` on the rod and slider
nodes whose ``forceUserFunction`` (Python) returns the generalised forces of the contact force
and friction moments (one Python call per residual evaluation); the impact speed δ̇⁻ is recorded
by a Python pre-step user function at the first step that starts in contact (Exudyn has no
event location; mechrel locates onsets to 1 nm, see the physics comparison).

Integrators: mechrel ``rk4`` at step h; Exudyn's explicit RK44 refuses the model ("explicit
integrator detected object … which contains constraints that cannot be solved": Exudyn's
explicit solvers do not support joints), so Exudyn runs its default implicit generalised-α
(spectral radius 1, modified Newton, its default tolerances) at the same fixed step h. h is
chosen so that 1° of crank rotation is a whole number of steps (mechrel also lands on its
output instants every degree).

Timing: each configuration is run ``--repeats`` times, mechrel and Exudyn interleaved;
median and minimum wall time per crank revolution. mechrel's time is ``simulate()`` (compile
scene, assembly, ideal kinematics, integration, outputs every degree, energies); Exudyn's is
``SolveDynamic`` (the model is built before, untimed; no solution file, no sensors).

Physics check (separate, untimed runs sampled at every step): number of impacts, first impact
time, maximum penetration, the eccentricity vector before the first impact, and the peak slider
position deviation from the ideal mechanism over the run.

Run::

    python benchmarks/bench_exudyn.py --json /tmp/bench_exudyn.json
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from mechrel.forces.params import unpack_params  # noqa: E402
from mechrel.mechanics.kinematics import assemble  # noqa: E402
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

SCENE = "slider-crank-dry"


from _common import git_state  # noqa: E402  (benchmarks/ is sys.path[0])

def scene_data():
    sc = load_scene(SCENE)
    cs = compile_scene(sc)
    # the numbers, checked against the scene
    b = sc.bodies
    assert (b["crank"].mass, b["rod"].mass, b["slider"].mass) == (0.30, 0.21, 0.14)
    assert (b["crank"].inertia, b["rod"].inertia) == (1e-4, 2.5e-4)
    assert abs(sc.drivers["crank"].speed - 5000 * 2 * math.pi / 60) < 1e-9
    j = sc.joints["C"]
    assert (j.bearing_radius, j.clearance, j.model) == (10e-3, 0.5e-3, "dry")
    q0, _ = assemble(cs.ideal, cs.q_guess, 0.0)
    qa, va = assemble(cs.assembly, q0, 0.0)
    return sc, cs, qa, va, unpack_params(cs.dynamic.cl_p[0])


class ExudynSliderCrank:
    """The slider-crank in Exudyn with a Python user-function clearance force."""

    def __init__(self, revolutions, h, record=False, spectral_radius=1.0):
        import exudyn as exu
        from exudyn.itemInterface import (LoadMassProportional, MarkerBodyMass,
                                          MarkerBodyPosition, MarkerNodeCoordinate,
                                          NodePointGround, NodeRigidBody2D,
                                          ObjectConnectorCoordinate,
                                          ObjectGenericODE2, ObjectGround, ObjectJointRevolute2D,
                                          ObjectRigidBody2D)
        self.exu = exu
        sc, cs, qa, va, p = scene_data()
        self.omega = sc.drivers["crank"].speed
        self.revolutions = revolutions
        self.h = h
        self.T = revolutions * 2 * math.pi / self.omega
        self.n_steps = int(round(self.T / h))
        SC = exu.SystemContainer()
        mbs = SC.AddSystem()
        self.SC, self.mbs = SC, mbs
        ground = mbs.AddObject(ObjectGround())
        nG = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
        mGc = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nG, coordinate=0))
        g = list(sc.gravity) + [0.0]
        nodes, objs = {}, {}
        for k, name in enumerate(cs.body_names):
            b = sc.bodies[name]
            nodes[name] = mbs.AddNode(NodeRigidBody2D(
                referenceCoordinates=list(qa[3 * k:3 * k + 3]),
                initialVelocities=list(va[3 * k:3 * k + 3])))
            objs[name] = mbs.AddObject(ObjectRigidBody2D(mass=b.mass, inertia=b.inertia,
                                                         nodeNumber=nodes[name]))
            mbs.AddLoad(LoadMassProportional(
                markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=objs[name])), loadVector=g))

        def mpos(name, s):
            return mbs.AddMarker(MarkerBodyPosition(bodyNumber=objs[name],
                                                    localPosition=[s[0], s[1], 0.0]))

        pts = {n: sc.bodies[n].points for n in cs.body_names}
        mO = mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground,
                                              localPosition=list(sc.ground["O"]) + [0.0]))
        mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[mO, mpos("crank", pts["crank"]["O"])]))
        mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[mpos("crank", pts["crank"]["A"]),
                                                           mpos("rod", pts["rod"]["A"])]))
        for coord in (1, 2):  # slider: y = 0 and angle = 0 (the line through O along x)
            mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[
                mGc, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes["slider"],
                                                        coordinate=coord))]))
        mbs.AddObject(ObjectConnectorCoordinate(
            markerNumbers=[mGc, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes["crank"],
                                                                   coordinate=2))],
            velocityLevel=True, offset=self.omega))

        # ---- the clearance joint: bearing rod.B, journal slider.B
        refR = np.array(qa[3:6])
        refS = np.array(qa[6:9])
        sB = tuple(pts["rod"]["B"])
        sS = tuple(pts["slider"]["B"])
        assert sS == (0.0, 0.0)
        c, RB, RS = p["clearance"], p["bearing_radius"], p["journal_radius"]
        K, nexp = p["stiffness"], p["exponent"]
        ce, floor = p["restitution"], p["impact_speed_floor"]
        cf, v0, v1 = p["friction_coefficient"], p["v0"], p["v1"]
        damp = 0.75 * (1.0 - ce * ce)
        st = {"hist": 0.0, "impacts": 0, "calls": 0, "max_pen": 0.0, "first_impact": None,
              "t": [], "x": [], "ex": [], "ey": []}
        self.state = st

        def kin(q, qt):
            xr, yr, tr = refR[0] + q[0], refR[1] + q[1], refR[2] + q[2]
            ct, sn = math.cos(tr), math.sin(tr)
            ax, ay = ct * sB[0] - sn * sB[1], sn * sB[0] + ct * sB[1]
            return (xr + ax, yr + ay, qt[0] - ay * qt[2], qt[1] + ax * qt[2],
                    refS[0] + q[3], refS[1] + q[4], qt[3], qt[4], ax, ay, qt[2], qt[5])

        def force(mbs_, t, item, q, qt):
            st["calls"] += 1
            bx, by, bvx, bvy, sx, sy, svx, svy, ax, ay, wB, wS = kin(q, qt)
            ex, ey = sx - bx, sy - by
            r = math.hypot(ex, ey)
            delta = r - c
            if delta <= 0.0:
                return [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
            nx, ny = ex / r, ey / r
            tx, ty = -ny, nx
            vx, vy = svx - bvx, svy - bvy
            dd = vx * nx + vy * ny
            hist = st["hist"]
            vimp = max(hist, floor) if hist > 0.0 else max(dd, floor)
            FN = max(0.0, K * delta ** nexp * (1.0 + damp * dd / vimp))
            FT = 0.0
            if cf > 0.0:
                vT = vx * tx + vy * ty + wS * RS - wB * RB
                a = abs(vT)
                cd = 0.0 if a < v0 else (1.0 if a > v1 else (a - v0) / (v1 - v0))
                FT = -cf * cd * FN * math.copysign(1.0, vT)
            Fx, Fy = -FN * nx + FT * tx, -FN * ny + FT * ty
            # rod (bearing): −F at rod.B (arm A(θ) s_B from the rod's centre) and M_B = −R_B F_T;
            # slider (journal): F at its centre and M_S = R_S F_T
            return [-Fx, -Fy, -(ax * Fy - ay * Fx) - RB * FT, Fx, Fy, RS * FT]

        mbs.AddObject(ObjectGenericODE2(nodeNumbers=[nodes["rod"], nodes["slider"]],
                                        massMatrix=np.zeros((6, 6)), forceUserFunction=force))
        mbs.Assemble()
        iR, iS = mbs.GetNodeODE2Index(nodes["rod"]), mbs.GetNodeODE2Index(nodes["slider"])
        sd = mbs.systemData

        def prestep(mbs_, t_end):
            # Exudyn passes the time the step will reach; the state is the one at its start
            t = t_end - h
            q = sd.GetODE2Coordinates()
            qt = sd.GetODE2Coordinates_t()
            bx, by, bvx, bvy, sx, sy, svx, svy, *_ = kin(
                (q[iR], q[iR + 1], q[iR + 2], q[iS], q[iS + 1], q[iS + 2]),
                (qt[iR], qt[iR + 1], qt[iR + 2], qt[iS], qt[iS + 1], qt[iS + 2]))
            ex, ey = sx - bx, sy - by
            r = math.hypot(ex, ey)
            delta = r - c
            if delta > 0.0:
                if st["hist"] == 0.0:  # onset: record the impact speed
                    st["hist"] = max(((svx - bvx) * ex + (svy - bvy) * ey) / r, floor)
                    st["impacts"] += 1
                    if st["first_impact"] is None:
                        st["first_impact"] = t
                if delta > st["max_pen"]:
                    st["max_pen"] = delta
            else:
                st["hist"] = 0.0
            if record:
                st["t"].append(t)
                st["x"].append(sx)
                st["ex"].append(ex)
                st["ey"].append(ey)
            return True

        mbs.SetPreStepUserFunction(prestep)
        ss = exu.SimulationSettings()
        ti = ss.timeIntegration
        ti.numberOfSteps = self.n_steps
        ti.endTime = self.T
        ti.verboseMode = 0
        ti.generalizedAlpha.spectralRadius = spectral_radius
        ss.solution.file.write = False
        ss.solution.sensors.active = False
        ss.displayComputationTime = False
        self.ss = ss

    def solve(self):
        t0 = time.perf_counter()
        ok = self.exu.SolveDynamic(self.mbs, self.ss,
                                   solverType=self.exu.DynamicSolverType.GeneralizedAlpha)
        wall = time.perf_counter() - t0
        if not ok:
            raise RuntimeError("Exudyn SolveDynamic failed")
        return wall


def run_mechrel(h, revolutions, sample_step=None):
    over = {"analysis.cycles": revolutions}
    if sample_step is not None:
        over["analysis.sample_step"] = sample_step
    sc = load_scene(SCENE, overrides=over)
    t0 = time.perf_counter()
    r = simulate(sc, integrator="rk4", step=h)
    return time.perf_counter() - t0, r


def physics(h, revolutions, spectral_radius):
    """Untimed runs sampled at every step: impacts, penetration, slider position."""
    _, r = run_mechrel(h, revolutions, sample_step=h)
    c = 0.5e-3
    pen_m = (r.orbits["C"]["eps"] - 1.0) * c
    x_m = r.outputs["slider"]["displacement"]
    t_m = r.time
    first_m = float(t_m[np.argmax(pen_m > 0)]) if np.any(pen_m > 0) else None
    ex = ExudynSliderCrank(revolutions, h, record=True, spectral_radius=spectral_radius)
    ex.solve()
    st = ex.state
    t_e, x_e = np.array(st["t"]), np.array(st["x"])
    x_ideal = r.ideal["slider"]["displacement"]
    # eccentricity vector before the first impact (both codes), on mechrel's grid: the journal
    # flies free in the bearing until then, driven by the rod's motion
    t_first = min(v for v in (first_m, st["first_impact"]) if v is not None)
    pre = t_m < t_first
    x_e_on_m = np.interp(t_m, t_e, x_e)
    e_m = np.stack([r.orbits["C"]["ex"], r.orbits["C"]["ey"]], 1)
    e_e = np.stack([np.interp(t_m, t_e, st["ex"]), np.interp(t_m, t_e, st["ey"])], 1)
    return {
        "mechrel": {"impacts": r.stats["n_impacts"], "first_impact_s": first_m,
                    "max_penetration_m": float(pen_m.max()),
                    "max_slider_dev_from_ideal_m": float(np.max(np.abs(x_m - x_ideal)))},
        "exudyn": {"impacts": st["impacts"], "first_impact_s": st["first_impact"],
                   "max_penetration_m": st["max_pen"],
                   "max_slider_dev_from_ideal_m": float(np.max(np.abs(x_e_on_m - x_ideal))),
                   "user_function_calls": st["calls"], "steps": ex.n_steps},
        "e_max_diff_before_first_impact_m": float(np.max(np.hypot(*(e_m[pre] - e_e[pre]).T)))
        if pre.any() else None,
        "slider_x_max_diff_whole_run_m": float(np.max(np.abs(x_m - x_e_on_m))),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--revolutions", type=int, default=2, help="the scene's two revolutions")
    ap.add_argument("--steps-per-degree", type=int, nargs="+", default=[3, 30],
                    help="h = (1 degree of crank rotation) / k; 30 -> h = 1.11 µs")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--spectral-radius", type=float, default=1.0)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    if args.json:
        args.json = str(Path(args.json).resolve())
    os.chdir(tempfile.mkdtemp(prefix="bench_exudyn_"))  # Exudyn may still create solution/
    import exudyn
    sc, cs, *_ = scene_data()
    omega = sc.drivers["crank"].speed
    run_mechrel(1e-5, 1)  # warm numba's cache
    ExudynSliderCrank(1, 1e-5).solve()  # warm Exudyn
    results = []
    for k in args.steps_per_degree:
        h = math.radians(1.0) / omega / k
        tm, te, tm_int = [], [], []
        for _ in range(args.repeats):
            w, r = run_mechrel(h, args.revolutions)
            tm.append(w / args.revolutions)
            tm_int.append(r.stats["wall_time"] / args.revolutions)
            ex = ExudynSliderCrank(args.revolutions, h, spectral_radius=args.spectral_radius)
            te.append(ex.solve() / args.revolutions)
        phys = physics(h, args.revolutions, args.spectral_radius)
        res = {"h": h, "steps_per_rev": int(round(2 * math.pi / omega / h)),
               "mechrel_per_rev": {"median": statistics.median(tm), "min": min(tm), "all": tm,
                                   "integration_median": statistics.median(tm_int)},
               "exudyn_per_rev": {"median": statistics.median(te), "min": min(te), "all": te},
               "mechrel_stats": {k2: r.stats[k2] for k2 in ("n_steps", "n_rhs", "n_impacts",
                                                            "n_onset_rejections")},
               "physics": phys}
        res["speedup_median"] = res["exudyn_per_rev"]["median"] / res["mechrel_per_rev"]["median"]
        res["speedup_min"] = res["exudyn_per_rev"]["min"] / res["mechrel_per_rev"]["min"]
        results.append(res)
        print(json.dumps(res, indent=1, default=float), flush=True)

    print("\n| h (s) | steps/rev | mechrel RK4 s/rev (median / min) | integration only (median) | "
          "Exudyn gen-α s/rev (median / min) | speed-up (median / min) |")
    print("|---|---|---|---|---|---|")
    for r in results:
        m, e = r["mechrel_per_rev"], r["exudyn_per_rev"]
        print(f"| {r['h']:.3g} | {r['steps_per_rev']} | {m['median']:.3f} / {m['min']:.3f} | "
              f"{m['integration_median']:.3f} | {e['median']:.3f} / {e['min']:.3f} | "
              f"{r['speedup_median']:.1f}× / {r['speedup_min']:.1f}× |")
    print("\n| h (s) | code | impacts | first impact (ms) | max penetration (µm) | "
          "max |slider x − ideal| (µm) |")
    print("|---|---|---|---|---|---|")
    for r in results:
        for code in ("mechrel", "exudyn"):
            p = r["physics"][code]
            fi = p["first_impact_s"]
            print(f"| {r['h']:.3g} | {code} | {p['impacts']} | "
                  f"{fi * 1e3 if fi is not None else float('nan'):.4f} | "
                  f"{p['max_penetration_m'] * 1e6:.2f} | "
                  f"{p['max_slider_dev_from_ideal_m'] * 1e6:.1f} |")
        ph = r["physics"]
        print(f"| {r['h']:.3g} | both | max \\|e_mechrel − e_exudyn\\| before the first impact: "
              f"{ph['e_max_diff_before_first_impact_m'] * 1e6:.4f} µm; max \\|slider x "
              f"difference\\| over the run: {ph['slider_x_max_diff_whole_run_m'] * 1e6:.1f} µm "
              "| | | | |")
    meta = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
            "machine": f"{platform.node()} {platform.machine()}, {os.cpu_count()} cores, "
                       f"load average {os.getloadavg()}",
            "exudyn": exudyn.__version__, "python": platform.python_version(),
            "git": git_state()}
    print(f"\n{meta['date']}; {meta['machine']}; exudyn {meta['exudyn']}; git {meta['git']}")
    if args.json:
        Path(args.json).write_text(json.dumps({"meta": meta, "results": results}, indent=1,
                                              default=float))


if __name__ == "__main__":
    main()
