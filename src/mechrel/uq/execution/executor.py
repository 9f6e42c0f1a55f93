"""The one place where estimators evaluate a model: :func:`evaluate`.

Guarantees
----------
* **Same numbers for any ``n_jobs``, backend and chunking.** The model is deterministic and all
  random draws (designs, allowable draws, bootstrap) happen in the parent process before or after
  dispatch; workers only evaluate rows of a fixed design matrix, and results are written back by
  row index. No per-task randomness exists, so no per-task seeds are needed. (Should a future
  model need randomness per task, derive it with ``numpy.random.SeedSequence(seed).spawn`` over
  the fixed chunking that ``chunk_size`` defines — it never depends on ``n_jobs``.)
* **Failures never kill the run and are never dropped.** ``ModelFailure`` and the other
  per-sample :class:`mechrel.errors.MechrelError` subclasses (``SimulationError``,
  ``AssemblyError``, ``SceneError``) raised by ``model.evaluate`` — and non-finite outputs — mark
  that row ``"failed"`` with its reason; its ``Y`` row is NaN. ``StudyError`` (a wrong set-up,
  e.g. a wrong output length) and any other exception (a bug) stop the run.
* **Resume.** With ``cache=``, finished chunks are written to the cache as they arrive; a rerun
  evaluates only rows missing from the cache (``n_model_calls`` counts the calls actually made).
* **Worker reuse.** loky keeps its worker processes alive between calls (reusable executor), so
  per-process start-up costs (numba loading its on-disk cache) are paid once per worker, not per
  chunk or per estimator.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from mechrel._checks import ARGS
from mechrel.errors import MechrelError, StudyError

from ._workers import (chunk_ledger, register_backend, safe_path_environment, starting_chunk,
                       worker_died)
from .cache import as_cache
from ..problem.model import (RowFailures, as_output_index, check_model, describe_model,
                             evaluate_rows)

__all__ = ["Evaluations", "EvaluationCount", "evaluate", "BACKENDS", "combined_cache_key"]

BACKENDS = ("loky", "dask", "sequential")
STATUS_OK = "ok"
STATUS_FAILED = "failed"


def _readonly(a: np.ndarray) -> np.ndarray:
    """A read-only array of ``a``'s values: ``a`` itself when it is read-only already (frozen
    by its owner, e.g. the executor's own result arrays or another ``Evaluations``' arrays),
    else a frozen copy (the caller's array stays the caller's)."""
    if isinstance(a, np.ndarray) and not a.flags.writeable:
        return a
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class EvaluationCount:
    """How many model evaluations an estimate rests on, and where they came from: the one
    count that every line and file of a study reports (:attr:`Evaluations.count`). Rows
    neither computed nor cached were given precomputed (``evaluations=``).

    Parameters
    ----------
    evaluations : int
        Rows of inputs the estimate rests on (``Evaluations.n``; a result's ``n_evaluations``).
    computed : int
        Of them, evaluated by the model in this run (simulated, for the mechanism model).
    cached : int
        Of them, read from the evaluation cache.
    failed : int
        Of them, failed samples (computed or cached).

    Examples
    --------
    >>> EvaluationCount(71, 66, 5, 0).text()
    '71 model evaluations (66 computed, 5 from the cache)'
    >>> (EvaluationCount(13, 12, 1, 0) - EvaluationCount(11, 10, 1, 0)).text()
    '2 model evaluations (2 computed)'
    """

    evaluations: int = 0
    computed: int = 0
    cached: int = 0
    failed: int = 0

    def __add__(self, other: EvaluationCount) -> EvaluationCount:
        return EvaluationCount(*(a + b for a, b in zip(self.as_tuple(), other.as_tuple())))

    def __sub__(self, other: EvaluationCount) -> EvaluationCount:
        return EvaluationCount(*(a - b for a, b in zip(self.as_tuple(), other.as_tuple())))

    def as_tuple(self) -> tuple[int, int, int, int]:
        """``(evaluations, computed, cached, failed)``.

        Returns
        -------
        tuple of int
            The four counts.

        Examples
        --------
        >>> EvaluationCount(3, 2, 1, 0).as_tuple()
        (3, 2, 1, 0)
        """
        return (self.evaluations, self.computed, self.cached, self.failed)

    def as_dict(self) -> dict[str, int]:
        """The counts under the names of the files (``summary.json``, the provenance).

        Returns
        -------
        dict
            ``n_evaluations``, ``n_computed``, ``n_cached``, ``n_failed``.

        Examples
        --------
        >>> EvaluationCount(3, 2, 1, 0).as_dict()
        {'n_evaluations': 3, 'n_computed': 2, 'n_cached': 1, 'n_failed': 0}
        """
        return dict(zip(("n_evaluations", "n_computed", "n_cached", "n_failed"),
                        self.as_tuple()))

    def text(self) -> str:
        """The count in words, as the summaries print it.

        Returns
        -------
        str
            ``"N model evaluations (C computed, K from the cache, F failed)"``, leaving out
            the parts that are zero.

        Examples
        --------
        >>> EvaluationCount(10, 8, 2, 1).text()
        '10 model evaluations (8 computed, 2 from the cache, 1 failed)'
        """
        given = self.evaluations - self.computed - self.cached
        parts = [f"{k} {what}" for k, what in ((self.computed, "computed"),
                                               (self.cached, "from the cache"),
                                               (given, "precomputed"),
                                               (self.failed, "failed")) if k]
        return (f"{self.evaluations} model evaluation{'' if self.evaluations == 1 else 's'}"
                + (f" ({', '.join(parts)})" if parts else ""))


@dataclass(frozen=True, eq=False)
class Evaluations:
    """Model evaluations at a design ``X`` (frozen); what :func:`evaluate` returns.

    Parameters
    ----------
    X : ndarray, shape (n, d)
        The inputs, one row per sample.
    Y : ndarray, shape (n, n_out)
        The outputs, NaN rows for failed samples.
    status : ndarray, shape (n,)
        ``"ok"`` or ``"failed"`` per row.
    reasons : tuple
        Per row, the failure's reason (None when ok).
    input_names : tuple of str
        The model's input names.
    output_index : pandas.Index
        The model's output labels.
    cache_key : str, optional
        The model's cache key (None for precomputed evaluations).
    n_model_calls : int, default 0
        Rows the model evaluated in this run (cache hits excluded; :attr:`count`'s
        ``computed``).
    n_cached : int, default 0
        Rows read from the evaluation cache.
    wall_time : float, default 0.0
        Seconds spent in :func:`evaluate`.
    settings : dict
        The executor's settings.
    model : dict
        What the model is (:func:`mechrel.uq.problem.model.describe_model`; for the mechanism
        model the scene's name, hash and source); empty for precomputed evaluations.

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.uq import evaluate, linear_model
    >>> ev = evaluate(linear_model([1.0], [[2.0]], ["x"]), np.array([[0.0], [1.0]]),
    ...               progress=False)
    >>> ev.Y.tolist(), ev.n_ok, ev.n_failed
    ([[1.0], [3.0]], 2, 0)
    """

    X: np.ndarray
    Y: np.ndarray
    status: np.ndarray
    reasons: tuple
    input_names: tuple[str, ...]
    output_index: pd.Index
    cache_key: str | None = None
    n_model_calls: int = 0
    n_cached: int = 0
    wall_time: float = 0.0
    settings: dict = field(default_factory=dict)
    model: dict = field(default_factory=dict)

    def __post_init__(self):
        X = np.asarray(self.X, dtype=float)
        Y = np.asarray(self.Y, dtype=float)
        if X.ndim != 2 or Y.ndim != 2 or X.shape[0] != Y.shape[0]:
            raise StudyError(f"evaluations: X (n, d) and Y (n, n_out) must have the same n, got {X.shape}, {Y.shape}")
        names = tuple(self.input_names)
        if len(names) != X.shape[1]:
            raise StudyError(f"evaluations: {len(names)} input names for X with {X.shape[1]} columns")
        idx = as_output_index(self.output_index, what="evaluations.output_index")
        if len(idx) != Y.shape[1]:
            raise StudyError(f"evaluations: output_index has {len(idx)} labels for Y with {Y.shape[1]} columns")
        status = np.asarray(self.status)
        if status.dtype != np.dtype("<U6"):
            status = status.astype("<U6")
        if status.ndim == 1 and status.size > 1 and status.strides[0] == 0:
            ok = np.full(status.shape, status[0] == STATUS_OK)  # one value n times: compared once
        else:
            ok = status == STATUS_OK
        if status.shape != (X.shape[0],) or not (ok.all() or np.all(status[~ok] == STATUS_FAILED)):
            raise StudyError("evaluations.status: one of 'ok'/'failed' per row required")
        reasons = tuple(self.reasons)
        if len(reasons) != X.shape[0]:
            raise StudyError("evaluations.reasons: one entry per row required")
        # per failed row (only): NaN outputs and a reason; an ok row has none (vectorised: no
        # Python loop over the rows unless a row needs mending)
        failed = np.flatnonzero(~ok)
        if failed.size and not np.all(np.isnan(Y[failed])):
            Y = np.array(Y)
            Y[failed] = np.nan
        # the failed rows are NaN now: any other non-finite entry is in an ok row (a finite
        # sum of all the entries says that none is NaN or infinite, without a mask of them)
        with np.errstate(over="ignore", invalid="ignore"):
            sums_finite = not failed.size and np.isfinite(Y.sum())
        if (not sums_finite
                and Y.size - np.count_nonzero(np.isfinite(Y)) != failed.size * Y.shape[1]):
            raise StudyError(
                "evaluations: rows marked 'ok' contain non-finite outputs; mark them 'failed' with a reason"
            )
        missing = [i for i in failed.tolist() if reasons[i] is None]
        if missing or reasons.count(None) != ok.sum() + len(missing):
            reasons = tuple(None if o else (r if r is not None else "unknown")
                            for o, r in zip(ok, reasons))
        object.__setattr__(self, "X", _readonly(X))
        object.__setattr__(self, "Y", _readonly(Y))
        object.__setattr__(self, "status", _readonly(status))
        object.__setattr__(self, "reasons", reasons)
        object.__setattr__(self, "input_names", names)
        object.__setattr__(self, "output_index", idx)
        object.__setattr__(self, "settings", dict(self.settings))
        object.__setattr__(self, "model", dict(self.model))
        ok.setflags(write=False)
        object.__setattr__(self, "_ok", ok)  # not a field: the mask of ``ok``, computed once

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_arrays(
        cls,
        X: Any,
        Y: Any,
        *,
        input_names: Any = None,
        output_index: Any = None,
        status: Any = None,
        reasons: Any = None,
        cache_key: str | None = None,
    ) -> Evaluations:
        """Wrap precomputed arrays as evaluations.

        Rows of ``Y`` with a non-finite value are marked failed (reason ``"non-finite output"``)
        unless ``status`` is given.

        Parameters
        ----------
        X : array_like, shape (n, d)
            The inputs, one row per sample.
        Y : array_like, shape (n,) or (n, n_out)
            The outputs.
        input_names : sequence of str, optional
            The input names (default ``x0, x1, ...``).
        output_index : pandas.Index, optional
            The output labels (default ``RangeIndex(n_out, name="output")``).
        status : array_like of str, optional
            ``"ok"`` or ``"failed"`` per row (default: from the finiteness of ``Y``).
        reasons : sequence, optional
            Per row, the failure's reason or None.
        cache_key : str, optional
            The model's cache key, if known.

        Returns
        -------
        Evaluations
            The wrapped evaluations.

        Raises
        ------
        StudyError
            If the shapes of ``X``, ``Y``, the names or the index do not agree.

        Examples
        --------
        >>> ev = Evaluations.from_arrays([[0.0], [1.0]], [1.0, float("nan")], input_names=["x"])
        >>> ev.status.tolist(), ev.reasons
        (['ok', 'failed'], (None, 'non-finite output'))
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        Y = np.asarray(Y, dtype=float)
        if Y.ndim == 1:
            Y = Y[:, None]
        if input_names is None:
            input_names = tuple(f"x{j}" for j in range(X.shape[1]))
        if output_index is None:
            output_index = pd.RangeIndex(Y.shape[1], name="output")
        if status is None:
            finite = np.all(np.isfinite(Y), axis=1)
            status = np.where(finite, STATUS_OK, STATUS_FAILED)
            if reasons is None:
                reasons = [None if f else "non-finite output" for f in finite]
        if reasons is None:
            reasons = [None if s == STATUS_OK else "unknown" for s in status]
        return cls(X, Y, status, tuple(reasons), tuple(input_names), output_index, cache_key=cache_key)

    # ------------------------------------------------------------------ views
    @property
    def n(self) -> int:
        """The number of samples (rows).

        Returns
        -------
        int
            ``X.shape[0]``.

        Examples
        --------
        >>> Evaluations.from_arrays([[0.0], [1.0]], [1.0, 2.0]).n
        2
        """
        return self.X.shape[0]

    @property
    def ok(self) -> np.ndarray:
        """Which rows were evaluated successfully.

        Returns
        -------
        ndarray of bool, shape (n,)
            True where ``status == "ok"``.

        Examples
        --------
        >>> Evaluations.from_arrays([[0.0], [1.0]], [1.0, float("inf")]).ok.tolist()
        [True, False]
        """
        return self._ok

    @property
    def n_ok(self) -> int:
        """The number of successful rows.

        Returns
        -------
        int
            ``ok.sum()``.

        Examples
        --------
        >>> Evaluations.from_arrays([[0.0], [1.0]], [1.0, float("inf")]).n_ok
        1
        """
        return int(self.ok.sum())

    @property
    def n_failed(self) -> int:
        """The number of failed rows.

        Returns
        -------
        int
            ``n - n_ok``.

        Examples
        --------
        >>> Evaluations.from_arrays([[0.0], [1.0]], [1.0, float("inf")]).n_failed
        1
        """
        return self.n - self.n_ok

    @property
    def count(self) -> EvaluationCount:
        """How many rows, computed in this run, read from the cache, failed.

        Returns
        -------
        EvaluationCount
            ``(n, n_model_calls, n_cached, n_failed)``.

        Examples
        --------
        >>> Evaluations.from_arrays([[0.0], [1.0]], [1.0, float("nan")]).count.text()
        '2 model evaluations (2 precomputed, 1 failed)'
        """
        return EvaluationCount(self.n, int(self.n_model_calls), int(self.n_cached),
                               self.n_failed)

    def failure_counts(self) -> dict[str, int]:
        """Count the failed rows by reason, most frequent first.

        Returns
        -------
        dict of str to int
            ``{reason: count}``.

        Examples
        --------
        >>> Evaluations.from_arrays([[0.0], [1.0]], [float("nan"), float("inf")]).failure_counts()
        {'non-finite output': 2}
        """
        reasons = self.reasons
        return dict(Counter(reasons[i] for i in np.flatnonzero(~self.ok)).most_common())

    def failures(self) -> pd.DataFrame:
        """The failed rows: their inputs and reason.

        Returns
        -------
        pandas.DataFrame
            Indexed by the sample's position; the input columns and ``reason``.

        Examples
        --------
        >>> Evaluations.from_arrays([[0.0], [1.0]], [1.0, float("nan")],
        ...                         input_names=["x"]).failures().to_dict("list")
        {'x': [1.0], 'reason': ['non-finite output']}
        """
        bad = ~self.ok
        df = pd.DataFrame(self.X[bad], columns=list(self.input_names), index=np.flatnonzero(bad))
        df.index.name = "sample"
        df["reason"] = [r for r in self.reasons if r is not None]
        return df

    def to_frame(self) -> pd.DataFrame:
        """One row per sample: the inputs, ``status``, ``reason`` and the outputs.

        Returns
        -------
        pandas.DataFrame
            Two-level columns: ``("input", name)``, ``("status", "")``, ``("reason", "")`` and
            ``("output", label)``.

        Examples
        --------
        >>> df = Evaluations.from_arrays([[0.5]], [2.0], input_names=["x"]).to_frame()
        >>> df.columns.tolist()
        [('input', 'x'), ('status', ''), ('reason', ''), ('output', '0')]
        """
        cols_in = pd.MultiIndex.from_tuples([("input", n) for n in self.input_names])
        df_in = pd.DataFrame(self.X, columns=cols_in)
        out_labels = [("output", str(lbl)) for lbl in self.output_index.tolist()]
        df_out = pd.DataFrame(self.Y, columns=pd.MultiIndex.from_tuples(out_labels))
        df_st = pd.DataFrame({("status", ""): self.status, ("reason", ""): list(self.reasons)})
        df = pd.concat([df_in, df_st, df_out], axis=1)
        df.index.name = "sample"
        return df

    def subset(self, rows: Any) -> Evaluations:
        """The evaluations of some rows.

        Parameters
        ----------
        rows : array_like of bool or int
            A boolean mask of length n or integer positions.

        Returns
        -------
        Evaluations
            The selected rows (the counters and settings are kept).

        Examples
        --------
        >>> ev = Evaluations.from_arrays([[0.0], [1.0], [2.0]], [0.0, 1.0, 4.0])
        >>> ev.subset([True, False, True]).Y.ravel().tolist()
        [0.0, 4.0]
        """
        rows = np.asarray(rows)
        if rows.dtype == bool:
            rows = np.flatnonzero(rows)
        return Evaluations(
            self.X[rows], self.Y[rows], self.status[rows], tuple(self.reasons[i] for i in rows),
            self.input_names, self.output_index, self.cache_key, self.n_model_calls, self.n_cached,
            self.wall_time, self.settings, self.model,
        )

    def select_outputs(self, outputs: Any) -> Evaluations:
        """Keep some outputs.

        Parameters
        ----------
        outputs : sequence
            Labels of ``output_index``, a boolean mask, or integer positions.

        Returns
        -------
        Evaluations
            The same rows with the selected output columns.

        Raises
        ------
        StudyError
            If a label is unknown, a position out of range or a mask of the wrong length.

        Examples
        --------
        >>> ev = Evaluations.from_arrays([[0.0]], [[1.0, 2.0, 3.0]])
        >>> ev.select_outputs([2, 0]).Y.tolist()
        [[3.0, 1.0]]
        """
        pos = resolve_outputs(self.output_index, outputs)
        return Evaluations(
            self.X, self.Y[:, pos], self.status, self.reasons, self.input_names,
            self.output_index[pos], self.cache_key, self.n_model_calls, self.n_cached,
            self.wall_time, self.settings, self.model,
        )

    def reduce(self, reducer: Callable) -> Evaluations:
        """Apply a reducer to the outputs (e.g. :func:`mechrel.uq.peak_abs`); failed rows stay failed.

        Parameters
        ----------
        reducer : callable
            ``reducer(Y, output_index) -> (Z, new_index)`` with ``Z`` of shape (n, k) or (n,); rows
            with a non-finite reduced value become failures (``"non-finite reduced output"``).

        Returns
        -------
        Evaluations
            The reduced evaluations (the reducer's name is added to ``settings``).

        Raises
        ------
        StudyError
            If the reducer does not return one row per sample.

        Examples
        --------
        >>> ev = Evaluations.from_arrays([[0.0]], [[1.0, -3.0]])
        >>> ev.reduce(lambda Y, idx: (np.abs(Y).max(axis=1), pd.Index(["peak"]))).Y.tolist()
        [[3.0]]
        """
        Z, idx = reducer(np.array(self.Y), self.output_index)
        Z = np.asarray(Z, dtype=float)
        if Z.ndim == 1:
            Z = Z[:, None]
        if Z.shape[0] != self.n:
            raise StudyError(f"reducer: must return one row per sample ({self.n}), got {Z.shape[0]}")
        ok = self.ok & np.all(np.isfinite(Z), axis=1)
        reasons = list(self.reasons)
        for i in np.flatnonzero(self.ok & ~ok):
            reasons[i] = "non-finite reduced output"
        status = np.where(ok, STATUS_OK, STATUS_FAILED)
        return Evaluations(
            self.X, Z, status, reasons, self.input_names, idx, self.cache_key, self.n_model_calls,
            self.n_cached, self.wall_time, {**self.settings, "reducer": getattr(reducer, "__name__", repr(reducer))},
            self.model,
        )


def resolve_outputs(index: pd.Index, outputs: Any) -> np.ndarray:
    """Positions of ``outputs`` (labels, boolean mask or integer positions) in ``index``."""
    if outputs is None:
        return np.arange(len(index))
    arr = np.asarray(outputs, dtype=object)
    if arr.dtype == object and len(arr) and all(isinstance(v, (bool, np.bool_)) for v in arr.ravel()):
        mask = np.asarray(outputs, dtype=bool)
        if mask.shape != (len(index),):
            raise StudyError(f"outputs: boolean mask must have {len(index)} entries, got {mask.shape}")
        return np.flatnonzero(mask)
    if (not isinstance(index, pd.MultiIndex) and index.dtype.kind in "iu"
            and all(isinstance(v, (int, np.integer)) for v in outputs)):
        pos = index.get_indexer(list(outputs))
    elif all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in outputs):
        pos = np.asarray(list(outputs), dtype=int)
        if np.any((pos < 0) | (pos >= len(index))):
            raise StudyError(f"outputs: positions must be in [0, {len(index)}), got {list(outputs)}")
        return pos
    else:
        pos = index.get_indexer(list(outputs))
    if np.any(pos < 0):
        bad = [o for o, p in zip(outputs, pos) if p < 0][:3]
        raise StudyError(f"outputs: labels {bad} are not in the model's output_index (e.g. {index[:3].tolist()})")
    return pos


def combined_cache_key(model: Any, input_names: tuple[str, ...], n_out: int) -> str:
    """The model's cache key bound to the input order and the output count.

    Parameters
    ----------
    model : Model
        A model with a ``cache_key()`` method.
    input_names : tuple of str
        The input names, in the order of the design's columns.
    n_out : int
        The number of outputs.

    Returns
    -------
    str
        A SHA-256 hex digest: a change of the model's key, the input order or the output count
        gives another key (a cache never mixes them).

    Examples
    --------
    >>> from mechrel.uq import linear_model
    >>> m = linear_model([0.0], [[1.0, 1.0]], ["a", "b"])
    >>> combined_cache_key(m, ("a", "b"), 1) != combined_cache_key(m, ("b", "a"), 1)
    True
    """
    import hashlib

    key = str(model.cache_key())
    return hashlib.sha256(f"{key}|{'|'.join(input_names)}|{n_out}".encode()).hexdigest()


def _evaluate_chunk(model: Any, X: np.ndarray, n_out: int, chunk_id: int):
    """Worker: evaluate the rows of one chunk; per-sample failures are recorded, not raised.

    Returns ``(chunk_id, Y, ok, failed, n_rows)``: the chunk's outputs (NaN in failed rows), the
    mask of its successful rows and ``failed``, the ``(row, reason)`` pairs of its failed rows
    only (a chunk without failures carries no per-row Python objects). A model with a true
    ``vectorized`` attribute is called once for the whole chunk (:func:`_batch`), any other row
    by row (:func:`~mechrel.uq.problem.model.evaluate_rows`). On an interrupt the rows finished
    so far ride on the ``KeyboardInterrupt`` as ``.finished`` (``(n_finished, Y, ok,
    reasons)``), so that the in-process loop can cache them."""
    starting_chunk(chunk_id)
    if getattr(model, "vectorized", False) and X.shape[0]:
        Y, ok, failed = _batch(model, X, n_out)  # X: the chunk's own copy of its rows
    else:
        Y, ok, reasons = evaluate_rows(model.evaluate, X, n_out)
        failed = tuple((int(i), reasons[i]) for i in np.flatnonzero(~ok))
    return chunk_id, Y, ok, failed, X.shape[0]


def _reason(exc: MechrelError) -> str:
    """A failed sample's reason, as :func:`~mechrel.uq.problem.model.evaluate_rows` words it."""
    return getattr(exc, "reason", None) or f"{type(exc).__name__}: {exc}"


def _batch(model: Any, X: np.ndarray, n_out: int):
    """``model.evaluate_batch(X)`` as ``(Y, ok, failed)`` (see :func:`_evaluate_chunk`).

    The batch reports its own failed rows: a row with a non-finite output is a failure
    ("non-finite output"), and a :class:`~mechrel.uq.problem.model.RowFailures` gives every
    row's outputs and the failed rows' reasons, recorded as they are; the other rows are kept,
    none is evaluated again. A batch that raises another per-sample error says no more than
    that some row failed: it is split in halves, each evaluated again, until the rows that
    raise stand alone (k failing rows among m cost about 2 k log2(m / k) more calls, against m
    calls row by row), and each of those fails with the reason it raises with."""
    m = X.shape[0]
    try:
        Y = model.evaluate_batch(X)
        given = None
    except StudyError:
        raise
    except RowFailures as exc:  # the batch recorded its failing rows with their reasons
        Y, given = exc.Y, exc.failed
        if exc.n_rows != m:
            raise StudyError(f"model.evaluate_batch: RowFailures carries {exc.n_rows} "
                             f"reasons for {m} rows; allowed: one per row") from None
    except MechrelError as exc:  # some row raised: isolate it
        if m == 1:
            return np.full((1, n_out), np.nan), np.zeros(1, dtype=bool), ((0, _reason(exc)),)
        return _halves(model, X, n_out)
    Y = np.asarray(Y, dtype=float)
    if Y.shape != (m, n_out):
        raise StudyError(f"model.evaluate_batch returned shape {Y.shape} for {m} rows; "
                         f"expected ({m}, {n_out})")
    fin = np.isfinite(Y)
    if given is None and fin.all():  # the usual chunk: one reduction, no per-row work
        return Y, np.ones(m, dtype=bool), ()
    # the rows with a non-finite entry: those whose sum is not finite (a NaN or an infinity
    # makes any sum so; a product with ones, which is fast, where a reduction along rows of a
    # few outputs costs 30 ns a row), then entry by entry where a sum overflowed
    with np.errstate(over="ignore", invalid="ignore"):
        ok = np.isfinite(Y @ np.ones(n_out))
    if not ok.all():
        ok[~ok] = fin[~ok].all(axis=1)
    if given:
        ok[list(given)] = False
    bad = np.flatnonzero(~ok)
    if not bad.size:
        return Y, ok, ()
    n_bad = n_out - np.count_nonzero(fin[bad], axis=1)  # non-finite entries per failed row
    given = given or {}
    text = {k: f"non-finite output ({k} of {n_out} entries)" for k in set(n_bad.tolist())}
    failed = tuple((i, given.get(i) or text[k]) for i, k in zip(bad.tolist(), n_bad.tolist()))
    if (n_bad < n_out).any():  # a failed row with a finite entry: NaN, in a copy of our own
        Y = np.array(Y)  # (the model's array is not ours to write into)
        Y[bad] = np.nan
    return Y, ok, failed


def _halves(model: Any, X: np.ndarray, n_out: int):
    """:func:`_batch` of each half of ``X``, joined; an interrupt in the second half carries the
    first half's rows as finished (``KeyboardInterrupt.finished``)."""
    h = X.shape[0] // 2
    Y0, ok0, failed0 = _batch(model, X[:h], n_out)
    try:
        Y1, ok1, failed1 = _batch(model, X[h:], n_out)
    except KeyboardInterrupt as exc:
        k, Yk, okk, rk = getattr(exc, "finished", (0, Y0[:0], ok0[:0], []))
        reasons0 = [None] * h
        for i, r in failed0:
            reasons0[i] = r
        exc.finished = (h + k, np.concatenate([Y0, Yk]), np.concatenate([ok0, okk]),
                        reasons0 + list(rk))
        raise
    return (np.concatenate([Y0, Y1]), np.concatenate([ok0, ok1]),
            failed0 + tuple((h + i, r) for i, r in failed1))


def _check_picklable(model: Any) -> None:
    """Fail early, with a clear message, if the model cannot be shipped to workers."""
    import cloudpickle  # a dependency of ours (pyproject.toml); loky and dask use it too

    try:
        cloudpickle.dumps(model)
    except Exception as e:  # noqa: BLE001 - any pickling error means the same thing here
        raise StudyError(
            f"model: {type(model).__name__} cannot be pickled for parallel workers ({type(e).__name__}: {e}); "
            "keep open files, locks and clients out of the model, or use n_jobs=1"
        ) from None


def _consume(gen, collect) -> None:
    """Feed finished chunks to ``collect``; on an abort, cancel the rest quietly (joblib warns
    that finished-but-unread tasks are discarded: they are not cached, and are simply
    re-evaluated on resume)."""
    try:
        for res in gen:
            collect(res)
    except BaseException:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=r".*tasks have been successfully executed\s+but not used")
            gen.close()
        raise


