"""Validation: a raw scene mapping (parsed TOML, after ``extends`` and overrides) → a frozen
:class:`~mechrel.scene.model.Scene`, and the inverse (a scene's canonical raw mapping).

Every problem raises one :class:`~mechrel.errors.SceneError` whose message reads
``SOURCE: PATH = VALUE: PROBLEM; allowed: WHAT`` (``SOURCE`` is the file or ``<mapping>``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import fields
from types import MappingProxyType
from typing import Any, cast

from .._checks import _MISSING, _one_of, _typename, describe_number, fmt_value, join, suggest
from .._checks import Checker as _Checker
from ..errors import SceneError
from ..forces.models import MODELS, PARAMS, SUBTABLE_PARAMS
from ..forces.packing import pack_joint
from ._schema import (
    ANALYSIS_KEYS, BODY_KEYS, DRIVER_KEYS, DRIVER_KEYS_BY_LAW, JOINT_KEYS, JOINT_KEYS_BY_TYPE,
    JOINT_TYPES, NAME_RE, NAME_RULE, SOLVER_KEYS, TOP_KEYS,
)
from .model import (
    DRIVER_LAWS, FORMULATIONS, GROUND, INTEGRATOR_NAMES, MAX_STEPS_LIMIT, SUBTABLE_CLASSES,
    Analysis, Body, Driver, Joint, Output, PointRef, Scene, Solver, SubTable,
)

COINCIDENT_TOL = 1e-9  # m: two joint points closer than this on one body form a zero-length link
_LINE_JOINTS = ("translational", "pin-in-slot")  # a point on a line of another body


class Checker(_Checker):
    """The validation toolkit's checker (:mod:`mechrel._checks`), raising
    :class:`~mechrel.errors.SceneError`, with the scene's names."""

    error = SceneError

    def name(self, path: str, name: str, what: str) -> str:
        if not isinstance(name, str) or not NAME_RE.match(name):
            self.fail(path, name, f"invalid {what} name", NAME_RULE)
        return name


# ----------------------------------------------------------------------------- builder

def _to_body_frame(g, position, angle) -> tuple[float, float]:
    """A point given in ground coordinates at the initial configuration, ``g``, in the frame of
    a body whose centre of mass is at ``position`` with angle ``angle`` there:
    ``s = A(angle)ᵀ (g − position)`` (m); for angle 0 (cos 1, sin 0 exactly) simply
    ``g − position``."""
    dx, dy = g[0] - position[0], g[1] - position[1]
    c, sn = math.cos(angle), math.sin(angle)
    return (c * dx + sn * dy, -sn * dx + c * dy)


_REQUIRED_HINTS = {
    "name": "a string naming the scene",
    "bodies": "a [bodies.NAME] table per moving body",
    "analysis": "an [analysis] table (duration or cycles, sample_step or sample_step_angle)",
    "mass": describe_number(gt=0, unit="kg"),
    "inertia": describe_number(gt=0, unit="kg m^2"),
    "position": "a pair [x, y] of finite numbers (m)",
    "type": _one_of(JOINT_TYPES),
    "connects": "an array of point references 'body.point'",
    "direction": "a pair [x, y] of finite numbers, not both zero",
    "angle": describe_number(unit="rad"),
    "body": "the name of a moving body",
    "law": _one_of(DRIVER_LAWS),
    "angle0": describe_number(unit="rad"),
    "speed": describe_number(unit="rad/s"),
    "acceleration": describe_number(unit="rad/s^2"),
    "amplitude": describe_number(unit="rad"),
    "frequency": describe_number(ge=0, unit="rad/s"),
    "ramp_time": describe_number(gt=0, unit="s"),
    "point": "a point reference 'body.point' on a moving body",
    "axis": "a pair [x, y] of finite numbers, not both zero",
}


#: Per driver law, its required values besides body, law and angle0.
_DRIVER_REQUIRED = {"constant-speed": ("speed",), "constant-acceleration": ("acceleration",),
                    "harmonic": ("amplitude", "frequency"), "smooth-start": ("speed", "ramp_time")}
#: Per driver law, the hint an unknown field gets when it is another law's field.
_DRIVER_HINTS = {law: {k: f" (not used by law '{law}')" for k in DRIVER_KEYS}
                 for law in DRIVER_KEYS_BY_LAW}
#: A driver value's unit and lower bound (``ge``; None: none).
_DRIVER_UNITS = {"speed": ("rad/s", None), "acceleration": ("rad/s^2", None),
                 "amplitude": ("rad", None), "frequency": ("rad/s", 0), "phase": ("rad", None),
                 "ramp_time": ("s", None)}

#: Per joint type, the hint an unknown field gets when it is another type's field.
_JOINT_HINTS = {jtype: {k: f" ('{k}' belongs to "
                           f"{' or '.join(t for t, ks in JOINT_KEYS_BY_TYPE.items() if k in ks)} "
                           "joints)" for k in JOINT_KEYS if k not in own}
                for jtype, own in JOINT_KEYS_BY_TYPE.items()}


