"""Batched evaluation of the mechanism model (issue 14 §2): ``MechanismModel.evaluate_batch``
gives, row by row, the numbers of a plain :func:`mechrel.simulation.simulate` of each sample,
bitwise, for any batch (chunk) size and number of workers; failures stay per sample with the
reason row-by-row evaluation gives; the executor records a batch's ``RowFailures`` as they are.

Cost: ~60 two-cycle simulations of the default study's model (≈0.04 s each) and one start of
two loky workers; the slider-crank cases are kinematic or one short cycle each.
"""

from __future__ import annotations

import pickle
import re

import numpy as np
import pytest

from mechrel.errors import SceneError, StudyError
from mechrel.study.study import load_study
from mechrel.uq import FunctionModel, ModelFailure
from mechrel.uq.execution.executor import evaluate
from mechrel.uq.problem.model import evaluate_rows
from mechrel.uq.problem.mechanism import MechanismModel, _stable_reason
from mechrel.uq.problem.model import RowFailures
from mechrel.uq.problem.allowables import EXTREME_STATS

BAD_CLEARANCE = -1e-4  # refused by the scene's validation: a recorded failure, not an error


def _reference_row(model, x):
    """The model's outputs at ``x`` from the full :func:`simulate` path (``model.simulate``:
    an integrator made for the sample and the provenance recorded), extracted independently."""
    res = model.simulate(x)
    k = model.crank_angles.size
    parts = [res.error(model.output, q)[-k:] for q in model.quantities]
    if model.with_extremes:
        parts.append(np.array([res.extremes[model.output][q][s]
                               for q in model.quantities for s in EXTREME_STATS]))
    return np.concatenate(parts)


@pytest.fixture(scope="module")
def study_model():
    study = load_study("nine-bar-lubricated")
    model = study.model()
    X = study.uncertain_inputs().sample(8, "sobol", 20221014)
    X[4, 0] = BAD_CLEARANCE  # one sample the scene refuses
    return model, X


def test_batch_rows_equal_plain_simulation_and_failures_keep_their_reason(study_model):
    model, X = study_model
    assert model.vectorized is True
    with pytest.raises(RowFailures) as info:
        model.evaluate_batch(X[:6])
    got = info.value
    assert got.reasons[4] is not None and all(r is None for i, r in enumerate(got.reasons)
                                              if i != 4)
    # the failed row's reason is the one row-by-row evaluation raises with
    with pytest.raises(ModelFailure) as single:
        model.evaluate(X[4])
    assert got.reasons[4] == single.value.reason
    assert "joints.C1.clearance" in got.reasons[4]
    for i in (0, 1, 2, 3, 5):
        # bitwise: the batch shares one integrator object and skips the provenance, nothing
        # that enters the numbers
        assert np.array_equal(got.Y[i], _reference_row(model, X[i])), i
        assert np.array_equal(got.Y[i], model.evaluate(X[i])), i
    # a batch without failures returns its rows
    Y = model.evaluate_batch(X[:3])
    assert np.array_equal(Y, got.Y[:3])


def test_same_numbers_for_any_chunk_size_and_worker_count(study_model):
    model, X = study_model
    runs = {(cs, jobs): evaluate(model, X, n_jobs=jobs, chunk_size=cs, progress=False)
            for cs in (1, 7, 64) for jobs in (1, 2)}
    first = runs[(1, 1)]
    assert first.n_failed == 1 and first.status[4] == "failed"
    assert first.n_model_calls == X.shape[0]
    for key, ev in runs.items():
        assert np.array_equal(ev.Y, first.Y, equal_nan=True), key
        assert ev.reasons == first.reasons, key
        assert list(ev.status) == list(first.status), key


def test_batch_reuses_the_integrator_only_for_equal_solver_settings():
    # the integrator's tolerance is itself the sampled input: each row needs its own solver,
    # and each row's numbers are those of a plain simulation at its rtol
    model = MechanismModel("slider-crank-lubricated", ["solver.rtol"], angle_step=30.0,
                           overrides={"solver.rtol": 1e-5, "solver.atol": 1e-8})
    X = np.array([[1e-5], [1e-6], [1e-5], [2.0]])  # rtol = 2 is refused by the integrator
    with pytest.raises(RowFailures) as info:
        model.evaluate_batch(X)
    got = info.value
    assert [r is None for r in got.reasons] == [True, True, True, False]
    assert "rtol" in got.reasons[3]
    for i in range(3):
        assert np.array_equal(got.Y[i], _reference_row(model, X[i])), i
    assert np.array_equal(got.Y[0], got.Y[2])
    assert not np.array_equal(got.Y[0], got.Y[1])  # a tolerance 10x tighter moves the numbers