VECTORIZED_CHUNK = 8192
"""The most rows :func:`default_chunk_size` gives a vectorised model's chunk."""


def default_chunk_size(n: int, vectorized: bool = False, cap: int | None = None) -> int:
    """About 64 chunks of the ``n`` samples, each of 1..1000 samples for a model evaluated row
    by row, of 1..:data:`VECTORIZED_CHUNK` rows for a vectorised one (one call per chunk: the
    executor's own work, tens of µs a chunk, stays a few per cent of a cheap model's), or of
    1..``cap`` (a model's ``max_chunk_rows``); depends only on the number of samples and the
    model, never on the workers."""
    if cap is None:
        cap = VECTORIZED_CHUNK if vectorized else 1000
    return int(min(cap, max(1, math.ceil(n / 64))))


def local_workers(n_jobs: int, n_tasks: int) -> int:
    """The processes of a local pool for ``n_jobs`` (-1: all cores) and ``n_tasks`` chunks: at
    most one per chunk and one per core, but two whenever more than one was asked for (so that
    the model still runs in a worker, as with two). ``--jobs 100000`` on two cores used to
    start a process per chunk (180 and more), which then shared the cores for minutes.

    Parameters
    ----------
    n_jobs : int
        The workers asked for (>= 1, or -1).
    n_tasks : int
        The chunks to evaluate.

    Returns
    -------
    int
        The pool's size (-1 left to joblib: all cores).
    """
    if n_jobs <= 1:
        return n_jobs
    return min(n_jobs, max(2, min(n_tasks, os.cpu_count() or 1)))