class _Builder(Checker):
    required_hints = _REQUIRED_HINTS

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # the packed force-law parameters of each clearance joint validated, by joint name
        # (pack_joint is the force law's check: its product is kept for the compiled scene)
        self.packed: dict[str, Any] = {}

    def build(self, raw: Any) -> Scene:
        top = self.table("", raw)
        self.keys("", top, TOP_KEYS, required=("name", "bodies", "analysis"), what="a scene",
                  hints={"extends": " ('extends' must be resolved by load_scene)"})
        name = self.string("name", top["name"], "a non-empty string")
        if not name.strip():
            self.fail("name", name, "empty scene name", "a non-empty string")
        description = self.string("description", top.get("description", ""))
        gravity = self.vec2("gravity", top.get("gravity", (0.0, -9.81)), unit="m/s^2")
        ground = self._ground(top.get("ground", {}))
        bodies = self._bodies(top["bodies"])
        joints = self._joints(top.get("joints", {}), bodies, ground)
        self._zero_length_links(bodies, joints)
        drivers = self._drivers(top.get("drivers", {}), bodies)
        outputs = self._outputs(top.get("outputs", {}), bodies, ground, joints)
        analysis = self._analysis(top["analysis"], drivers)
        solver = self._solver(top.get("solver", {}))
        return Scene(
            name=name, description=description, bodies=MappingProxyType(bodies),
            ground=MappingProxyType(ground), joints=MappingProxyType(joints),
            drivers=MappingProxyType(drivers), outputs=MappingProxyType(outputs),
            analysis=analysis, solver=solver, gravity=gravity,
        )

    # -- ground and bodies
    def _points(self, path: str, v: Any, what: str) -> dict[str, tuple[float, float]]:
        pts = self.table(path, v, "a table of named points NAME = [x, y] (m)")
        out = {}
        for pn, pv in pts.items():
            self.name(join(path, pn), pn, what)
            out[pn] = self.vec2(join(path, pn), pv, unit="m")
        return out

    def _ground(self, v: Any) -> dict:
        g = self.table("ground", v, "a [ground.points] table")
        self.keys("ground", g, ("points",), what="the ground")
        return self._points("ground.points", g.get("points", {}), "ground point")

    def _bodies(self, v: Any) -> dict[str, Body]:
        bt = self.table("bodies", v, "a [bodies.NAME] table per moving body")
        if not bt:
            self.fail("bodies", v, "no bodies defined", "at least one [bodies.NAME] table")
        return {name: self._body(name, b) for name, b in bt.items()}

    def _body(self, name: str, b: Any) -> Body:
        p = join("bodies", name)
        self.name(p, name, "body")
        if name == GROUND:
            self.fail(p, b, f"the body name '{GROUND}' is reserved for the frame "
                            "(its points go in [ground.points])",
                      "any other identifier (letters, digits and underscores, no dots)")
        self.table(p, b)
        self.keys(p, b, BODY_KEYS, required=("mass", "inertia", "position"), what="a body")
        position = self.vec2(p + ".position", b["position"], unit="m")
        angle = self.number(p + ".angle", b.get("angle", 0.0), unit="rad")
        placed = None
        if "global_points" in b:
            if "points" in b:
                self.fail(p, {"points": b["points"], "global_points": b["global_points"]},
                          "both points and global_points are given",
                          "exactly one of points (body frame, m) or global_points (ground "
                          "coordinates at the initial configuration, m)")
            placed = self._points(p + ".global_points", b["global_points"], "point")
            points = {k: _to_body_frame(v, position, angle) for k, v in placed.items()}
        else:
            points = self._points(p + ".points", b.get("points", {}), "point")
        return Body(
            name=name,
            mass=self.number(p + ".mass", b["mass"], gt=0, unit="kg"),
            inertia=self.number(p + ".inertia", b["inertia"], gt=0, unit="kg m^2"),
            position=position, angle=angle, points=MappingProxyType(points),
            global_points=None if placed is None else MappingProxyType(placed),
        )

    def _ref(self, path: str, v: Any, bodies: Mapping[str, Body], ground: Mapping,
             *, ground_ok: bool = True, body_ok: bool = True) -> PointRef:
        form = "a point reference 'body.point', e.g. 'crank.A' or 'ground.O'"
        s = self.string(path, v, form)
        parts = s.split(".")
        if len(parts) != 2 or not all(parts):
            self.fail(path, v, "not a point reference", form)
        body, point = parts
        if body == GROUND:
            if not ground_ok:
                self.fail(path, v, "a ground point is not allowed here",
                          "a point on a moving body: " + _one_of(list(bodies)))
            known = list(ground)
        elif body in bodies:
            if not body_ok:
                self.fail(path, v, "must be a ground point",
                          _one_of([f"{GROUND}.{q}" for q in ground]))
            known = list(bodies[body].points)
        else:
            allowed = ([GROUND] if ground_ok else []) + list(bodies)
            self.fail(path, v, f"unknown body '{body}'{suggest(body, allowed)}",
                      "a point on " + _one_of(allowed))
        if point not in known:
            self.fail(path, v, f"unknown point '{point}' on {body}{suggest(point, known)}",
                      _one_of([f"{body}.{q}" for q in known]))
        return PointRef(body, point)

    def _refs(self, path: str, v: Any, n: int, what: str) -> Sequence:
        allowed = f"an array of {n} point reference{'s' if n > 1 else ''} 'body.point'"
        if v is _MISSING:
            self.fail(path, v, "missing required field", allowed)
        if isinstance(v, str) or not isinstance(v, (list, tuple)):
            self.fail(path, v, f"expected an array, got {_typename(v)}", allowed)
        if len(v) != n:
            self.fail(path, v, f"{what} connects {n} point{'s' if n > 1 else ''}, got {len(v)}",
                      allowed)
        return v

    # -- joints
    def _joints(self, v: Any, bodies: Mapping[str, Body], ground: Mapping) -> dict[str, Joint]:
        jt = self.table("joints", v, "a [joints.NAME] table per joint")
        return {name: self._joint(name, j, bodies, ground) for name, j in jt.items()}

    def _joint(self, name: str, j: Any, bodies: Mapping[str, Body], ground: Mapping,
               keep: Mapping[Any, Any] | None = None) -> Joint:
        """One joint; ``keep``: what of a revolute joint was validated before with the same
        content and is taken as it is (:class:`~mechrel.scene._values.SceneValues`): its
        sub-tables that hold no value (by name), the model unchanged; and, when the values are
        numbers at its numeric fields only (its ``type`` kept: the table's shape is the one
        validated), its other fields by name and, by ``("params", sub-table)``, the other
        parameters of a sub-table that holds a value. The rules that read a changed value all
        run, in their order."""
        p = join("joints", name)
        if keep and "type" in keep:  # only numbers changed: type, fields and points as before
            return self._revolute(p, name, j, bodies, ground, keep)
        self.name(p, name, "joint")
        self.table(p, j)
        if "type" not in j:
            self.fail(p + ".type", _MISSING, "missing required field", _one_of(JOINT_TYPES))
        jtype = self.choice(p + ".type", j["type"], JOINT_TYPES)
        what = f"a {jtype} joint"
        required = ("type", "connects") + {"translational": ("direction", "angle"),
                                           "pin-in-slot": ("direction",),
                                           "fixed-angle": ("angle",)}.get(jtype, ())
        if jtype in _LINE_JOINTS:
            self._no_clearance(p, j, jtype)
        self.keys(p, j, JOINT_KEYS_BY_TYPE[jtype], required=required, what=what,
                  hints=_JOINT_HINTS[jtype])
        if jtype == "revolute":
            return self._revolute(p, name, j, bodies, ground, keep or {})
        if jtype in _LINE_JOINTS:
            return self._line_joint(p, name, jtype, j, bodies, ground)
        c = self._refs(p + ".connects", j["connects"], 1, "a fixed-angle joint")
        a = self._ref(p + ".connects[0]", c[0], bodies, ground, ground_ok=False)
        return Joint(name=name, type="fixed-angle", points=(a,),
                     angle=self.number(p + ".angle", j["angle"], unit="rad"))

    def _no_clearance(self, p: str, j: Mapping, jtype: str) -> None:
        """A clearance field on a translational or pin-in-slot joint: one error saying that
        clearance there is not supported (docs/scenes.md, "Clearance joints")."""
        asked = [k for k in ("model", "clearance", "bearing_radius", "length",
                             "initial_eccentricity", "initial_eccentricity_rate",
                             *SUBTABLE_CLASSES) if k in j]
        if asked:
            k = asked[0]
            self.fail(f"{p}.{k}", j[k],
                      f"clearance in a {jtype} joint is not supported: the clearance models "
                      f"({', '.join(MODELS)}) are force laws of a journal in a circular "
                      "bearing, and a slider's play in its guide (two guide faces, the block's "
                      "corners, its tilt) is none of them",
                      f"an ideal {jtype} joint (no {', '.join(asked)}); put the clearance in a "
                      "revolute joint, e.g. the pin of the slider or of the slotted link")

    def _line_joint(self, p: str, name: str, jtype: str, j: Mapping, bodies, ground) -> Joint:
        """A translational or pin-in-slot joint: the point ``connects[0]`` on the line through
        ``connects[1]`` along ``direction`` (written in the frame of ``connects[1]``'s body,
        as that body's points are)."""
        c = self._refs(p + ".connects", j["connects"], 2, f"a {jtype} joint")
        a = self._ref(p + ".connects[0]", c[0], bodies, ground)
        b = self._ref(p + ".connects[1]", c[1], bodies, ground)
        if a.body == b.body:
            what = "the ground to itself" if a.body == GROUND else f"body '{a.body}' to itself"
            self.fail(p + ".connects", c, f"the joint connects {what}",
                      "a point of one body and a point on the line of another (or of the "
                      "ground)")
        d = self.vec2(p + ".direction", j["direction"], nonzero=True)
        norm = math.hypot(*d)
        angle = (self.number(p + ".angle", j["angle"], unit="rad")
                 if jtype == "translational" else None)
        return Joint(name=name, type=cast(Any, jtype), points=(a, b),
                     direction=(d[0] / norm, d[1] / norm), angle=angle)

    def _revolute(self, p: str, name: str, j: Mapping, bodies, ground,
                  keep: Mapping[Any, Any]) -> Joint:
        if "connects" in keep:
            a, b = keep["connects"]
        else:
            c = self._refs(p + ".connects", j["connects"], 2, "a revolute joint")
            a = self._ref(p + ".connects[0]", c[0], bodies, ground)
            b = self._ref(p + ".connects[1]", c[1], bodies, ground)
            if a.body == b.body:
                what = ("the ground to itself" if a.body == GROUND
                        else f"body '{a.body}' to itself")
                self.fail(p + ".connects", c, f"the joint connects {what}",
                          "two points on different bodies (or a body and the ground)")
        model = keep["model"] if "model" in keep else self.choice(
            p + ".model", j.get("model", "ideal"), ("ideal", *MODELS))
        ideal = model == "ideal"
        kind = f"a '{model}' clearance joint"
        if not ideal:
            for k, unit in (("clearance", "m, > 0"), ("bearing_radius", "m, > clearance"),
                            ("length", "m, > 0")):
                if k not in j:
                    self.fail(p + "." + k, _MISSING, f"missing required field of {kind}",
                              f"a finite number ({unit})")
        clearance = keep["clearance"] if "clearance" in keep else self.number(
            p + ".clearance", j.get("clearance", 0.0), ge=0, unit="m")
        if not ideal and clearance <= 0:
            self.fail(p + ".clearance", j["clearance"], f"{kind} needs a clearance > 0",
                      describe_number(gt=0, unit="m"))
        bearing_radius = length = None
        if "bearing_radius" in j:
            bearing_radius = keep["bearing_radius"] if "bearing_radius" in keep else self.number(
                p + ".bearing_radius", j["bearing_radius"], gt=0, unit="m")
            if clearance >= bearing_radius:
                self.fail(p + ".clearance", j.get("clearance", 0.0),
                          f"the radial clearance must be smaller than bearing_radius = "
                          f"{fmt_value(bearing_radius)} (the journal radius is bearing_radius - "
                          f"clearance)", "0 < clearance < bearing_radius (m)")
        if "length" in j:
            length = keep["length"] if "length" in keep else self.number(
                p + ".length", j["length"], gt=0, unit="m")
        ecc = keep["initial_eccentricity"] if "initial_eccentricity" in keep else self.vec2(
            p + ".initial_eccentricity", j.get("initial_eccentricity", (0.0, 0.0)), unit="m")
        if (not ideal or ecc != (0.0, 0.0)) and not math.hypot(*ecc) < clearance:
            self.fail(p + ".initial_eccentricity", j["initial_eccentricity"],
                      f"|e| = {math.hypot(*ecc):g} m is not inside the clearance circle "
                      f"(clearance = {clearance:g} m)", "|initial_eccentricity| < clearance")
        ecc_rate = (keep["initial_eccentricity_rate"] if "initial_eccentricity_rate" in keep
                    else self.vec2(p + ".initial_eccentricity_rate",
                                   j.get("initial_eccentricity_rate", (0.0, 0.0)), unit="m/s"))
        # which sub-tables a model needs comes from its row in the table of models; a sub-table
        # given but not needed is validated too (and ignored by the force law)
        needs = () if ideal else MODELS[model].requires
        subs: dict[str, Any] = {}
        for k in SUBTABLE_CLASSES:
            if k in keep:  # its content passed these checks before (the model unchanged)
                subs[k] = keep[k] if k in j or k in needs else None
            else:
                subs[k] = (self._subtable(join(p, k), k, j.get(k, {}), model,
                                          keep.get(("params", k)))
                           if k in j or k in needs else None)
        joint = Joint(name=name, type="revolute", points=(a, b), model=model,
                      clearance=clearance, bearing_radius=bearing_radius, length=length,
                      initial_eccentricity=ecc, initial_eccentricity_rate=ecc_rate, **subs)
        if not ideal:
            self._force_law(p, joint)
        return joint

    def _force_law(self, p: str, joint: Joint) -> None:
        """The force law's cross-field rules (e.g. the finite film's L/D range), checked by
        :func:`mechrel.forces.params.pack_params`, the one validator, and reported with the
        scene path of the field."""
        try:
            self.packed[joint.name] = pack_joint(joint)
        except SceneError as err:
            field = cast(str, err.path)  # pack_params names the parameter of every error
            # a derived value (the contact stiffness) is named with what it is computed from
            derived = ("; it is computed from bearing_radius, clearance and the contact's "
                       "elastic moduli: check those for extreme values"
                       if field == "stiffness" else "")
            if not hasattr(err, "allowed"):  # a derived value's own check: name the joint
                raise SceneError(f"{p}: {err}{derived}",
                                 path=join(p, field) if field else p) from None
            where = {param: join(join(p, sub), key) for sub, keys in SUBTABLE_PARAMS.items()
                     for key, param in keys.items()}
            self.fail(where.get(field, join(p, field)), err.value,
                      f"not allowed by the '{joint.model}' force law{derived}", err.allowed)

    def _subtable(self, path: str, sub: str, v: Any, model: str,
                  kept: Mapping[str, Any] | None = None) -> SubTable:
        """A clearance joint's sub-table, checked by the declarations of its parameters
        (:data:`mechrel.forces.models.PARAMS`: range, choices or true/false), then by the
        cross-field rules the force law states with scene paths. ``kept``: the parameters
        validated before with the same content (only numbers changed in the table), taken as
        they are."""
        params = {prm.key: prm for prm in PARAMS.values() if prm.sub == sub}
        if kept is None:
            t = self.table(path, v)
            self.keys(path, t, tuple(params), what=f"[{sub}]")
        else:
            t = v
        d: dict[str, Any] = {}
        for key, prm in params.items():
            val = t.get(key, prm.default)
            if kept is not None and key in kept:
                d[key] = kept[key]
            elif prm.choices is not None:
                d[key] = self.choice(join(path, key), val, prm.choices)
            elif prm.boolean:
                if not isinstance(val, bool):
                    self.fail(join(path, key), val, f"expected true or false, got "
                              f"{_typename(val)}", "true or false")
                d[key] = val
            else:
                spec: dict[str, Any] = dict(prm.limit)
                if prm.unit != "-":
                    spec["unit"] = prm.unit
                d[key] = self.number(join(path, key), val, **spec)
        if "v0" in d and "v1" in d and not d["v1"] > d["v0"]:  # friction's dynamic correction
            self.fail(path + ".v1", d["v1"], f"must be greater than v0 = {fmt_value(d['v0'])}",
                      "v1 > v0 >= 0 (m/s)")
        row = MODELS.get(model)
        if "viscosity" in d and row is not None and row.has_film and not d["viscosity"] > 0:
            names = [f"'{m.name}'" for m in MODELS.values() if m.has_film]
            films = " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)
            self.fail(path + ".viscosity", d["viscosity"],
                      f"a '{model}' joint needs a film, and a film of zero viscosity carries no "
                      "load", f"> 0 (Pa s) for models {films}")
        return SUBTABLE_CLASSES[sub](**d)

    def _zero_length_links(self, bodies: Mapping[str, Body], joints: Mapping[str, Joint]) -> None:
        used: dict[str, dict[str, str]] = {}
        for j in joints.values():
            if j.type != "revolute":
                continue
            for r in j.points:
                if r.body != GROUND:
                    used.setdefault(r.body, {}).setdefault(r.point, j.name)
        for body, pts in used.items():
            names = list(pts)
            coords = bodies[body].points
            for i, p1 in enumerate(names):
                for p2 in names[i + 1:]:
                    if math.dist(coords[p1], coords[p2]) < COINCIDENT_TOL:
                        placed = bodies[body].global_points
                        table = "points" if placed is None else "global_points"
                        self.fail(f"bodies.{body}.{table}.{p2}",
                                  coords[p2] if placed is None else placed[p2],
                                  f"coincides with point '{p1}' while both carry revolute joints "
                                  f"(joints.{pts[p1]}, joints.{pts[p2]}): a zero-length link",
                                  f"distinct positions (at least {COINCIDENT_TOL:g} m apart), or "
                                  "one shared point for both joints")

    # -- drivers, outputs
    def _drivers(self, v: Any, bodies: Mapping[str, Body]) -> dict[str, Driver]:
        dt = self.table("drivers", v, "a [drivers.NAME] table per driven body")
        out: dict[str, Driver] = {}
        driven: dict[str, str] = {}
        for name, d in dt.items():
            p = join("drivers", name)
            self.name(p, name, "driver")
            self.table(p, d)
            if "law" not in d:
                self.fail(p + ".law", _MISSING, "missing required field", _one_of(DRIVER_LAWS))
            law = self.choice(p + ".law", d["law"], DRIVER_LAWS)
            self.keys(p, d, DRIVER_KEYS_BY_LAW[law],
                      required=("body", "law", "angle0") + _DRIVER_REQUIRED[law],
                      what=f"a '{law}' driver", hints=_DRIVER_HINTS[law])
            body = self.string(p + ".body", d["body"], "the name of a moving body")
            if body not in bodies:
                self.fail(p + ".body", body, f"unknown body '{body}'{suggest(body, bodies)}",
                          _one_of(list(bodies)))
            if body in driven:
                self.fail(p + ".body", body,
                          f"body '{body}' is already driven by drivers.{driven[body]}",
                          "at most one driver per body")
            driven[body] = name
            kw = dict(angle0=self.number(p + ".angle0", d["angle0"], unit="rad"))
            for k in DRIVER_KEYS_BY_LAW[law][3:]:
                if k in d:
                    unit, ge = _DRIVER_UNITS[k]
                    if k == "ramp_time":
                        kw[k] = self.number(f"{p}.{k}", d[k], gt=0, unit=unit)
                    else:
                        kw[k] = self.number(f"{p}.{k}", d[k], ge=ge, unit=unit)
            # law is one of DRIVER_LAWS (checked above), the Literal the field declares
            out[name] = Driver(name=name, body=body, law=cast(Any, law), **kw)
        return out

    def _outputs(self, v: Any, bodies, ground, joints) -> dict[str, Output]:
        from ..outputs import OUTPUT_KINDS

        ot = self.table("outputs", v, "an [outputs.NAME] table per output")
        out = {}
        for name, o in ot.items():
            p = join("outputs", name)
            self.name(p, name, "output")
            self.table(p, o)
            kind = self.choice(p + ".kind", o.get("kind", "point"), tuple(OUTPUT_KINDS))
            fields_ = OUTPUT_KINDS[kind].fields
            self.keys(p, o, ("kind",) + fields_, required=fields_,
                      what=f"an output of kind '{kind}'")
            values = {f: self._output_field(f"{p}.{f}", f, o[f], bodies, ground, joints)
                      for f in fields_}
            out[name] = Output(name=name, kind=kind, **values)
        return out

    def _output_field(self, path: str, field: str, v: Any, bodies, ground, joints):
        """One field of an output table, by its name (the fields the output kinds of
        mechrel.outputs.OUTPUT_KINDS use; a kind with a new field adds it here, to
        ``OUTPUT_KEYS`` and to ``Output``)."""
        if field == "point":
            return self._ref(path, v, bodies, ground, ground_ok=False)
        if field == "axis":
            ax = self.vec2(path, v, nonzero=True)
            n = math.hypot(*ax)
            return (ax[0] / n, ax[1] / n)
        if field == "body":
            body = self.string(path, v, "the name of a moving body")
            if body not in bodies:
                self.fail(path, body, f"unknown body{suggest(body, list(bodies))}",
                          f"one of {', '.join(bodies)}")
            return body
        # joint: a revolute joint with clearance data (an ideal one reads as concentric)
        usable = [n for n, j in joints.items() if j.type == "revolute" and j.clearance > 0]
        allowed = (f"a revolute joint with a clearance: one of {', '.join(usable)}"
                   if usable else "a revolute joint with a clearance (this scene has none: "
                   "give a joint clearance, bearing_radius and length)")
        joint = self.string(path, v, allowed)
        if joint not in joints:
            self.fail(path, joint, f"unknown joint{suggest(joint, list(joints))}", allowed)
        if joint not in usable:
            self.fail(path, joint, "has no clearance" if joints[joint].type == "revolute"
                      else f"not a revolute joint (a {joints[joint].type} joint)", allowed)
        return joint

    # -- analysis, solver
    def _analysis(self, v: Any, drivers: Mapping[str, Driver]) -> Analysis:
        a = self.table("analysis", v)
        self.keys("analysis", a, ANALYSIS_KEYS, what="[analysis]")
        if "duration" in a and "cycles" in a:
            self.fail("analysis", {"duration": a["duration"], "cycles": a["cycles"]},
                      "both duration and cycles are given",
                      "exactly one of analysis.duration (s) or analysis.cycles")
        if "duration" not in a and "cycles" not in a:
            self.fail("analysis.duration", _MISSING, "neither duration nor cycles is given",
                      "exactly one of analysis.duration (s, > 0) or analysis.cycles (> 0, with "
                      "analysis.cycle_driver)")
        if "sample_step" in a and "sample_step_angle" in a:
            self.fail("analysis", {"sample_step": a["sample_step"],
                                   "sample_step_angle": a["sample_step_angle"]},
                      "both sample_step and sample_step_angle are given",
                      "exactly one of analysis.sample_step (s) or analysis.sample_step_angle (rad)")
        if "sample_step" not in a and "sample_step_angle" not in a:
            self.fail("analysis.sample_step", _MISSING,
                      "neither sample_step nor sample_step_angle is given",
                      "exactly one of analysis.sample_step (s, > 0) or analysis.sample_step_angle "
                      "(rad, > 0, with analysis.cycle_driver)")
        duration = cycles = sample_step = sample_step_angle = None
        if "duration" in a:
            duration = self.number("analysis.duration", a["duration"], gt=0, unit="s")
        else:
            cycles = self.number("analysis.cycles", a["cycles"], gt=0,
                                 unit="periods of the cycle driver")
        if "sample_step" in a:
            sample_step = self.number("analysis.sample_step", a["sample_step"], gt=0, unit="s")
        else:
            sample_step_angle = self.number("analysis.sample_step_angle", a["sample_step_angle"],
                                            gt=0, unit="rad")
        speed = None
        cycle_driver = None
        constant = [n for n, d in drivers.items() if d.law == "constant-speed" and d.speed != 0]
        if "cycle_driver" in a:
            cycle_driver = self.string(
                "analysis.cycle_driver", a["cycle_driver"],
                "a constant-speed driver with speed != 0: " + _one_of(constant))
            if cycle_driver not in drivers:
                self.fail("analysis.cycle_driver", cycle_driver,
                          f"unknown driver '{cycle_driver}'{suggest(cycle_driver, drivers)}",
                          "a constant-speed driver with speed != 0: " + _one_of(constant))
            d = drivers[cycle_driver]
            if d.law != "constant-speed":
                self.fail("analysis.cycle_driver", cycle_driver,
                          f"driver '{cycle_driver}' has law '{d.law}', so it has no period",
                          "a constant-speed driver with speed != 0: " + _one_of(constant))
            if d.speed == 0:
                self.fail("analysis.cycle_driver", cycle_driver,
                          f"driver '{cycle_driver}' has speed 0, so it has no period",
                          "a constant-speed driver with speed != 0: " + _one_of(constant))
            speed = abs(d.speed)
        elif cycles is not None or sample_step_angle is not None:
            why = "analysis.cycles" if cycles is not None else "analysis.sample_step_angle"
            self.fail("analysis.cycle_driver", _MISSING,
                      f"missing required field (needed by {why})",
                      "a constant-speed driver with speed != 0: " + _one_of(constant))
        if duration is not None:
            span = duration
        else:
            assert cycles is not None and speed is not None  # cycles need the driver (above)
            span = cycles * 2 * math.pi / speed
        if sample_step is not None and sample_step > span:
            self.fail("analysis.sample_step", a["sample_step"],
                      f"larger than the analysis span of {span:g} s",
                      f"0 < sample_step <= {span:g} s")
        if sample_step_angle is not None:
            assert speed is not None  # a sample_step_angle needs the cycle driver (above)
            if sample_step_angle / speed > span:
                self.fail("analysis.sample_step_angle", a["sample_step_angle"],
                          f"larger than the analysis span of {span * speed:g} rad of "
                          f"'{cycle_driver}' rotation",
                          f"0 < sample_step_angle <= {span * speed:g} rad")
        return Analysis(duration=duration, cycles=cycles, cycle_driver=cycle_driver,
                        sample_step=sample_step, sample_step_angle=sample_step_angle)

    def _solver(self, v: Any) -> Solver:
        s = self.table("solver", v)
        self.keys("solver", s, SOLVER_KEYS, what="[solver]")
        kw: dict[str, Any] = {}
        if "integrator" in s:
            kw["integrator"] = self.choice("solver.integrator", s["integrator"], INTEGRATOR_NAMES)
        if "formulation" in s:
            kw["formulation"] = self.choice("solver.formulation", s["formulation"], FORMULATIONS)
        for k, unit in (("step", "s"), ("atol", None)):
            if k in s:
                kw[k] = self.number("solver." + k, s[k], gt=0, unit=unit)
        if "rtol" in s:  # a relative tolerance of 1 or more asks for no accuracy at all
            kw["rtol"] = self.number("solver.rtol", s["rtol"], gt=0, lt=1)
        if "max_steps" in s:
            kw["max_steps"] = self.integer("solver.max_steps", s["max_steps"], gt=0,
                                           le=MAX_STEPS_LIMIT)
        for k in ("baumgarte_alpha", "baumgarte_beta"):
            if k in s:
                kw[k] = self.number("solver." + k, s[k], ge=0, unit="1/s")
        for k, unit in (("assembly_tolerance", "m, rad"), ("onset_tolerance", "m")):
            if k in s:
                kw[k] = self.number("solver." + k, s[k], gt=0, unit=unit)
        return Solver(**kw)


