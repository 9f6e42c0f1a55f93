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

Integrity: every row carries a SHA-256 checksum of its content (model key, ``x``, status,
outputs, reason). A row whose checksum does not match — changed outside mechrel, written by a
mechrel version without checksums, or with outputs of the wrong length or non-finite outputs
marked ok — is never used: it is evaluated again and overwritten, and a
:class:`~mechrel.errors.MechrelWarning` says how many rows were set aside. A file that is not a
sqlite database, is damaged (``PRAGMA quick_check``), or holds tables of another layout is
refused with a :class:`~mechrel.errors.CacheError` naming the file and what to do (delete it,
or run without the cache); so is a cache that cannot be written (read-only, full disk) — the
rows stored before stay.

Concurrency: the executor writes from the parent process only, one transaction per finished
chunk (so an interrupted run loses at most the chunks in flight). sqlite's own locking makes one
writer plus any number of readers safe; two concurrent runs writing the same cache file are
serialised by sqlite but not coordinated (they may both evaluate the same sample; the later write
wins with identical content). ``mechrel reliability`` and ``mechrel sensitivity`` lock their
output folder (and so its cache) for the whole run.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import sqlite3
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from mechrel.errors import CacheError, MechrelWarning, StudyError

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
    checksum  TEXT,
    PRIMARY KEY (model_key, x_hash)
);
"""
_COLUMNS = ("model_key", "x_hash", "x", "ok", "y", "reason", "created", "checksum")
# The layout before row checksums: opened, given the column, its rows never used (no checksum).
_COLUMNS_V1 = _COLUMNS[:-1]
SCHEMA_VERSION = 2  # PRAGMA user_version of a cache with row checksums
_WHAT_TO_DO = ("delete the file (its finished evaluations are then run again) or run without "
               "the cache (--no-cache; cache=None in Python)")


def _x_bytes(x: np.ndarray) -> bytes:
    return np.ascontiguousarray(x, dtype="<f8").tobytes()


def _x_hash(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()


def _checksum(model_key: str, x_hash: str, ok: int, yb: bytes | None, reason: str | None) -> str:
    """SHA-256 of a row's content (what a lookup returns), fields length-prefixed so that no
    two different rows share the text that is hashed."""
    h = hashlib.sha256()
    for part in (model_key.encode(), x_hash.encode(), b"1" if ok else b"0",
                 b"\x00" if yb is None else b"\x01" + yb,
                 b"\x00" if reason is None else b"\x01" + reason.encode("utf-8", "surrogatepass")):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


class EvaluationCache:
    """The SQLite store of finished model evaluations, keyed by the model's cache key and the input
    row.

    Use it through ``evaluate(..., cache=EvaluationCache(path))`` or ``cache=path``: cached rows
    are not evaluated again, and each finished chunk is stored at once (an interrupted run
    resumes).

    Parameters
    ----------
    directory : str or path-like
        A directory holding ``evaluations.sqlite`` — or, when the path ends in ``.sqlite``,
        ``.sqlite3`` or ``.db`` and is not an existing directory, that database file itself.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from mechrel.uq import EvaluationCache, evaluate, linear_model
    >>> model = linear_model([0.0], [[2.0]], ["x"])
    >>> with tempfile.TemporaryDirectory() as d:
    ...     first = evaluate(model, np.array([[1.0], [2.0]]), cache=EvaluationCache(d), progress=False)
    ...     again = evaluate(model, np.array([[1.0], [2.0]]), cache=EvaluationCache(d), progress=False)
    >>> first.n_model_calls, again.n_model_calls, again.n_cached
    (2, 0, 2)
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
            raise CacheError(f"cache: {str(self.directory)!r}: cannot create the folder "
                             f"({e.strerror or e}); allowed: a folder that can be created, or "
                             "no cache (--no-cache; cache=None in Python)") from None
        if self.path.is_dir():
            raise CacheError(f"cache: {str(self.path)!r} is a folder; allowed: a cache file "
                             f"(or a folder without one) — {_WHAT_TO_DO}")
        self._open()

    @contextlib.contextmanager
    def _guard(self):
        """Sqlite and OS errors as a :class:`CacheError` naming the file."""
        try:
            yield
        except (sqlite3.DatabaseError, OSError) as exc:
            self._fail("cannot be used", exc)

    def _fail(self, problem: str, exc: BaseException | None = None, todo: str = _WHAT_TO_DO):
        why = f" ({type(exc).__name__}: {exc})" if exc is not None else ""
        # one line: sqlite's reports (quick_check's, for one) span several
        text = " ".join(f"{problem}{why}".split())
        raise CacheError(f"cache: {str(self.path)!r}: {text}; allowed: {todo}") from None

    def _open(self) -> None:
        """Check the file (a sqlite database that passes ``quick_check``, holding only a table
        of this layout, or of the layout before checksums, which gains the column), create the
        table if missing, and prove that it can be written (a write of ``user_version``)."""
        try:
            with self._connect() as con:
                check = con.execute("PRAGMA quick_check").fetchall()
                if check != [("ok",)]:
                    # its report: a line per problem (hundreds, for a page), under a header
                    found = [line.strip() for row in check for line in str(row[0]).splitlines()
                             if line.strip() and not line.startswith("***")]
                    more = f", and {len(found) - 1} more" if len(found) > 1 else ""
                    self._fail(f"the file is damaged (sqlite quick_check: "
                               f"{found[0] if found else 'not ok'}{more})")
                tables = {r[0] for r in con.execute(
                    "SELECT name FROM sqlite_master WHERE type = 'table'")}
                if tables - {"evaluations"}:
                    self._fail(f"not a mechrel cache (tables {sorted(tables)})")
                if tables:
                    cols = tuple(r[1] for r in con.execute("PRAGMA table_info(evaluations)"))
                    if cols == _COLUMNS_V1:
                        con.execute("ALTER TABLE evaluations ADD COLUMN checksum TEXT")
                    elif cols != _COLUMNS:
                        self._fail(f"not a mechrel cache of this version (table evaluations "
                                   f"has columns {list(cols)}, expected {list(_COLUMNS)})")
                con.executescript("BEGIN;" + _SCHEMA + f"PRAGMA user_version = {SCHEMA_VERSION};"
                                  "COMMIT;")
        except sqlite3.DatabaseError as exc:
            if isinstance(exc, sqlite3.OperationalError) and _is_write_error(exc):
                self._fail("cannot be written", exc, _WRITE_TODO)
            self._fail("not a readable mechrel cache", exc)
        except OSError as exc:
            self._fail("cannot be opened", exc, _WRITE_TODO)

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
        """Look up the rows of ``X`` for one model key.

        Parameters
        ----------
        model_key : str
            The combined cache key (:func:`~mechrel.uq.execution.executor.combined_cache_key`).
        X : ndarray, shape (n, d)
            The input rows.
        n_out : int
            The number of outputs a cached ok row must hold.

        Returns
        -------
        found : ndarray of bool, shape (n,)
            Which rows are cached (a corrupted row counts as not cached).
        Y : ndarray, shape (n, n_out)
            Their outputs (NaN where not found or failed).
        ok : ndarray of bool, shape (n,)
            Which found rows were successful.
        reasons : list
            Per row, the cached failure's reason or None.

        Raises
        ------
        CacheError
            If the database cannot be read.

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     c = EvaluationCache(d)
        ...     c.store("k", np.array([[1.0]]), np.array([[2.0]]), np.array([True]), [None])
        ...     found, Y, ok, reasons = c.lookup("k", np.array([[1.0], [5.0]]), 1)
        >>> found.tolist(), Y[0].tolist()
        ([True, False], [2.0])
        """
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
        rejected = 0
        try:
            with self._connect() as con:
                uniq = list(pos)
                for start in range(0, len(uniq), 500):
                    part = uniq[start : start + 500]
                    q = ("SELECT x_hash, x, ok, y, reason, checksum FROM evaluations "
                         "WHERE model_key = ? AND x_hash IN (" + ",".join("?" * len(part)) + ")")
                    for h, xb, okv, yb, reason, cs in con.execute(q, [model_key, *part]):
                        if not self._row_valid(model_key, h, xb, okv, yb, reason, cs, n_out):
                            rejected += len(pos.get(h, ()))
                            continue
                        for i in pos[h]:
                            if xb != _x_bytes(X[i]):  # pragma: no cover - sha256 collision
                                continue
                            found[i] = True
                            ok[i] = bool(okv)
                            if okv:
                                Y[i] = np.frombuffer(yb, dtype="<f8")
                            else:
                                reasons[i] = reason
        except sqlite3.DatabaseError as exc:
            self._fail("cannot be read", exc)
        if rejected:
            warnings.warn(MechrelWarning(
                f"cache: {str(self.path)!r}: {rejected} cached row(s) fail their checksum or "
                "layout check (changed outside mechrel, or written without checksums): not "
                "used, evaluated again and overwritten"), stacklevel=2)
        return found, Y, ok, reasons

    @staticmethod
    def _row_valid(model_key, h, xb, okv, yb, reason, cs, n_out) -> bool:
        """A row may be used: its checksum matches its content, its ``x`` hashes to its key,
        and an ok row holds ``n_out`` finite outputs (a failed row: a reason, no outputs)."""
        if not isinstance(cs, str) or not isinstance(xb, bytes) or okv not in (0, 1):
            return False
        if yb is not None and not isinstance(yb, bytes) or reason is not None and not isinstance(reason, str):
            return False
        if cs != _checksum(model_key, h, okv, yb, reason) or _x_hash(xb) != h:
            return False
        if okv:
            if yb is None or len(yb) != 8 * n_out:
                return False
            return bool(np.all(np.isfinite(np.frombuffer(yb, dtype="<f8"))))
        return yb is None and reason is not None

    # ------------------------------------------------------------------ writing
    def store(self, model_key: str, X: np.ndarray, Y: np.ndarray, ok: np.ndarray, reasons) -> None:
        """Insert or replace rows, in one transaction.

        Parameters
        ----------
        model_key : str
            The combined cache key.
        X : ndarray, shape (n, d)
            The input rows.
        Y : ndarray, shape (n, n_out)
            Their outputs.
        ok : ndarray of bool, shape (n,)
            Which rows were successful.
        reasons : sequence
            Per row, the failure's reason or None.

        Raises
        ------
        CacheError
            If the database cannot be written (read-only, disk full).

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     c = EvaluationCache(d)
        ...     c.store("k", np.array([[1.0], [2.0]]), np.array([[2.0], [np.nan]]),
        ...             np.array([True, False]), [None, "diverged"])
        ...     c.stats()
        {'k': {'ok': 1, 'failed': 1}}
        """
        now = time.time()
        rows = []
        for x, y, o, r in zip(np.asarray(X, dtype=float), np.asarray(Y, dtype=float), ok, reasons):
            xb = _x_bytes(x)
            xh, okv = _x_hash(xb), int(bool(o))
            yb = np.ascontiguousarray(y, dtype="<f8").tobytes() if o else None
            reason = None if o else str(r)
            rows.append((model_key, xh, xb, okv, yb, reason, now,
                         _checksum(model_key, xh, okv, yb, reason)))
        try:
            with self._connect() as con:
                con.executemany(
                    "INSERT OR REPLACE INTO evaluations (model_key, x_hash, x, ok, y, reason, "
                    "created, checksum) VALUES (?, ?, ?, ?, ?, ?, ?, ?)", rows)
        except (sqlite3.DatabaseError, OSError) as exc:
            self._fail(f"cannot store {len(rows)} finished evaluation(s); the rows stored before "
                       "are kept", exc, _WRITE_TODO)

    def forget_failures(self, model_key: str | None = None) -> int:
        """Delete the cached failures, of one model key or of all.

        Parameters
        ----------
        model_key : str, optional
            The key whose failures to delete (default: all keys).

        Returns
        -------
        int
            How many rows were deleted.

        Raises
        ------
        CacheError
            If the database cannot be written.

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     c = EvaluationCache(d)
        ...     c.store("k", np.array([[1.0], [2.0]]), np.array([[2.0], [np.nan]]),
        ...             np.array([True, False]), [None, "diverged"])
        ...     c.forget_failures(), c.stats()
        (1, {'k': {'ok': 1, 'failed': 0}})
        """
        return self._delete("ok = 0", model_key)

    def clear(self, model_key: str | None = None) -> int:
        """Delete all cached rows, of one model key or of all.

        Parameters
        ----------
        model_key : str, optional
            The key whose rows to delete (default: all keys).

        Returns
        -------
        int
            How many rows were deleted.

        Raises
        ------
        CacheError
            If the database cannot be written.

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     c = EvaluationCache(d)
        ...     c.store("k", np.array([[1.0]]), np.array([[2.0]]), np.array([True]), [None])
        ...     c.clear("k"), c.stats()
        (1, {})
        """
        return self._delete("1", model_key)

    def _delete(self, condition: str, model_key: str | None) -> int:
        """Delete the rows meeting the SQL ``condition`` (a constant of this class), of one
        model key or of all; returns how many."""
        with self._guard(), self._connect() as con:
            if model_key is None:
                cur = con.execute(f"DELETE FROM evaluations WHERE {condition}")
            else:
                cur = con.execute(f"DELETE FROM evaluations WHERE {condition} AND model_key = ?",
                                  (model_key,))
            return cur.rowcount

    def stats(self) -> dict[str, Any]:
        """Count the cached rows per model key.

        Returns
        -------
        dict
            ``{key: {"ok": n, "failed": m}}``.

        Raises
        ------
        CacheError
            If the database cannot be read.

        Examples
        --------
        >>> import tempfile
        >>> with tempfile.TemporaryDirectory() as d:
        ...     EvaluationCache(d).stats()
        {}
        """
        out: dict[str, Any] = {}
        with self._guard(), self._connect() as con:
            for key, okv, cnt in con.execute(
                "SELECT model_key, ok, COUNT(*) FROM evaluations GROUP BY model_key, ok"
            ):
                out.setdefault(key, {"ok": 0, "failed": 0})["ok" if okv else "failed"] = cnt
        return out


_WRITE_TODO = ("a cache in a writable folder on a disk with free space — free space or fix the "
               "permissions, or run without the cache (--no-cache; cache=None in Python)")


def _is_write_error(exc: sqlite3.OperationalError) -> bool:
    text = str(exc).lower()
    return any(w in text for w in ("readonly", "read-only", "disk is full", "unable to open",
                                   "disk i/o"))


def as_cache(cache: Any) -> EvaluationCache | None:
    """Turn what ``evaluate(cache=...)`` accepts into a cache.

    Parameters
    ----------
    cache : None, EvaluationCache, str or path-like
        No cache, a cache, or the directory (or database file) of one.

    Returns
    -------
    EvaluationCache or None
        The cache (None for None).

    Raises
    ------
    StudyError
        If ``cache`` is of another type.

    Examples
    --------
    >>> as_cache(None) is None
    True
    """
    if cache is None or isinstance(cache, EvaluationCache):
        return cache
    if isinstance(cache, (str, os.PathLike)):
        return EvaluationCache(cache)
    raise StudyError(
        f"cache: expected None, a directory path or an EvaluationCache, got {type(cache).__name__}"
    )
