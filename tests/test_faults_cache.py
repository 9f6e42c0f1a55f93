"""Fault injection, caches: a damaged, foreign, tampered, read-only or full cache ends in one
clear error (or a warning for single rows), never in a used damaged row, and keeps good rows."""

from __future__ import annotations

import re
import sqlite3
import warnings

import numpy as np
import pytest

from mechrel.errors import CacheError, MechrelWarning, StudyError
from mechrel.uq import EvaluationCache, evaluate, linear_model
from mechrel.uq.execution import cache as cache_mod

NAMES = ("a", "b")
MODEL = linear_model([0.5, -1.0], [[1.0, 2.0], [0.0, -3.0]], NAMES)  # y = c + A x, exact
X = np.arange(20, dtype=float).reshape(10, 2) / 7.0
Y_EXACT = np.array([0.5, -1.0]) + X @ np.array([[1.0, 2.0], [0.0, -3.0]]).T
TODO = r"allowed: delete the file \(its finished evaluations are then run again\) or run " \
       r"without the cache \(--no-cache; cache=None in Python\)"


def _filled(tmp_path):
    ev = evaluate(MODEL, X, cache=tmp_path, progress=False)
    assert ev.n_model_calls == 10
    return tmp_path / EvaluationCache.FILENAME


def _rerun(tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ev = evaluate(MODEL, X, cache=tmp_path, progress=False)
    return ev, [str(w.message) for w in caught if issubclass(w.category, MechrelWarning)]


def test_rows_carry_checksums_and_a_clean_rerun_uses_all(tmp_path):
    db = _filled(tmp_path)
    with sqlite3.connect(db) as con:
        nulls = "SELECT COUNT(*) FROM evaluations WHERE checksum IS NULL"
        assert con.execute(nulls).fetchone() == (0,)
        assert con.execute("PRAGMA user_version").fetchone() == (cache_mod.SCHEMA_VERSION,)
    ev, warned = _rerun(tmp_path)
    assert (ev.n_cached, ev.n_model_calls, warned) == (10, 0, [])
    # the cache stores the float64 bytes: the cached Y is bitwise the evaluated Y
    assert np.array_equal(ev.Y, evaluate(MODEL, X, progress=False).Y)


@pytest.mark.parametrize("tamper, n_bad", [
    # a changed output: the checksum no longer matches
    ("UPDATE evaluations SET y = ? WHERE rowid IN (SELECT rowid FROM evaluations LIMIT 2)", 2),
    # NULL outputs on ok rows
    ("UPDATE evaluations SET y = NULL WHERE rowid IN (SELECT rowid FROM evaluations LIMIT 3)", 3),
    # a row turned into a failure by hand
    ("UPDATE evaluations SET ok = 0, reason = 'x' WHERE rowid IN "
     "(SELECT rowid FROM evaluations LIMIT 1)", 1),
    # rows without a checksum (as written by mechrel before checksums)
    ("UPDATE evaluations SET checksum = NULL WHERE rowid IN "
     "(SELECT rowid FROM evaluations LIMIT 4)", 4),
])
def test_tampered_rows_are_not_used_and_good_rows_are_kept(tmp_path, tamper, n_bad):
    db = _filled(tmp_path)
    with sqlite3.connect(db) as con:
        args = (np.array([1e9, 1e9]).tobytes(),) if "?" in tamper else ()
        assert con.execute(tamper, args).rowcount == n_bad
    ev, warned = _rerun(tmp_path)
    # the damaged rows are evaluated again (and only they), the others come from the cache
    assert (ev.n_cached, ev.n_model_calls) == (10 - n_bad, n_bad)
    np.testing.assert_allclose(ev.Y, Y_EXACT, rtol=1e-15, atol=1e-15)  # y = c + A x: exact sums
    assert ev.n_failed == 0
    assert len(warned) == 1 and f"{n_bad} cached row(s) fail their checksum" in warned[0]
    assert str(db) in warned[0]
    # ... and overwritten with good rows: a third run uses all ten without a warning
    ev, warned = _rerun(tmp_path)
    assert (ev.n_cached, ev.n_model_calls, warned) == (10, 0, [])


def test_cache_of_the_layout_before_checksums_is_upgraded_and_its_rows_rerun(tmp_path):
    db = tmp_path / EvaluationCache.FILENAME
    with sqlite3.connect(db) as con:
        con.execute(cache_mod._SCHEMA.replace("    checksum  TEXT,\n", ""))
        con.execute("INSERT INTO evaluations VALUES ('k', 'h', x'00', 1, x'00', NULL, 0)")
    EvaluationCache(tmp_path)
    with sqlite3.connect(db) as con:
        cols = [r[1] for r in con.execute("PRAGMA table_info(evaluations)")]
    assert tuple(cols) == cache_mod._COLUMNS


@pytest.mark.parametrize("content, problem", [
    (b"this is not a database at all, just some text" * 50,
     r"not a readable mechrel cache \(DatabaseError: file is not a database\)"),
    (b"SQLite format 3\x00" + b"\xff" * 300, r"not a readable mechrel cache \(DatabaseError: "),
])
def test_garbage_file_is_one_clear_error(tmp_path, content, problem):
    (tmp_path / EvaluationCache.FILENAME).write_bytes(content)
    with pytest.raises(CacheError,
                       match=rf"^cache: '{tmp_path}/evaluations.sqlite': {problem}.*; {TODO}$"):
        evaluate(MODEL, X, cache=tmp_path, progress=False)


def test_truncated_file_is_one_clear_error(tmp_path):
    # enough rows for several pages, then cut the file in the middle of a page
    Xbig = np.random.default_rng(0).normal(size=(400, 2))
    evaluate(MODEL, Xbig, cache=tmp_path, progress=False)
    db = tmp_path / EvaluationCache.FILENAME
    data = db.read_bytes()
    assert len(data) > 4 * 4096
    db.write_bytes(data[: len(data) // 2 + 100])
    with pytest.raises(CacheError, match=rf"^cache: '{db}': (the file is damaged|not a readable "
                                         rf"mechrel cache).*; {TODO}$"):
        evaluate(MODEL, Xbig, cache=tmp_path, progress=False)


def test_a_damaged_page_is_one_line(tmp_path):
    # sqlite's quick_check reports a damaged page as a header and a line per cell, which the
    # message embedded verbatim (4 lines and more); now: the first problem and how many more
    Xbig = np.random.default_rng(0).normal(size=(400, 2))
    evaluate(MODEL, Xbig, cache=tmp_path, progress=False)
    db = tmp_path / EvaluationCache.FILENAME
    data = bytearray(db.read_bytes())
    data[3 * 4096 + 8: 3 * 4096 + 40] = b"\x7f" * 32  # the cell pointers of the fourth page
    db.write_bytes(bytes(data))
    with pytest.raises(CacheError) as info:
        evaluate(MODEL, Xbig, cache=tmp_path, progress=False)
    assert re.fullmatch(rf"cache: '{re.escape(str(db))}': the file is damaged \(sqlite "
                        r"quick_check: On tree page \d+ cell \d+: [^;]+, and \d+ more\); "
                        + TODO, str(info.value)), str(info.value)


def test_database_of_another_layout_is_refused_and_left_alone(tmp_path):
    db = tmp_path / EvaluationCache.FILENAME
    with sqlite3.connect(db) as con:
        con.execute("CREATE TABLE evaluations (id INTEGER, value REAL)")
        con.execute("INSERT INTO evaluations VALUES (1, 2.0)")
    before = db.read_bytes()
    with pytest.raises(CacheError, match=r"not a mechrel cache of this version \(table evaluations "
                                         r"has columns \['id', 'value'\]"):
        EvaluationCache(tmp_path)
    with sqlite3.connect(tmp_path / "other.db") as con:
        con.execute("CREATE TABLE users (name TEXT)")
    with pytest.raises(CacheError, match=r"not a mechrel cache \(tables \['users'\]\)"):
        EvaluationCache(tmp_path / "other.db")
    assert db.read_bytes() == before  # nothing written into a file that is not ours


def test_cache_path_that_is_a_folder(tmp_path):
    (tmp_path / "c.sqlite").mkdir()
    (tmp_path / "c.sqlite" / EvaluationCache.FILENAME).mkdir()
    with pytest.raises(CacheError, match=r"is a folder; allowed: a cache file"):
        EvaluationCache(tmp_path / "c.sqlite")
    assert issubclass(CacheError, StudyError)  # the command line prints it as one line


def _limited_connect(max_pages):
    real = sqlite3.connect

    def connect(*args, **kwargs):
        con = real(*args, **kwargs)
        con.execute(f"PRAGMA max_page_count = {max_pages}")  # sqlite's own 'disk is full'
        return con
    return connect


def test_full_disk_stops_with_one_line_and_keeps_the_stored_rows(tmp_path, monkeypatch):
    """Sqlite's max_page_count makes it report SQLITE_FULL ('database or disk is full') exactly
    as on a full disk: the first chunks fit, a later one does not."""
    Xbig = np.random.default_rng(1).normal(size=(600, 2))
    EvaluationCache(tmp_path)
    pages = (tmp_path / EvaluationCache.FILENAME).stat().st_size // 4096
    monkeypatch.setattr(cache_mod.sqlite3, "connect", _limited_connect(pages + 30))
    with pytest.raises(CacheError, match=r"cannot store \d+ finished evaluation\(s\); the rows "
                                         r"stored before are kept \(OperationalError: database or "
                                         r"disk is full\); allowed: a cache in a writable "
                                         r"folder on a disk with free space"):
        evaluate(MODEL, Xbig, cache=tmp_path, progress=False, chunk_size=50)
    monkeypatch.undo()
    stored = sum(v["ok"] for v in EvaluationCache(tmp_path).stats().values())
    assert 0 < stored < 600 and stored % 50 == 0  # whole chunks, one transaction each
    ev = evaluate(MODEL, Xbig, cache=tmp_path, progress=False, chunk_size=50)
    assert (ev.n_cached, ev.n_model_calls) == (stored, 600 - stored)


def test_unwritable_cache_is_refused_before_any_evaluation(tmp_path, monkeypatch):
    """A read-only file or folder (simulated: the tests may run as root, who can write
    anywhere): sqlite's own error at the first write, which the cache makes on opening."""
    evaluate(MODEL, X, cache=tmp_path, progress=False)
    real = sqlite3.connect
    monkeypatch.setattr(cache_mod.sqlite3, "connect",
                        lambda p, **kw: real(f"file:{p}?mode=ro", uri=True, **kw))
    calls = []
    counted = linear_model([0.0], [[1.0, 0.0]], NAMES)
    monkeypatch.setattr(counted, "evaluate", lambda x: calls.append(x) or np.array([x[0]]))
    with pytest.raises(CacheError, match=r"cannot be written \(OperationalError: attempt to write "
                                         r"a readonly database\); allowed: a cache in a writable "
                                         r"folder"):
        evaluate(counted, X, cache=tmp_path, progress=False)
    assert calls == []
