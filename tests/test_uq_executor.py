"""Executor: same numbers for any n_jobs/backend, failures recorded, cache, resume after a kill."""

from __future__ import annotations

import functools
import json
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mechrel.errors import SimulationError, StudyError
from mechrel.uq import (
    Allowable,
    EvaluationCache,
    Evaluations,
    FunctionModel,
    ModelFailure,
    Normal,
    UncertainInputs,
    evaluate,
    linear_model,
    monte_carlo,
)

INPUTS = UncertainInputs.from_specs({"x0": Normal(0.0, 1.0), "x1": Normal(1.0, 0.5)})


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


# ---------------------------------------------------------------- parallel reproducibility
def test_same_seed_same_numbers_for_any_n_jobs_and_backend():
    pytest.importorskip("distributed")
    from dask.distributed import Client, LocalCluster

    model = linear_model([0.1, -0.5], [[0.5, 0.0], [0.2, 0.3]], INPUTS.names)
    kw = dict(model=model, inputs=INPUTS, n=512, seed=77, allowable=Allowable(1.0, 0.3),
              chunk_size=32)
    ref = monte_carlo(**kw, n_jobs=1)
    loky = monte_carlo(**kw, n_jobs=2, backend="loky")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, \
            Client(cluster):
        dask = monte_carlo(**kw, n_jobs=2, backend="dask")
    for other in (loky, dask):
        assert np.array_equal(other.evaluations.Y, ref.evaluations.Y)
        pd.testing.assert_frame_equal(other.table, ref.table, check_exact=True)
        pd.testing.assert_frame_equal(other.whole_cycle, ref.whole_cycle, check_exact=True)
    assert (loky.evaluations.settings["backend"] == "loky"
            and dask.evaluations.settings["backend"] == "dask")
    # results do not depend on the chunking either
    other = monte_carlo(**{**kw, "chunk_size": 7}, n_jobs=1)
    pd.testing.assert_frame_equal(other.table, ref.table, check_exact=True)


def test_dask_without_client_is_a_clear_error():
    pytest.importorskip("distributed")
    model = linear_model([0.0], [[1.0, 0.0]], INPUTS.names)
    with pytest.raises(StudyError,
                       match=r"backend='dask': no Dask client is active; create one first"):
        evaluate(model, np.zeros((4, 2)), n_jobs=2, backend="dask", progress=False)


def test_backend_argument_errors():
    model = linear_model([0.0], [[1.0, 0.0]], INPUTS.names)
    with pytest.raises(StudyError,
                       match=r"backend: got 'threads'; allowed: \['loky', 'dask', 'sequential'\]"):
        evaluate(model, np.zeros((4, 2)), backend="threads")
    with pytest.raises(StudyError,
                       match=r"n_jobs = 0: must be >= 1 or -1; allowed: an integer >= 1, or -1"):
        evaluate(model, np.zeros((4, 2)), n_jobs=0)
    with pytest.raises(StudyError,
                       match=r"X: expected shape \(n, 2\) for inputs \['x0', 'x1'\], got \(4, 3\)"):
        evaluate(model, np.zeros((4, 3)))

    class Unpicklable:
        input_names = ("x0", "x1")
        output_index = pd.Index(["y"])

        def __init__(self):
            self.lock = threading.Lock()

        def evaluate(self, x):
            return np.array([x[0]])

        def cache_key(self):
            return "unpicklable"

    with pytest.raises(StudyError, match=r"model: Unpicklable cannot be pickled for parallel "
                                         r"workers \(TypeError"):
        evaluate(Unpicklable(), np.zeros((4, 2)), n_jobs=2, progress=False)
    # ...but it is a valid Model and runs in-process
    assert evaluate(Unpicklable(), np.ones((4, 2)), progress=False).n_ok == 4


# ---------------------------------------------------------------- failures
def _mixed(x):
    if x[0] > 1.0:
        raise ModelFailure("clearance joint jammed")
    if x[0] < -1.5:
        raise SimulationError("step size underflow at t=0.12 s")
    if x[1] > 1.8:
        return np.array([np.nan, 1.0])
    return np.array([x[0], x[1]])


