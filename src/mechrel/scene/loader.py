"""Loading scenes: sources (embedded name, TOML file, mapping), ``extends``, dotted overrides,
canonical raw mapping and scene hash."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any

from ..errors import SceneError
from ._schema import EXCLUSIVE, SCHEMA, Named
from ._validate import build_scene, fmt_value, scene_to_raw, suggest
from .model import Scene

SceneSource = str | os.PathLike | Mapping | Scene
Overrides = Mapping[str, Any] | Sequence[str] | Sequence[tuple[str, Any]]

_MAPPING_LABEL = "<mapping>"


# ----------------------------------------------------------------------------- freezing

_LEAVES = frozenset((float, int, str, bool, type(None)))  # the types TOML leaves have

def freeze(v: Any) -> Any:
    """Read-only deep copy: tables → ``MappingProxyType``, arrays → tuples.

    Parameters
    ----------
    v : object
        A parsed TOML value (tables, arrays, scalars).

    Returns
    -------
    object
        The frozen copy (scalars as they are).

    Examples
    --------
    >>> frozen = freeze({"points": {"A": [0.05, 0.0]}})
    >>> frozen["points"]["A"]
    (0.05, 0.0)
    >>> frozen["points"]["B"] = (0.0, 0.0)
    Traceback (most recent call last):
    ...
    TypeError: 'mappingproxy' object does not support item assignment
    """
    if type(v) in _LEAVES:  # most values (and no Mapping ABC check for them)
        return v
    if isinstance(v, Mapping):
        return MappingProxyType({k: freeze(x) for k, x in v.items()})
    if isinstance(v, (list, tuple)):
        return tuple(freeze(x) for x in v)
    return v


def thaw(v: Any) -> Any:
    """Mutable deep copy of a (possibly frozen) raw mapping: tables → dict, arrays → list.

    Parameters
    ----------
    v : object
        A raw value, frozen (:func:`freeze`) or not.

    Returns
    -------
    object
        The mutable copy (scalars as they are).

    Examples
    --------
    >>> thaw(freeze({"points": {"A": [0.05, 0.0]}}))
    {'points': {'A': [0.05, 0.0]}}
    """
    if type(v) in _LEAVES:
        return v
    if isinstance(v, Mapping):
        return {k: thaw(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [thaw(x) for x in v]
    return v


# ----------------------------------------------------------------------------- embedded scenes

def _data_dir():
    return resources.files("mechrel.scene").joinpath("data")


def embedded_names() -> tuple[str, ...]:
    """Names of the scenes shipped in ``mechrel/scene/data``.

    Returns
    -------
    tuple of str
        The names, sorted.

    Examples
    --------
    >>> "nine-bar-lubricated" in embedded_names()
    True
    """
    return tuple(sorted(p.name[:-5] for p in _data_dir().iterdir() if p.name.endswith(".toml")))


def list_scenes() -> dict[str, str]:
    """``{name: description}`` of every embedded scene (each one is loaded and validated).

    Returns
    -------
    dict
        ``{name: description}``.

    Examples
    --------
    >>> "nine-bar-lubricated" in list_scenes()
    True
    """
    return {name: load_scene(name).description for name in embedded_names()}


# ----------------------------------------------------------------------------- reading

class _Doc:
    """One parsed TOML document with where it came from. ``root``: the folder that files it
    names (``extends``) must stay in — the folder of the file the caller gave (``None``: only
    embedded scenes may be named)."""

    def __init__(self, raw: dict, label: str, base_dir: Path | None, key: str,
                 root: Path | None = None):
        self.raw, self.label, self.base_dir, self.key = raw, label, base_dir, key
        self.root = root


# Deepest nesting of tables and arrays a scene or study file may have (the embedded scenes
# use 4); deeper documents are refused before anything recurses over them.
MAX_DEPTH = 32


def check_depth(raw: Any, label: str, error=SceneError) -> None:
    """Refuse a parsed document nested deeper than :data:`MAX_DEPTH` (iteratively: the check
    itself does not recurse).

    Parameters
    ----------
    raw : object
        The parsed document.
    label : str
        The file's name for the message.
    error : type, default SceneError
        The error class raised (``StudyError`` for study files).

    Raises
    ------
    mechrel.errors.SceneError
        (or ``error``) The document is nested too deeply.

    Examples
    --------
    >>> check_depth({"a": {"b": [1, 2]}}, "scene.toml")   # fine: returns None
    >>> deep = [0]
    >>> for _ in range(MAX_DEPTH):
    ...     deep = [deep]
    >>> check_depth(deep, "scene.toml")
    Traceback (most recent call last):
    ...
    mechrel.errors.SceneError: scene.toml: [0]...[0]: tables and arrays nested more than 32 ...
    """
    stack = [(raw, 0, "")]
    while stack:
        node, depth, path = stack.pop()
        if depth > MAX_DEPTH:
            message = (f"{path or '(top level)'}: tables and arrays nested more than "
                       f"{MAX_DEPTH} levels deep; allowed: at most {MAX_DEPTH} levels")
            raise (error(message, source=label) if error is SceneError
                   else error(f"{label}: {message}"))
        if isinstance(node, Mapping):
            stack.extend((v, depth + 1, f"{path}.{k}" if path else str(k)) for k, v in node.items())
        elif isinstance(node, (list, tuple)):
            stack.extend((v, depth + 1, f"{path}[{i}]") for i, v in enumerate(node))


def read_toml_text(data: bytes, label: str, error=SceneError) -> dict:
    """Parse the bytes of a scene or study file: UTF-8 with or without a byte-order mark,
    valid TOML, at most :data:`MAX_DEPTH` levels deep; one ``error`` naming ``label``
    otherwise.

    Parameters
    ----------
    data : bytes
        The file's content.
    label : str
        The file's name for messages.
    error : type, default SceneError
        The error class raised (``StudyError`` for study files).

    Returns
    -------
    dict
        The parsed TOML.

    Raises
    ------
    mechrel.errors.SceneError
        (or ``error``) Not UTF-8, not TOML, or nested too deeply.

    Examples
    --------
    >>> read_toml_text(b'\\xef\\xbb\\xbfname = "demo"', "demo.toml")   # with a byte-order mark
    {'name': 'demo'}
    >>> read_toml_text(b"name = ", "demo.toml")
    Traceback (most recent call last):
    ...
    mechrel.errors.SceneError: demo.toml: TOML syntax error: ...
    """
    def fail(message):
        raise (error(message, source=label) if error is SceneError
               else error(f"{label}: {message}")) from None
    try:
        text = data.decode("utf-8-sig")  # a byte-order mark, if any, is not part of the TOML
    except UnicodeDecodeError as e:
        fail(f"the file is not UTF-8 text ({e.reason} at byte {e.start}); allowed: a UTF-8 "
             "TOML file")
    try:
        raw = _parse_toml(text, label)
    except RecursionError:
        fail(f"tables or arrays nested too deeply to parse; allowed: at most {MAX_DEPTH} levels")
    except SceneError as e:
        if error is SceneError:
            raise
        fail(str(e).removeprefix(f"{label}: "))
    check_depth(raw, label, error)
    return raw


def _parse_toml(text: str, label: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        where = str(e)
        if "line" not in where:  # "(at end of document)": say which line that is
            lines = text.splitlines() or [""]
            where += f" (line {len(lines)}, column {len(lines[-1]) + 1})"
        raise SceneError(f"TOML syntax error: {where}; allowed: valid TOML (https://toml.io)",
                         source=label) from None


def _read_embedded(name: str) -> _Doc:
    entry = _data_dir().joinpath(name + ".toml")
    label = f"embedded:{name}"
    base = Path(str(_data_dir()))
    return _Doc(read_toml_text(entry.read_bytes(), label), label,
                base if base.is_dir() else None, label, root=None)


def _read_file(path: Path, *, hint: str = "", root: Path | None = None) -> _Doc:
    """The document of the file ``path``; ``root``: the folder its ``extends`` must stay in
    (default: its own folder — a file the caller named directly)."""
    label = str(path)
    try:
        is_file = path.is_file()
    except OSError as e:  # a name the file system refuses (too long: ENAMETOOLONG)
        raise SceneError(f"cannot read the file: {e.strerror}; allowed: a readable TOML file",
                         source=label) from None
    if not is_file:
        names = embedded_names()
        raise SceneError(f"no such scene file '{path}'{hint}; allowed: an existing TOML file or "
                         f"an embedded scene name: {', '.join(names)}", source=None, path=None)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise SceneError(f"cannot read the file: {e.strerror}; allowed: a readable TOML file",
                         source=label) from None
    folder = path.resolve().parent
    return _Doc(read_toml_text(data, label), label, folder, str(path.resolve()),
                root=folder if root is None else root)


def _read_source(source: Any) -> tuple[_Doc, str | None]:
    """The document for ``source`` and the value for :attr:`Scene.source`."""
    if isinstance(source, Mapping):
        check_depth(source, _MAPPING_LABEL)
        return _Doc(thaw(source), _MAPPING_LABEL, Path.cwd(), _MAPPING_LABEL,
                    root=Path.cwd().resolve()), None
    if isinstance(source, str):
        if source in embedded_names():
            doc = _read_embedded(source)
            return doc, doc.label
        if not (source.endswith(".toml") or "/" in source or os.sep in source
                or Path(source).is_file()):
            names = embedded_names()
            raise SceneError(
                f"unknown scene '{source}'{suggest(source, names)}: not an embedded scene and not "
                f"a file; allowed: an embedded scene name ({', '.join(names)}) or a path to a "
                f"TOML file")
        doc = _read_file(Path(source))
        return doc, str(source)
    if isinstance(source, os.PathLike):
        doc = _read_file(Path(source))
        return doc, str(Path(source))
    raise SceneError(f"scene source {fmt_value(source)} is of type {type(source).__name__}; "
                     "allowed: an embedded scene name, a path (str or Path) or a mapping")


# ----------------------------------------------------------------------------- extends

def deep_merge(base: Mapping, over: Mapping, path: str = "") -> dict:
    """``over`` on top of ``base``: tables merge recursively, any other value replaces. In a
    table listed in ``EXCLUSIVE`` (``analysis``), setting one key of a mutually exclusive pair
    drops the other inherited key (so a variant may switch ``cycles`` to ``duration``).

    Parameters
    ----------
    base, over : mapping
        Raw scene tables; ``over`` wins.
    path : str, default ""
        Dotted path of these tables in the scene (selects the ``EXCLUSIVE`` pairs).

    Returns
    -------
    dict
        The merged copy (neither argument is changed).

    Examples
    --------
    >>> deep_merge({"analysis": {"cycles": 1, "sample_step": 1e-4}},
    ...            {"analysis": {"duration": 0.5}})
    {'analysis': {'sample_step': 0.0001, 'duration': 0.5}}
    """
    out = thaw(base)
    for a, b in EXCLUSIVE.get(path, ()):
        if a in over and b not in over:
            out.pop(b, None)
        elif b in over and a not in over:
            out.pop(a, None)
    for k, v in over.items():
        sub = f"{path}.{k}" if path else k
        if isinstance(v, Mapping) and isinstance(out.get(k), Mapping):
            out[k] = deep_merge(out[k], v, sub)
        else:
            out[k] = thaw(v)
    return out


def _looks_like_path(s: str) -> bool:
    return s.endswith(".toml") or "/" in s or os.sep in s


def _resolve_extends(doc: _Doc, chain: tuple[str, ...] = ()) -> dict:
    raw = doc.raw
    if not isinstance(raw, Mapping) or "extends" not in raw:
        return raw
    raw = dict(raw)
    ext = raw.pop("extends")
    names = embedded_names()
    allowed = (f"an embedded scene name ({', '.join(names)}) or a path to a TOML file "
               "(relative to the extending file, in the folder of the scene file given or "
               "below it)")
    if not isinstance(ext, str) or not ext:
        raise SceneError(f"extends = {fmt_value(ext)}: expected a non-empty string; allowed: "
                         f"{allowed}", source=doc.label, path="extends")
    if _looks_like_path(ext):
        p = Path(ext)
        if not p.is_absolute():
            p = (doc.base_dir or Path.cwd()) / p
        if doc.root is None or not p.resolve().is_relative_to(doc.root):
            # a file outside the folder of the file the caller named: not read (its content
            # could end up in an error message); a caller who means it names it directly
            where = ("an embedded scene names only embedded scenes" if doc.root is None else
                     f"it is outside {str(doc.root)!r}, the folder of the scene file given")
            raise SceneError(f"extends = {fmt_value(ext)}: not read: {where}; allowed: "
                             f"{allowed}; a file elsewhere can be given directly (as the "
                             "SCENE argument, or to load_scene)", source=doc.label,
                             path="extends")
        if not p.is_file():
            raise SceneError(f"extends = {fmt_value(ext)}: no such file '{p}'; allowed: {allowed}",
                             source=doc.label, path="extends")
        key = str(p.resolve())
        root = doc.root
        reader = lambda: _read_file(p, root=root)  # noqa: E731
    else:
        if ext not in names:
            raise SceneError(f"extends = {fmt_value(ext)}: unknown embedded scene"
                             f"{suggest(ext, names)}; allowed: {allowed}",
                             source=doc.label, path="extends")
        key = f"embedded:{ext}"
        reader = lambda: _read_embedded(ext)  # noqa: E731
    if key in chain or key == doc.key:
        cycle = " -> ".join((*chain, doc.key, key))
        raise SceneError(f"extends = {fmt_value(ext)}: circular extends ({cycle}); allowed: a "
                         "chain of bases that ends", source=doc.label, path="extends")
    base = _resolve_extends(reader(), (*chain, doc.key))
    if not isinstance(base, Mapping):
        return raw
    return deep_merge(base, raw)


# ----------------------------------------------------------------------------- overrides

_NUMBER_RE = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\Z")


def parse_value(text: str) -> Any:
    """An override VALUE: a TOML literal (``0.3e-3``, ``"dry"``, ``[1.0, 2.0]``, ``true``,
    ``{viscosity = 0.2}``); a plain number TOML rejects (``.5``, ``5.``); otherwise the text
    itself as a string (so ``dry`` means ``"dry"``).

    Parameters
    ----------
    text : str
        The text after ``=``.

    Returns
    -------
    object
        The value.

    Examples
    --------
    >>> parse_value("0.3e-3"), parse_value(".5"), parse_value("dry"), parse_value("[1.0, 2.0]")
    (0.0003, 0.5, 'dry', [1.0, 2.0])
    """
    s = text.strip()
    try:
        doc = tomllib.loads(f"__value__ = {s}")
        if set(doc) == {"__value__"}:
            check_depth(doc, "", _value_too_deep(s))  # the value one level down, as in a file
            return doc["__value__"]
    except tomllib.TOMLDecodeError:
        pass
    except RecursionError:  # the parser recurses per level: thousands of levels exhaust it
        raise _value_too_deep(s)("") from None
    if _NUMBER_RE.match(s):
        return float(s)
    return s


def _value_too_deep(text: str):
    """The error class :func:`check_depth` raises for an override value: one message naming
    the (shortened) value."""
    def error(message, source=None):
        return SceneError(f"override value {fmt_value(text)}: tables and arrays nested more "
                          f"than {MAX_DEPTH} levels deep; allowed: at most {MAX_DEPTH} levels")
    return error


def parse_override(text: str) -> tuple[str, Any]:
    """``"PATH=VALUE"`` → ``(PATH, value)`` (see :func:`parse_value`).

    Parameters
    ----------
    text : str
        ``PATH=VALUE``, spaces around ``=`` allowed.

    Returns
    -------
    (str, object)
        The path and the parsed value.

    Raises
    ------
    mechrel.errors.SceneError
        The text has no ``=`` or no path.

    Examples
    --------
    >>> parse_override("joints.C1.clearance = 0.3e-3")
    ('joints.C1.clearance', 0.0003)
    >>> parse_override("joints.C1.clearance")
    Traceback (most recent call last):
    ...
    mechrel.errors.SceneError: override "joints.C1.clearance": expected PATH=VALUE; ...
    """
    if not isinstance(text, str) or "=" not in text:
        raise SceneError(f"override {fmt_value(text)}: expected PATH=VALUE; allowed: e.g. "
                         "joints.C1.clearance=0.3e-3 or joints.C1.model=dry")
    path, _, value = text.partition("=")
    try:
        return path.strip(), parse_value(value)
    except SceneError as exc:  # a value nested too deeply: say which path it was for
        raise SceneError(f"{path.strip()}: {exc}", path=path.strip()) from None


def _normalise_overrides(overrides: Any) -> list[tuple[str, Any, str]]:
    """(path, value, text for messages) triples."""
    if overrides is None:
        return []
    if isinstance(overrides, Mapping):
        return [(str(k), v, f"{k}={fmt_value(v)}") for k, v in overrides.items()]
    if isinstance(overrides, str):
        overrides = [overrides]
    out = []
    try:
        items = list(overrides)
    except TypeError:
        raise SceneError(f"overrides {fmt_value(overrides)}: not a mapping or a sequence; allowed: "
                         "a mapping {path: value} or a sequence of 'PATH=VALUE' strings") from None
    for item in items:
        if isinstance(item, str):
            p, v = parse_override(item)
            out.append((p, v, item.strip()))
        elif isinstance(item, (tuple, list)) and len(item) == 2 and isinstance(item[0], str):
            out.append((item[0], item[1], f"{item[0]}={fmt_value(item[1])}"))
        else:
            raise SceneError(f"override {fmt_value(item)}: not a 'PATH=VALUE' string; allowed: "
                             "e.g. joints.C1.clearance=0.3e-3")
    return out


# Two derived paths (docs/scenes.md, "Overrides"): one component of an array value, and the
# distance between two points of one body (or of the ground).
_COMPONENT_RE = re.compile(r"(?P<base>.+)\[(?P<index>\d+)\]\Z")
_LENGTH_RE = re.compile(r"(?P<owner>ground|bodies\.[A-Za-z_][A-Za-z0-9_]*)\.length\("
                        r"(?P<fixed>[A-Za-z_][A-Za-z0-9_]*),(?P<moved>[A-Za-z_][A-Za-z0-9_]*)\)\Z")
_LENGTH_FORM = "OWNER.length(P,Q) with OWNER 'ground' or 'bodies.NAME' and P, Q two of its points"


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _length_points(raw: Mapping, m: re.Match, source: str | None):
    """``(points table path, P, Q)`` of a matched ``OWNER.length(P,Q)`` path: the body's
    ``global_points`` where it is written by them (a distance is the same in either frame)."""
    table = f"{m['owner']}.points"
    owner = raw.get("bodies", {}).get(m["owner"][7:]) if m["owner"] != "ground" else None
    if isinstance(owner, Mapping) and "global_points" in owner and "points" not in owner:
        table = f"{m['owner']}.global_points"
    return (table, get_value(raw, f"{table}.{m['fixed']}", source=source),
            get_value(raw, f"{table}.{m['moved']}", source=source))


def _component(raw: Mapping, m: re.Match, where: str, path: str,
               source: str | None) -> tuple[Any, int]:
    """``(array, i)`` of a matched ``PATH[i]`` path; a :class:`SceneError` starting with
    ``where`` when the value at PATH has no component i."""
    array = get_value(raw, m["base"], source=source)
    i = int(m["index"])
    if isinstance(array, (str, Mapping)) or not isinstance(array, (list, tuple)) \
            or i >= len(array):
        raise SceneError(f"{where}: '{m['base']}' = {fmt_value(array)} has no component {i}; "
                         "allowed: an index below the array's length", source=source, path=path)
    return array, i


def get_value(raw: Mapping, path: str, *, source: str | None = None) -> Any:
    """The value at the dotted ``path`` of a scene's raw mapping, including the derived paths
    that :func:`apply_override` sets: ``PATH[i]`` (component ``i`` of an array, e.g.
    ``ground.points.O4[0]``) and ``OWNER.length(P,Q)`` (the distance |Q − P| in m between
    points P and Q of a body, e.g. ``bodies.crank.length(O,A)``, or of the ground).

    Parameters
    ----------
    raw : mapping
        A scene's raw mapping (``Scene.raw``).
    path : str
        The dotted path.
    source : str, optional
        The scene's file, for the message.

    Returns
    -------
    object
        The value (a length in m for ``length(P,Q)``).

    Raises
    ------
    mechrel.errors.SceneError
        The path is not in the scene (the message names it).

    Examples
    --------
    >>> raw = load_scene("slider-crank").raw
    >>> get_value(raw, "drivers.crank.law"), get_value(raw, "bodies.crank.length(O,A)")
    ('constant-speed', 0.05)
    >>> get_value(raw, "bodies.crank.points.A[0]")
    0.025
    """
    m = _LENGTH_RE.match(path)
    if m:
        _, p, q = _length_points(raw, m, source)
        return math.hypot(q[0] - p[0], q[1] - p[1])
    m = _COMPONENT_RE.match(path)
    if m:
        array, i = _component(raw, m, path, path, source)
        return array[i]
    node: Any = raw
    for part in path.split("."):
        if not isinstance(node, Mapping) or part not in node:
            raise SceneError(f"{path}: not a value of the scene (no {part!r} there); allowed: a "
                             "dotted scene path like joints.C1.clearance, PATH[i] for a "
                             f"component of an array, or {_LENGTH_FORM}", source=source,
                             path=path)
        node = node[part]
    return node


def _derived_override(raw: dict, path: str, value: Any, text: str,
                      source: str | None) -> tuple[str, Any] | None:
    """The plain (path, value) that a derived path stands for, or None for a plain path.

    ``PATH[i] = x`` sets component i of the array at PATH. ``OWNER.length(P,Q) = L`` moves Q
    along the line from P through Q so that |Q − P| = L exactly:
    Q' = P + L (Q − P)/|Q − P| (P, the direction and every other point stay)."""
    m = _LENGTH_RE.match(path)
    if m:
        table, p, q = _length_points(raw, m, source)
        d = math.hypot(q[0] - p[0], q[1] - p[1])
        if not (_is_number(value) and math.isfinite(value) and value > 0):
            raise SceneError(f"override '{text}': a length must be a number > 0 (m); allowed: "
                             "a positive distance", source=source, path=path)
        if not d > 0:
            raise SceneError(f"override '{text}': points {m['fixed']} and {m['moved']} of "
                             f"{m['owner']} coincide, so the line along which {m['moved']} "
                             "moves is undefined; allowed: two distinct points",
                             source=source, path=path)
        s = value / d
        return (f"{table}.{m['moved']}",
                [p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])])
    m = _COMPONENT_RE.match(path)
    if m:
        array, i = _component(raw, m, f"override '{text}'", path, source)
        new = list(array)
        new[i] = value
        return m["base"], new
    if "(" in path or "[" in path:
        raise SceneError(f"override '{text}': malformed path '{path}'; allowed: a dotted path, "
                         f"PATH[i] for a component of an array, or {_LENGTH_FORM}",
                         source=source, path=path)
    return None


