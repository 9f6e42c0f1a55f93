"""What a sample costs around its physics (issue 35), before and after, interleaved.

Each case runs in a fresh process on one source tree (``PYTHONPATH=TREE/src``), the trees
alternating (the order reversed every round); the figures are medians over the rounds, and
each process reports the machine's load. Every case also hashes the outputs it computed, so
that the two trees are shown to give the same numbers, bitwise.

Cases
-----
``tolerance``
    Geometric tolerances on an ideal mechanism: the slider-crank with its crank length, rod
    length and crank pivot height uncertain (``MechanismModel``, analysis every 18°, one
    cycle), 200 samples evaluated in one ``evaluate_batch``, with and without the cycle
    extremes. Set against one ``simulate()`` of the nominal scene (the embedded
    ``slider-crank``: one cycle at 1°) and of the model's own scene (its 18° grid), and against
    the floor: the compiled kinematic analysis of the instants a sample needs (its output
    grid and, with the extremes, the 3 601 points of the extremes' window), timed alone.
``lubricated``
    The main study's model (``load_study("nine-bar-lubricated").model()``: clearances,
    viscosity and crank speed uncertain, two cycles): 16 Sobol samples in one
    ``evaluate_batch``; each sample's time split into the compiled kernels (the Radau kernel,
    ``radau5_kernel``, and the kinematic analysis) and the Python around them (the rest,
    ``Radau._advance``'s own Python included: until 2026-11-29 the split timed
    ``Radau._advance`` whole, which put that Python, ~0.5 ms, on the kernel's side), and that
    Python as a fraction of the kernel's time in the same run (``cpu_python_per_kernel``:
    steadier than either time on a machine whose speed drifts); then the same Python with the
    Radau kernel replayed from its recorded outputs (``cpu_python_kernel_replayed``: no
    kernel runs between two samples' Python, so this is the Python's warm cost, with the
    caches as the previous sample's Python left them; the outputs, bitwise the run's, are
    still copied out, and that copy counts as the kernel's).
``vectorised``
    A vectorised ``FunctionModel`` (the slider-crank's closed-form slider position error at 8
    crank angles for three length tolerances, 10⁶ rows) through ``evaluate`` against the plain
    NumPy expression on the same rows (whole, and in chunks of 1000 and of 8192 rows: the
    fastest is the yardstick); then 1 % of the rows failing, reported by the model as NaN
    rows (a row mask), by ``RowFailures`` (its failed rows' reasons as ``{row: reason}``,
    ``row_failures``, and as a list with an entry per row, ``row_failures_list``), and by
    raising ``ModelFailure`` for the whole batch (on 2·10⁵ rows, as in the issue); then
    ``monte_carlo`` of the same model at 10⁶ samples (after a first run at 10³ samples, timed
    on its own: what a process pays once), with a fixed and with a sampled allowable, each
    run's result released before the next as the NumPy yardstick's is, then with a fixed
    allowable and the results kept (``monte_carlo_kept``: each run takes 10⁸ bytes of fresh
    memory, whose kernel time, ``sys_*``, is large on a virtual machine), and the time it
    takes to draw the samples; and the run's phases one by one (``phase_*``, CPU). Every
    figure is given as wall time and as this process's CPU time (``cpu_*``): on a shared
    machine the CPU time is what the work costs.

Run::

    git archive 13cfa17 | tar -x -C /tmp/before   # the code before issue 35
    python benchmarks/bench_sample_cost.py --before /tmp/before --rounds 5 \\
        --json /tmp/bench_sample_cost.json

A tree whose numba cache is cold compiles its kernels in its first process (minutes): run
once with ``--rounds 1`` first. ``--cases`` picks cases; ``--after`` another tree than this
checkout.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import timed  # noqa: E402  (benchmarks/ is sys.path[0])

CASES = ("tolerance", "lubricated", "vectorised")
HERE = Path(__file__).resolve()


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype=float).tobytes())
    return h.hexdigest()[:16]


class _Clock:
    """Wall-clock and CPU seconds of this process: on a machine shared by several jobs the
    CPU time of a single-threaded process is what its work costs, the wall time what it
    waited too."""

    def __init__(self):
        self.wall = time.perf_counter()
        self.cpu = time.process_time()

    def lap(self) -> tuple[float, float]:
        return time.perf_counter() - self.wall, time.process_time() - self.cpu


def _best_of(fn, reps):
    """Medians of ``reps`` timed calls: ``(wall s, CPU s)``."""
    out = []
    for _ in range(reps):
        c = _Clock()
        fn()
        out.append(c.lap())
    return tuple(statistics.median(o[i] for o in out) for i in range(2))


# ----------------------------------------------------------------------------- cases (child)

def case_tolerance() -> dict:
    from mechrel.mechanics.kinematics import assemble, kinematic_analysis
    from mechrel.mechanics.system import compile_scene
    from mechrel.scene import load_scene
    from mechrel.simulation import KINEMATIC_POINTS, analysis_window, output_times, simulate
    from mechrel.simulation.extremes import _window_points
    from mechrel.uq.problem.mechanism import MechanismModel

    inputs = {"crank": ["bodies.crank.length(O,A)"], "rod": ["bodies.rod.length(A,B)"],
              "pivot_y": ["ground.points.O[1]"]}
    nominal = load_scene("slider-crank")
    out = {}
    for extremes in (False, True):
        m = MechanismModel("slider-crank", inputs, angle_step=18.0, extremes=extremes)
        rng = np.random.default_rng(1)
        X = m.nominal + rng.standard_normal((200, 3)) * [20e-6, 30e-6, 10e-6]
        m.evaluate_batch(X[:4])  # warm: kernels loaded, anything made once made
        Y = m.evaluate_batch(X)
        # blocks of 20 samples alternating with 20 simulate() of the nominal scene and of the
        # model's scene, so that a change of the machine's load moves all three alike
        blocks = {"sample": [], "nominal": [], "model": []}
        for k in range(0, X.shape[0], 20):
            for key, fn in (("sample", lambda: m.evaluate_batch(X[k:k + 20])),
                            ("nominal", lambda: [simulate(nominal) for _ in range(20)]),
                            ("model", lambda: [simulate(m.scene) for _ in range(20)])):
                c = _Clock()
                fn()
                blocks[key].append([t / 20 for t in c.lap()])
        (per_sample, sim_nominal, sim_model), (cpu_sample, cpu_nominal, cpu_model) = (
            [statistics.median(b[i] for b in blocks[k]) for k in ("sample", "nominal", "model")]
            for i in range(2))
        # the floor: the compiled kinematic analysis of the instants one sample needs
        c = compile_scene(m.scene)
        tol = m.scene.solver.assembly_tolerance
        q0, _ = assemble(c.ideal, c.q_guess, 0.0, tol=tol)
        times = output_times(m.scene, c)
        inst = [times]
        if extremes:
            t_win = analysis_window(c, times)
            T, sel, _ = _window_points(times, t_win, np.linspace(t_win, float(times[-1]),
                                                                  KINEMATIC_POINTS + 1))
            inst.append(np.concatenate([times[~sel], T]))
        floors = [_best_of(lambda t=t: kinematic_analysis(c.ideal, q0, t, tol=tol), 51)
                  for t in inst]
        floor, cpu_floor = (sum(f[i] for f in floors) for i in range(2))
        key = "extremes" if extremes else "no_extremes"
        out[key] = {"per_sample": per_sample, "simulate_nominal": sim_nominal,
                    "simulate_model_scene": sim_model, "floor_kinematics": floor,
                    "cpu_per_sample": cpu_sample, "cpu_simulate_nominal": cpu_nominal,
                    "cpu_simulate_model_scene": cpu_model, "cpu_floor_kinematics": cpu_floor,
                    "n_instants": int(sum(t.size for t in inst)),
                    "ratio_to_simulate_nominal": per_sample / sim_nominal,
                    "cpu_ratio_to_simulate_nominal": cpu_sample / cpu_nominal,
                    "ratio_to_floor": per_sample / floor,
                    "cpu_ratio_to_floor": cpu_sample / cpu_floor, "digest": _digest(Y)}
    return out


def case_lubricated() -> dict:
    import mechrel.integrate.radau as radau
    from mechrel.mechanics import kinematics
    from mechrel.study.study import load_study

    study = load_study("nine-bar-lubricated")
    model = study.model()
    X = study.uncertain_inputs().sample(16, "sobol", 20221014)
    model.evaluate_batch(X[:2])
    spent = {"radau": 0.0, "kinematics": 0.0}

    spent.update(radau_cpu=0.0, kinematics_cpu=0.0)
    # the Radau kernel's outputs of the first round's samples, in call order, for the replay
    # below (the later rounds' outputs are released as a run releases them)
    kernel, recorded, n = radau.radau5_kernel, [], X.shape[0]

    def recording(*a):
        out = kernel(*a)
        if len(recorded) < n:
            recorded.append(out)
        return out

    radau.radau5_kernel = recording
    # the compiled kernel itself: Radau._advance's own Python (the reduced system, its state
    # before and after the kernel) is Python around the kernel too
    for name, obj, attr in (("radau", radau, "radau5_kernel"),
                            ("kinematics", kinematics, "_kinematics"),
                            ("kinematics", kinematics, "_construct")):
        cpu = timed(getattr(obj, attr), spent, name + "_cpu", time.process_time)
        setattr(obj, attr, timed(cpu, spent, name))
    rounds = []
    for _ in range(3):
        spent.update(radau=0.0, kinematics=0.0, radau_cpu=0.0, kinematics_cpu=0.0)
        c = _Clock()
        Y = model.evaluate_batch(X)
        wall, cpu = c.lap()
        rounds.append((wall, spent["radau"], spent["kinematics"], cpu, spent["radau_cpu"],
                       spent["kinematics_cpu"]))
    med = [statistics.median(r[i] for r in rounds) / n for i in range(6)]
    rest = statistics.median((w - r - k) / n for w, r, k, *_ in rounds)
    rest_cpu = statistics.median((w - r - k) / n for *_, w, r, k in rounds)
    # the Python as a fraction of the kernel's time in the same run: this virtual machine's
    # speed drifts by ±15 % within minutes, and both move with it, so the fraction compares
    # two trees more steadily than either time does
    share = statistics.median((w - r - k) / r for *_, w, r, k in rounds)
    # the same Python with the Radau kernel replayed: each call returns copies of the outputs
    # it recorded in the first round (the log, ~0.8 MB, is still written, by the copy; the
    # copies' time is the kernel's side), so no kernel runs between two samples' Python and
    # evicts the interpreter's code and data from the caches: the Python's warm cost, what
    # this code would cost a sample if the kernel took no time and touched nothing else
    calls = iter(())

    def replay(*a):
        return tuple(x.copy() if isinstance(x, np.ndarray) else x for x in next(calls))

    radau.radau5_kernel = timed(timed(replay, spent, "radau_cpu", time.process_time), spent,
                                 "radau")
    warm = []
    for _ in range(5):
        calls = iter(recorded)
        spent.update(radau=0.0, kinematics=0.0, radau_cpu=0.0, kinematics_cpu=0.0)
        c = _Clock()
        Yr = model.evaluate_batch(X)
        cpu = c.lap()[1]
        warm.append((cpu - spent["radau_cpu"] - spent["kinematics_cpu"]) / n)
    radau.radau5_kernel = kernel
    assert np.array_equal(Yr, Y, equal_nan=True)  # the replay is the run, bitwise
    return {"per_sample": med[0], "radau_kernel": med[1], "kinematic_analysis": med[2],
            "python_around_kernel": rest, "cpu_per_sample": med[3], "cpu_radau_kernel": med[4],
            "cpu_kinematic_analysis": med[5], "cpu_python_around_kernel": rest_cpu,
            "cpu_python_per_kernel": share, "cpu_python_kernel_replayed": statistics.median(warm),
            "digest": _digest(Y)}


TH = np.radians(np.arange(0.0, 360.0, 45.0))
X0 = np.array([0.05, 0.12, 0.0])


def slider_error(X):
    """Slider position error (m) of the slider-crank at 8 crank angles for crank length r,
    rod length l and pivot height e (closed form)."""
    r, l, e = X[:, :1], X[:, 1:2], X[:, 2:3]
    S, C = np.sin(TH), np.cos(TH)
    x = r * C + np.sqrt(l * l - (r * S - e) ** 2)
    return x - (X0[0] * C + np.sqrt(X0[1] ** 2 - (X0[0] * S) ** 2))


def _bad(X):
    return X[:, 2] > 2.326 * 1e-5  # the pivot 2.326 σ high: 1 % of the rows


def slider_error_nan(X):
    Y = slider_error(X)
    Y[_bad(X)] = np.nan  # a row mask
    return Y


def slider_error_rows(X):
    """The failed rows' reasons as ``{row: reason}`` (the form since issue 35's second part;
    the per-row list where the tree's ``RowFailures`` predates it: there ``reasons`` is no
    class attribute)."""
    from mechrel.uq.problem.model import RowFailures

    Y = slider_error(X)
    bad = _bad(X)
    if bad.any():
        Y[bad] = np.nan
        if not hasattr(RowFailures, "reasons"):
            raise RowFailures(Y, ["pivot too high" if b else None for b in bad])
        raise RowFailures(Y, dict.fromkeys(np.flatnonzero(bad).tolist(), "pivot too high"))
    return Y


def slider_error_rows_list(X):
    """The failed rows' reasons as a list with one entry per row (None where it succeeded)."""
    from mechrel.uq.problem.model import RowFailures

    Y = slider_error(X)
    bad = _bad(X)
    if bad.any():
        Y[bad] = np.nan
        raise RowFailures(Y, ["pivot too high" if b else None for b in bad])
    return Y