def test_failures_are_recorded_with_reasons_never_dropped():
    X = INPUTS.sample(400, seed=3)
    m = FunctionModel(_mixed, INPUTS.names, ["a", "b"])
    ev = evaluate(m, X, n_jobs=2, chunk_size=25, progress=False)
    jam = X[:, 0] > 1.0
    under = (X[:, 0] < -1.5) & ~jam
    nonfin = (X[:, 1] > 1.8) & ~jam & ~under
    assert ev.n == 400 and ev.n_failed == int(jam.sum() + under.sum() + nonfin.sum())
    counts = ev.failure_counts()
    assert counts["clearance joint jammed"] == jam.sum()
    assert counts["SimulationError: step size underflow at t=0.12 s"] == under.sum()
    assert counts["non-finite output (1 of 2 entries)"] == nonfin.sum()
    assert list(ev.status[jam]) == ["failed"] * int(jam.sum())
    assert np.all(np.isnan(ev.Y[~ev.ok]))
    fr = ev.failures()
    assert len(fr) == ev.n_failed and set(fr.columns) == {"x0", "x1", "reason"}
    assert ev.to_frame().shape == (400, 2 + 2 + 2)


def _bug(x):
    if x[0] > 0.5:
        raise ZeroDivisionError("a bug, not a failed sample")
    return np.array([x[0]])


def _wrong_length(x):
    return np.array([1.0, 2.0])


def test_bugs_and_set_up_errors_stop_the_run(tmp_path):
    X = np.linspace(0, 1, 20)[:, None] * np.ones((1, 2))
    m = FunctionModel(_bug, INPUTS.names, ["y"])
    with pytest.raises(ZeroDivisionError):
        evaluate(m, X, chunk_size=5, cache=tmp_path, progress=False)
    # the chunks finished before the bug are kept
    assert EvaluationCache(tmp_path).stats()[
        next(iter(EvaluationCache(tmp_path).stats()))]["ok"] == 10
    with pytest.raises(StudyError, match=r"returned 2 outputs, (model\.)?output_index has 1"):
        evaluate(FunctionModel(_wrong_length, INPUTS.names, ["y"]), X, progress=False)


# ---------------------------------------------------------------- cache, resume
def _counted(x, counter, bomb):
    """Appends one line per call; raises KeyboardInterrupt once the bomb's count is reached."""
    with open(counter, "a") as f:
        f.write(np.asarray(x, dtype="<f8").tobytes().hex() + "\n")
    if os.path.exists(bomb):
        with open(counter) as f:
            if sum(1 for _ in f) >= int(Path(bomb).read_text()):
                raise KeyboardInterrupt
    return np.array([x[0] + 2 * x[1], x[0] * x[1]])


def test_interrupted_run_resumes_without_recomputing(tmp_path):
    counter, bomb, cache = tmp_path / "calls.txt", tmp_path / "bomb", tmp_path / "cache"
    model = FunctionModel(functools.partial(_counted, counter=str(counter), bomb=str(bomb)),
                          INPUTS.names, ["s", "p"])
    X = INPUTS.sample(100, seed=4)
    bomb.write_text("35")
    with pytest.raises(KeyboardInterrupt):
        evaluate(model, X, chunk_size=10, cache=cache, progress=False)
    assert len(_lines(counter)) == 35
    stats = EvaluationCache(cache).stats()
    # three finished chunks and the 4 samples finished in the interrupted one persisted
    assert sum(v["ok"] for v in stats.values()) == 34
    bomb.unlink()
    ev = evaluate(model, X, chunk_size=10, cache=cache, progress=False)
    assert ev.n_cached == 34 and ev.n_model_calls == 66
    assert len(_lines(counter)) == 35 + 66
    # only the interrupted sample was evaluated twice, the cached 34 never again
    first = _lines(counter)[:34]
    assert not set(first) & set(_lines(counter)[35:])
    assert _lines(counter)[34] in _lines(counter)[35:]
    ref = evaluate(model, X, progress=False)  # no cache
    assert np.array_equal(ev.Y, ref.Y)
    again = evaluate(model, X, cache=cache, progress=False)
    assert again.n_model_calls == 0 and again.n_cached == 100 and np.array_equal(again.Y, ref.Y)