def apply_override(raw: dict, path: str, value: Any, *, text: str | None = None,
                   source: str | None = None) -> None:
    """Set the dotted ``path`` of ``raw`` (in place) to ``value``, checking the path against the
    scene layout: every step must be a known field or an existing named entry, and only the
    last step may be a non-table field. Missing fixed sub-tables (``[solver]``,
    ``[joints.X.lubricant]``, ...) are created.

    Two derived paths set part of a value (see :func:`get_value`): ``PATH[i]`` one component
    of an array (``ground.points.O4[0]``), and ``OWNER.length(P,Q)`` the distance between two
    points of a body or of the ground, by moving Q along the line from P through Q.

    Parameters
    ----------
    raw : dict
        A mutable raw scene mapping (:func:`thaw` of ``Scene.raw``), changed in place.
    path : str
        The dotted path.
    value : object
        The new value (SI units).
    text : str, optional
        The override as the user wrote it, for messages.
    source : str, optional
        The scene's file, for messages.

    Raises
    ------
    mechrel.errors.SceneError
        Unknown or malformed path, or a value that cannot go there.

    Examples
    --------
    >>> raw = thaw(load_scene("slider-crank").raw)
    >>> apply_override(raw, "bodies.crank.length(O,A)", 0.06)
    >>> get_value(raw, "bodies.crank.length(O,A)")
    0.06
    >>> try:
    ...     apply_override(raw, "joints.C.clearence", 1e-4)
    ... except SceneError as err:
    ...     print(err)
    override 'joints.C.clearence=0.0001': unknown field 'clearence' at 'joints.C.clearence'
    (did you mean 'clearance'?); allowed: fields type, connects, model, clearance, ...
    """
    text = text or f"{path}={fmt_value(value)}"
    derived = _derived_override(raw, path, value, text, source)
    if derived is not None:
        path, value = derived

    def fail(problem: str, allowed: str) -> None:
        raise SceneError(f"override '{text}': {problem}; allowed: {allowed}", source=source,
                         path=path)

    parts = path.split(".")
    if not path or any(not p for p in parts):
        fail(f"malformed path '{path}'", "a dotted path of field names, e.g. joints.C1.clearance")
    node: Any = SCHEMA
    cur: dict = raw
    for i, seg in enumerate(parts):
        here = ".".join(parts[: i + 1])
        last = i == len(parts) - 1
        if isinstance(node, Named):
            child = node.child
            if seg not in cur:
                known = list(cur)
                if not last or child is not None and not isinstance(value, Mapping):
                    fail(f"unknown {node.what} '{seg}' at '{here}'{suggest(seg, known)}",
                         f"one of {', '.join(known)}" if known else f"no {node.what} is defined")
        else:
            if seg not in node:
                keys = list(node)
                fail(f"unknown field '{seg}' at '{here}'{suggest(seg, keys)}",
                     "fields " + ", ".join(keys))
            child = node[seg]
        if last:
            cur[seg] = thaw(value)
            table_path = ".".join(parts[:-1])
            for a, b in EXCLUSIVE.get(table_path, ()):
                if seg == a:
                    cur.pop(b, None)
                elif seg == b:
                    cur.pop(a, None)
            return
        if child is None:
            fail(f"'{here}' is a value, not a table, so '{path}' cannot be set",
                 f"'{here}' itself, e.g. {here}=...")
        if seg not in cur:
            cur[seg] = {}
        elif not isinstance(cur[seg], Mapping):
            fail(f"'{here}' = {fmt_value(cur[seg])} is not a table", f"'{here}' itself")
        elif not isinstance(cur[seg], dict):
            cur[seg] = thaw(cur[seg])
        cur = cur[seg]
        node = child


