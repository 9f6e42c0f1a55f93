"""Batched evaluation of the mechanism model (issue 14 §2): ``MechanismModel.evaluate_batch``
gives, row by row, the numbers of a plain :func:`mechrel.simulation.simulate` of each sample,
bitwise, for any batch (chunk) size and number of workers; failures stay per sample with the
reason row-by-row evaluation gives; the executor records a batch's ``RowFailures`` as they are.

Cost: ~60 two-cycle simulations of the default study's model (≈0.04 s each) and one start of
two loky workers; the slider-crank cases are kinematic or one short cycle each.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from mechrel.errors import StudyError
from mechrel.studies.study import load_study
from mechrel.uq import FunctionModel, ModelFailure
from mechrel.uq.execution.executor import evaluate
from mechrel.uq.problem.model import evaluate_rows
from mechrel.uq.problem.mechanism import MechanismModel
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