def slider_error_raises(X):
    from mechrel.uq import ModelFailure

    if _bad(X).any():
        raise ModelFailure("pivot too high")
    return slider_error(X)


def case_vectorised() -> dict:
    from mechrel.uq import (Allowable, FunctionModel, Normal, UncertainInputs, evaluate,
                            monte_carlo)
    from mechrel.uq.execution.executor import default_chunk_size

    labels = [f"x@{a:g}" for a in np.degrees(TH)]
    inputs = UncertainInputs.from_specs({"r": Normal(0.05, 2e-5), "l": Normal(0.12, 3e-5),
                                         "e": Normal(0.0, 1e-5)})
    n = 10**6
    X = inputs.sample(n, "random", 1)

    def model(f, key):
        return FunctionModel(f, ["r", "l", "e"], labels, key=key, vectorized=True)

    try:  # the tree's chunk of a vectorised model (since issue 35's third part)
        cs = default_chunk_size(n, vectorized=True)
    except TypeError:
        cs = default_chunk_size(n)
    whole = _best_of(lambda: slider_error(X), 3)
    # in chunks of 1000 and of 8192 rows (the row-by-row and the vectorised default), the
    # same for every tree: the yardstick does not depend on the tree's executor
    chunks = [_best_of(lambda k=k: np.concatenate([slider_error(X[s:s + k])
                                                   for s in range(0, n, k)]), 3)
              for k in (1000, 8192)]
    out = {"n": n, "chunk_size": cs}
    for i, clock in enumerate(("", "cpu_")):  # the NumPy yardstick: the fastest way
        out[clock + "numpy_whole"] = whole[i]
        out[clock + "numpy_chunks"], out[clock + "numpy_chunks_8192"] = (c[i] for c in chunks)
        out[clock + "numpy"] = min(whole[i], *(c[i] for c in chunks))
    ev = evaluate(model(slider_error, "ok"), X, progress=False)
    t = _best_of(lambda: evaluate(model(slider_error, "ok"), X, progress=False), 3)
    out["evaluate"], out["cpu_evaluate"] = t
    for clock in ("", "cpu_"):
        out[clock + "evaluate_over_numpy"] = out[clock + "evaluate"] / out[clock + "numpy"]
    out["digest_ok"] = _digest(ev.Y)
    # 1 % of the rows failing, on 2·10⁵ rows (the case; the code before needed a
    # minute or more per run at 10⁶), against the same rows without failures
    m = 2 * 10**5
    out["m"] = m
    base = _best_of(lambda: evaluate(model(slider_error, "ok"), X[:m], progress=False), 3)
    out["no_failures_2e5"], out["cpu_no_failures_2e5"] = base
    for name, f in (("nan_rows", slider_error_nan), ("row_failures", slider_error_rows),
                    ("row_failures_list", slider_error_rows_list),
                    ("raising", slider_error_raises)):
        c = _Clock()
        ev = evaluate(model(f, name), X[:m], progress=False)
        t = c.lap()
        out[name + "_2e5"], out["cpu_" + name + "_2e5"] = t
        for i, clock in enumerate(("", "cpu_")):
            out[clock + name + "_over_no_failures"] = t[i] / base[i]
        out[name + "_failed"] = ev.n_failed
        out["digest_" + name] = _digest(ev.Y)
    c = _Clock()
    X_mc = inputs.sample(n, "random", 2)
    sampling = c.lap()
    del X_mc

    def mc(k, sd):
        return monte_carlo(model=model(slider_error, "ok"), inputs=inputs, n=k, seed=1,
                           allowable=Allowable(1e-4, sd), progress=False)

    def runs_of(key, sd, keep=False):
        """Three runs at 10⁶ rows, medians; each run's result released before the next, as
        the NumPy yardstick's output is (``keep``: kept, all three alive at the end). Also
        the kernel's share of the CPU time, ``sys_*`` (a mean): what faulting in fresh memory
        costs (a kept result makes the next run take its arrays from fresh memory)."""
        runs = []

        def one():
            if not keep:
                runs.clear()
            runs.append(mc(n, sd))
        s0 = resource.getrusage(resource.RUSAGE_SELF).ru_stime
        out[key], out["cpu_" + key] = _best_of(one, 3)
        out["sys_" + key] = (resource.getrusage(resource.RUSAGE_SELF).ru_stime - s0) / 3
        return runs[-1]

    # what a run costs once per process (loading compiled code, reading package metadata),
    # then the run at 10⁶ rows, median of 3: the throughput. With a fixed allowable (σ_I = 0)
    # and with a sampled one (σ_I = 20 µm: one N(0,1) draw per sample, scaled per output);
    # then the fixed one again with each run's result kept alive
    c = _Clock()
    mc(1000, 0.0)
    out["monte_carlo_first_1e3"], out["cpu_monte_carlo_first_1e3"] = c.lap()
    r = runs_of("monte_carlo", 0.0)
    out["monte_carlo_evaluate"] = float(r.evaluations.wall_time)
    out["monte_carlo_sampling"], out["cpu_monte_carlo_sampling"] = sampling
    out["digest_mc"] = _digest(r.to_frame().select_dtypes("number").to_numpy())
    del r
    r = runs_of("monte_carlo_sampled_I", 2e-5)
    out["digest_mc_sampled_I"] = _digest(r.to_frame().select_dtypes("number").to_numpy())
    del r
    r = runs_of("monte_carlo_kept", 0.0, keep=True)
    assert _digest(r.to_frame().select_dtypes("number").to_numpy()) == out["digest_mc"]
    del r
    for key in ("monte_carlo", "monte_carlo_sampled_I", "monte_carlo_kept"):
        for clock in ("", "cpu_"):
            out[clock + key + "_over_numpy"] = out[clock + key] / out[clock + "numpy"]
    out.update(_monte_carlo_phases(inputs, model(slider_error, "ok"), n))
    return out


