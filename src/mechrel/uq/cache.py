"""Persistent cache of finished model evaluations (sqlite3, standard library).

One row per (model key, exact bytes of x). The model key is ``model.cache_key()`` combined with
the input names and the number of outputs, so a changed scene, model version or output grid
never reuses old rows. ``x`` is stored as its float64 little-endian bytes: a sample is a cache
hit only if it is bit-for-bit the same vector (samples regenerated from the same seed are).

Failed samples are cached too, with their reason: a model is deterministic, so re-running a
failed sample gives the same failure. If you changed something that is *not* in the cache key
(e.g. fixed a bug in the simulator without bumping its version), either pass
``retry_failed=True`` to :func:`mechrel.uq.evaluate` (cached failures are evaluated again and
overwritten) or call :meth:`EvaluationCache.forget_failures`.

Concurrency: the executor writes from the parent process only, one transaction per finished
chunk (so an interrupted run loses at most the chunks in flight). sqlite's own locking makes one
writer plus any number of readers safe; two concurrent runs writing the same cache file are
serialised by sqlite but not coordinated (they may both evaluate the same sample; the later write
wins with identical content).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import sqlite3
import time
from pathlib import Path
from typing import Any

import numpy as np

from mechrel.errors import StudyError

__all__ = ["EvaluationCache", "as_cache"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS evaluations (
    model_key TEXT NOT NULL,
    x_hash    TEXT NOT NULL,
    x         BLOB NOT NULL,
    ok        INTEGER NOT NULL,
    y         BLOB,
    reason    TEXT,
    created   REAL NOT NULL,
    PRIMARY KEY (model_key, x_hash)
);
"""


def _x_bytes(x: np.ndarray) -> bytes:
    return np.ascontiguousarray(x, dtype="<f8").tobytes()


def _x_hash(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()


class EvaluationCache:
    """A directory holding ``evaluations.sqlite`` — or, when the path ends in ``.sqlite``,
    ``.sqlite3`` or ``.db`` and is not an existing directory, that database file itself.

    Use it through ``evaluate(..., cache=EvaluationCache(path))`` or ``cache=path``.
    """

    FILENAME = "evaluations.sqlite"
    SUFFIXES = (".sqlite", ".sqlite3", ".db")

    def __init__(self, directory: str | os.PathLike):
        given = Path(directory)
        if given.suffix in self.SUFFIXES and not given.is_dir():
            self.directory, self.path = given.parent, given
        else:
            self.directory, self.path = given, given / self.FILENAME
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise StudyError(f"cache: cannot create directory {str(self.directory)!r}: {e}") from None
        with self._connect() as con:
            con.executescript(_SCHEMA)

    def __repr__(self) -> str:
        return f"EvaluationCache({str(self.path)!r})"

    def __reduce__(self):
        return (type(self), (str(self.path if self.path.name != self.FILENAME else self.directory),))

    @contextlib.contextmanager
    def _connect(self):
        """A connection that commits on success, rolls back on error, and is always closed."""
        con = sqlite3.connect(self.path, timeout=60.0)
        try:
            with con:
                yield con
        finally:
            con.close()

    # ------------------------------------------------------------------ reading
    def lookup(self, model_key: str, X: np.ndarray, n_out: int):
        """Return (found, Y, ok, reasons) for the rows of X (found: bool mask)."""
        X = np.asarray(X, dtype=float)
        n = X.shape[0]
        found = np.zeros(n, dtype=bool)
        ok = np.zeros(n, dtype=bool)
        Y = np.full((n, n_out), np.nan)
        reasons: list[str | None] = [None] * n
        hashes = [_x_hash(_x_bytes(x)) for x in X]
        pos: dict[str, list[int]] = {}
        for i, h in enumerate(hashes):
            pos.setdefault(h, []).append(i)
        with self._connect() as con:
            uniq = list(pos)
            for start in range(0, len(uniq), 500):
                part = uniq[start : start + 500]
                q = (
                    "SELECT x_hash, x, ok, y, reason FROM evaluations WHERE model_key = ? AND x_hash IN ("
                    + ",".join("?" * len(part))
                    + ")"
                )
                for h, xb, okv, yb, reason in con.execute(q, [model_key, *part]):
                    for i in pos[h]:
                        if xb != _x_bytes(X[i]):  # pragma: no cover - sha256 collision
                            continue
                        found[i] = True
                        ok[i] = bool(okv)
                        if okv:
                            y = np.frombuffer(yb, dtype="<f8")
                            if y.shape[0] != n_out:
                                found[i] = False  # stale layout; re-evaluate
                                continue
                            Y[i] = y
                        else:
                            reasons[i] = reason
        return found, Y, ok, reasons

    # ------------------------------------------------------------------ writing
    def store(self, model_key: str, X: np.ndarray, Y: np.ndarray, ok: np.ndarray, reasons) -> None:
        """Insert or replace rows (one transaction)."""
        now = time.time()
        rows = []
        for x, y, o, r in zip(np.asarray(X, dtype=float), np.asarray(Y, dtype=float), ok, reasons):
            xb = _x_bytes(x)
            rows.append(
                (model_key, _x_hash(xb), xb, int(bool(o)),
                 np.ascontiguousarray(y, dtype="<f8").tobytes() if o else None,
                 None if o else str(r), now)
            )
        with self._connect() as con:
            con.executemany(
                "INSERT OR REPLACE INTO evaluations (model_key, x_hash, x, ok, y, reason, created) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                rows,
            )

    def forget_failures(self, model_key: str | None = None) -> int:
        """Delete cached failures (of one model key, or all); return how many were deleted."""
        with self._connect() as con:
            if model_key is None:
                cur = con.execute("DELETE FROM evaluations WHERE ok = 0")
            else:
                cur = con.execute("DELETE FROM evaluations WHERE ok = 0 AND model_key = ?", (model_key,))
            return cur.rowcount

    def clear(self, model_key: str | None = None) -> int:
        """Delete all cached rows (of one model key, or all)."""
        with self._connect() as con:
            if model_key is None:
                cur = con.execute("DELETE FROM evaluations")
            else:
                cur = con.execute("DELETE FROM evaluations WHERE model_key = ?", (model_key,))
            return cur.rowcount

    def stats(self) -> dict[str, Any]:
        """Counts per model key: {key: {"ok": n, "failed": m}}."""
        out: dict[str, Any] = {}
        with self._connect() as con:
            for key, okv, cnt in con.execute(
                "SELECT model_key, ok, COUNT(*) FROM evaluations GROUP BY model_key, ok"
            ):
                out.setdefault(key, {"ok": 0, "failed": 0})["ok" if okv else "failed"] = cnt
        return out


def as_cache(cache: Any) -> EvaluationCache | None:
    """None / EvaluationCache / path → EvaluationCache or None."""
    if cache is None or isinstance(cache, EvaluationCache):
        return cache
    if isinstance(cache, (str, os.PathLike)):
        return EvaluationCache(cache)
    raise StudyError(
        f"cache: expected None, a directory path or an EvaluationCache, got {type(cache).__name__}"
    )