def test_callback_abort_with_loky_resumes(tmp_path):
    model = linear_model([0.0], [[1.0, 2.0]], INPUTS.names, key="abort-test")
    X = INPUTS.sample(200, seed=8)

    def abort(done, total):
        if done >= 40:
            raise RuntimeError("user abort")

    with pytest.raises(RuntimeError, match="user abort"):
        evaluate(model, X, n_jobs=2, chunk_size=20, cache=tmp_path, callback=abort, progress=False)
    cached = sum(v["ok"] for v in EvaluationCache(tmp_path).stats().values())
    assert 40 <= cached < 200
    ev = evaluate(model, X, n_jobs=2, chunk_size=20, cache=tmp_path, progress=False)
    assert ev.n_cached == cached and ev.n_model_calls == 200 - cached
    assert np.array_equal(ev.Y, evaluate(model, X, progress=False).Y)


_FLAKY_FLAG = "flaky-flag"


def _flaky(x, flag):
    if x[0] > 0.5 and os.path.exists(flag):
        raise ModelFailure("solver diverged")
    return np.array([x[0]])


def test_failures_are_cached_and_can_be_retried(tmp_path):
    flag = tmp_path / _FLAKY_FLAG
    flag.write_text("on")
    model = FunctionModel(functools.partial(_flaky, flag=str(flag)), INPUTS.names, ["y"])
    X = INPUTS.sample(50, seed=2)
    n_bad = int(np.sum(X[:, 0] > 0.5))
    ev1 = evaluate(model, X, cache=tmp_path / "c", progress=False)
    assert ev1.n_failed == n_bad > 0
    flag.unlink()  # "fix" something outside the cache key
    ev2 = evaluate(model, X, cache=tmp_path / "c", progress=False)
    assert (ev2.n_model_calls == 0 and ev2.n_failed == n_bad
            and ev2.failure_counts() == {"solver diverged": n_bad})
    ev3 = evaluate(model, X, cache=tmp_path / "c", retry_failed=True, progress=False)
    assert ev3.n_model_calls == n_bad and ev3.n_failed == 0
    # or forget them explicitly
    flag.write_text("on")
    c = EvaluationCache(tmp_path / "d")
    evaluate(model, X, cache=c, progress=False)
    assert c.forget_failures() == n_bad
    flag.unlink()
    assert evaluate(model, X, cache=c, progress=False).n_model_calls == n_bad


def test_cache_path_may_name_the_database_file(tmp_path):
    model = linear_model([0.0], [[1.0, 0.0]], INPUTS.names, key="file")
    X = INPUTS.sample(10, seed=1)
    evaluate(model, X, cache=tmp_path / "run" / "evaluations.sqlite", progress=False)
    assert (tmp_path / "run" / "evaluations.sqlite").is_file()
    assert evaluate(model, X, cache=tmp_path / "run", progress=False).n_cached == 10  # same file


def test_provenance_is_json_serialisable():
    import json

    from mechrel.uq import fosm, ishigami_inputs, ishigami_model, polynomial_chaos, sobol_indices

    model = linear_model([0.1], [[0.5, 0.2]], INPUTS.names)
    allow = Allowable(1.0, 0.3)
    results = [
        fosm(model=model, inputs=INPUTS, allowable=allow, progress=False),
        monte_carlo(model=model, inputs=INPUTS, n=64, allowable=allow, progress=False),
        polynomial_chaos(model=model, inputs=INPUTS, order=1, progress=False),
        sobol_indices(model=ishigami_model(), inputs=ishigami_inputs(), n=16, progress=False),
    ]
    for r in results:
        text = json.dumps(r.provenance)
        assert "versions" in text and "model_cache_key" in text
        assert r.provenance["model"]["kind"] == "FunctionModel"  # the model's own account
    # precomputed evaluations know no model; the estimator says so instead of inventing one
    done = results[0].evaluations
    pre = fosm(evaluations=Evaluations.from_arrays(done.X, done.Y, input_names=INPUTS.names),
               inputs=INPUTS, allowable=allow)
    assert pre.provenance["model"] is None


def test_cache_key_separates_models(tmp_path):
    X = INPUTS.sample(10, seed=1)
    a = linear_model([0.0], [[1.0, 0.0]], INPUTS.names, key="v1")
    b = linear_model([0.0], [[1.0, 0.0]], INPUTS.names, key="v2")
    evaluate(a, X, cache=tmp_path, progress=False)
    assert evaluate(b, X, cache=tmp_path, progress=False).n_model_calls == 10
    assert evaluate(a, X, cache=tmp_path, progress=False).n_model_calls == 0
    # a different sample is a miss, bit for bit
    X2 = X.copy()
    X2[0, 0] = np.nextafter(X2[0, 0], np.inf)
    assert evaluate(a, X2, cache=tmp_path, progress=False).n_model_calls == 1