def _monte_carlo_phases(inputs, model, n) -> dict:
    """What a Monte Carlo run of the vectorised case is made of, phase by phase, as
    ``monte_carlo`` calls them (median of 3, CPU seconds, ``phase_*``): drawing the inputs
    (and ``ndtri`` of as many uniforms alone, the floor of a normal input's inverse CDF),
    ``evaluate``, the counts inside a fixed and a sampled allowable, the moments."""
    from scipy import special

    from mechrel.uq import Allowable, evaluate
    from mechrel.uq.estimators.monte_carlo import reliability_from_samples, sample_moments
    from mechrel.uq.problem.inputs import as_seed_sequence, child_seed

    ss = as_seed_sequence(1)
    X = inputs.sample(n, "random", child_seed(ss, 0))
    X.setflags(write=False)
    ev = evaluate(model, X, progress=False)
    U = np.random.default_rng(0).random((n, X.shape[1]))

    def counts(sd):
        return lambda: reliability_from_samples(
            ev, allowable=Allowable(1e-4, sd), event="two-sided", allowable_mode="sampled",
            seed=child_seed(ss, 1), confidence_level=0.95, ci_method="wilson",
            failures="exclude")
    phases = {"sampling": lambda: inputs.sample(n, "random", child_seed(ss, 0)),
              "ndtri": lambda: special.ndtri(U),
              "evaluate": lambda: evaluate(model, X, progress=False),
              "counts_fixed": counts(0.0), "counts_sampled": counts(2e-5),
              "moments": lambda: sample_moments(ev.Y, rows=ev.ok, confidence_level=0.95)}
    return {"phase_" + k: _best_of(f, 3)[1] for k, f in phases.items()}


