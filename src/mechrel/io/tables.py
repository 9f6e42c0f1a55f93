"""Writing result tables (CSV or Parquet, by file extension) and provenance (JSON)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import MechrelError

TABLE_SUFFIXES = (".csv", ".parquet")


def write_table(frame, path) -> Path:
    """Write a DataFrame to ``path``: ``.csv`` or ``.parquet`` (needs pyarrow)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise MechrelError(f"--out: {str(path)!r} has extension {suffix or '(none)'!r}; "
                           f"allowed: {', '.join(TABLE_SUFFIXES)}")
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".csv":
        frame.to_csv(path, index=False)
    else:
        try:
            frame.to_parquet(path, index=False)
        except ImportError as exc:
            raise MechrelError("writing Parquet needs pyarrow: pip install 'mechrel[parquet]'"
                               ) from exc
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