def build_scene(raw: Any, source: str | None,
                overridden: Sequence[tuple[str, str]] = ()) -> Scene:
    """Validate ``raw`` and build the scene (``raw``/``source`` not yet attached)."""
    return _Builder(source, overridden).build(raw)


# ----------------------------------------------------------------------------- canonical raw

def _pair(v) -> list[float]:
    return [float(v[0]), float(v[1])]


# The fields written into the canonical raw mapping (and so into the scene hash) even at their
# default: the ones that existed when the hash started leaving defaults out (mechrel 0.33), so
# that the hashes of the scenes written before did not move. A field added since is written only
# when it differs from its default, so adding a field with a default moves no scene's hash and
# orphans no evaluation cache. (A clearance joint's sub-tables say it per parameter:
# mechrel.forces.models.Param.hashed_at_default.)
_HASHED_AT_DEFAULT: dict[type, frozenset[str]] = {
    Analysis: frozenset({"duration", "cycles", "cycle_driver", "sample_step",
                         "sample_step_angle"}),
    Solver: frozenset({"integrator", "step", "rtol", "atol", "max_steps", "baumgarte_alpha",
                       "baumgarte_beta", "assembly_tolerance", "onset_tolerance",
                       "formulation"}),
}


def _table(obj, hashed_at_default: frozenset[str]) -> dict:
    """A dataclass's table of :func:`scene_to_raw`: its fields that are not None, those not in
    ``hashed_at_default`` only when they differ from their default."""
    out = {}
    for f in fields(obj):
        v = getattr(obj, f.name)
        if v is not None and (f.name in hashed_at_default or v != f.default):
            out[f.name] = v
    return out


