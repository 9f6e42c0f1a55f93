"""mechrel.scene: the scene schema (frozen dataclasses), TOML loading and validation, dotted
overrides, ``extends`` variants, embedded scenes and the scene hash. See docs/scenes.md."""

from ..errors import SceneError
from .loader import (
    apply_override, canonical_json, embedded_names, list_scenes, load_scene, parse_override,
    parse_value, scene_hash, with_overrides,
)
from .model import (
    CLEARANCE_MODELS, DRIVER_LAWS, FORMULATIONS, GROUND, INTEGRATOR_NAMES, QUANTITIES, Analysis,
    SUBTABLE_CLASSES, Body, Contact, Driver, Friction, Joint, Lubricant, Output, PointRef, Scene,
    Solver, SubTable, Transition,
)

__all__ = [
    "load_scene", "list_scenes", "embedded_names", "with_overrides", "scene_hash",
    "canonical_json", "parse_override", "parse_value", "apply_override", "SceneError",
    "Scene", "Body", "PointRef", "Joint", "Contact", "Friction", "Lubricant", "Transition",
    "SubTable", "SUBTABLE_CLASSES",
    "Driver", "Output", "Analysis", "Solver",
    "GROUND", "CLEARANCE_MODELS", "DRIVER_LAWS", "QUANTITIES", "INTEGRATOR_NAMES",
    "FORMULATIONS",
]
