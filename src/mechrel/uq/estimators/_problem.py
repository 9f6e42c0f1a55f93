"""What every rare-event estimator shares: the limit state in standard normal space, evaluated
through the executor (cache, parallel workers, resume, failures recorded per row), and the
frozen result base with provenance."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from ..._checks import ARGS
from .._common import check_inputs, make_provenance
from ..execution.executor import Evaluations, evaluate
from ..problem.inputs import UncertainInputs
from ..problem.model import check_model
from ..problem.limit_state import LimitState

FAILURE_MODES = ("exclude", "as_failure")


def refuse_evaluations(evaluations: Any, what: str) -> None:
    """The rare-event methods choose their points as they go (FORM's search, the samples
    around the design point, the subset levels): precomputed ``evaluations=`` are an error."""
    if evaluations is not None:
        raise StudyError(f"{what}: evaluations = {type(evaluations).__name__}: precomputed evaluations "
                         "cannot be used, the method chooses its points as it goes; allowed: model= and "
                         "inputs= (with cache=, a rerun evaluates nothing)")


def common_settings(*, failures: str, max_failure_fraction: float) -> None:
    ARGS.choice("failures", failures, FAILURE_MODES)
    ARGS.fraction("max_failure_fraction", max_failure_fraction)


class Problem:
    """g(u) for u in the standard normal space of (model inputs, random allowables).

    ``u`` maps to physical inputs by the Nataf transform of ``inputs``
    (:meth:`UncertainInputs.from_standard_normal`); the random allowables are independent
    standard-normal coordinates appended after the model's. Every call goes through
    :func:`mechrel.uq.evaluate` and is kept (``evaluations``) for provenance.
    """

    def __init__(self, *, model: Any, inputs: Any, limit_state: Any, n_jobs: int, backend: str,
                 cache: Any, progress: bool, chunk_size: int | None, what: str):
        if model is None:
            raise StudyError(f"{what}: model = None: required; allowed: a mechrel.uq Model (e.g. FunctionModel)")
        names, index = check_model(model)
        if inputs is None:
            raise StudyError(f"{what}: inputs = None: required; allowed: an UncertainInputs")
        inputs = check_inputs(inputs, names)
        if limit_state is None:
            limit_state = LimitState.margin()
        if not isinstance(limit_state, LimitState):
            raise StudyError(f"{what}: limit_state = {limit_state!r}: not a LimitState; allowed: "
                             "LimitState.margin/exceedance/from_function/series/parallel")
        self.what = what
        self.model = model
        self.model_inputs = inputs
        self.limit_state = limit_state
        self.bound = limit_state.bind(index)
        extra = limit_state.random_allowables
        self.d_model = len(names)
        self.n_out = len(index)
        if extra:
            corr = None
            if inputs.correlation is not None:
                corr = np.eye(len(names) + len(extra))
                corr[: len(names), : len(names)] = inputs.correlation
            self.inputs = UncertainInputs(names + tuple(extra), inputs.marginals + tuple(extra.values()), corr)
        else:
            self.inputs = inputs
        self.executor = {"n_jobs": n_jobs, "backend": backend, "cache": cache, "progress": progress,
                         "chunk_size": chunk_size}
        self.evaluations: list[Evaluations] = []
        self._memo: dict = {}
        self.t0 = time.perf_counter()

    @property
    def d(self) -> int:
        return self.inputs.d

    @property
    def names(self) -> tuple[str, ...]:
        return self.inputs.names

    def to_x(self, U: np.ndarray) -> np.ndarray:
        return self.inputs.from_standard_normal(np.atleast_2d(np.asarray(U, dtype=float)))

    def g(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple]:
        """(g (n,), ok (n,), reasons) at the rows of U (n, d); failed rows have g = NaN."""
        return self.g_at_x(self.to_x(np.atleast_2d(np.asarray(U, dtype=float))))

    def g_at_x(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple]:
        """As :meth:`g`, at physical points X (n, d): the model's inputs, then the random
        allowables."""
        ev = evaluate(self.model, X[:, : self.d_model], **self.executor)
        self.evaluations.append(ev)
        A = X[:, self.d_model:] if X.shape[1] > self.d_model else None
        G = np.full(X.shape[0], np.nan)
        ok = ev.ok.copy()
        reasons = list(ev.reasons)
        if ok.any():
            G[ok] = self.bound(ev.Y[ok], None if A is None else A[ok])
        bad = ok & ~np.isfinite(G)
        for i in np.flatnonzero(bad):
            reasons[i] = "non-finite limit-state value"
        ok &= ~bad
        G[~ok] = np.nan
        return G, ok, tuple(reasons)

    def members(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple, np.ndarray, np.ndarray | None]:
        """The members' margins (:attr:`BoundLimitState.members`) at the rows of U (n, d).

        Returns ``(Gm (n, n_members), ok (n,), reasons, Y (n, n_out), A)``: failed rows have
        NaN margins; ``Y`` the model outputs and ``A`` the random allowables (or None). The
        system margin is ``self.bound.system_from_members(Gm)``, bitwise :meth:`g`'s. A point
        this problem evaluated before is taken from its memory, not evaluated again (FORM's
        searches meet their own stencils and line-search points again).
        """
        U = np.atleast_2d(np.asarray(U, dtype=float))
        memo = self._memo
        keys = [u.tobytes() for u in U]
        new = [i for i, k in enumerate(keys) if k not in memo]
        # a point evaluated before in this run (the searches' stencils and line searches meet
        # again) is not sent to the executor again
        new = [i for j, i in enumerate(new) if keys[i] not in {keys[n] for n in new[:j]}]
        if new:
            X = self.to_x(U[new])
            ev = evaluate(self.model, X[:, : self.d_model], **self.executor)
            self.evaluations.append(ev)
            A = X[:, self.d_model:] if X.shape[1] > self.d_model else None
            Gm = np.full((X.shape[0], self.n_members), np.nan)
            ok = ev.ok.copy()
            reasons = list(ev.reasons)
            if ok.any():
                Gm[ok] = self.bound.member_values(ev.Y[ok], None if A is None else A[ok])
            bad = ok & ~np.all(np.isfinite(Gm), axis=1)
            for i in np.flatnonzero(bad):
                reasons[i] = "non-finite limit-state value"
            ok &= ~bad
            Gm[~ok] = np.nan
            for j, i in enumerate(new):
                memo[keys[i]] = (Gm[j], bool(ok[j]), reasons[j], ev.Y[j], None if A is None else A[j])
        rows = [memo[k] for k in keys]
        Gm = np.array([r[0] for r in rows])
        ok = np.array([r[1] for r in rows], dtype=bool)
        Y = np.array([r[3] for r in rows])
        A = None if rows[0][4] is None else np.array([r[4] for r in rows])
        return Gm, ok, tuple(r[2] for r in rows), Y, A

    @property
    def n_members(self) -> int:
        """The number of members (elementary failure modes) of the limit state."""
        if not hasattr(self, "_n_members"):
            self._n_members = len(self.bound.members)
        return self._n_members

    @property
    def n_evaluations(self) -> int:
        return int(sum(e.n for e in self.evaluations))

    def all_evaluations(self) -> Evaluations | None:
        """The rows of every executor call, concatenated in call order."""
        return concat_evaluations(self.evaluations)

    def provenance(self, *, method: str, seed: Any, settings: dict, extra_evaluations=()) -> dict:
        evs = list(extra_evaluations) + self.evaluations
        prov = make_provenance(method=method, seed=seed, evaluations=evs, settings=settings,
                               wall_time=time.perf_counter() - self.t0, inputs=self.inputs)
        prov["limit_state"] = self.limit_state.describe()
        return prov


def concat_evaluations(evs: list) -> Evaluations | None:
    """Several :class:`Evaluations` of one model as one, rows in order (None for none)."""
    evs = [e for e in evs if e is not None]
    if not evs:
        return None
    if len(evs) == 1:
        return evs[0]
    e0 = evs[-1]
    return Evaluations(
        np.concatenate([e.X for e in evs]), np.concatenate([e.Y for e in evs]),
        np.concatenate([e.status for e in evs]), tuple(r for e in evs for r in e.reasons),
        e0.input_names, e0.output_index, e0.cache_key, sum(e.n_model_calls for e in evs),
        sum(e.n_cached for e in evs), sum(e.wall_time for e in evs), e0.settings, e0.model,
    )


class RareEventResult:
    """Common part of every rare-event result (mixed into each frozen result dataclass).

    ``table``: one row (index: the limit state's name) with at least ``pf``, ``beta``
    (generalised index −Φ⁻¹(pf)) and ``n_evaluations``; ``.to_frame()`` returns a copy.
    """

    table: pd.DataFrame

    def to_frame(self) -> pd.DataFrame:
        return self.table.copy()

    @property
    def pf(self) -> float:
        """Probability of failure P(g ≤ 0)."""
        return float(self.table["pf"].iloc[0])

    @property
    def beta(self) -> float:
        """Reliability index: −Φ⁻¹(pf) (FORM: the signed distance of the design point)."""
        return float(self.table["beta"].iloc[0])

    @property
    def n_evaluations(self) -> int:
        """Model evaluations this result used (rows sent to the executor, cache hits included)."""
        return int(self.table["n_evaluations"].iloc[0])