# ----------------------------------------------------------------------------- public API

def _finish(raw: Any, label: str, scene_source: str | None,
            overridden: Sequence[tuple[str, str]]) -> Scene:
    scene = build_scene(raw, label, overridden)
    return dataclasses.replace(scene, source=scene_source, raw=freeze(scene_to_raw(scene)))


def load_scene(source: SceneSource, *, overrides: Overrides = ()) -> Scene:
    """Load and validate a scene.

    ``source``: an embedded scene name (``"nine-bar"``, see :func:`list_scenes`), a path to a
    TOML file (``str`` or ``Path``), an already-parsed mapping, or a :class:`Scene` (then this is
    :func:`with_overrides`). A top-level ``extends = NAME_OR_PATH`` deep-merges the file over
    its base. ``overrides``: ``{"joints.C1.clearance": 0.3e-3}`` or ``["joints.C1.clearance=0.3e-3",
    "joints.C1.model=dry"]``; applied in order to the raw mapping before validation.

    Parameters
    ----------
    source : str, Path, mapping or Scene
        The scene: an embedded name, a TOML file, a parsed mapping or a scene.
    overrides : mapping or sequence of str, optional
        ``{dotted path: value}`` or ``"dotted.path=VALUE"`` strings (values in SI units, as
        in the file), applied in order before validation.

    Returns
    -------
    Scene
        Frozen, validated; values in SI units.

    Raises
    ------
    SceneError
        One error for any problem, naming the source, the field path, the value and what is
        allowed (and the override that set it).

    Examples
    --------
    >>> scene = load_scene("nine-bar-dry", overrides={"joints.C1.clearance": 0.3e-3})
    >>> scene.joints["C1"].model, scene.joints["C1"].clearance
    ('dry', 0.0003)
    >>> load_scene("nine-bar-dry", overrides=["joints.C1.clearance=-1"])
    Traceback (most recent call last):
    ...
    mechrel.errors.SceneError: embedded:nine-bar-dry: joints.C1.clearance = -1...
    """
    if isinstance(source, Scene):
        return with_overrides(source, overrides)
    doc, scene_source = _read_source(source)
    raw = _resolve_extends(doc)
    ovs = _normalise_overrides(overrides)
    if ovs:
        if not isinstance(raw, Mapping):
            build_scene(raw, doc.label)  # raises: not a table
        raw = thaw(raw)
        for path, value, text in ovs:
            apply_override(raw, path, value, text=text, source=doc.label)
    return _finish(raw, doc.label, scene_source, [(p, t) for p, _, t in ovs])