def child(case: str) -> None:
    la0 = os.getloadavg()[0]
    out = {"tolerance": case_tolerance, "lubricated": case_lubricated,
           "vectorised": case_vectorised}[case]()
    out["load"] = [la0, os.getloadavg()[0]]
    import mechrel
    out["mechrel"] = mechrel.__file__
    print(json.dumps(out))


# ----------------------------------------------------------------------------- parent

def run(tree: Path, case: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    p = subprocess.run([sys.executable, str(HERE), "--child", case], env=env,
                       capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(f"{tree} {case}: {p.stderr[-3000:]}")
    got = json.loads(p.stdout.strip().splitlines()[-1])
    assert got["mechrel"].startswith(str(tree)), got["mechrel"]
    return got


def _medians(runs: list[dict]) -> dict:
    out = {}
    for k, v in runs[0].items():
        if isinstance(v, dict):
            out[k] = _medians([r[k] for r in runs])
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            out[k] = statistics.median(r[k] for r in runs)
        elif k.startswith("digest") or k in ("mechrel",):
            vals = {r[k] for r in runs}
            out[k] = vals.pop() if len(vals) == 1 else sorted(vals)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", type=Path, required=False)
    ap.add_argument("--after", type=Path, default=HERE.parents[1])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", choices=CASES)
    a = ap.parse_args(argv)
    if a.child:
        child(a.child)
        return
    trees = {"after": a.after.resolve()}
    if a.before:
        trees = {"before": a.before.resolve(), **trees}
    results = {case: {t: [] for t in trees} for case in a.cases}
    for r in range(a.rounds):
        for case in a.cases:
            order = list(trees) if r % 2 == 0 else list(trees)[::-1]
            for t in order:
                got = run(trees[t], case)
                results[case][t].append(got)
                print(f"round {r + 1} {case} {t}: load {got['load'][0]:.1f}", flush=True)
    summary = {case: {t: _medians(runs) for t, runs in by.items()}
               for case, by in results.items()}
    print(json.dumps(summary, indent=1))
    if a.before:
        for case, by in summary.items():
            same = {k: by["before"][k] == by["after"][k] for k in by["after"]
                    if k.startswith("digest")}
            for k, v in by["after"].items():
                if isinstance(v, dict):
                    same.update({f"{k}.{j}": by["before"][k][j] == w for j, w in v.items()
                                 if j.startswith("digest")})
            print(f"{case}: the same numbers, bitwise: {same}")
    if a.json:
        Path(a.json).write_text(json.dumps({"summary": summary, "runs": results}, indent=1))


if __name__ == "__main__":
    main()
