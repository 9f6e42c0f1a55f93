"""Scenes that differ from one scene only in values at fixed paths (a sample of a study).

:class:`SceneValues` gives, for each set of values, the scene that
:func:`~mechrel.scene.with_overrides` gives (equal, the same canonical raw mapping and so the
same :func:`~mechrel.scene.scene_hash`), and for a value the scene refuses the same
:class:`~mechrel.errors.SceneError` with the same message. It gets there by running the
validation (:mod:`mechrel.scene._validate`, the one statement of every rule) on the tables the
values sit in, not on the whole scene:

* the values go into a copy of the raw mapping by :func:`~mechrel.scene.loader.apply_override`,
  as overrides do (so derived paths ``PATH[i]`` and ``OWNER.length(P,Q)`` and their checks are
  the same), copying only the tables on their way;
* a joint, a body or the ground points whose table holds a value is validated again by the
  builder's own method for one joint, one body or the ground (a joint's sub-tables that hold
  none of the values, its model unchanged, are the scene's: they passed the same checks with
  the same content; when the values are floats at a revolute joint's numeric fields, its
  type, points, model, other fields and other parameters are the scene's too, every rule
  that reads a changed value runs, and only the changed fields of its raw table are written
  again); a change of the points or of a joint's type or connects
  also runs the check of zero-length links, a change of a joint the outputs' (they
  name joints), a change of a driver the drivers' table and the analysis' (which reads the
  cycle driver's speed);
* the tables that hold none of the values are taken from the scene as they are: they passed
  the same rules with the same content, and the rules of one table read the others only for
  what these values cannot change (the names of bodies, points and joints, a joint's type),
  which ``tests/test_scene_values.py`` checks on the builder itself.

Validation runs in the order of a full build, so that of two bad values the one a full build
reports first is reported. Values at any other path (the solver, a body's mass, the
analysis, gravity) go through :func:`~mechrel.scene.with_overrides` as they are.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

from .._checks import fmt_value
from ._validate import _Builder, _pair, body_to_raw, driver_to_raw, joint_to_raw
from .loader import (_COMPONENT_RE, _LENGTH_RE, _MAPPING_LABEL, apply_override, freeze,
                     with_overrides)
from .model import SUBTABLE_CLASSES, Scene

__all__ = ["SceneValues", "table_of", "value_path"]



def value_path(path: str) -> str:
    """The plain dotted path a value is set at: a derived path ``PATH[i]`` sets PATH,
    ``OWNER.length(P,Q)`` the point ``OWNER.points.Q``; another path is itself.

    Parameters
    ----------
    path : str
        A dotted scene path (without a leading ``-``).

    Returns
    -------
    str
        The plain path.

    Examples
    --------
    >>> value_path("bodies.crank.length(O,A)"), value_path("ground.points.O[1]")
    ('bodies.crank.points.A', 'ground.points.O')
    """
    m = _LENGTH_RE.match(path)
    if m:
        return f"{m['owner']}.points.{m['moved']}"
    m = _COMPONENT_RE.match(path)
    return m["base"] if m else path


def table_of(path: str) -> tuple[str, ...] | None:
    """The table a dotted scene path sets a value in: ``("ground",)``, ``("body", NAME)``,
    ``("joint", NAME)`` or ``("drivers",)``, or None for a path elsewhere.

    Derived paths count as the value they set: ``PATH[i]`` as PATH, ``OWNER.length(P,Q)`` as
    the point Q of OWNER.

    Parameters
    ----------
    path : str
        A dotted scene path (without a leading ``-``).

    Returns
    -------
    tuple of str or None
        The table.

    Examples
    --------
    >>> table_of("bodies.crank.length(O,A)"), table_of("joints.C1.lubricant.viscosity")
    (('body', 'crank'), ('joint', 'C1'))
    >>> table_of("drivers.crank.speed"), table_of("solver.rtol") is None
    (('drivers',), True)
    """
    parts = value_path(path).split(".")
    if len(parts) == 3 and parts[:2] == ["ground", "points"]:
        return ("ground",)
    if len(parts) >= 3 and parts[0] == "bodies":
        return ("body", parts[1])
    if len(parts) >= 3 and parts[0] == "joints":
        return ("joint", parts[1])
    if len(parts) >= 3 and parts[0] == "drivers":
        return ("drivers",)
    return None


def _spine(raw: Mapping, path: str | tuple[str, ...]) -> dict:
    """A copy of ``raw`` in which the tables on the way to ``path`` (or to the plain path
    ``value_path(path)`` split at its dots) are dicts of their own (the others are shared,
    frozen), so that :func:`apply_override` writes into copies only."""
    top = raw if isinstance(raw, dict) else dict(raw)
    cur = top
    for seg in (value_path(path).split(".") if isinstance(path, str) else path)[:-1]:
        child = cur.get(seg)
        if not isinstance(child, Mapping):
            break  # missing or not a table: apply_override creates it or refuses the path
        if not isinstance(child, dict):
            child = cur[seg] = dict(child)
        cur = child
    return top


#: A revolute joint's fields other than its type, points, model and sub-tables: kept as the
#: scene's when the values change other fields of the joint only.
_NUMERIC_KEPT = ("clearance", "bearing_radius", "length", "initial_eccentricity",
                 "initial_eccentricity_rate")


def _output_facts(joint) -> tuple[str, bool]:
    """What the outputs' validation reads of a joint (besides its name): its type and whether
    it has a clearance (an output of kind ``joint`` needs a revolute joint with one)."""
    return joint.type, joint.type == "revolute" and joint.clearance > 0


class _OverrideText:
    """``PATH=VALUE`` of a value, worded only when a message names it (``str``)."""

    __slots__ = ("path", "value")

    def __init__(self, path, value):
        self.path, self.value = path, value

    def __str__(self) -> str:
        return f"{self.path}={fmt_value(self.value)}"


class SceneValues:
    """The scenes of ``scene`` with values at ``paths`` (see the module docstring).

    Parameters
    ----------
    scene : Scene
        The validated scene the values are set in.
    paths : sequence of str
        The dotted scene paths whose values change (as overrides name them).

    Examples
    --------
    >>> from mechrel.scene import load_scene, scene_hash, with_overrides
    >>> base = load_scene("nine-bar-lubricated")
    >>> at = SceneValues(base, ["joints.C1.clearance", "drivers.crank1.speed"])
    >>> values = {"joints.C1.clearance": 4e-4, "drivers.crank1.speed": -9.0}
    >>> scene_hash(at(values)) == scene_hash(with_overrides(base, values))
    True
    """

    def __init__(self, scene: Scene, paths: Sequence[str]):
        self.scene = scene
        self.label = scene.source or _MAPPING_LABEL
        tables = [table_of(p) for p in paths]
        # only the tables of existing joints, bodies and drivers are validated on their own
        self.incremental = bool(scene.raw) and all(
            t is not None and (t[0] != "joint" or t[1] in scene.joints)
            and (t[0] != "body" or t[1] in scene.bodies) for t in tables)
        # a plain path (not PATH[i] or OWNER.length(P,Q)) to a number of the scene: what
        # apply_override checks of it does not depend on the value (the schema, the tables on
        # the way), so it is checked once here and a value is then set at its place directly
        self._leaves: dict[str, tuple[str, ...]] = {}
        self._parts = {p: tuple(value_path(p).split(".")) for p in paths}
        for path in paths if self.incremental else ():
            if _LENGTH_RE.match(path) or _COMPONENT_RE.match(path):
                continue
            parts = tuple(path.split("."))
            node: Any = scene.raw
            for part in parts:
                node = node.get(part) if isinstance(node, Mapping) else None
            if isinstance(node, float):
                apply_override(_spine(scene.raw, path), path, node, source=self.label)
                self._leaves[path] = parts
        self.joints = tuple(n for n in scene.joints if ("joint", n) in tables)
        # per joint, its sub-tables no value sits in (and the model not among the values):
        # their content and the model are the scene's, so their validation is the scene's
        self._keep: dict[str, dict[str, Any]] = {}
        for name in self.joints:
            fields = {value_path(p).split(".")[2] for p in paths
                      if table_of(p) == ("joint", name)}
            joint = scene.joints[name]
            if "model" not in fields and joint.type == "revolute":
                self._keep[name] = {k: getattr(joint, k) for k in SUBTABLE_CLASSES
                                    if k not in fields}
        # per joint whose values are numbers at its numeric fields only (plain paths to floats
        # of the scene: its clearance, radius, length, sub-table parameters): with float values
        # the rest of it is kept too (its type, points, model, other fields and parameters),
        # and its raw table is the scene's with the changed fields written again
        self._numeric: dict[str, tuple[dict, tuple[str, ...]]] = {}
        self._joint_of = {p: t[1] for p, t in zip(paths, tables)
                          if t is not None and t[0] == "joint"}
        for name in self.joints:
            joint = scene.joints[name]
            mine = [p for p, n in self._joint_of.items() if n == name]
            if joint.type != "revolute" or not all(p in self._leaves for p in mine) \
                    or scene.raw["joints"][name] != freeze(joint_to_raw(joint)):
                continue
            fields = tuple(dict.fromkeys(self._leaves[p][2] for p in mine))
            keep: dict[Any, Any] = {**self._keep.get(name, {}), "type": joint.type,
                                    "connects": joint.points, "model": joint.model}
            keep.update({f: getattr(joint, f) for f in _NUMERIC_KEPT if f not in fields})
            for sub in SUBTABLE_CLASSES:
                if sub in fields:
                    changed = {self._leaves[p][3] for p in mine if self._leaves[p][2] == sub}
                    table = getattr(joint, sub)
                    keep["params", sub] = {f.name: getattr(table, f.name)
                                           for f in dataclasses.fields(table)
                                           if f.name not in changed}
            self._numeric[name] = (keep, fields)
        self.bodies = tuple(n for n in scene.bodies if ("body", n) in tables)
        self.ground = ("ground",) in tables
        self.drivers = ("drivers",) in tables
        # the check of zero-length links reads the points and the joints' type and points:
        # with none of them among the values it passes as it did for the scene
        self._links = self.ground or bool(self.bodies) or any(
            value_path(p).split(".")[2].split("[")[0] in ("type", "connects")
            for p in paths if table_of(p) is not None and table_of(p)[0] == "joint")

    def __call__(self, values: Mapping[str, Any]) -> Scene:
        return self.validate(values)[0]

    def validate(self, values: Mapping[str, Any]) -> tuple[Scene, Mapping[str, Any]]:
        """The scene with ``values`` set.

        Parameters
        ----------
        values : mapping
            ``{dotted path: value}`` at (some of) the paths given (SI units).

        Returns
        -------
        Scene
            The scene :func:`~mechrel.scene.with_overrides` gives for ``values``.
        dict
            The packed force-law parameters of the clearance joints validated again, by joint
            name (:func:`~mechrel.forces.packing.pack_joint`: the force law's own check,
            kept for the compiled scene); empty when the scene was validated in full.

        Raises
        ------
        mechrel.errors.SceneError
            As :func:`~mechrel.scene.with_overrides` raises it for these values.
        """
        scene = self.scene
        if not self.incremental:
            return with_overrides(scene, values), {}
        raw: Any = scene.raw
        overrides = [(str(p), v, _OverrideText(p, v)) for p, v in values.items()]
        for path, value, text in overrides:
            raw = _spine(raw, self._parts.get(path) or path)
            parts = self._leaves.get(path)
            if parts is not None and isinstance(value, float):
                node = raw
                for part in parts[:-1]:
                    node = node[part]
                node[parts[-1]] = value
            else:
                apply_override(raw, path, value, text=str(text), source=self.label)
        b = _Builder(self.label, [(p, t) for p, _, t in overrides])
        new_raw = dict(scene.raw)
        changed: dict[str, Any] = {}
        ground, bodies, joints = scene.ground, scene.bodies, scene.joints
        # in the order of a full build (_Builder.build)
        if self.ground:
            ground = MappingProxyType(b._ground(raw.get("ground", {})))
            changed["ground"] = ground
            new_raw["ground"] = freeze({"points": {k: _pair(v) for k, v in ground.items()}})
        if self.bodies:
            bodies = dict(bodies)
            table = dict(new_raw["bodies"])
            for name in self.bodies:
                bodies[name] = b._body(name, raw["bodies"][name])
                table[name] = freeze(body_to_raw(bodies[name]))
            bodies = changed["bodies"] = MappingProxyType(bodies)
            new_raw["bodies"] = MappingProxyType(table)
        if self.joints:
            joints = dict(joints)
            table = dict(new_raw["joints"])
            # a joint with a value that is not a float is validated as any other table
            other = {self._joint_of[p] for p, v, _ in overrides
                     if p in self._joint_of and not isinstance(v, float)}
            for name in self.joints:
                numeric = self._numeric.get(name) if name not in other else None
                if numeric is None:
                    joints[name] = b._joint(name, raw["joints"][name], bodies, ground,
                                            self._keep.get(name))
                    table[name] = freeze(joint_to_raw(joints[name]))
                else:
                    keep, fields = numeric
                    joints[name] = b._joint(name, raw["joints"][name], bodies, ground, keep)
                    table[name] = MappingProxyType(
                        {**table[name], **freeze(joint_to_raw(joints[name], fields))})
            joints = changed["joints"] = MappingProxyType(joints)
            new_raw["joints"] = MappingProxyType(table)
        if self._links:
            b._zero_length_links(bodies, joints)
        drivers = scene.drivers
        if self.drivers:
            drivers = changed["drivers"] = MappingProxyType(
                b._drivers(raw.get("drivers", {}), bodies))
            new_raw["drivers"] = freeze({n: driver_to_raw(d) for n, d in drivers.items()})
        # the outputs' rules read of a joint its name, its type and whether it has a
        # clearance: with those unchanged the outputs are the scene's
        if any(_output_facts(joints[n]) != _output_facts(scene.joints[n]) for n in self.joints):
            changed["outputs"] = MappingProxyType(
                b._outputs(raw.get("outputs", {}), bodies, ground, joints))
        if self.drivers:
            changed["analysis"] = b._analysis(raw["analysis"], drivers)
        return dataclasses.replace(scene, raw=MappingProxyType(new_raw), **changed), b.packed
