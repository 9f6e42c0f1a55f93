"""One validation toolkit: each value a user gives has one rule, whoever reads it.

The scene files (:mod:`mechrel.scene`), the study files (:mod:`mechrel.study.study`), the
estimators' arguments (:mod:`mechrel.uq`) and the command line (:mod:`mechrel.cli`) check
their values with a :class:`Checker`, so that a value breaking a rule gets the same message
wherever it was given: ``SOURCE: PATH = VALUE: PROBLEM; allowed: WHAT`` (``SOURCE`` is the
file, ``<mapping>`` or absent for a Python argument; the command line shows the value
only, after argparse's ``argument --NAME:``).

The rules for values that several layers accept (:meth:`Checker.sample_count`,
:meth:`Checker.seed`, :meth:`Checker.fraction`, :meth:`Checker.jobs`,
:meth:`Checker.angle_step`) live here and nowhere else.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import Any, NoReturn

import numpy as np

from .errors import InputError, SceneError, StudyError

_MISSING = object()


# ----------------------------------------------------------------------------- formatting

def fmt_value(v: Any, limit: int = 80) -> str:
    """A value as it would be written in TOML, shortened to ``limit`` characters."""
    s = _fmt(v)
    return s if len(s) <= limit else s[: limit - 3] + "..."


# TOML's escapes in a basic string; other control characters (and the bidirectional-text
# controls, which reorder what a terminal shows) as \uXXXX: a value in a message is one line
_STRING_ESCAPES = {c: f"\\u{c:04x}" for c in (*range(0x20), *range(0x7f, 0xa0), 0x061c, 0x200e,
                                                0x200f, *range(0x202a, 0x202f),
                                                *range(0x2066, 0x206a))}
_STRING_ESCAPES.update({ord("\\"): "\\\\", ord('"'): '\\"', ord("\b"): "\\b", ord("\t"): "\\t",
                        ord("\n"): "\\n", ord("\f"): "\\f", ord("\r"): "\\r"})


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.translate(_STRING_ESCAPES) + '"'
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, int):
        return repr(v)
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{k} = {_fmt(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return repr(v)


def _typename(v: Any) -> str:
    if v is None:
        return "None"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (int, float)):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, Mapping):
        return "a table"
    if isinstance(v, (list, tuple)):
        return "an array"
    return f"a {type(v).__name__}"


def _bound(x: float) -> str:
    return f"{x:g}"


def describe_number(gt=None, ge=None, lt=None, le=None, unit: str | None = None,
                    integer: bool = False) -> str:
    """Describe the numbers a range admits, for the "allowed: WHAT" part of a message.

    Parameters
    ----------
    gt, ge : float, optional
        Lower bound, exclusive or inclusive (at most one of them).
    lt, le : float, optional
        Upper bound, exclusive or inclusive (at most one of them).
    unit : str, optional
        Unit appended in parentheses.
    integer : bool, default False
        Describe integers instead of finite numbers.

    Returns
    -------
    str
        The description.

    Examples
    --------
    >>> describe_number(gt=0, le=1)
    'a finite number in (0, 1]'
    >>> describe_number(ge=2, integer=True), describe_number(gt=0, unit="m")
    ('an integer >= 2', 'a finite number > 0 (m)')
    """
    kind = "an integer" if integer else "a finite number"
    lo = (gt, "(") if gt is not None else (ge, "[") if ge is not None else None
    hi = (lt, ")") if lt is not None else (le, "]") if le is not None else None
    if lo and hi:
        rng = f" in {lo[1]}{_bound(lo[0])}, {_bound(hi[0])}{hi[1]}"
    elif lo:
        rng = f" {'>' if gt is not None else '>='} {_bound(lo[0])}"
    elif hi:
        rng = f" {'<' if lt is not None else '<='} {_bound(hi[0])}"
    else:
        rng = ""
    return kind + rng + (f" ({unit})" if unit else "")


def suggest(word: str, choices: Iterable[str]) -> str:
    close = difflib.get_close_matches(str(word), list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _one_of(choices: Sequence[str]) -> str:
    return "one of " + ", ".join(str(c) for c in choices) if choices else "none defined"


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def join(prefix: str, key: str) -> str:
    """``prefix.key``; a key that is not a bare TOML key is quoted as TOML does."""
    key = str(key)
    if not _BARE_KEY.fullmatch(key):  # ASCII letters, digits, '_' and '-', at least one
        key = '"' + key.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return f"{prefix}.{key}" if prefix else key


# ----------------------------------------------------------------------------- checker

class Checker:
    """Type and range checks that raise ``error`` naming source, path and value.

    Parameters
    ----------
    source : str or None
        Where the values come from, the message's prefix (a file name, ``"<mapping>"``);
        None for a Python argument or a command-line option.
    overridden : sequence of (str, object)
        ``(dotted path, override text)`` of the values set by overrides, named in the message
        of a failure at (or next to) that path (the text is what ``str`` gives of the object:
        it can be worded only when a message needs it).
    error : type of InputError, optional
        The exception raised (default: the class attribute, :class:`~mechrel.errors.SceneError`);
        it is called as ``error(message, source=..., path=...)``.

    Examples
    --------
    >>> from mechrel.errors import StudyError
    >>> Checker(None, error=StudyError).sample_count("n", 1)
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: n = 1: must be >= 2; allowed: an integer >= 2 (a sample count)
    """

    error: type[InputError] = SceneError

    def __init__(self, source: str | None = None, overridden: Sequence[tuple[str, object]] = (),
                 *, error: type[InputError] | None = None):
        self.source = source
        self.overridden = tuple(overridden)  # (dotted path, override text)
        if error is not None:
            self.error = error

    # -- failure
    def fail(self, path: str, value: Any, problem: str, allowed: str | None = None) -> NoReturn:
        """Raise ``error`` with ``PATH = VALUE: PROBLEM; allowed: ALLOWED`` (``VALUE: ...``
        when ``path`` is empty, ``PATH: ...`` when the value is missing)."""
        if value is _MISSING:
            msg = f"{path}: {problem}"
        elif not path:
            msg = f"{fmt_value(value)}: {problem}"
        else:
            msg = f"{path} = {fmt_value(value)}: {problem}"
        if allowed:
            msg += f"; allowed: {allowed}"
        direct = [t for o, t in self.overridden
                  if path == o or path.startswith((o + ".", o + "[")) or o.startswith(path + ".")]
        parent = path.rsplit(".", 1)[0]
        near = [t for o, t in self.overridden if o.rsplit(".", 1)[0] == parent]
        if direct:
            msg += f" (value set by override '{direct[-1]}')"
        elif near:
            msg += f" (after override '{near[-1]}')"
        raise self.error(msg, source=self.source, path=path or None)

    # -- structure
    def table(self, path: str, v: Any, allowed: str = "a table") -> Mapping:
        if not isinstance(v, (dict, MappingProxyType)) and not isinstance(v, Mapping):
            self.fail(path, v, f"expected a table, got {_typename(v)}", allowed)
        for k in v:
            if not isinstance(k, str):
                self.fail(join(path, str(k)), v[k], f"key {k!r} is not a string", "string keys")
        return v

    def keys(self, path: str, d: Mapping, allowed: Sequence[str], required: Sequence[str] = (),
             what: str | None = None, hints: Mapping[str, str] | None = None) -> None:
        for k, v in d.items():
            if k not in allowed:
                where = f" for {what}" if what else ""
                hint = (hints or {}).get(k, "")
                self.fail(join(path, k), v,
                          f"unknown field '{k}'{where}{suggest(k, allowed)}{hint}",
                          "fields " + ", ".join(allowed))
        for k in required:
            if k not in d:
                where = f" of {what}" if what else ""
                self.fail(join(path, k), _MISSING, f"missing required field{where}",
                          self.required_hint(k))

    required_hints: dict[str, str] = {}

    def required_hint(self, key: str) -> str | None:
        return self.required_hints.get(key)

    # -- leaves
    def number(self, path: str, v: Any, *, gt=None, ge=None, lt=None, le=None,
               unit: str | None = None) -> float:
        def fail(problem: str) -> NoReturn:  # the range is described only for a message
            self.fail(path, v, problem, describe_number(gt, ge, lt, le, unit))

        if v is _MISSING:
            fail("missing required field")
        if isinstance(v, bool):
            fail("expected a number, got a boolean")
        if not isinstance(v, (int, float)):
            fail(f"expected a number, got {_typename(v)}")
        try:
            x = float(v)
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            fail("not a finite number")
        if gt is not None and not x > gt:
            fail(f"must be > {_bound(gt)}")
        if ge is not None and not x >= ge:
            fail(f"must be >= {_bound(ge)}")
        if lt is not None and not x < lt:
            fail(f"must be < {_bound(lt)}")
        if le is not None and not x <= le:
            fail(f"must be <= {_bound(le)}")
        return x

    def integer(self, path: str, v: Any, *, gt=None, ge=None, le=None,
                what: str | None = None) -> int:
        allowed = describe_number(gt, ge, le=le, integer=True) + (f" ({what})" if what else "")
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
            got = "a boolean" if isinstance(v, (bool, np.bool_)) else _typename(v)
            self.fail(path, v, f"expected an integer, got {got}", allowed)
        if gt is not None and not v > gt:
            self.fail(path, v, f"must be > {gt}", allowed)
        if ge is not None and not v >= ge:
            self.fail(path, v, f"must be >= {ge}", allowed)
        if le is not None and not v <= le:
            self.fail(path, v, f"must be <= {le}", allowed)
        return int(v)

    def string(self, path: str, v: Any, allowed: str = "a string") -> str:
        if v is _MISSING:
            self.fail(path, v, "missing required field", allowed)
        if not isinstance(v, str):
            self.fail(path, v, f"expected a string, got {_typename(v)}", allowed)
        return v

    def choice(self, path: str, v: Any, choices: Sequence[str]) -> str:
        if isinstance(v, str) and v in choices:  # allowed: no message to word
            return v
        allowed = _one_of(choices)
        s = self.string(path, v, allowed)
        if s not in choices:
            self.fail(path, v, f"unknown value{suggest(s, choices)}", allowed)
        return s

    def vec2(self, path: str, v: Any, *, unit: str | None = None,
             nonzero: bool = False) -> tuple[float, float]:
        allowed = "a pair [x, y] of finite numbers" + (f" ({unit})" if unit else "")
        if nonzero:
            allowed += ", not both zero"
        if v is _MISSING:
            self.fail(path, v, "missing required field", allowed)
        if isinstance(v, (str, bytes)) or not isinstance(v, (list, tuple)):
            self.fail(path, v, f"expected an array of 2 numbers, got {_typename(v)}", allowed)
        if len(v) != 2:
            self.fail(path, v, f"expected 2 components, got {len(v)}", allowed)
        out = []
        for i, x in enumerate(v):
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                self.fail(path, v, f"component {i} is {_typename(x)}, not a number", allowed)
            try:
                fx = float(x)
            except OverflowError:
                fx = math.inf
            if not math.isfinite(fx):
                self.fail(path, v, f"component {i} is not a finite number", allowed)
            out.append(fx)
        if nonzero and math.hypot(*out) == 0.0:
            self.fail(path, v, "zero-length vector", allowed)
        return (out[0], out[1])

    def choices(self, path: str, v: Any, choices: Sequence[str]) -> tuple[str, ...]:
        """A non-empty array of distinct values, each one of ``choices``."""
        allowed = f"a non-empty array of distinct values from {', '.join(choices)}"
        if isinstance(v, str) or not isinstance(v, (list, tuple)) or not v:
            self.fail(path, v, "not a non-empty array", allowed)
        for i, x in enumerate(v):
            self.choice(f"{path}[{i}]", x, choices)
        if len(set(v)) != len(v):
            self.fail(path, v, "a value is repeated", allowed)
        return tuple(v)

    # -- the rules of values that several layers accept
    def sample_count(self, path: str, v: Any) -> int:
        """The number of samples of an estimator (Monte Carlo, PCE, Sobol' base samples): an
        integer >= 2, the fewest with a sample variance."""
        return self.integer(path, v, ge=2, what="a sample count")

    def seed(self, path: str, v: Any) -> int | None:
        """A random seed: None (fresh entropy, recorded) or an integer >= 0."""
        return None if v is None else self.integer(path, v, ge=0, what="a seed")

    def fraction(self, path: str, v: Any, *, open_lo: bool = False,
                 open_hi: bool = False) -> float:
        """A number in [0, 1]; ``open_lo``/``open_hi`` exclude 0/1 (e.g. a confidence level)."""
        return self.number(path, v, gt=0 if open_lo else None, ge=None if open_lo else 0,
                           lt=1 if open_hi else None, le=None if open_hi else 1)

    def jobs(self, path: str, v: Any) -> int:
        """A number of parallel workers: an integer >= 1, or -1 (all cores, or all of a
        Dask cluster's workers)."""
        allowed = "an integer >= 1, or -1 (all cores or all the cluster's workers)"
        if isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) and v == -1:
            return -1
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
            self.fail(path, v, f"expected an integer, got {_typename(v)}", allowed)
        if v < 1:
            self.fail(path, v, "must be >= 1 or -1", allowed)
        return int(v)

    def angle_step(self, path: str, v: Any) -> float:
        """A crank-angle step (degrees): a number > 0 that divides 360, at least
        :data:`MIN_ANGLE_STEP` (the outputs have 360 / step + 1 angles per quantity; below it
        every float quotient is a whole number, so 1e-300 "divided" 360)."""
        x = self.number(path, v, gt=0, unit="degrees")
        if x < MIN_ANGLE_STEP:
            self.fail(path, v, f"{360.0 / x:.3g} angles a cycle",
                      f"a divisor of 360 (degrees) >= {MIN_ANGLE_STEP:g} (at most "
                      f"{round(360 / MIN_ANGLE_STEP)} angles a cycle), e.g. 18, 10 or 5")
        if 360.0 / x != round(360.0 / x):
            self.fail(path, v, "does not divide 360 degrees",
                      "a divisor of 360 (degrees), e.g. 18, 10 or 5")
        return x


MIN_ANGLE_STEP = 1e-3
"""Smallest crank-angle step (degrees) :meth:`Checker.angle_step` accepts."""

ARGS = Checker(error=StudyError)
"""The checker of the estimators' and models' Python arguments (:mod:`mechrel.uq`): no source,
raises :class:`~mechrel.errors.StudyError`."""