def _check_backend(backend: str, n_jobs: Any) -> int:
    if backend not in BACKENDS:
        raise StudyError(f"backend: got {backend!r}; allowed: {list(BACKENDS)}")
    n_jobs = ARGS.jobs("n_jobs", n_jobs)
    if backend == "dask":
        try:
            from distributed import get_client
        except ImportError:
            raise StudyError(
                "backend='dask': dask.distributed is not installed (pip install 'mechrel[dask]')"
            ) from None
        try:
            get_client()
        except ValueError:
            raise StudyError(
                "backend='dask': no Dask client is active; create one first, e.g. "
                "`from dask.distributed import Client, LocalCluster; client = Client(LocalCluster())` "
                "or `Client('tcp://scheduler:8786')`"
            ) from None
    return int(n_jobs)


def evaluate(
    model: Any,
    X: Any,
    *,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
    retry_failed: bool = False,
    callback: Callable[[int, int], None] | None = None,
) -> Evaluations:
    """Evaluate ``model`` at every row of ``X`` (n, d).

    Parameters
    ----------
    model : Model
        What to evaluate (:class:`~mechrel.uq.Model`: e.g. a :class:`~mechrel.uq.FunctionModel`
        or a :class:`~mechrel.uq.MechanismModel`).
    X : array_like, shape (n, d)
        The design, one row per sample, columns in the order of ``model.input_names``. The
        result keeps it read-only: a read-only float64 array as it is (its owner has frozen
        it, e.g. the design an estimator drew), anything else as a copy.
    n_jobs
        Parallel workers (-1: all cores / all Dask workers). ``n_jobs=1`` runs in-process. A
        local pool has at most one worker per chunk and per core (:func:`local_workers`).
    backend
        ``"loky"`` (joblib's process pool, default), ``"dask"`` (joblib's Dask backend; needs an
        active ``dask.distributed.Client``) or ``"sequential"`` (in-process loop).
    cache
        ``None``, a directory or an :class:`EvaluationCache`: cached rows are not re-evaluated and
        each finished chunk is stored immediately (resume after an interruption).
    progress
        Show a tqdm progress bar over samples.
    chunk_size
        Samples per task (default: about 64 chunks, at most 1000 samples each, or
        :data:`VECTORIZED_CHUNK` for a vectorised model, or the model's ``max_chunk_rows``;
        never depends on ``n_jobs``).
    retry_failed
        Re-evaluate rows whose cached result is a failure.
    callback
        ``callback(n_done, n_todo)`` after each stored chunk; raising from it aborts the run
        (the chunks stored so far stay cached).

    Returns
    -------
    Evaluations
        The outputs, one row per row of ``X``; a failed sample is a NaN row with its reason.

    Raises
    ------
    StudyError
        If ``X`` is not a finite (n, d) array for the model's inputs, the backend, ``n_jobs``
        or ``chunk_size`` is invalid, the model cannot be pickled for workers, or the cache
        belongs to another model (:class:`~mechrel.errors.CacheError`).

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.uq import evaluate, linear_model
    >>> ev = evaluate(linear_model([0.0], [[2.0]], ["x"]), np.array([[1.0], [2.0]]),
    ...               progress=False)
    >>> ev.Y.ravel().tolist(), ev.n_model_calls
    ([2.0, 4.0], 2)
    """
    t0 = time.perf_counter()
    input_names, output_index = check_model(model)
    n_out = len(output_index)
    # the design is kept in the result, read-only: a read-only float array (frozen by its
    # owner, e.g. the design an estimator drew) as it is, anything else as a copy of its own
    if not (isinstance(X, np.ndarray) and X.dtype == np.float64 and not X.flags.writeable):
        try:
            X = np.array(X, dtype=float)
        except (TypeError, ValueError):
            raise StudyError("X: must be a numeric (n, d) array") from None
    if X.ndim == 1 and X.shape[0] == len(input_names):
        X = X[None, :]
    if X.ndim != 2 or X.shape[1] != len(input_names):
        raise StudyError(f"X: expected shape (n, {len(input_names)}) for inputs {list(input_names)}, got {X.shape}")
    if not np.all(np.isfinite(X)):
        bad = ~np.isfinite(X)
        rows, cols = np.flatnonzero(bad.any(axis=1)), np.flatnonzero(bad.any(axis=0))
        i = int(rows[0])
        raise StudyError(
            f"X: inputs {[input_names[k] for k in cols]} are not finite in {rows.size} of "
            f"{X.shape[0]} rows (first: row {i}, {dict(zip(input_names, X[i].tolist()))}); "
            "allowed: finite inputs")
    n_jobs = _check_backend(backend, n_jobs)
    if chunk_size is not None and (isinstance(chunk_size, bool) or not isinstance(chunk_size, (int, np.integer)) or chunk_size < 1):
        raise StudyError(f"chunk_size: must be a positive integer or None, got {chunk_size!r}")
    cache = as_cache(cache)
    key = combined_cache_key(model, input_names, n_out)
    if n_jobs != 1 and backend != "sequential":
        _check_picklable(model)

    n = X.shape[0]
    vectorized = bool(getattr(model, "vectorized", False))
    Y = np.empty((n, n_out))  # every row is written: from the cache or by its chunk
    ok = np.zeros(n, dtype=bool)
    reasons: dict[int, str] = {}  # the failed rows' reasons (an ok row has none)
    done = np.zeros(n, dtype=bool)
    if cache is not None and n:
        found, Yc, okc, rc = cache.lookup(key, X, n_out)
        use = found & (okc | (not retry_failed))
        Y[use] = Yc[use]
        ok[use] = okc[use]
        for i in np.flatnonzero(use & ~okc).tolist():  # a cached success has no reason
            reasons[i] = rc[i]
        done = use
    n_cached = int(done.sum())
    n_failed = int((done & ~ok).sum())
    todo = np.flatnonzero(~done)
    cs = (int(chunk_size) if chunk_size is not None
          else default_chunk_size(len(todo), vectorized,
                                  getattr(model, "max_chunk_rows", None)))
    chunks = [todo[s : s + cs] for s in range(0, len(todo), cs)]
    # a chunk of consecutive rows (all of them when nothing is cached) is read and written as a
    # slice: a block copy instead of a gather and a scatter by index
    spans = [slice(int(r[0]), int(r[-1]) + 1) if r[-1] - r[0] + 1 == len(r) else r
             for r in chunks]

    def rows_of(cid: int) -> np.ndarray:
        """The chunk's rows of ``X``, the chunk's own copy (a model may write into it)."""
        span = spans[cid]
        return X[span].copy() if isinstance(span, slice) else X[span]

    from tqdm.auto import tqdm

    bar = tqdm(total=len(todo), disable=not progress, desc="model evaluations", unit="sample",
               postfix={"cached": n_cached} if n_cached else None)
    n_calls = 0
    n_done = 0

    def _collect(result) -> None:
        # one chunk at a time: its rows' outputs by one array assignment, its failed rows (only
        # those) by their reasons, one cache transaction, one progress update
        nonlocal n_calls, n_done, n_failed
        cid, Yk, okk, failed, ncalls = result
        rows = chunks[cid]
        Y[spans[cid]] = Yk
        ok[spans[cid]] = okk
        if failed:
            span = spans[cid]
            if isinstance(span, slice):
                reasons.update((span.start + i, r) for i, r in failed)
            else:
                reasons.update(zip(rows[[i for i, _ in failed]].tolist(), (r for _, r in failed)))
        n_calls += ncalls
        n_done += len(rows)
        if cache is not None:
            rk: list[str | None] = [None] * len(rows)
            for i, r in failed:
                rk[i] = r
            cache.store(key, X[spans[cid]], Yk, okk, rk)
        bar.update(len(rows))
        if failed:
            n_failed += len(failed)
            if progress:
                bar.set_postfix(failed=n_failed, refresh=False)
        if callback is not None:
            callback(n_done, len(todo))

    try:
        if chunks:
            if backend == "sequential" or n_jobs == 1:
                for cid, rows in enumerate(chunks):
                    try:
                        result = _evaluate_chunk(model, rows_of(cid), n_out, cid)
                    except KeyboardInterrupt as exc:  # keep the samples finished in this chunk
                        k, Yk, okk, rk = getattr(exc, "finished", (0, None, None, None))
                        if cache is not None and k:
                            cache.store(key, X[rows[:k]], Yk, okk, rk)
                        raise
                    _collect(result)
            else:
                import joblib

                tasks = (joblib.delayed(_evaluate_chunk)(model, rows_of(cid), n_out, cid)
                         for cid in range(len(chunks)))
                if backend == "dask":
                    with joblib.parallel_config(backend="dask"):
                        gen = joblib.Parallel(n_jobs=n_jobs, return_as="generator_unordered")(tasks)
                        _consume(gen, _collect)
                else:
                    from joblib.externals.loky.process_executor import TerminatedWorkerError

                    with safe_path_environment(), chunk_ledger() as ledger:
                        gen = joblib.Parallel(n_jobs=local_workers(n_jobs, len(chunks)),
                                              backend=register_backend(),
                                              return_as="generator_unordered")(tasks)
                        try:
                            _consume(gen, ledger.collecting(_collect))
                        except TerminatedWorkerError as exc:  # one line, not 40
                            raise worker_died(exc, [chunks[c] for c in ledger.running()],
                                              cache) from None
    finally:
        bar.close()

    # the arrays are this call's own: frozen in place, not copied again by Evaluations; the
    # status of a run without failures is one "ok" seen n times (a read-only view, no memory)
    if ok.all():
        status = np.broadcast_to(np.array(STATUS_OK, dtype="<U6"), (n,))
    else:
        status = np.full(n, STATUS_OK, dtype="<U6")
        status[~ok] = STATUS_FAILED
        status.setflags(write=False)
    X.setflags(write=False)
    Y.setflags(write=False)
    if reasons:
        per_row: list[str | None] = [None] * n
        for i, r in reasons.items():
            per_row[i] = r
        reasons_t = tuple(per_row)
    else:
        reasons_t = (None,) * n
    return Evaluations(
        X, Y, status, reasons_t, input_names, output_index,
        cache_key=str(model.cache_key()), n_model_calls=n_calls, n_cached=n_cached,
        wall_time=time.perf_counter() - t0,
        settings={"n_jobs": n_jobs, "backend": backend if n_jobs != 1 else "sequential",
                  "chunk_size": cs, "cache": None if cache is None else str(cache.path),
                  "retry_failed": bool(retry_failed)},
        model=describe_model(model),
    )
