"""Run the maintained benchmarks by name: ``python -m benchmarks --list | NAME... | --all``.

Every script in this folder backs a figure of the README or the docs (docs/performance.md
names each with its command, date, git and load). This runner lists them and runs the named
ones in turn, each in a fresh process on this checkout's sources (``PYTHONPATH=src`` first),
with options shared by all of them:

``--quick``
    each benchmark's shortest settings (a smoke run: the figures are not the documented ones);
``--json DIR``
    a benchmark that writes JSON (``--json FILE``) writes ``DIR/NAME.json``; the runner writes
    ``DIR/runs.json``: per run the command, exit status, wall time, the load average before and
    after, the date and ``git describe``, and the benchmark's own JSON where it wrote one;
``-- ARGS``
    passed on to every named benchmark (e.g. ``python -m benchmarks effects -- --repeats 9``).

The exit status is 0 when every run succeeded, 1 otherwise. Developer tools (comparing two
source trees, profiling the kernels) are in ``tools/``; one-off investigations are in the
git history (docs/dev/retired-benchmarks.md).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


@dataclass(frozen=True)
class Benchmark:
    """One maintained benchmark: its script, what it measures, where its figures are stated,
    how long its documented command takes on the 2-core development machine with a warm numba
    cache as its docstring or docs/performance.md state it (empty where neither does), the
    shortest settings (``quick``), whether it takes ``--json FILE`` and optional packages."""

    script: str
    measures: str
    cited_in: str
    takes: str
    quick: tuple[str, ...] = ()
    json: bool = False
    needs: tuple[str, ...] = ()


BENCHMARKS: dict[str, Benchmark] = {
    "integrators": Benchmark(
        "bench_integrators.py", "every integrator's steps, evaluations, time and error",
        "docs/performance.md, Integrators", "≈ 2 min", ("--repeats", "1", "--skip-lubricated",
                                                       "--out", os.devnull)),
    "accuracy-scenes": Benchmark(
        "bench_accuracy_scenes.py", "`mechrel accuracy` on every embedded scene, with figures",
        "docs/performance.md, Which tolerance", "≈ 5 min",
        ("--scenes", "nine-bar", "--repeats", "1", "--out", "results/bench_quick/accuracy",
         "--figdir", "results/bench_quick/accuracy")),
    "dry-radau": Benchmark(
        "bench_dry_radau.py", "dry scenes: DOPRI5 against radau per cycle",
        "docs/performance.md, Integrators", "≈ 1 min",
        ("--repeats", "1", "--scenes", "slider-crank-dry")),
    "study-tolerance": Benchmark(
        "bench_study_tolerance.py", "the study's sampling tolerance against the inputs' spread",
        "docs/performance.md, Which tolerance; the default study's file", "1–2 min",
        ("--n", "2"), json=True),
    "start-transient": Benchmark(
        "bench_start_transient.py", "the start transient left in the default study's cycle",
        "docs/studies.md, Which cycle is analysed", "", (), json=True),
    "formulations": Benchmark(
        "bench_formulations.py", "radau on the reduced against the absolute equations",
        "docs/performance.md, Formulations", "≈ 2 min",
        ("--repeats", "1", "--scenes", "slider-crank-lubricated"), json=True),
    "floor": Benchmark(
        "bench_floor.py", "cost per cycle against the floor of the fewest steps",
        "docs/performance.md, Against other codes and against the floor", "3–5 min",
        ("--repeats", "1"), json=True),
    "effects": Benchmark(
        "bench_effects.py", "what each declared effect costs on the nine-bar",
        "docs/performance.md, Effects; docs/mechanics.md", "≈ 2 min",
        ("--repeats", "1", "--rhs-time", "0.2", "--rhs-rounds", "5")),
    "bearing-models": Benchmark(
        "bench_bearing_models.py", "long, short and finite-length film per cycle",
        "docs/performance.md, Film models; docs/forces.md", "", ("--rounds", "1")),
    "extremes": Benchmark(
        "bench_extremes.py", "what the cycle extremes cost",
        "docs/performance.md, Cycle extremes; README", "",
        ("--repeats", "1", "--scene", "slider-crank-lubricated")),
    "signal-watch": Benchmark(
        "bench_signal_watch.py", "what watching for Ctrl-C/SIGTERM during a kernel costs",
        "docs/architecture.md", "", ("--reps", "3")),
    "estimators": Benchmark(
        "bench_estimators.py", "FOSM, MC, PCE and Sobol' error against evaluations, with figures",
        "docs/performance.md, Estimators", "≈ 2 min",
        ("--n-ref", "64", "--ref-order", "2", "--mc-n", "16", "--pce-orders", "1",
         "--sobol-n", "8", "--replicates", "1", "--out", "results/bench_quick/estimators")),
    "rare-events": Benchmark(
        "bench_rare_events.py", "rare-event methods against exact P_f; Python call overhead",
        "docs/performance.md, Estimators", "1–2 min",
        ("--reps", "2", "--rows", "2000", "--repeat", "1",
         "--out", "results/bench_quick/rare_events")),
    "system-reliability": Benchmark(
        "bench_system_reliability.py", "whole-cycle and system reliability against references",
        "docs/uq.md, The whole cycle as a series system", "", ("--seeds", "2")),
    "inverse-coverage": Benchmark(
        "bench_inverse_coverage.py", "coverage of the inverse question's intervals",
        "docs/uq.md, The inverse question", "3–6 min", ("--reps", "2")),
    "ak": Benchmark(
        "bench_ak.py", "active learning on analytic problems: calls, error, coverage",
        "docs/performance.md, Estimators; docs/uq.md", "",
        ("--seeds", "1", "--tolerance", "0.1", "--out", "results/bench_quick/bench_ak.csv")),
    "ak-ninebar": Benchmark(
        "bench_ak_ninebar.py", "active learning on the main study against 10⁴ Monte Carlo",
        "docs/performance.md, Estimators", "",
        ("--seeds", "1", "--skip-mc", "--out", "results/bench_quick/ak_ninebar")),
    "ak-workers": Benchmark(
        "bench_ak_workers.py", "active learning on the main study: one against two workers",
        "docs/performance.md, Estimators; docs/uq.md", "≈ 2 min",
        ("--rounds", "1"), json=True),
    "gp-libraries": Benchmark(
        "bench_gp_libraries.py", "which Kriging library: fit time and accuracy",
        "docs/uq.md, Active learning", "", ("--reps", "1", "--n", "50", "--d", "3")),
    "design-slider-crank": Benchmark(
        "bench_design_slider_crank.py",
        "tolerance allocation with the whole-cycle against the per-angle constraint",
        "docs/validation.md, Design for reliability", "3–4 min",
        ("--n", "4000", "--n-verify", "20000", "--tradeoff", "2",
         "--figure", "results/bench_quick/design_slider_crank.png")),
    "sample-cost": Benchmark(
        "bench_sample_cost.py", "what a sample costs around its physics, two trees compared",
        "docs/performance.md, A sample costs what its physics costs; docs/uq.md", "",
        ("--rounds", "1", "--cases", "vectorised"), json=True),
    "sample-floor": Benchmark(
        "bench_sample_floor.py", "the Python around a lubricated sample's kernels, by ablation",
        "docs/performance.md, A sample costs what its physics costs", "10–20 min",
        ("--rounds", "1", "--batches", "1", "--modes", "none", "at"), json=True),
    "dispatch": Benchmark(
        "bench_dispatch.py", "what a compiled call taking the mechanism costs from Python",
        "docs/performance.md, A sample costs what its physics costs", "",
        ("--rounds", "1", "--calls", "2000")),
    "mc-throughput": Benchmark(
        "bench_mc_throughput.py", "Monte Carlo samples per second with 1 and 2 workers",
        "docs/performance.md, Workers and Dask", "2–3 min", ("--n", "8", "--rounds", "1"),
        json=True),
    "cold-start": Benchmark(
        "bench_cold_start.py", "the main job's one-off compilation on a cold numba cache",
        "docs/performance.md, Caches and the cold start", "≈ 1 min/run",
        ("--rounds", "1", "--modes", "two"), json=True),
    "lubricated-ninebar": Benchmark(
        "bench_lubricated_ninebar.py", "the lubricated nine-bar against the NumPy/SciPy baseline",
        "docs/performance.md, Against other codes and against the floor", "5–10 min",
        ("--quick",), json=True),
    "exudyn": Benchmark(
        "bench_exudyn.py", "the dry slider-crank against Exudyn at a fixed step",
        "docs/performance.md, Against other codes and against the floor", "≈ 1 min",
        ("--repeats", "1", "--steps-per-degree", "3"), json=True, needs=("exudyn",)),
}


def _git_state() -> str:
    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT,
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _list() -> str:
    width = max(map(len, BENCHMARKS))
    rows = [f"{'name':<{width}}  {'takes':<12}  what it measures (where its figures are)"]
    for name, b in BENCHMARKS.items():
        extra = f"; needs {', '.join(b.needs)}" if b.needs else ""
        rows.append(f"{name:<{width}}  {b.takes or '–':<12}  {b.measures} "
                    f"({b.cited_in}{extra})")
    return "\n".join(rows)


def _run(name: str, quick: bool, json_dir: Path | None, extra: list[str]) -> dict:
    b = BENCHMARKS[name]
    cmd = [sys.executable, str(HERE / b.script), *(b.quick if quick else ()), *extra]
    out_json = None
    if json_dir is not None and b.json:
        out_json = json_dir / f"{name}.json"
        cmd += ["--json", str(out_json)]
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT / "src"),
                                                      env.get("PYTHONPATH")]))
    print(f"== {name}: {' '.join(cmd[1:])}", flush=True)
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    status = subprocess.run(cmd, cwd=ROOT, env=env).returncode
    record = {
        "name": name, "command": cmd[1:], "status": status,
        "wall_s": round(time.perf_counter() - t0, 3),
        "load_before": [round(x, 2) for x in load_before],
        "load_after": [round(x, 2) for x in os.getloadavg()],
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "git": _git_state(), "quick": quick,
    }
    if out_json is not None and out_json.exists():
        record["result"] = json.loads(out_json.read_text(encoding="utf-8"))
    print(f"== {name}: exit status {status}, {record['wall_s']:.1f} s", flush=True)
    return record


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, extra = argv[:cut], argv[cut + 1:]
    ap = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__.split("\n")[0],
                                 epilog=_list(), formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to run, in this order")
    ap.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    ap.add_argument("--all", action="store_true", help="run every benchmark")
    ap.add_argument("--quick", action="store_true", help="each benchmark's shortest settings")
    ap.add_argument("--json", type=Path, default=None, metavar="DIR",
                    help="collect the runs (and the benchmarks' own JSON) in DIR")
    args = ap.parse_args(argv)
    if args.list:
        print(_list())
        return 0
    unknown = [n for n in args.names if n not in BENCHMARKS]
    if unknown:
        ap.error(f"unknown benchmark {unknown[0]!r}; allowed: {', '.join(BENCHMARKS)} "
                 "(python -m benchmarks --list)")
    names = list(BENCHMARKS) if args.all else args.names
    if not names:
        ap.error("name one or more benchmarks, or --all, or --list")
    if args.json is not None:
        args.json.mkdir(parents=True, exist_ok=True)
    records = [_run(n, args.quick, args.json, extra) for n in names]
    if args.json is not None:
        (args.json / "runs.json").write_text(json.dumps(records, indent=1), encoding="utf-8")
    failed = [r["name"] for r in records if r["status"] != 0]
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