def test_batch_with_geometric_inputs_against_the_nominal_design():
    # no clearance joint: kinematic analysis against the nominal reference, per row
    model = MechanismModel("slider-crank", ["bodies.crank.length(O,A)"], angle_step=30.0)
    L = model.nominal[0]  # the scene's own crank length (m)
    X = np.array([[L - 1e-4], [L + 1e-4], [L]])
    Y = model.evaluate_batch(X)
    for i in range(3):
        assert np.array_equal(Y[i], _reference_row(model, X[i])), i
    # the nominal length has no error: its extremes and angle errors vanish to round-off
    assert np.max(np.abs(Y[2])) < 1e-9


def test_batch_input_shape_is_checked(study_model):
    model, X = study_model
    with pytest.raises(StudyError, match=r"X: expected shape \(m, 3\) for inputs "
                                         r"\['clearance', 'viscosity', 'speed'\], got \(3, 2\)"):
        model.evaluate_batch(X[:3, :2])


def _rows_with_failures(X):
    """A batch that records its own failures: row i fails when x0 < 0."""
    Y = np.column_stack([X[:, 0] + X[:, 1], X[:, 0] * X[:, 1]])
    reasons = [f"x0 < 0 (row {i})" if x[0] < 0 else None for i, x in enumerate(X)]
    if any(reasons):
        raise RowFailures(np.where(X[:, :1] < 0, np.nan, Y), reasons)
    return Y


def _rows_wrong_count(X):
    raise RowFailures(np.zeros((len(X), 2)), [None])


def test_executor_records_row_failures_as_given_and_rejects_a_wrong_count():
    X = np.array([[1.0, 2.0], [-1.0, 2.0], [3.0, 4.0], [-2.0, 1.0]])
    model = FunctionModel(_rows_with_failures, ["a", "b"], ["s", "p"], key="rows",
                          vectorized=True)
    ev = evaluate(model, X, chunk_size=4, progress=False)
    assert list(ev.status) == ["ok", "failed", "ok", "failed"]
    # the batch's own reasons, not "non-finite output" and no row-by-row re-run
    assert ev.reasons == (None, "x0 < 0 (row 1)", None, "x0 < 0 (row 3)")
    assert ev.n_model_calls == 4
    assert np.array_equal(ev.Y[[0, 2]], [[3.0, 2.0], [7.0, 12.0]])
    bad = FunctionModel(_rows_wrong_count, ["a", "b"], ["s", "p"], key="rows2", vectorized=True)
    with pytest.raises(StudyError, match="RowFailures carries 1 reasons for 4 rows; allowed: "
                                         "one per row"):
        evaluate(bad, X, chunk_size=4, progress=False)


def test_row_failures_pickle_with_their_rows():
    exc = RowFailures(np.array([[1.0], [np.nan]]), [None, "why"])
    back = pickle.loads(pickle.dumps(exc))
    assert back.reasons == [None, "why"] and np.array_equal(back.Y, exc.Y, equal_nan=True)
    assert str(back) == "1 of 2 rows failed, the first: why"
    exc = RowFailures(np.array([[1.0], [np.nan], [np.nan]]), {2: "b", np.int64(1): "a"})
    back = pickle.loads(pickle.dumps(exc))
    assert back.failed == {1: "a", 2: "b"} and back.reasons == [None, "a", "b"]
    assert str(back) == "2 of 3 rows failed, the first: a"


def _rows_with_failures_mapping(X):
    """:func:`_rows_with_failures`, its failed rows' reasons as ``{row: reason}``."""
    Y = np.column_stack([X[:, 0] + X[:, 1], X[:, 0] * X[:, 1]])
    bad = np.flatnonzero(X[:, 0] < 0)
    if bad.size:
        raise RowFailures(np.where(X[:, :1] < 0, np.nan, Y),
                          {int(i): f"x0 < 0 (row {i})" for i in bad})
    return Y


