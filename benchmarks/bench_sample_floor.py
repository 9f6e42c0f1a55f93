"""The floor of the Python around the kernels in a lubricated sample (issue 35), by ablation.

``bench_sample_cost.py --cases lubricated`` measures the Python around the compiled kernels
in a sample of the main study's model (``load_study("nine-bar-lubricated").model()``, 16 Sobol
samples in one ``evaluate_batch``): each sample's CPU time less the Radau kernel's and the
kinematic analysis'. This script asks what that figure would become if whole pieces of the
sample's Python cost nothing, which is the most a redesign of those pieces could give. Each
piece is replaced by an oracle: in a first batch it runs and its results are recorded in call
order; in the measured batches each call returns the recorded result at once. The outputs
must stay bitwise those of the recorded batch (checked), so the oracle is the run with that
piece's time taken out, and nothing else changed.

Pieces (``--modes``; ``+`` joins pieces into one mode):

``at``
    ``PreparedScene.at``: the sample's values validated by the scene's rules on the tables
    they sit in, the sample's ``Scene`` built, the compiled arrays patched (what a Scene-free
    validation with the rules as data would shrink).
``values``
    ``evaluators.values`` wherever the run and the reference call it: the output values of
    the run, of its extremes' window and of the ideal counterpart.
``extremes``
    the extremes' window (``_window_points``, ``_window_values``: the outputs at its points)
    and the extremes themselves (``_extremes_of``).
``orbits``
    the joints' orbits and the energy after the run (``_orbits_and_energy``, their check).
``assemble``
    the assembly of positions and velocities at t = 0 (two compiled calls).
``crank``
    the crank angle of the output instants (``_crank_angle``).
``reduced``
    Radau's Python around its kernel on the reduced equations: the reduced system
    (``reduced_system``: the construction plan's lookup), the reduced state before the kernel
    (``reduced_coordinates``), the mechanism without clearance forces
    (``without_clearance_forces``) and the expansion after it (``_finish_reduced``): what one
    compiled call for the state, the kernel and the expansion would leave of it (the kernel
    still runs).

``none`` is the run as it is; the default modes are ``none``, each piece alone, the first six
together (all of the sample's Python outside the integrator) and all seven. Each mode runs in a
fresh process (one batch recorded, then ``--batches`` measured batches, medians), the modes
interleaved round by round with the order reversed every other round; the figures are medians
over the rounds. Like ``bench_sample_cost.py`` it reports the Python per sample (CPU ms) and
the Python as a share of the kernels' CPU time in the same run, steadier on a machine whose
speed drifts.

Run::

    python benchmarks/bench_sample_floor.py --rounds 7 --json /tmp/bench_sample_floor.json

(10–20 minutes on the two-core development machine).

The kernels must be in numba's cache (run any study once first): a cold cache compiles them
in the first process.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from _common import timed  # noqa: E402  (benchmarks/ is sys.path[0])

HERE = Path(__file__).resolve()
PIECES = ("at", "values", "extremes", "orbits", "assemble", "crank", "reduced")
MODES = ("none", *PIECES, "+".join(PIECES[:-1]), "+".join(PIECES))


def _targets(piece: str):
    """``(owner, attribute)`` of the functions that make up ``piece``, where the sample's
    code looks them up."""
    import mechrel.integrate.radau as radau
    import mechrel.simulation.prepared as prepared
    import mechrel.simulation.reference as reference
    import mechrel.simulation.run as run

    return {"at": [(prepared.PreparedScene, "at")],
            "values": [(run, "values"), (reference, "values")],
            "extremes": [(run, "_extremes_of"), (run, "_window_points"),
                         (run, "_window_values")],
            "orbits": [(run, "_orbits_and_energy"), (run, "_check_orbits")],
            "assemble": [(run, "assemble")],
            "crank": [(run, "_crank_angle")],
            "reduced": [(radau, "reduced_system"), (radau, "reduced_coordinates"),
                        (radau, "without_clearance_forces"), (radau, "_finish_reduced")]}[piece]


_RECORDING = [0]  # oracle calls under way in the recording batch


class _Oracle:
    """``fn`` recording its results in call order, then (``replaying``) returning them in the
    same order without running; :attr:`call` is the function put in ``fn``'s place (a plain
    function, so that a method replaced by it is still bound to its instance). A call made
    inside another oracle's call (``values`` inside ``_window_values``) is neither recorded
    nor replayed: it runs where its caller runs, and its caller's replay skips it."""

    def __init__(self, fn):
        self.fn, self.results, self.next, self.replaying = fn, [], 0, False

        def call(*a, **kw):
            if _RECORDING[0]:
                return self.fn(*a, **kw)
            if not self.replaying:
                _RECORDING[0] += 1
                try:
                    out = self.fn(*a, **kw)
                finally:
                    _RECORDING[0] -= 1
                self.results.append(out)
                return out
            out = self.results[self.next]
            self.next += 1
            return out

        self.call = call