_KILL_SCRIPT = textwrap.dedent(
    """
    import functools, json, sys, time
    import numpy as np
    from mechrel.uq import FunctionModel, Normal, UncertainInputs, evaluate

    def slow(x, counter):
        time.sleep(0.05)
        with open(counter, "a") as f:
            f.write(np.asarray(x, dtype="<f8").tobytes().hex() + "\\n")
        return np.array([x[0] + x[1]])

    if __name__ == "__main__":
        cache, counter, out = sys.argv[1:4]
        inputs = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1)})
        X = inputs.sample(60, seed=1)
        model = FunctionModel(functools.partial(slow, counter=counter), inputs.names, ["y"],
                              key="kill-test")
        ev = evaluate(model, X, cache=cache, chunk_size=5, progress=False)
        json.dump({"calls": ev.n_model_calls, "cached": ev.n_cached,
                   "Y": ev.Y.ravel().tolist()}, open(out, "w"))
    """
)


def _ok_rows(db: Path) -> int:
    if not db.exists():
        return 0
    try:
        with sqlite3.connect(db, timeout=5) as con:
            return con.execute("SELECT COUNT(*) FROM evaluations WHERE ok = 1").fetchone()[0]
    except sqlite3.OperationalError:
        return 0


def test_killed_process_resumes_from_cache(tmp_path):
    """SIGKILL (no cleanup at all) in the middle of a run; the rerun evaluates only what is not
    in the cache: counted through a file the model appends to on every call."""
    script = tmp_path / "run.py"
    script.write_text(_KILL_SCRIPT)
    cache, counter, out = tmp_path / "cache", tmp_path / "calls.txt", tmp_path / "out.json"
    db = cache / EvaluationCache.FILENAME
    proc = subprocess.Popen([sys.executable, str(script), str(cache), str(counter), str(out)])
    try:
        deadline = time.time() + 120
        while _ok_rows(db) < 10 and proc.poll() is None and time.time() < deadline:
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    assert not out.exists(), "the run finished before it could be killed"
    cached = _ok_rows(db)
    calls_before = _lines(counter)
    assert 10 <= cached < 60 and len(calls_before) >= cached
    subprocess.run([sys.executable, str(script), str(cache), str(counter), str(out)], check=True,
                   timeout=300)
    res = json.loads(out.read_text())
    assert res["cached"] == cached and res["calls"] == 60 - cached
    calls_after = _lines(counter)[len(calls_before):]
    assert len(calls_after) == 60 - cached
    with sqlite3.connect(db) as con:
        assert con.execute("SELECT COUNT(*) FROM evaluations WHERE ok = 1").fetchone()[0] == 60
    X = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1)}).sample(60, seed=1)
    np.testing.assert_array_equal(res["Y"], X[:, 0] + X[:, 1])


def test_a_local_pool_has_at_most_a_worker_per_chunk_and_per_core(monkeypatch):
    # --jobs 100000 on two cores started a process per chunk (180 and more) that shared the
    # cores for minutes; the numbers never depend on the workers
    import joblib

    from mechrel.uq.execution.executor import local_workers

    cores = os.cpu_count() or 1
    assert local_workers(1, 50) == 1 and local_workers(-1, 50) == -1
    assert local_workers(100000, 16) == max(2, min(16, cores))
    assert local_workers(100000, 1) == 2 and local_workers(3, 100) == min(3, max(2, cores))
    sizes = []
    real = joblib.Parallel

    def recording(*a, **kw):
        sizes.append(kw.get("n_jobs"))
        return real(*a, **kw)

    monkeypatch.setattr(joblib, "Parallel", recording)
    X = INPUTS.sample(40, seed=3)
    m = FunctionModel(_mixed, INPUTS.names, ["a", "b"])
    many = evaluate(m, X, n_jobs=100000, chunk_size=10, progress=False)
    assert sizes == [max(2, min(4, cores))]
    one = evaluate(m, X, n_jobs=1, chunk_size=10, progress=False)
    assert np.array_equal(many.Y, one.Y, equal_nan=True)