def test_row_failures_by_row_are_recorded_as_the_per_row_form():
    X = np.random.default_rng(4).standard_normal((300, 2))
    ev = {}
    for name, f in (("list", _rows_with_failures), ("mapping", _rows_with_failures_mapping)):
        model = FunctionModel(f, ["a", "b"], ["s", "p"], key=name, vectorized=True)
        ev[name] = evaluate(model, X, chunk_size=300, progress=False)
    # the reasons are counted from the batch's first row: in one chunk, the sample's index
    assert ev["mapping"].reasons == ev["list"].reasons
    assert ev["mapping"].n_failed == int((X[:, 0] < 0).sum()) and ev["mapping"].n_model_calls == 300
    assert np.array_equal(ev["mapping"].Y, ev["list"].Y, equal_nan=True)
    assert list(ev["mapping"].status) == list(ev["list"].status)


@pytest.mark.parametrize("key", [4, -1, 1.0, True, "0"])
def test_row_failures_name_only_rows_of_the_batch(key):
    with pytest.raises(StudyError, match=rf"RowFailures: {re.escape(repr(key))} is not a row of "
                                         r"the batch of 4 rows; allowed: integers 0\.\.3"):
        RowFailures(np.zeros((4, 1)), {key: "why"})


def test_evaluate_rows_hands_the_finished_rows_to_an_interrupt():
    calls = []

    def one(x):
        calls.append(x[0])
        if x[0] == 2.0:
            raise KeyboardInterrupt
        if x[0] == 1.0:
            raise ModelFailure("one is refused")
        return np.array([10.0 * x[0]])

    with pytest.raises(KeyboardInterrupt) as info:
        evaluate_rows(one, np.array([[0.0], [1.0], [2.0], [3.0]]), 1)
    k, Y, ok, reasons = info.value.finished
    assert k == 2 and calls == [0.0, 1.0, 2.0]
    assert Y[0, 0] == 0.0 and np.isnan(Y[1, 0]) and list(ok) == [True, False]
    assert reasons == [None, "one is refused"]


# ----------------------------------------------------------------------------- issue 35
# A vectorised model's chunk is handled as a chunk: one call, its failed rows reported by the
# model (a row mask of NaN, RowFailures) and recorded as they are, never a re-run; a batch
# that raises is split in halves until the raising rows stand alone. The numbers are the same
# for any chunk size and worker count, bitwise, and those of row-by-row evaluation.

def _sums(X):
    """Exact arithmetic (sums and products of small binary fractions): the same bits whether
    evaluated on one row or a batch, by NumPy's vector loop or its scalar tail."""
    return np.column_stack([X[:, 0] + X[:, 1], X[:, 0] * X[:, 1]])


CALLS: list[int] = []


def _sums_masked(X):
    CALLS.append(X.shape[0])
    Y = _sums(X)
    Y[X[:, 0] < 0] = np.nan  # a row mask: these rows failed
    return Y


def _sums_raising(X):
    CALLS.append(X.shape[0])
    if (X[:, 0] < 0).any():
        raise ModelFailure("x0 < 0")
    return _sums(X)


def _design(n=257, seed=3):
    rng = np.random.default_rng(seed)
    X = np.round(rng.uniform(-1, 8, size=(n, 2)) * 8) / 8  # multiples of 1/8: exact sums
    X[:, 0] = np.abs(X[:, 0])
    X[rng.choice(n, size=5, replace=False), 0] = -1.0  # 5 failing rows (2 %)
    return X


def test_a_masked_batch_is_called_once_per_chunk_and_its_rows_kept():
    X = _design()
    model = FunctionModel(_sums_masked, ["a", "b"], ["s", "p"], key="masked", vectorized=True)
    CALLS.clear()
    ev = evaluate(model, X, chunk_size=64, progress=False)
    assert CALLS == [64, 64, 64, 64, 1]  # no row evaluated twice
    bad = X[:, 0] < 0
    assert list(ev.status == "failed") == list(bad)
    assert set(ev.failure_counts()) == {"non-finite output (2 of 2 entries)"}
    assert np.array_equal(ev.Y[~bad], _sums(X[~bad]))
    assert ev.count.as_tuple() == (257, 257, 0, 5)


