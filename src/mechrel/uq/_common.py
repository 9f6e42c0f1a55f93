"""Shared helpers: provenance records, argument checks, model/inputs/evaluations plumbing."""

from __future__ import annotations

import datetime as _dt
import functools
import platform
from importlib.metadata import PackageNotFoundError, version
from typing import Any

import numpy as np
import pandas as pd

from mechrel._machine import physical_memory
from mechrel.errors import StudyError

from .execution.executor import EvaluationCount, Evaluations, evaluate
from .problem.inputs import UncertainInputs
from .problem.model import check_model

_PACKAGES = ("mechrel", "numpy", "scipy", "pandas", "chaospy", "numpoly", "SALib", "joblib")


class SampleFailuresError(StudyError):
    """An estimator refused to analyse because of failed samples.

    Raised when more than ``max_failure_fraction`` of the samples (or, for Sobol' indices, of
    the Saltelli blocks) failed, or when too few successful samples are left to estimate
    anything. Dropping many failed samples biases the estimate when failures depend on the
    inputs, so the refusal is deliberate; the samples are not lost: ``evaluations`` holds every
    one of them, with the reasons of the failed ones (``evaluations.failures()``).

    Parameters
    ----------
    message : str
        What was refused and why.
    evaluations : Evaluations
        The evaluations the estimator refused to analyse.

    Examples
    --------
    >>> import numpy as np
    >>> from mechrel.uq import Normal, SampleFailuresError, UncertainInputs, evaluate, monte_carlo
    >>> from mechrel.uq import FunctionModel
    >>> model = FunctionModel(lambda X: np.log(X[:, 0]), ["x"], ["y"], vectorized=True)
    >>> ev = evaluate(model, np.array([[1.0], [-1.0], [-2.0]]), progress=False)
    >>> try:
    ...     monte_carlo(evaluations=ev, allowable={"y": (1.0, 0.0)})
    ... except SampleFailuresError as exc:
    ...     print(exc.evaluations.n_failed, "of", exc.evaluations.n)
    2 of 3
    """

    def __init__(self, message: str, evaluations: Evaluations):
        super().__init__(message)
        self.evaluations = evaluations


def package_versions() -> dict[str, str]:
    """The versions of Python and of the packages a result depends on (a new dict)."""
    return dict(_package_versions())


@functools.cache
def _package_versions() -> dict[str, str]:
    # read once per process: the package metadata lookups cost ~40 ms per result
    out = {"python": platform.python_version()}
    for p in _PACKAGES:
        try:
            out[p] = version(p)
        except PackageNotFoundError:  # pragma: no cover
            out[p] = "not installed"
    return out


def make_provenance(
    *,
    method: str,
    seed: Any,
    evaluations: list[Evaluations],
    settings: dict,
    wall_time: float,
    inputs: UncertainInputs | None = None,
) -> dict:
    """The provenance dict every estimator result carries."""
    evs = [e for e in evaluations if e is not None]
    keys = sorted({e.cache_key for e in evs if e.cache_key is not None})
    models = []
    for e in evs:  # the distinct model descriptions, in order
        if e.model and e.model not in models:
            models.append(e.model)
    return {
        "method": method,
        "seed": seed,
        # the count of model evaluations under the names every file uses (EvaluationCount)
        **sum((e.count for e in evs), EvaluationCount()).as_dict(),
        "wall_time": float(wall_time),
        "model_cache_key": keys[0] if len(keys) == 1 else (keys or None),
        "model": models[0] if len(models) == 1 else (models or None),
        "inputs": None if inputs is None else inputs.describe(),
        "settings": dict(settings),
        "executor": evs[0].settings if evs else None,
        "versions": package_versions(),
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }


def check_inputs(inputs: Any, input_names: tuple[str, ...] | None) -> UncertainInputs:
    if not isinstance(inputs, UncertainInputs):
        raise StudyError(
            f"inputs: expected an UncertainInputs (UncertainInputs.from_specs(...)), got {type(inputs).__name__}"
        )
    if input_names is not None:
        return inputs.reordered(input_names)
    return inputs


def exclusive_source(model: Any, evaluations: Any, *, what: str) -> None:
    if (model is None) == (evaluations is None):
        raise StudyError(
            f"{what}: pass exactly one of model= (evaluated here) or evaluations= (precomputed), "
            f"got {'both' if model is not None else 'neither'}"
        )
    if model is not None:
        check_model(model)
    if evaluations is not None and not isinstance(evaluations, Evaluations):
        raise StudyError(
            f"{what}: evaluations= must be an Evaluations (from mechrel.uq.evaluate or "
            f"Evaluations.from_arrays), got {type(evaluations).__name__}"
        )


# A run holds its design and its outputs about this many times over (the executor's arrays,
# the read-only copies in Evaluations, an estimator's working copy).
MEMORY_COPIES = 3