def with_overrides(scene: Scene, overrides: Overrides) -> Scene:
    """A new scene: ``scene``'s raw mapping with ``overrides`` applied, validated again.

    Parameters
    ----------
    scene : Scene
        The scene to start from (left unchanged).
    overrides : mapping or sequence of str
        As for :func:`load_scene`.

    Returns
    -------
    Scene
        The new scene (same source).

    Raises
    ------
    SceneError
        An override naming an unknown field or setting a value the scene refuses.

    Examples
    --------
    >>> base = load_scene("slider-crank-dry")
    >>> changed = with_overrides(base, ["joints.C.friction.coefficient=0.05"])
    >>> changed.joints["C"].friction.coefficient, base.joints["C"].friction.coefficient
    (0.05, 0.01)
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"with_overrides: scene must be a Scene, got {type(scene).__name__} "
                        f"{scene!r:.60}; to load and override in one call: "
                        "load_scene(source, overrides=...)")
    raw = thaw(scene.raw) if scene.raw else scene_to_raw(scene)
    ovs = _normalise_overrides(overrides)
    label = scene.source or _MAPPING_LABEL
    for path, value, text in ovs:
        apply_override(raw, path, value, text=text, source=label)
    return _finish(raw, label, scene.source, [(p, t) for p, _, t in ovs])


def _json_table(value: Any) -> dict:
    """``default`` of the canonical encoder: a frozen table (``MappingProxyType``) as a dict."""
    if isinstance(value, Mapping):
        return dict(value)
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


# The frozen raw mapping is encoded as it is: tables through _json_table, arrays (tuples) as
# JSON arrays like lists. The same text as encoding a thawed copy, without making the copy
# (which took three quarters of the time).
_CANONICAL_ENCODER = json.JSONEncoder(sort_keys=True, separators=(",", ":"),
                                      ensure_ascii=False, allow_nan=False, default=_json_table)


def canonical_json(scene: Scene) -> str:
    """Canonical JSON of the scene's raw mapping (sorted keys, no spaces, exact floats).

    Parameters
    ----------
    scene : mechrel.scene.model.Scene
        The scene.

    Returns
    -------
    str
        The JSON text (what :func:`scene_hash` hashes).

    Examples
    --------
    >>> canonical_json(load_scene("slider-crank"))[:40]
    '{"analysis":{"cycle_driver":"crank","cyc'
    """
    raw = scene.raw if scene.raw else scene_to_raw(scene)
    return _CANONICAL_ENCODER.encode(raw)


def scene_hash(scene: Scene) -> str:
    """SHA-256 (hex) of :func:`canonical_json`: equal for scenes with the same content whatever
    the file layout, formatting, defaults written out or not; different when any value differs.
    The source path is not part of it.

    Computed once per :class:`Scene` object and kept on it (every :func:`~mechrel.simulate`
    records it in its provenance): a scene is frozen, so its hash cannot change. A scene built
    directly from mutable mappings that are changed afterwards would keep a stale hash, as it
    would keep stale validation.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    str
        64 hexadecimal digits.

    Examples
    --------
    >>> a = load_scene("nine-bar-dry")
    >>> b = load_scene("nine-bar-dry", overrides={"joints.C1.clearance": 0.3e-3})
    >>> len(scene_hash(a)), scene_hash(a) == scene_hash(b)
    (64, False)
    >>> back = with_overrides(b, {"joints.C1.clearance": a.joints["C1"].clearance})
    >>> scene_hash(back) == scene_hash(a)
    True
    """
    cached = scene.__dict__.get("_scene_hash")
    if cached is None:
        cached = hashlib.sha256(canonical_json(scene).encode("utf-8")).hexdigest()
        object.__setattr__(scene, "_scene_hash", cached)  # not a field: eq/repr/replace ignore it
    return cached