def test_a_raising_batch_isolates_its_failing_rows_by_halves():
    X = _design()
    model = FunctionModel(_sums_raising, ["a", "b"], ["s", "p"], key="raising",
                          vectorized=True)
    CALLS.clear()
    ev = evaluate(model, X, chunk_size=64, progress=False)
    bad = X[:, 0] < 0
    assert list(ev.status == "failed") == list(bad)
    assert all(r == "x0 < 0" for r in ev.reasons if r is not None)
    assert np.array_equal(ev.Y[~bad], _sums(X[~bad]))
    # 5 failing rows: far fewer rows evaluated again than row by row would (2 x 257 + ...)
    assert sum(CALLS) < 4 * X.shape[0] and len(CALLS) < X.shape[0]
    assert ev.n_model_calls == X.shape[0]  # rows computed, each counted once


@pytest.mark.parametrize("func", [_sums_masked, _sums_raising, _rows_with_failures,
                                  _rows_with_failures_mapping],
                         ids=["mask", "raising", "RowFailures", "RowFailures-by-row"])
def test_vectorised_results_do_not_depend_on_chunks_workers_or_batching(func):
    X = _design()
    vec = FunctionModel(func, ["a", "b"], ["s", "p"], key=func.__name__, vectorized=True)
    runs = {(cs, jobs): evaluate(vec, X, n_jobs=jobs, chunk_size=cs, progress=False)
            for cs in (1, 7, 64, None) for jobs in (1, 2)}
    # row by row: the same function on one row at a time (a row-wise model)
    one = FunctionModel(lambda x: func(x[None, :])[0], ["a", "b"], ["s", "p"],
                        key=func.__name__ + "-rows")
    first = evaluate(one, X, progress=False)
    assert first.n_failed == 5
    for key, ev in runs.items():
        assert ev.Y.tobytes() == first.Y.tobytes(), key
        assert list(ev.status) == list(first.status), key
        assert ev.count.as_tuple() == first.count.as_tuple(), key
        if func not in (_rows_with_failures, _rows_with_failures_mapping):  # reasons per row
            assert ev.reasons == first.reasons, key


def test_cache_writes_and_progress_come_once_per_chunk(tmp_path, monkeypatch):
    from mechrel.uq.execution.cache import EvaluationCache

    stored = []
    store = EvaluationCache.store
    monkeypatch.setattr(EvaluationCache, "store",
                        lambda self, key, X, *a: (stored.append(len(X)), store(self, key, X, *a)))
    done = []
    X = _design(n=100)
    model = FunctionModel(_sums_masked, ["a", "b"], ["s", "p"], key="cached", vectorized=True)
    ev = evaluate(model, X, chunk_size=32, cache=tmp_path, progress=False,
                  callback=lambda k, n: done.append((k, n)))
    assert stored == [32, 32, 32, 4] and done == [(32, 100), (64, 100), (96, 100), (100, 100)]
    again = evaluate(model, X, chunk_size=32, cache=tmp_path, progress=False)
    assert again.count.as_tuple() == (100, 0, 100, ev.n_failed)
    assert again.Y.tobytes() == ev.Y.tobytes() and again.reasons == ev.reasons


def test_an_interrupt_in_the_second_half_keeps_the_first_half():
    from mechrel.uq.execution.executor import _batch

    class Model:
        vectorized = True

        def evaluate_batch(self, X):
            if (X[:, 0] < 0).any():
                raise ModelFailure("x0 < 0")
            if (X[:, 0] == 9.0).any():  # Ctrl-C while the second half runs
                raise KeyboardInterrupt
            return _sums(X)

    X = np.array([[1.0, 2.0], [-1.0, 2.0], [3.0, 4.0], [9.0, 1.0]])
    with pytest.raises(KeyboardInterrupt) as info:
        _batch(Model(), X, 2)
    k, Y, ok, reasons = info.value.finished
    assert k == 2 and list(ok) == [True, False] and reasons == [None, "x0 < 0"]
    assert np.array_equal(Y[0], [3.0, 2.0])