def check_memory(n_rows: int, n_cols: int, what: str, value: Any) -> None:
    """Refuse, before anything is evaluated, a run whose design and outputs (``n_rows`` rows of
    ``n_cols`` float64, held :data:`MEMORY_COPIES` times) need more than the machine's physical
    memory; ``what = value`` is the argument that sets ``n_rows``."""
    row_bytes = MEMORY_COPIES * 8 * max(int(n_cols), 1)
    need, have = row_bytes * int(n_rows), physical_memory()
    if have is not None and need > have:  # (None: the OS does not say)
        rows_per_unit = int(n_rows) / int(value)  # e.g. d + 2 model runs per Saltelli sample
        raise StudyError(
            f"{what} = {value!r}: {int(n_rows):.3g} model runs of {n_cols} inputs and outputs "
            f"each need about {need / 2**30:.3g} GiB of memory, more than this machine's "
            f"{have / 2**30:.3g} GiB; allowed: {what} up to about "
            f"{have / row_bytes / rows_per_unit:.3g}")


def run(model: Any, X: np.ndarray, executor: dict) -> Evaluations:
    return evaluate(model, X, **executor)


def executor_kwargs(n_jobs, backend, cache, progress, chunk_size) -> dict:
    return {"n_jobs": n_jobs, "backend": backend, "cache": cache, "progress": progress, "chunk_size": chunk_size}


def failure_message(ev: Evaluations, *, limit: int = 5) -> str:
    counts = ev.failure_counts()
    top = "; ".join(f"{c}× {r}" for r, c in list(counts.items())[:limit])
    return f"{ev.n_failed} of {ev.n} samples failed ({top})"


def readonly(a: Any) -> np.ndarray:
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


def resolve_outputs_safe(index, output: Any) -> int:
    """Position of one output given by label (tuple for a MultiIndex) or integer position."""
    try:
        if output in index:
            loc = index.get_loc(output)
            if isinstance(loc, (int, np.integer)):
                return int(loc)
    except (TypeError, KeyError):
        pass
    if isinstance(output, (int, np.integer)) and not isinstance(output, bool) and 0 <= output < len(index):
        return int(output)
    raise StudyError(f"output: {output!r} is neither a label of the output index (e.g. {index[:2].tolist()}) "
                     f"nor a position in [0, {len(index)})")


def emit_warnings(messages, stacklevel: int = 3) -> tuple[str, ...]:
    """Issue each message as an :class:`~mechrel.errors.EstimateWarning` and return them as
    the tuple a result carries in its ``warnings`` field."""
    import warnings

    from mechrel.errors import EstimateWarning

    out = tuple(str(m) for m in messages)
    for m in out:
        warnings.warn(m, EstimateWarning, stacklevel=stacklevel)
    return out


def _labels(index, mask, limit: int = 3) -> str:
    """The first ``limit`` labels of ``index`` where ``mask`` holds, for messages."""
    picked = [index[i] for i in np.flatnonzero(mask)[:limit]]
    text = ", ".join(
        "(" + ", ".join(f"{v:g}°" if isinstance(v, float) else str(v) for v in p) + ")"
        if isinstance(p, tuple) else str(p) for p in picked)
    return text + (", ..." if int(np.sum(mask)) > limit else "")


def quantity_scale(index, Y: np.ndarray) -> np.ndarray:
    """Per output, the largest |value| among the outputs of its quantity (the first level of a
    MultiIndex; all outputs otherwise) over the rows of ``Y``: the scale against which a value
    counts as zero."""
    a = np.max(np.abs(Y), axis=0) if Y.size else np.zeros(len(index))
    if getattr(index, "nlevels", 1) > 1:
        groups = index.get_level_values(0)
        out = np.empty_like(a)
        for g in pd.unique(groups):
            m = np.asarray(groups == g)
            out[m] = a[m].max()
        return out
    return np.full_like(a, a.max() if a.size else 0.0)


class CountedByProvenance:
    """Base of the result classes whose model evaluations are counted in their provenance.

    Examples
    --------
    >>> from mechrel.uq import FOSMResult, MonteCarloResult
    >>> issubclass(FOSMResult, CountedByProvenance), issubclass(MonteCarloResult, CountedByProvenance)
    (True, True)
    """

    __slots__ = ()

    @property
    def n_evaluations(self) -> int:
        """The model evaluations behind the estimate.

        Rows sent to the executor, cache hits included (``provenance["n_evaluations"]``).

        Returns
        -------
        int
            The number of evaluations (for FOSM 2d + 1, for Monte Carlo ``n``, ...).

        Examples
        --------
        >>> class R(CountedByProvenance):
        ...     provenance = {"n_evaluations": 7}
        >>> R().n_evaluations
        7
        """
        return int(self.provenance["n_evaluations"])  # type: ignore[attr-defined]