def child(mode: str, batches: int) -> dict:
    import mechrel.integrate.radau as radau
    from mechrel.mechanics import kinematics
    from mechrel.study.study import load_study

    la0 = os.getloadavg()[0]
    study = load_study("nine-bar-lubricated")
    model = study.model()
    X = study.uncertain_inputs().sample(16, "sobol", 20221014)
    model.evaluate_batch(X[:2])  # warm: kernels loaded, the prepared scene made
    oracles = []
    for piece in ([] if mode == "none" else mode.split("+")):
        for owner, attr in _targets(piece):
            oracles.append(_Oracle(getattr(owner, attr)))
            setattr(owner, attr, oracles[-1].call)
    recorded = model.evaluate_batch(X)
    for o in oracles:
        o.replaying = True
    spent = {"kernels": 0.0}
    for owner, attr in ((radau, "radau5_kernel"), (kinematics, "_kinematics"),
                        (kinematics, "_construct")):
        setattr(owner, attr, timed(getattr(owner, attr), spent, "kernels", time.process_time))
    python, share = [], []
    n = X.shape[0]
    for _ in range(batches):
        for o in oracles:
            o.next = 0
        spent["kernels"] = 0.0
        t0 = time.process_time()
        Y = model.evaluate_batch(X)
        cpu = time.process_time() - t0
        assert np.array_equal(Y, recorded, equal_nan=True), "an oracle changed the outputs"
        python.append((cpu - spent["kernels"]) / n)
        share.append((cpu - spent["kernels"]) / spent["kernels"])
    return {"mode": mode, "cpu_python_per_sample": statistics.median(python),
            "cpu_python_per_kernel": statistics.median(share),
            "load": [la0, os.getloadavg()[0]]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--batches", type=int, default=3, help="measured batches per process")
    ap.add_argument("--modes", nargs="+", default=list(MODES))
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", default=None)
    a = ap.parse_args(argv)
    for m in a.modes + ([a.child] if a.child else []):
        if m != "none" and not set(m.split("+")) <= set(PIECES):
            ap.error(f"mode {m!r}: 'none' or pieces joined by '+', each one of {PIECES}")
    if a.child:
        print(json.dumps(child(a.child, a.batches)))
        return
    runs: dict[str, list] = {m: [] for m in a.modes}
    for r in range(a.rounds):
        for m in (a.modes if r % 2 == 0 else a.modes[::-1]):
            p = subprocess.run([sys.executable, str(HERE), "--child", m, "--batches",
                                str(a.batches)], capture_output=True, text=True)
            if p.returncode:
                raise RuntimeError(f"{m}: {p.stderr[-3000:]}")
            got = json.loads(p.stdout.strip().splitlines()[-1])
            runs[m].append(got)
            print(f"round {r + 1} {m}: {got['cpu_python_per_sample'] * 1e3:.2f} ms, "
                  f"{got['cpu_python_per_kernel']:.2%} of the kernels, load "
                  f"{got['load'][0]:.1f}", flush=True)
    print(f"\n{'mode':45s} {'Python/sample (CPU ms)':>26s} {'share of the kernels':>24s}")
    summary = {}
    for m, rs in runs.items():
        ms = [r["cpu_python_per_sample"] * 1e3 for r in rs]
        sh = [r["cpu_python_per_kernel"] * 100 for r in rs]
        summary[m] = {"cpu_python_ms": statistics.median(ms), "range_ms": [min(ms), max(ms)],
                      "share_percent": statistics.median(sh), "range_percent": [min(sh), max(sh)]}
        print(f"{m:45s} {statistics.median(ms):8.2f} ({min(ms):.2f}-{max(ms):.2f}) "
              f"{statistics.median(sh):12.2f} % ({min(sh):.2f}-{max(sh):.2f})")
    if a.json:
        Path(a.json).write_text(json.dumps({"summary": summary, "runs": runs}, indent=1))


if __name__ == "__main__":
    main()