def test_the_mechanism_sample_path_is_bitwise_the_full_path_with_mixed_inputs():
    # a clearance and a length tolerance: the sample's compiled scene is patched (its
    # clearance row, the crank pin's coordinates), the nominal reference is prepared once per
    # clearance; every row equals the full path (scene rebuilt, simulate with provenance)
    model = MechanismModel("slider-crank-lubricated",
                           {"c": ["joints.C.clearance"], "r": ["bodies.crank.length(O,A)"]},
                           quantities=["velocity"], angle_step=90.0, cycles=1,
                           overrides={"solver.rtol": 1e-5, "solver.atol": 1e-8})
    assert model.nominal_reference
    c0, r0 = model.nominal
    X = np.array([[c0, r0], [c0, r0 + 1e-4], [1.2 * c0, r0 - 1e-4], [c0, -0.05]])
    with pytest.raises(RowFailures) as info:
        model.evaluate_batch(X)
    got = info.value
    with pytest.raises(SceneError) as full:  # the full path's own message (numbers as '#')
        model.simulate(X[3])
    assert "a length must be a number > 0" in str(full.value)
    assert got.reasons[3] == _stable_reason(full.value)
    for i in range(3):
        assert got.Y[i].tobytes() == _reference_row(model, X[i]).tobytes(), i
    assert model._samples.prepared.patchable
    assert len(model._samples.references) == 2  # one per clearance value met


def test_the_nominal_reference_of_geometric_samples_is_analysed_once(monkeypatch):
    import mechrel.simulation.reference as simulation  # where the reference is analysed

    model = MechanismModel("slider-crank", ["bodies.crank.length(O,A)",
                                            "bodies.rod.length(A,B)"], angle_step=30.0)
    seen = []
    kin = simulation.kinematic_analysis
    monkeypatch.setattr(simulation, "kinematic_analysis",
                        lambda system, *a, **kw: (seen.append(id(system)), kin(system, *a,
                                                                              **kw))[1])
    L = model.nominal
    X = L + np.array([[1e-5, 0.0], [0.0, -2e-5], [3e-5, 1e-5], [-1e-5, 1e-5]])
    Y = model.evaluate_batch(X)
    ref = next(iter(model._samples.references.values()))
    n_ref = sum(1 for s in seen if s == id(ref._compiled.ideal))
    # the reference at the output grid and at the extremes' window, once each, for 4 samples
    assert n_ref == 2
    for i in range(4):
        assert Y[i].tobytes() == _reference_row(model, X[i]).tobytes(), i


def test_rows_that_fail_at_each_step_of_a_batch_keep_their_reasons():
    # evaluate_batch runs its rows' runs step by step for a few rows at a time
    # (MechanismModel.STEP_ROWS): their scenes, then the integrations, then the checks after
    # them. A row failing at each of those steps fails alone, with the reason row-by-row
    # evaluation gives, and the other rows are bitwise theirs, for any grouping of the rows.
    model = MechanismModel("slider-crank-lubricated",
                           ["joints.C.lubricant.viscosity", "solver.rtol"], angle_step=30.0,
                           overrides={"solver.rtol": 1e-5, "solver.atol": 1e-8,
                                      "solver.formulation": "absolute"})
    X = np.array([[0.4, 1e-5],
                  [1e-6, 1e-5],   # the integration fails (the film cannot carry the load)
                  [0.3, 1e-5],
                  [0.4, 1e-2],    # after the integration: the ideal joints drift apart
                  [-1.0, 1e-5],   # the scene refuses it (before any step runs)
                  [0.5, 1e-5]])
    expected = []
    for x in X:
        try:
            expected.append(model.evaluate(x))
        except ModelFailure as exc:
            expected.append(exc.reason)
    assert "step size underflow" in expected[1] and "drifted apart" in expected[3]
    assert "viscosity" in expected[4]
    for rows in (1, 2, 4, 8):
        model.STEP_ROWS = rows
        with pytest.raises(RowFailures) as info:
            model.evaluate_batch(X)
        got = info.value
        for i, want in enumerate(expected):
            if isinstance(want, str):
                assert got.reasons[i] == want, (rows, i)
            else:
                assert got.reasons[i] is None and np.array_equal(got.Y[i], want), (rows, i)


