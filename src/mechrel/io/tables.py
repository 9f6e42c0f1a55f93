"""Writing result tables (CSV or Parquet, by file extension) and provenance (JSON)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import MechrelError

TABLE_SUFFIXES = (".csv", ".parquet")


def check_table_path(path) -> Path:
    """``path`` as a table file that can be written: a ``.csv`` or ``.parquet`` name (the
    latter with pyarrow installed) in a folder that exists or can be created. Called before a
    long computation, so that a wrong ``--out`` fails at once, not after it."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise MechrelError(f"--out: {str(path)!r} has extension {suffix or '(none)'!r}; "
                           f"allowed: {', '.join(TABLE_SUFFIXES)}")
    if suffix == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise MechrelError("--out: writing Parquet needs pyarrow: pip install "
                               "'mechrel[parquet]', or write .csv") from None
    if path.is_dir():
        raise MechrelError(f"--out: {str(path)!r} is a folder; allowed: a file name ending in "
                           f"{' or '.join(TABLE_SUFFIXES)}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MechrelError(f"--out: cannot create the folder {str(path.parent)!r} "
                           f"({exc.strerror}); allowed: a path in a writable folder") from None
    return path


def write_table(frame, path) -> Path:
    """Write a DataFrame to ``path``: ``.csv`` or ``.parquet`` (needs pyarrow)."""
    path = check_table_path(path)
    try:
        if path.suffix.lower() == ".csv":
            frame.to_csv(path, index=False)
        else:
            frame.to_parquet(path, index=False)
    except OSError as exc:
        raise MechrelError(f"--out: cannot write {str(path)!r} ({exc.strerror or exc}); "
                           "allowed: a path in a writable folder") from None
    return path


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else str(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def write_json(data: dict, path) -> Path:
    """Write a dict (numpy values allowed; non-finite floats as strings) as indented JSON."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(_jsonable(data), indent=2) + "\n")
    return path
