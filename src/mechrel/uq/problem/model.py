"""The model protocol: the only thing the estimators know about a mechanism.

A *model* maps one input vector ``x`` (the uncertain inputs, in the order of
``input_names``) to one output vector (the signed output errors, labelled by
``output_index``). It must be

* **deterministic**: the same ``x`` gives the same bytes out (the cache, the resume and the
  "identical for any ``n_jobs`` and backend" guarantee rely on it);
* **picklable**: it is shipped to joblib/Dask workers (loky and Dask use cloudpickle, so a
  closure works there; the plain ``pickle`` used elsewhere needs module-level functions);
* **honest about failure**: a sample that cannot be evaluated (assembly fails, the integrator
  gives up, ...) raises :class:`ModelFailure` (or any other
  :class:`mechrel.errors.MechrelError`) with a reason. The executor records the reason and
  carries on. Any other exception is treated as a bug and stops the run (finished chunks stay
  in the cache).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
import pandas as pd

from mechrel.errors import MechrelError, StudyError, interrupt_of

__all__ = ["Model", "ModelFailure", "RowFailures", "FunctionModel", "evaluate_rows", "check_model",
           "describe_model", "as_output_index"]


class ModelFailure(MechrelError, RuntimeError):
    """A model could not be evaluated at one input sample.

    Raise it from ``Model.evaluate`` with a short, *stable* reason (the executor counts failures
    by their reason string, so put the sample-specific numbers at the end or leave them out).

    Parameters
    ----------
    reason : str
        Why the sample failed, e.g. ``"integrator step too small"``.

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.uq import FunctionModel, ModelFailure, evaluate
    >>> def sqrt_model(x):
    ...     if x[0] < 0:
    ...         raise ModelFailure("negative input")
    ...     return np.sqrt(x)
    >>> ev = evaluate(FunctionModel(sqrt_model, ["x"], ["y"]), np.array([[4.0], [-1.0]]),
    ...               progress=False)
    >>> float(ev.Y[0, 0]), ev.reasons
    (2.0, (None, 'negative input'))
    """

    def __init__(self, reason: str):
        self.reason = str(reason)
        super().__init__(self.reason)

    def __reduce__(self):  # picklable across process boundaries with its reason
        return (type(self), (self.reason,))


class RowFailures(ModelFailure):
    """Some rows of a batch failed: raised by a model's ``evaluate_batch`` that records its
    rows' failures itself (the executor keeps the other rows, and evaluates none again).

    Parameters
    ----------
    Y : array (m, n_out)
        Every row's outputs; the failed rows' are ignored (NaN).
    reasons : mapping of int to str, or sequence of (str or None)
        The failed rows' reasons (each stable, as ``ModelFailure.reason``): either
        ``{row: reason}`` for the failed rows only, rows counted from 0 in ``Y`` (what a large
        batch should give: no Python object per successful row), or one entry per row, None
        where the row succeeded.

    Attributes
    ----------
    failed : dict of int to str
        The failed rows' reasons, by row, in row order.
    n_rows : int
        The rows of the batch: ``len(Y)`` for the mapping, ``len(reasons)`` for the sequence.
    reasons : list of (str or None)
        One entry per row, None where the row succeeded (built on demand).

    Raises
    ------
    StudyError
        If a key of the mapping is not a row of ``Y``.

    Examples
    --------
    >>> import numpy as np
    >>> exc = RowFailures(np.array([[1.0], [np.nan]]), [None, "clearance <= 0"])
    >>> str(exc), exc.reasons
    ('1 of 2 rows failed, the first: clearance <= 0', [None, 'clearance <= 0'])
    >>> Y = np.zeros((1000, 2))
    >>> Y[[3, 7]] = np.nan
    >>> exc = RowFailures(Y, {7: "film rupture", 3: "assembly failed"})
    >>> str(exc), exc.failed
    ('2 of 1000 rows failed, the first: assembly failed', {3: 'assembly failed', 7: 'film rupture'})
    """

    def __init__(self, Y, reasons):
        self.Y = np.asarray(Y, dtype=float)
        self._given = reasons
        if isinstance(reasons, Mapping):
            m = self.Y.shape[0] if self.Y.ndim else 0
            failed = {}
            for i, r in reasons.items():
                if not (type(i) is int and 0 <= i < m) and (  # a row number: checked at once
                        isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer))
                        or not 0 <= i < m):
                    raise StudyError(f"RowFailures: {i!r} is not a row of the batch of {m} rows; "
                                     f"allowed: integers 0..{m - 1}")
                if r is not None:
                    failed[int(i)] = r if type(r) is str else str(r)
            self.failed = dict(sorted(failed.items()))
            self.n_rows = m
        else:
            self.failed = {i: r if type(r) is str else str(r)
                           for i, r in enumerate(reasons) if r is not None}
            self.n_rows = len(reasons)
        first = next(iter(self.failed.values()), None)
        super().__init__(f"{len(self.failed)} of {self.n_rows} rows failed"
                         + (f", the first: {first}" if self.failed else ""))

    @property
    def reasons(self) -> list:
        """The reasons one entry per row (built from :attr:`failed` on each access).

        Returns
        -------
        list of (str or None)
            ``n_rows`` entries: None where the row succeeded, else its reason.

        Examples
        --------
        >>> RowFailures(np.zeros((3, 1)), {1: "why"}).reasons
        [None, 'why', None]
        """
        out: list = [None] * self.n_rows
        for i, r in self.failed.items():
            out[i] = r
        return out

    def __reduce__(self):  # picklable across process boundaries with its rows, as given
        return (type(self), (self.Y, self._given))


@runtime_checkable
class Model(Protocol):
    """What every estimator evaluates (a structural protocol: nothing to inherit).

    A model has ``input_names``, ``output_index`` and ``evaluate(x)``; ``cache_key()`` and
    ``describe()`` are optional (the cache and the provenance use them when present).

    Parameters
    ----------
    *args, **kwargs
        Not used: a protocol is not instantiated; a class satisfies it by its attributes.

    Attributes
    ----------
    input_names
        One name per entry of ``x``. For the mechanism model these are dotted scene paths
        (e.g. ``"joints.C1.clearance"``); they must match the names of the
        :class:`~mechrel.uq.UncertainInputs` used with the model.
    output_index
        A :class:`pandas.Index` labelling the outputs, usually a ``MultiIndex`` with levels
        ``quantity`` (``displacement``, ``velocity``, ``acceleration``) and ``crank_angle``
        (degrees). Reliability estimators look up default allowables by the ``quantity`` level.

    Examples
    --------
    >>> from mechrel.uq import Model, linear_model
    >>> isinstance(linear_model([0.0], [[1.0]], ["x"]), Model)
    True
    """

    input_names: tuple[str, ...]
    output_index: pd.Index
    # Optional (not part of the runtime check): ``output_noise: float``, the relative noise of the
    # outputs (e.g. the integrator's rtol); FOSM's automatic finite-difference step uses it; and
    # ``describe() -> dict``, a JSON-friendly account of what the model is (for the mechanism
    # model: the scene's name, hash and source), which every result's provenance records.

    def evaluate(self, x: np.ndarray) -> np.ndarray:
        """The outputs at one input vector.

        Parameters
        ----------
        x : ndarray, shape (d,)
            The inputs, in the order of ``input_names`` (SI units).

        Returns
        -------
        ndarray, shape (n_out,)
            The outputs, in the order of ``output_index``.

        Raises
        ------
        ModelFailure
            When the model cannot be evaluated at ``x`` (the executor records the sample as failed
            with the reason).

        Examples
        --------
        >>> from mechrel.uq import linear_model
        >>> linear_model([1.0], [[2.0]], ["x"]).evaluate(np.array([3.0])).tolist()
        [7.0]
        """
        ...

    # Optional (not part of the runtime check): ``vectorized: bool`` and
    # ``evaluate_batch(X (m, d)) -> (m, n_out)``; when ``vectorized`` is true the executor calls
    # ``evaluate_batch`` once per chunk (see :class:`FunctionModel`). A batch reports its failed
    # rows itself, and the rest of the batch is kept as it is: a non-finite row (a row mask of
    # NaN) is a failure with the reason "non-finite output"; :class:`RowFailures` carries every
    # row's outputs and the failed rows' reasons ({row: reason}; see
    # :class:`mechrel.uq.problem.mechanism.MechanismModel`). A batch that loops over its rows
    # attaches the rows finished before an interrupt as ``KeyboardInterrupt.finished``;
    # :func:`evaluate_rows` does both. ``max_chunk_rows: int`` caps the executor's default
    # chunk (a model whose rows are simulations, each of milliseconds, keeps chunks of at most
    # 1000 rows: the progress and resume steps; a vectorised array expression takes up to
    # :data:`~mechrel.uq.execution.executor.VECTORIZED_CHUNK`).

    def cache_key(self) -> str:
        """A stable hash of everything that determines the outputs except ``x``.

        Returns
        -------
        str
            The key under which the evaluation cache stores the model's results.

        Examples
        --------
        >>> from mechrel.uq import linear_model
        >>> linear_model([1.0], [[2.0]], ["x"]).cache_key() == linear_model([1.0], [[2.0]], ["x"]).cache_key()
        True
        """
        ...


def as_output_index(index: Any, *, what: str = "output_index") -> pd.Index:
    """Coerce ``index`` to a pandas Index of unique output labels.

    Parameters
    ----------
    index : pandas.Index or sequence
        An Index, a MultiIndex, a sequence of labels, or a sequence of tuples (a MultiIndex).
    what : str, default "output_index"
        The field's name in the error message.

    Returns
    -------
    pandas.Index
        The labels.

    Raises
    ------
    StudyError
        If ``index`` is not a sequence, empty, or has duplicated labels.

    Examples
    --------
    >>> as_output_index([("v", 0.0), ("v", 90.0)]).nlevels
    2
    """
    if isinstance(index, pd.Index):
        out = index
    else:
        try:
            seq = list(index)
        except TypeError:
            raise StudyError(
                f"{what}: expected a pandas Index/MultiIndex or a sequence of labels, "
                f"got {type(index).__name__}"
            ) from None
        if seq and all(isinstance(s, tuple) for s in seq):
            out = pd.MultiIndex.from_tuples(seq)
        else:
            out = pd.Index(seq)
    if len(out) == 0:
        raise StudyError(f"{what}: must label at least one output, got an empty index")
    if not out.is_unique:
        dup = out[out.duplicated()].tolist()[:3]
        raise StudyError(f"{what}: labels must be unique, duplicated: {dup}")
    return out


def evaluate_rows(evaluate_one: Callable[[np.ndarray], Any], X: np.ndarray, n_out: int):
    """``evaluate_one`` at each row of ``X`` with the executor's per-sample failure capture.

    A failed row (a :class:`~mechrel.errors.MechrelError` other than ``StudyError``, or a
    non-finite output) is NaN with its reason. ``StudyError`` and any other exception (a bug)
    propagate; an interrupt carries the rows finished so far as
    ``.finished = (n_finished, Y, ok, reasons)``. A model's ``evaluate_batch`` that loops over
    its rows uses it too, so that its failures read exactly as row-by-row evaluation's (the
    executor itself runs a model without ``vectorized`` through it).

    Parameters
    ----------
    evaluate_one : callable
        ``evaluate_one(x) -> array of n_out`` for one row ``x`` (a model's ``evaluate``).
    X : ndarray, shape (m, d)
        The rows.
    n_out : int
        The number of outputs per row.

    Returns
    -------
    Y : ndarray, shape (m, n_out)
        The outputs; NaN in failed rows.
    ok : ndarray of bool, shape (m,)
        Which rows succeeded.
    reasons : list of (str or None)
        Per row: None when it succeeded, else why it failed.

    Raises
    ------
    StudyError
        ``evaluate_one`` returned the wrong number of outputs (or raised a StudyError itself).

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.uq import ModelFailure
    >>> def f(x):
    ...     if x[0] < 0:
    ...         raise ModelFailure("negative input")
    ...     return [np.sqrt(x[0])]
    >>> Y, ok, reasons = evaluate_rows(f, np.array([[4.0], [-1.0]]), 1)
    >>> Y[:, 0].tolist(), ok.tolist(), reasons
    ([2.0, nan], [True, False], [None, 'negative input'])
    """
    Y = np.full((X.shape[0], n_out), np.nan)
    ok = np.zeros(X.shape[0], dtype=bool)
    reasons: list[str | None] = [None] * X.shape[0]
    for i in range(X.shape[0]):
        try:
            y = evaluate_one(np.array(X[i]))
        except KeyboardInterrupt as exc:
            exc.finished = (i, Y[:i], ok[:i], reasons[:i])  # type: ignore[attr-defined]
            raise
        except SystemError as exc:  # an interrupt inside a numba callback (interrupt_of)
            interrupt = interrupt_of(exc)
            if interrupt is None:
                raise
            interrupt.finished = (i, Y[:i], ok[:i], reasons[:i])  # type: ignore[attr-defined]
            raise interrupt from None
        except StudyError:
            raise
        except MechrelError as e:  # ModelFailure, SimulationError, AssemblyError, SceneError
            reasons[i] = getattr(e, "reason", None) or f"{type(e).__name__}: {e}"
            continue
        y = np.asarray(y, dtype=float).reshape(-1)
        if y.shape[0] != n_out:
            raise StudyError(
                f"model.evaluate returned {y.shape[0]} outputs, model.output_index has {n_out}"
            )
        bad = ~np.isfinite(y)
        if bad.any():
            reasons[i] = f"non-finite output ({int(bad.sum())} of {n_out} entries)"
            continue
        Y[i] = y
        ok[i] = True
    return Y, ok, reasons


def check_model(model: Any) -> tuple[tuple[str, ...], pd.Index]:
    """Check that ``model`` implements the :class:`Model` protocol.

    Parameters
    ----------
    model : object
        The candidate model.

    Returns
    -------
    input_names : tuple of str
        Its input names.
    output_index : pandas.Index
        Its output labels.

    Raises
    ------
    StudyError
        If an attribute of the protocol is missing, or the names or labels are empty or
        duplicated.

    Examples
    --------
    >>> from mechrel.uq import linear_model
    >>> check_model(linear_model([0.0], [[1.0, 1.0]], ["a", "b"]))[0]
    ('a', 'b')
    """
    missing = [a for a in ("input_names", "output_index", "evaluate", "cache_key") if not hasattr(model, a)]
    if missing:
        raise StudyError(
            f"model: {type(model).__name__} does not implement the mechrel.uq.Model protocol, "
            f"missing {missing} (need input_names, output_index, evaluate(x), cache_key())"
        )
    names = tuple(str(n) for n in model.input_names)
    if len(names) == 0 or len(set(names)) != len(names):
        raise StudyError(f"model.input_names: must be non-empty and unique, got {names!r}")
    return names, as_output_index(model.output_index, what="model.output_index")


def _index_fingerprint(index: pd.Index) -> list:
    return [list(map(repr, index.names)), [repr(v) for v in index.tolist()]]


class FunctionModel:
    """A :class:`Model` wrapping a plain function ``func(x) -> array (n_out,)``.

    Parameters
    ----------
    func
        Called with one float64 vector ``x`` of length ``len(input_names)``. It may raise
        :class:`ModelFailure`. A module-level function (or a ``functools.partial`` of one) keeps
        the model picklable by the standard library; loky and Dask also accept closures.
    input_names
        Names of the entries of ``x``.
    output_index
        Labels of the outputs (any pandas Index or a sequence of labels/tuples).
    key
        A version tag you change whenever ``func`` changes meaning: the cache cannot see inside
        ``func``. The cache key hashes ``key``, the function's qualified name, the input names
        and the output labels.
    vectorized
        ``True``: ``func`` takes a batch ``X`` (m, d) and returns (m, n_out) (or (m,) for one
        output), and the executor calls it once per chunk instead of once per row (saving the
        per-call Python overhead). Failures stay per row, reported by ``func`` itself: a row with
        a non-finite output (a NaN row) is a failure with its reason, and ``func`` may raise
        :class:`RowFailures` with every row's outputs and the failed rows' reasons
        (``{row: reason}``); the other rows are kept. If the batch call raises :class:`ModelFailure` (or another per-sample
        ``MechrelError``), the executor evaluates the chunk's halves again until the rows that
        raise stand alone (docs/uq.md, "Vectorised models"). Not part of the cache key: a
        vectorised and a row-wise function computing the same numbers share cached results.

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.uq import FunctionModel
    >>> model = FunctionModel(lambda X: X[:, 0] * X[:, 1], ["a", "b"], ["ab"], vectorized=True)
    >>> model.evaluate(np.array([2.0, 3.0]))
    array([6.])
    """

    def __init__(
        self,
        func: Callable[[np.ndarray], Any],
        input_names: Sequence[str],
        output_index: Any,
        key: str = "",
        vectorized: bool = False,
    ):
        if not callable(func):
            raise StudyError(f"FunctionModel.func: must be callable, got {type(func).__name__}")
        if isinstance(input_names, str):
            raise StudyError(
                f"FunctionModel.input_names: expected a sequence of names, got the string {input_names!r}"
            )
        self.func = func
        self.input_names = tuple(str(n) for n in input_names)
        if len(self.input_names) == 0 or len(set(self.input_names)) != len(self.input_names):
            raise StudyError(
                f"FunctionModel.input_names: must be non-empty and unique, got {self.input_names!r}"
            )
        self.output_index = as_output_index(output_index, what="FunctionModel.output_index")
        self.key = str(key)
        if not isinstance(vectorized, (bool, np.bool_)):
            raise StudyError(f"FunctionModel.vectorized: got {vectorized!r}; allowed: True or False")
        self.vectorized = bool(vectorized)

    def __repr__(self) -> str:
        return (
            f"FunctionModel({_func_name(self.func)}, inputs={list(self.input_names)}, "
            f"n_out={len(self.output_index)}, key={self.key!r})"
        )

    def evaluate(self, x: np.ndarray) -> np.ndarray:
        """The outputs at one input vector.

        Parameters
        ----------
        x : array_like, shape (d,)
            The inputs, in the order of ``input_names``.

        Returns
        -------
        ndarray, shape (n_out,)
            The outputs.

        Raises
        ------
        StudyError
            If ``func`` returns another number of outputs than ``output_index`` labels.
        ModelFailure
            When ``func`` raises it.

        Examples
        --------
        >>> FunctionModel(lambda x: [x[0] + 1.0], ["x"], ["y"]).evaluate([1.0]).tolist()
        [2.0]
        """
        x = np.asarray(x, dtype=float)
        if self.vectorized:
            return self.evaluate_batch(x[None, :])[0]
        y = np.asarray(self.func(x), dtype=float).reshape(-1)
        if y.shape[0] != len(self.output_index):
            raise StudyError(
                f"FunctionModel {_func_name(self.func)}: returned {y.shape[0]} outputs, "
                f"output_index has {len(self.output_index)}"
            )
        return y

    def evaluate_batch(self, X: np.ndarray) -> np.ndarray:
        """The outputs at the rows of ``X``, in one call of a vectorised ``func`` (row by row otherwise).

        Parameters
        ----------
        X : array_like, shape (m, d)
            The input rows.

        Returns
        -------
        ndarray, shape (m, n_out)
            The outputs.

        Raises
        ------
        StudyError
            If ``func`` returns a wrong shape.
        ModelFailure
            When ``func`` raises it.

        Examples
        --------
        >>> m = FunctionModel(lambda X: X.sum(axis=1), ["a", "b"], ["s"], vectorized=True)
        >>> m.evaluate_batch(np.array([[1.0, 2.0], [3.0, 4.0]])).tolist()
        [[3.0], [7.0]]
        """
        X = np.asarray(X, dtype=float)
        n_out = len(self.output_index)
        if not self.vectorized:
            return np.stack([self.evaluate(x) for x in X]) if len(X) else np.empty((0, n_out))
        Y = np.asarray(self.func(X), dtype=float)
        if Y.ndim == 1 and n_out == 1:
            Y = Y[:, None]
        if Y.shape != (X.shape[0], n_out):
            raise StudyError(
                f"FunctionModel {_func_name(self.func)} (vectorized): returned shape {Y.shape} for "
                f"{X.shape[0]} rows; allowed: ({X.shape[0]}, {n_out})"
                + (f" or ({X.shape[0]},)" if n_out == 1 else "")
            )
        return Y

    def describe(self) -> dict:
        """A JSON-friendly description of the model, for provenance.

        Returns
        -------
        dict
            ``kind``, ``func`` (its qualified name), ``key`` and ``vectorized``.

        Examples
        --------
        >>> FunctionModel(len, ["x"], ["y"], key="v1").describe()
        {'kind': 'FunctionModel', 'func': 'builtins.len', 'key': 'v1', 'vectorized': False}
        """
        return {"kind": "FunctionModel", "func": _func_name(self.func), "key": self.key,
                "vectorized": self.vectorized}

    def cache_key(self) -> str:
        """A SHA-256 hash of the function's name, ``key``, the input names and the output labels.

        The cache cannot see inside ``func``: change ``key`` when ``func`` changes meaning.

        Returns
        -------
        str
            A hex digest.

        Examples
        --------
        >>> FunctionModel(len, ["x"], ["y"], key="v1").cache_key() != FunctionModel(
        ...     len, ["x"], ["y"], key="v2").cache_key()
        True
        """
        payload = json.dumps(
            {
                "kind": "FunctionModel",
                "func": _func_name(self.func),
                "key": self.key,
                "inputs": list(self.input_names),
                "outputs": _index_fingerprint(self.output_index),
            },
            sort_keys=True,
        )
        return hashlib.sha256(payload.encode()).hexdigest()


def describe_model(model: Any) -> dict:
    """What provenance records of ``model``.

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    dict
        Its ``describe()`` if it has one (an optional part of the protocol), else
        ``{"kind": type name}``.

    Examples
    --------
    >>> describe_model(object())
    {'kind': 'object'}
    """
    describe = getattr(model, "describe", None)
    if callable(describe):
        return dict(describe())
    return {"kind": type(model).__qualname__}


def _func_name(func: Any) -> str:
    base = getattr(func, "func", None)  # functools.partial
    if base is not None and callable(base):
        args = getattr(func, "args", ())
        kw = getattr(func, "keywords", {})
        return f"partial({_func_name(base)}, args={args!r}, kw={sorted(kw.items())!r})"
    mod = getattr(func, "__module__", "?")
    qn = getattr(func, "__qualname__", type(func).__qualname__)
    return f"{mod}.{qn}"