def _subtable_raw(sub: str, table: SubTable) -> dict:
    return _table(table, frozenset(prm.key for prm in PARAMS.values()
                                   if prm.sub == sub and prm.hashed_at_default))


def scene_to_raw(scene: Scene) -> dict:
    """The canonical raw mapping of a scene: every field explicit (defaults filled in, floats,
    normalised directions), ``None`` fields omitted, and a field added after mechrel 0.33
    omitted at its default (:data:`_HASHED_AT_DEFAULT`). Loading it gives back an equal
    scene."""
    return {
        "name": scene.name,
        "description": scene.description,
        "gravity": _pair(scene.gravity),
        "ground": {"points": {k: _pair(v) for k, v in scene.ground.items()}},
        "bodies": {n: body_to_raw(b) for n, b in scene.bodies.items()},
        "joints": {n: joint_to_raw(j) for n, j in scene.joints.items()},
        "drivers": {n: driver_to_raw(dr) for n, dr in scene.drivers.items()},
        "outputs": {n: _output_raw(o) for n, o in scene.outputs.items()},
        "analysis": _table(scene.analysis, _HASHED_AT_DEFAULT[Analysis]),
        "solver": _table(scene.solver, _HASHED_AT_DEFAULT[Solver]),
    }


def body_to_raw(b: Body) -> dict:
    """One body's table of :func:`scene_to_raw`: its points as written, in the body frame
    (``points``) or in ground coordinates (``global_points``, only when the body was written
    that way, so the scenes written before it keep their hash)."""
    if b.global_points is None:
        table = {"points": {k: _pair(v) for k, v in b.points.items()}}
    else:
        table = {"global_points": {k: _pair(v) for k, v in b.global_points.items()}}
    return {"mass": b.mass, "inertia": b.inertia, "position": _pair(b.position),
            "angle": b.angle, **table}


