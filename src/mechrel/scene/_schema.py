"""The scene file's table layout, shared by validation and by dotted-path overrides.

A *table* schema is a ``dict`` mapping each allowed key to the schema of its value: ``None``
for a leaf value (number, string, array), a nested ``dict`` for a fixed sub-table, or a
:class:`Named` for a table whose keys are user-chosen names (bodies, joints, points, ...).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, fields

from .model import SUBTABLE_CLASSES, Analysis, Solver


@dataclass(frozen=True)
class Named:
    """A table keyed by user-chosen names; every entry has schema ``child``."""

    child: dict | None
    what: str  # singular noun for messages: "body", "joint", "point", ...


NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
NAME_RULE = "an identifier: letters, digits and underscores, not starting with a digit (no dots)"

JOINT_TYPES = ("revolute", "translational", "pin-in-slot", "fixed-angle")

ANALYSIS_KEYS = tuple(f.name for f in fields(Analysis))
SOLVER_KEYS = tuple(f.name for f in fields(Solver))

JOINT_KEYS_BY_TYPE = {
    "revolute": ("type", "connects", "model", "clearance", "bearing_radius", "length",
                 "initial_eccentricity", "initial_eccentricity_rate", *SUBTABLE_CLASSES),
    "translational": ("type", "connects", "direction", "angle"),
    "pin-in-slot": ("type", "connects", "direction"),
    "fixed-angle": ("type", "connects", "angle"),
}
JOINT_KEYS = tuple(dict.fromkeys(k for ks in JOINT_KEYS_BY_TYPE.values() for k in ks))

DRIVER_KEYS_BY_LAW = {
    "constant-speed": ("body", "law", "angle0", "speed"),
    "constant-acceleration": ("body", "law", "angle0", "speed", "acceleration"),
    "harmonic": ("body", "law", "angle0", "amplitude", "frequency", "phase"),
    "smooth-start": ("body", "law", "angle0", "speed", "ramp_time"),
}
DRIVER_KEYS = tuple(dict.fromkeys(k for ks in DRIVER_KEYS_BY_LAW.values() for k in ks))

BODY_KEYS = ("mass", "inertia", "position", "angle", "points", "global_points")
# the fields of every output kind (mechrel.outputs.OUTPUT_KINDS says which kind uses which)
def _output_keys() -> tuple:
    from ..outputs import OUTPUT_KINDS
    return ("kind",) + tuple(dict.fromkeys(f for k in OUTPUT_KINDS.values() for f in k.fields))


OUTPUT_KEYS = _output_keys()
TOP_KEYS = ("name", "description", "gravity", "ground", "bodies", "joints", "drivers",
            "outputs", "analysis", "solver")

_SUBTABLES = {sub: dict.fromkeys(f.name for f in fields(cls))
              for sub, cls in SUBTABLE_CLASSES.items()}

SCHEMA: dict = {
    "name": None,
    "description": None,
    "gravity": None,
    "ground": {"points": Named(None, "ground point")},
    "bodies": Named({**dict.fromkeys(BODY_KEYS), "points": Named(None, "point"),
                     "global_points": Named(None, "point")}, "body"),
    "joints": Named({k: _SUBTABLES.get(k) for k in JOINT_KEYS}, "joint"),
    "drivers": Named(dict.fromkeys(DRIVER_KEYS), "driver"),
    "outputs": Named(dict.fromkeys(OUTPUT_KEYS), "output"),
    "analysis": dict.fromkeys(ANALYSIS_KEYS),
    "solver": dict.fromkeys(SOLVER_KEYS),
}

EXCLUSIVE = {"analysis": (("duration", "cycles"), ("sample_step", "sample_step_angle"))}
"""Mutually exclusive keys per table path: a layer (an ``extends``-ing file or an override)
that sets one key of a pair removes the other key inherited from below."""