def test_a_sample_run_in_steps_is_simulate_sample_and_times_its_own_steps():
    # sample_steps paused between its steps (the other samples of a batch run then): the
    # result is simulate_sample's, bitwise, and its total wall time leaves out the 0.6 s of
    # pauses (the run takes milliseconds)
    import math
    import time

    from mechrel.scene import load_scene, with_overrides
    from mechrel.simulation import make_integrator, sample_steps, simulate_sample

    scene = with_overrides(load_scene("slider-crank-lubricated"),
                           {"analysis.cycles": 1, "analysis.sample_step_angle": math.pi / 4})
    steps = sample_steps(scene, make_integrator(scene), extremes=True)
    kernel = next(steps)
    time.sleep(0.3)
    out = kernel()
    time.sleep(0.3)
    with pytest.raises(StopIteration) as done:
        steps.send(out)
    got = done.value.value
    ref = simulate_sample(scene, make_integrator(scene), extremes=True)
    assert np.array_equal(got.error("slider", "acceleration"), ref.error("slider", "acceleration"))
    assert got.extremes == ref.extremes
    assert got.stats["total_wall_time"] < 0.3, got.stats["total_wall_time"]


@pytest.mark.parametrize("how", ["ctrl-c", "inside a compiled callback"])
def test_an_interrupt_in_a_step_group_stops_the_batch_at_once(monkeypatch, how):
    # an interrupt during the second row's kernel of a group of four: no other kernel runs
    # after it, and the interrupt carries the rows finished before the group (the executor
    # caches those and re-runs the rest on resume)
    import signal

    import mechrel.integrate.radau as radau
    from mechrel.errors import Interrupted

    model = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
                           quantities=["velocity"], angle_step=90.0, cycles=1)
    model.STEP_ROWS = 4
    X = np.linspace(3e-4, 5e-4, 7)[:, None]
    kernel, calls = radau.radau5_kernel, []

    def interrupted(*a):
        calls.append(1)
        if len(calls) == 6:  # the second row of the second group (rows 4-6)
            if how == "ctrl-c":
                raise KeyboardInterrupt
            try:
                raise Interrupted(signal.SIGTERM)
            except Interrupted as exc:
                raise SystemError("<function _numba_unpickle> returned a result with an "
                                  "exception set") from exc
        return kernel(*a)

    monkeypatch.setattr(radau, "radau5_kernel", interrupted)
    with pytest.raises(KeyboardInterrupt) as info:
        model.evaluate_batch(X)
    assert len(calls) == 6  # the group's last two kernels did not run
    n, Y, ok, reasons = info.value.finished
    assert n == 4 and ok.all() and Y.shape[0] == 4
    monkeypatch.setattr(radau, "radau5_kernel", kernel)
    assert np.array_equal(Y, model.evaluate_batch(X[:4]))


def test_a_step_group_holds_at_most_step_bytes_of_kernel_outputs(monkeypatch):
    # the kernels of a group run back to back until their outputs (the solution logs) pass
    # STEP_BYTES; then those rows take their last steps before the next kernels run. With room
    # for all, four kernels then four last steps; with room for none, kernel and last steps
    # row by row (a dry nine-bar's log is 60 MB); the numbers are the same
    import mechrel.integrate.radau as radau
    import mechrel.simulation.run as run

    model = MechanismModel("slider-crank-lubricated", ["joints.C.clearance"],
                           quantities=["velocity"], angle_step=90.0, cycles=1)
    model.STEP_ROWS = 4
    X = np.linspace(3e-4, 5e-4, 4)[:, None]
    kernel, last = radau.radau5_kernel, run._window_values
    order = []

    def kernel_logged(*a):
        order.append("kernel")
        return kernel(*a)

    def last_logged(*a):
        order.append("last")
        return last(*a)

    monkeypatch.setattr(radau, "radau5_kernel", kernel_logged)
    monkeypatch.setattr(run, "_window_values", last_logged)
    got = {}
    for budget in (2**40, 0):
        model.STEP_BYTES = budget
        order.clear()
        got[budget] = model.evaluate_batch(X)
        if budget:
            assert order == ["kernel"] * 4 + ["last"] * 4
        else:
            assert order == ["kernel", "last"] * 4
    assert np.array_equal(got[0], got[2**40])
