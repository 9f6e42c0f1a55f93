"""Study files: a scene, uncertain inputs, allowable errors and estimator settings (TOML).

Format and examples: docs/studies.md. ``load_study(source)`` accepts an embedded study name,
a path, or a mapping, and validates every field with one :class:`~mechrel.errors.StudyError`
naming the file, the field, the value and what is allowed.
"""

from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

from ..errors import StudyError
from ..scene.model import QUANTITIES

_TOP = {"name", "description", "scene", "output", "angle_step", "cycles", "quantities",
        "scene_overrides", "inputs", "correlation", "allowable", "reliability", "sensitivity"}
_RELIABILITY = {"methods", "form", "n", "rule", "seed", "pce_order"}
_SENSITIVITY = {"n", "seed"}
METHODS = ("fosm", "mc", "pce")


@dataclass(frozen=True)
class Study:
    """A validated study. ``inputs`` maps an input name to its scene paths and distribution
    spec (a mapping understood by :meth:`mechrel.uq.inputs.UncertainInputs.from_specs`)."""

    name: str
    description: str
    scene: str
    output: str | None
    angle_step: float
    cycles: float | None
    quantities: tuple[str, ...]
    scene_overrides: Mapping[str, Any]
    inputs: Mapping[str, Mapping[str, Any]]
    paths: Mapping[str, tuple[str, ...]]
    correlation: Any
    allowable: Mapping[str, tuple[float, float]]
    reliability: Mapping[str, Any]
    sensitivity: Mapping[str, Any]
    source: str | None = field(default=None, compare=False)

    def model(self):
        """The :class:`~mechrel.uq.mechanism.MechanismModel` of this study."""
        from ..uq.mechanism import MechanismModel
        return MechanismModel(self.scene, dict(self.paths), output=self.output,
                              quantities=self.quantities, angle_step=self.angle_step,
                              cycles=self.cycles, overrides=dict(self.scene_overrides))

    def uncertain_inputs(self):
        """The :class:`~mechrel.uq.inputs.UncertainInputs` of this study."""
        from ..uq import UncertainInputs
        corr = self.correlation
        if isinstance(corr, Mapping):
            corr = {tuple(k.split(",")): v for k, v in corr.items()}
        return UncertainInputs.from_specs(dict(self.inputs), correlation=corr)

    def allowables(self):
        from ..uq import Allowable
        return {q: Allowable(*self.allowable[q]) for q in self.quantities}


def embedded_studies() -> tuple[str, ...]:
    d = resources.files("mechrel.studies").joinpath("data")
    return tuple(sorted(p.name[:-5] for p in d.iterdir() if p.name.endswith(".toml")))


def _fail(src, path, msg):
    raise StudyError(f"{src}: {path}: {msg}")


def _unknown(src, where, table, allowed):
    for key in table:
        if key not in allowed:
            near = difflib.get_close_matches(key, sorted(allowed), n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            _fail(src, f"{where}{key}", f"unknown field {key!r}{hint}; allowed: "
                  f"{', '.join(sorted(allowed))}")


def _number(src, path, value, *, positive=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(src, path, f"{value!r} is not a number")
    if positive and not value > 0:
        _fail(src, path, f"{value!r} must be > 0")
    return float(value)


def load_study(source, *, overrides: Mapping[str, Any] | None = None) -> Study:
    """Load and validate a study (embedded name, TOML path or mapping)."""
    base_dir = None
    if isinstance(source, Mapping):
        raw, label = dict(source), "<mapping>"
    else:
        text = None
        src = str(source)
        if src in embedded_studies():
            text = resources.files("mechrel.studies").joinpath("data", src + ".toml").read_text()
            label = f"<embedded study {src}>"
        else:
            p = Path(src)
            if not p.is_file():
                raise StudyError(f"study {src!r}: no such file and not an embedded study; "
                                 f"embedded: {', '.join(embedded_studies())}")
            text, label, base_dir = p.read_text(), str(p), p.parent
        try:
            raw = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise StudyError(f"{label}: TOML syntax error: {exc}") from None
    for key, value in (overrides or {}).items():
        node = raw
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    src = label
    _unknown(src, "", raw, _TOP)
    for req in ("scene", "inputs"):
        if req not in raw:
            _fail(src, req, "missing required field")
    scene = raw["scene"]
    if not isinstance(scene, str):
        _fail(src, "scene", f"{scene!r} must be an embedded scene name or a path (string)")
    if base_dir is not None and (base_dir / scene).is_file():
        scene = str(base_dir / scene)
    quantities = tuple(raw.get("quantities", QUANTITIES))
    for q in quantities:
        if q not in QUANTITIES:
            _fail(src, "quantities", f"{q!r} is not one of {', '.join(QUANTITIES)}")
    inputs, paths = {}, {}
    if not isinstance(raw["inputs"], Mapping) or not raw["inputs"]:
        _fail(src, "inputs", "must be a table of uncertain inputs, e.g. "
              "[inputs.clearance] paths = [...], distribution = 'normal', mean = …, std = …")
    for name, spec in raw["inputs"].items():
        if not isinstance(spec, Mapping):
            _fail(src, f"inputs.{name}", f"{spec!r} must be a table")
        spec = dict(spec)
        p = spec.pop("paths", [name])
        if isinstance(p, str) or not p or not all(isinstance(x, str) for x in p):
            _fail(src, f"inputs.{name}.paths", f"{p!r} must be a non-empty list of dotted "
                  "scene paths")
        paths[name] = tuple(p)
        inputs[name] = spec
    allowable = {}
    defaults = {"displacement": (0.012, 0.004), "velocity": (0.3, 0.1),
                "acceleration": (18.0, 6.0)}
    table = raw.get("allowable", {})
    _unknown(src, "allowable.", table, set(QUANTITIES))
    for q in quantities:
        t = table.get(q, {})
        _unknown(src, f"allowable.{q}.", t, {"mean", "std"})
        mean = _number(src, f"allowable.{q}.mean", t.get("mean", defaults[q][0]), positive=True)
        std = _number(src, f"allowable.{q}.std", t.get("std", defaults[q][1]))
        if std < 0:
            _fail(src, f"allowable.{q}.std", f"{std!r} must be >= 0")
        allowable[q] = (mean, std)
    rel = dict(raw.get("reliability", {}))
    _unknown(src, "reliability.", rel, _RELIABILITY)
    methods = rel.get("methods", ["fosm", "mc"])
    for m in methods:
        if m not in METHODS:
            _fail(src, "reliability.methods", f"{m!r} is not one of {', '.join(METHODS)}")
    rel["methods"] = tuple(methods)
    if "n" in rel:
        _number(src, "reliability.n", rel["n"], positive=True)
    sens = dict(raw.get("sensitivity", {}))
    _unknown(src, "sensitivity.", sens, _SENSITIVITY)
    angle_step = _number(src, "angle_step", raw.get("angle_step", 18.0), positive=True)
    cycles = raw.get("cycles")
    if cycles is not None:
        _number(src, "cycles", cycles, positive=True)
    study = Study(name=str(raw.get("name", Path(str(source)).stem if not isinstance(
        source, Mapping) else "study")), description=str(raw.get("description", "")),
        scene=scene, output=raw.get("output"), angle_step=angle_step, cycles=cycles,
        quantities=quantities, scene_overrides=dict(raw.get("scene_overrides", {})),
        inputs=inputs, paths=paths, correlation=raw.get("correlation"), allowable=allowable,
        reliability=rel, sensitivity=sens, source=label)
    # validate the inputs against chaospy/scipy and the scene paths early, with their names
    study.uncertain_inputs()
    return study