def joint_to_raw(j: Joint, only: Sequence[str] | None = None) -> dict:
    """One joint's table of :func:`scene_to_raw`; ``only``: just these of its fields (those
    a sample's values changed, :class:`~mechrel.scene._values.SceneValues`)."""
    d: dict[str, Any] = {"type": j.type, "connects": [str(r) for r in j.points]}
    if j.type == "revolute":
        d["model"] = j.model
        d["clearance"] = float(j.clearance)
        if j.bearing_radius is not None:
            d["bearing_radius"] = float(j.bearing_radius)
        if j.length is not None:
            d["length"] = float(j.length)
        d["initial_eccentricity"] = _pair(j.initial_eccentricity)
        d["initial_eccentricity_rate"] = _pair(j.initial_eccentricity_rate)
        for k in SUBTABLE_CLASSES:
            sub = getattr(j, k)
            if sub is not None and (only is None or k in only):
                d[k] = _subtable_raw(k, sub)
    else:
        if j.direction is not None:
            d["direction"] = _pair(j.direction)
        if j.angle is not None:  # all but pin-in-slot joints hold an angle
            d["angle"] = float(j.angle)
    return d if only is None else {k: d[k] for k in only if k in d}


def driver_to_raw(dr: Driver) -> dict:
    """One driver's table of :func:`scene_to_raw`."""
    d = {"body": dr.body, "law": dr.law, "angle0": float(dr.angle0)}
    for k in DRIVER_KEYS_BY_LAW[dr.law][3:]:
        d[k] = float(getattr(dr, k))
    return d


def _output_raw(o: Output) -> dict:
    """The canonical raw table of an output: its kind's fields, and ``kind`` only when it is
    not the default ``point`` (so the scenes written before output kinds keep their hash)."""
    from ..outputs import OUTPUT_KINDS

    raw: dict[str, Any] = {} if o.kind == "point" else {"kind": o.kind}
    for f in OUTPUT_KINDS[o.kind].fields:
        v = getattr(o, f)
        raw[f] = _pair(v) if f == "axis" else str(v)
    return raw
