"""Study files: a scene, uncertain inputs, allowable errors and estimator settings (TOML).

Format and examples: docs/studies.md. ``load_study(source)`` accepts an embedded study name,
a path, or a mapping, and validates every field with one :class:`~mechrel.errors.StudyError`
whose message reads, as the scene files' do, ``SOURCE: FIELD = VALUE: PROBLEM; allowed: WHAT``.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from .._checks import _MISSING, Checker, join, suggest
from ..errors import SceneError, StudyError
from ..outputs import QUANTITY_INFO
from ..scene.loader import check_depth, read_toml_text
from ..scene.model import QUANTITIES
from ..uq.estimators import METHODS as REGISTRY
from ..uq.problem.allowables import DEFAULT_ALLOWABLES, EVENTS
from ..uq.problem.inputs import SAMPLING_RULES
from ..uq.problem.mechanism import REFERENCES
from ..uq.surrogates.pce import MAX_EVALUATIONS


def study_methods() -> dict:
    """The registered methods a study runs, by their study-file name.

    ``fosm``, ``mc``, ``pce``, ``form``, ``sorm``, ``is``, ``subset``, and any method registered
    since (``mechrel reliability --method KEY``): every method of
    :data:`mechrel.uq.estimators.METHODS` except the sensitivity methods (``mechrel
    sensitivity``). Read from the registry at each call.

    Returns
    -------
    dict
        ``{key: Method}``, in the registry's order.

    Examples
    --------
    >>> list(study_methods())[:7]   # the built-in ones, then any registered since
    ['fosm', 'mc', 'pce', 'form', 'sorm', 'is', 'subset']
    """
    return {m.key: m for m in REGISTRY.values() if m.kind != "sensitivity"}


def rare_event_methods() -> dict:
    """The registry's rare-event methods by their study-file name.

    Returns
    -------
    dict
        ``{key: Method}`` of the methods of kind ``"rare_event"``.

    Examples
    --------
    >>> list(rare_event_methods())[:4]
    ['form', 'sorm', 'is', 'subset']
    """
    return {k: m for k, m in study_methods().items() if m.kind == "rare_event"}


def study_settings(method) -> dict:
    """The settings of a registered method that a study file may set in the table of its key.

    Those the registry checks; the others (e.g. a design point object) exist only in Python.

    Parameters
    ----------
    method : mechrel.uq.estimators.Method
        A registry entry.

    Returns
    -------
    dict
        ``{name: Setting}``.

    Examples
    --------
    >>> sorted(study_settings(study_methods()["sorm"]))  # doctest: +NORMALIZE_WHITESPACE
    ['contribution', 'curvature_step', 'formula', 'max_design_points', 'max_iter', 'scheme',
     'search', 'step', 'tol']
    """
    return {k: s for k, s in method.settings.items() if s.check is not None}


def _method_tables() -> dict:
    """The methods with a table of settings in a study file, by key."""
    return {k: m for k, m in study_methods().items() if study_settings(m)}


def study_fields() -> tuple[str, ...]:
    """The top-level fields of a study file, with one table per method that has settings.

    Returns
    -------
    tuple of str
        The field names, sorted.

    Examples
    --------
    >>> {"inputs", "allowable", "form", "subset"} <= set(study_fields())
    True
    """
    return tuple(sorted(("allowable", "angle_step", "correlation", "cycles", "description",
                         "design", "inputs", "inverse", "name", "output", "quantities",
                         "reference", "reliability", "scene", "scene_overrides", "sensitivity")
                        + tuple(_method_tables())))


_RELIABILITY = ("event", "max_failure_fraction", "methods", "n", "pce_max_evaluations",
                "pce_order", "rule", "seed")
_RENAMED = {"form": "event"}
"""Keys of ``[reliability]`` renamed: old -> new (an old key is an error naming the new)."""
_SENSITIVITY = ("max_failure_fraction", "n", "seed")
_INVERSE = ("methods", "target")
_DESIGN = ("constraints", "cost", "method", "seed", "sense", "tradeoff", "variables", "verify",
           "max_failure_fraction")
_DESIGN_VARIABLE = ("kind", "input", "paths", "lower", "upper", "start")
_VERIFY = ("method", "n", "n_per_level", "p0")


@dataclass(frozen=True)
class Study:
    """A validated study (made by :func:`load_study`).

    Parameters
    ----------
    name, description : str
        The study's name and description.
    scene : str
        The scene: an embedded name or a file path.
    output : str or None
        The scene output analysed (None: the scene's first).
    angle_step : float
        The crank-angle step of the analysis points (degrees).
    cycles : int or None
        The number of cycles simulated (None: the scene's).
    quantities : tuple of str
        The output's quantities analysed.
    scene_overrides : mapping
        ``{dotted scene path: value}`` applied to the scene (SI units).
    inputs : mapping
        Input name → its distribution spec (a mapping understood by
        :meth:`mechrel.uq.UncertainInputs.from_specs`; SI units).
    paths : mapping
        Input name → the scene paths it sets.
    correlation : mapping or None
        The Pearson correlation of the inputs (``{"a,b": rho}``) or None.
    allowable : mapping
        Quantity → ``(mean, std)`` of its allowable error (m, m/s, m/s²).
    reliability : mapping
        Every setting of ``[reliability]``, defaults filled in (``methods``, ``event``, ``n``,
        ``rule``, ``seed``, ``pce_order``, ``max_failure_fraction``).
    sensitivity : mapping
        Every setting of ``[sensitivity]`` (``n``, ``seed``, ``max_failure_fraction``).
    reference : {"nominal", "same-geometry"}, default "nominal"
        What the error is measured against under geometric inputs
        (:class:`~mechrel.uq.MechanismModel`).
    method_settings : mapping, optional
        Each method with settings (:func:`study_settings`) → those its table in the file gives,
        checked; the registry's defaults fill the rest when it runs.
    inverse : mapping, optional
        ``[inverse]``: ``target`` (the target reliability whose allowables ``mechrel
        reliability`` reports, or None) and ``methods`` (keys of
        :data:`mechrel.uq.inverse.INVERSE_METHODS`, or ``"auto"``).
    design : mapping or None, optional
        ``[design]`` (None: the study has none): ``variables`` (``{name: {kind, input, lower,
        upper, start}}``; a ``"scene"`` variable has ``paths`` instead of ``input``), ``cost``,
        ``sense``, ``constraints`` (``[{reliability, quantity, basis}]``), ``method`` (a key of
        :data:`mechrel.uq.design.DESIGN_METHODS`), ``settings`` (its table
        ``[design.KEY]``), ``verify``, ``tradeoff``, ``seed``, ``max_failure_fraction``
        (:mod:`mechrel.study.design`).
    source : str, optional
        Where the study was read from.

    Examples
    --------
    >>> s = load_study("nine-bar-lubricated")
    >>> s.scene, s.reliability["event"]
    ('nine-bar-lubricated', 'two-sided')
    """

    name: str
    description: str
    scene: str
    output: str | None
    angle_step: float
    cycles: int | None
    quantities: tuple[str, ...]
    scene_overrides: Mapping[str, Any]
    inputs: Mapping[str, Mapping[str, Any]]
    paths: Mapping[str, tuple[str, ...]]
    correlation: Any
    allowable: Mapping[str, tuple[float, float]]
    reliability: Mapping[str, Any]
    sensitivity: Mapping[str, Any]
    reference: str = "nominal"
    method_settings: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    inverse: Mapping[str, Any] = field(default_factory=lambda: {"target": None,
                                                                "methods": ("auto",)})
    design: Mapping[str, Any] | None = None
    source: str | None = field(default=None, compare=False)

    def model(self, sectors: bool = False):
        """The mechanism model of this study.

        Parameters
        ----------
        sectors : bool
            Also report each quantity's extremes per sector of the cycle (the members of the
            whole cycle's series system, for the rare-event methods).

        Returns
        -------
        mechrel.uq.problem.mechanism.MechanismModel
            The model of the study's scene, inputs, quantities and analysis grid.

        Raises
        ------
        StudyError
            If a scene path or an override does not fit the scene.

        Examples
        --------
        >>> s = load_study({"scene": "slider-crank-lubricated", "quantities": ["velocity"],
        ...                 "angle_step": 90.0, "inputs": {"c": {"paths": ["joints.C.clearance"],
        ...                 "distribution": "normal", "mean": 0.5e-3, "std": 2e-5}}})
        >>> s.model().input_names
        ('c',)
        """
        from ..uq.problem.mechanism import MechanismModel
        return MechanismModel(self.scene, dict(self.paths), output=self.output,
                              quantities=self.quantities, angle_step=self.angle_step,
                              cycles=self.cycles, overrides=dict(self.scene_overrides),
                              reference=self.reference, sectors=sectors)

    def uncertain_inputs(self):
        """The uncertain inputs of this study.

        Returns
        -------
        mechrel.uq.problem.inputs.UncertainInputs
            The inputs with their distributions and correlation (SI units).

        Examples
        --------
        >>> s = load_study({"scene": "slider-crank-lubricated", "quantities": ["velocity"],
        ...                 "inputs": {"c": {"paths": ["joints.C.clearance"],
        ...                 "distribution": "normal", "mean": 0.5e-3, "std": 2e-5}}})
        >>> s.uncertain_inputs().std.tolist()
        [2e-05]
        """
        from ..uq import UncertainInputs
        corr = self.correlation
        if isinstance(corr, Mapping):
            corr = {tuple(k.split(",")): v for k, v in corr.items()}
        return UncertainInputs.from_specs(dict(self.inputs), correlation=corr)

    def allowables(self):
        """The allowable errors of the study's quantities.

        Returns
        -------
        dict
            ``{quantity: Allowable}`` (m, m/s, m/s²).

        Examples
        --------
        >>> s = load_study({"scene": "slider-crank-lubricated", "quantities": ["velocity"],
        ...                 "inputs": {"c": {"paths": ["joints.C.clearance"],
        ...                 "distribution": "normal", "mean": 0.5e-3, "std": 2e-5}}})
        >>> s.allowables()
        {'velocity': Allowable(mean=0.3, std=0.1)}
        """
        from ..uq import Allowable
        return {q: Allowable(*self.allowable[q]) for q in self.quantities}


def embedded_studies() -> tuple[str, ...]:
    """The names of the study files shipped with mechrel (``mechrel reliability NAME``).

    Returns
    -------
    tuple of str
        The names, sorted.

    Examples
    --------
    >>> "nine-bar-lubricated" in embedded_studies()
    True
    """
    d = resources.files("mechrel.study").joinpath("data")
    return tuple(sorted(p.name[:-5] for p in d.iterdir() if p.name.endswith(".toml")))


class _Checker(Checker):
    """The validation toolkit's checks and messages, raising :class:`StudyError`."""

    error = StudyError
    required_hints = {"scene": "an embedded scene name or a path to a scene file",
                      "inputs": "[inputs.NAME] tables (paths, distribution and its parameters)"}


def _read(source) -> tuple[dict, str, Path | None]:
    """The raw mapping of ``source``, its label for messages and the folder it is in."""
    if isinstance(source, Mapping):
        check_depth(source, "<mapping>", StudyError)
        return copy.deepcopy(dict(source)), "<mapping>", None
    src = str(source)
    if src in embedded_studies():
        label, base_dir = f"<embedded study {src}>", None
        data = resources.files("mechrel.study").joinpath("data", src + ".toml").read_bytes()
    else:
        p = Path(src)
        if not p.is_file():
            raise StudyError(f"study {src!r}: no such file and not an embedded study; allowed: "
                             f"a study file or an embedded study: {', '.join(embedded_studies())}")
        label, base_dir = str(p), p.parent
        try:
            data = p.read_bytes()
        except OSError as exc:
            raise StudyError(f"{label}: cannot read the file: {exc.strerror}; allowed: a "
                             "readable TOML file") from None
    return read_toml_text(data, label, StudyError), label, base_dir


def _scene_source(c: _Checker, scene: str, base_dir: Path | None, given: bool) -> str:
    """The study's ``scene``: an embedded scene name as it is; a path relative to the study
    file's folder (the current folder for a mapping or an embedded study), which it must not
    leave — unless the caller gave it (``given``: an override), when it is taken as it is."""
    from ..scene.loader import _looks_like_path, embedded_names

    names = embedded_names()
    if scene in names or (given and not _looks_like_path(scene)):
        return scene
    folder = (base_dir or Path.cwd()).resolve()
    path = Path(scene)
    if given:
        return str(path)
    path = path if path.is_absolute() else folder / path
    if not _looks_like_path(scene) and not path.is_file():
        # a bare name is an embedded scene or a file beside the study (never one in the
        # current folder, whose content could then end up in a message)
        c.fail("scene", scene, f"not an embedded scene{suggest(scene, names)}, nor a file in "
               f"{str(folder)!r}, the folder of the study file",
               f"an embedded scene name ({', '.join(names)}) or a scene file in the study "
               "file's folder or below it")
    if not path.resolve().is_relative_to(folder):
        c.fail("scene", scene, f"not read: it is outside {str(folder)!r}, the folder of the "
               "study file", "an embedded scene name or a scene file in the study file's folder "
               "or below it; a scene file elsewhere can be given directly (--scene on the "
               "command line, overrides={'scene': path} in load_study)")
    return str(path)


def _apply_overrides(raw: dict, overrides: Mapping[str, Any], label: str) -> None:
    for key, value in overrides.items():
        node = raw
        *parents, leaf = key.split(".")
        for part in parents:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise StudyError(f"{label}: override {key!r}: {part!r} is not a table")
        node[leaf] = value


def _inputs(c: _Checker, table: Any) -> tuple[dict, dict]:
    """The distribution specs and the scene paths of ``[inputs]``; each scene path is set by
    one input only."""
    table = c.table("inputs", table, "a table of uncertain inputs, e.g. [inputs.clearance] "
                    "paths = [...], distribution = 'normal', mean = …, std = …")
    if not table:
        c.fail("inputs", table, "no uncertain inputs", "at least one [inputs.NAME] table")
    specs, paths, owner = {}, {}, {}
    for name, spec in table.items():
        where = join("inputs", name)
        spec = dict(c.table(where, spec, "a table with paths, distribution and its parameters"))
        p = spec.pop("paths", [name])
        allowed = "a non-empty array of dotted scene paths (a leading '-' negates the value)"
        if isinstance(p, str) or not isinstance(p, (list, tuple)) or not p:
            c.fail(where + ".paths", p, "not a non-empty array", allowed)
        for i, x in enumerate(p):
            c.string(f"{where}.paths[{i}]", x, allowed)
            target = x.lstrip("-")
            if target in owner:
                c.fail(where + ".paths", p, f"scene path {target!r} is also set by "
                       f"{owner[target]}", "each scene path set by one input only")
            owner[target] = where
        specs[name], paths[name] = spec, tuple(p)
    return specs, paths


def _correlation(c: _Checker, table: Any, names) -> dict | None:
    if table is None:
        return None
    allowed = f'"A,B" = Pearson correlation in [-1, 1], with A and B among {", ".join(names)}'
    table = c.table("correlation", table, "a table of " + allowed)
    seen: dict[frozenset, str] = {}
    for key, rho in table.items():
        pair = key.split(",")
        if len(pair) != 2 or not all(n in names for n in pair) or pair[0] == pair[1]:
            c.fail(join("correlation", key), rho, "not a pair of two input names", allowed)
        c.number(join("correlation", key), rho, ge=-1, le=1)
        other = seen.setdefault(frozenset(pair), key)
        if other != key:  # "A,B" and "B,A": one correlation given twice
            c.fail(join("correlation", key), rho,
                   f'the pair is given twice (also as "{other}" = {table[other]!r})',
                   "each pair once")
    return dict(table)


def _scene_or_none(scene: str, overrides: Mapping) -> Any:
    """The study's scene with its overrides, or None when it does not load (the model reports
    why when it is built)."""
    from ..scene import load_scene

    try:
        return load_scene(scene, overrides=dict(overrides))
    except (SceneError, OSError):
        return None


def _uncertain_or_none(specs: Mapping) -> Any:
    """The uncertain inputs of the specs, or None when a distribution is wrong (load_study
    reports it, naming the input)."""
    from ..uq import UncertainInputs

    try:
        return UncertainInputs.from_specs(dict(specs))
    except StudyError:
        return None


def _output_quantities(scene: str, output: Any, overrides: Mapping) -> tuple[str, ...]:
    """The quantities of the study's output (the scene's first output by default): a study
    without ``quantities`` analyses all of them. A scene that does not load, or an output it
    does not have, keeps the point kind's three here; the model then reports the problem."""
    from ..outputs import quantities_of

    base = _scene_or_none(scene, overrides)
    if base is None:
        return QUANTITIES
    name = output if isinstance(output, str) else next(iter(base.outputs), None)
    return quantities_of(base.outputs[name]) if name in base.outputs else QUANTITIES


def _allowables(c: _Checker, table: Any) -> dict:
    """Per quantity (mechrel.outputs.QUANTITY_INFO): the given mean and std, else the
    quantity's default allowable; a quantity without a default has none unless given."""
    table = c.table("allowable", table, "[allowable.QUANTITY] tables with mean and std")
    c.keys("allowable", table, tuple(QUANTITY_INFO), what="the allowables")
    out = {}
    for q, info in QUANTITY_INFO.items():
        if q not in table and q not in DEFAULT_ALLOWABLES:
            continue
        where = join("allowable", q)
        t = c.table(where, table.get(q, {}), "a table with mean and std")
        c.keys(where, t, ("mean", "std"), what="an allowable")
        if "mean" not in t and q not in DEFAULT_ALLOWABLES:
            c.fail(where + ".mean", t, "missing: this quantity has no default allowable",
                   f"a number > 0 ({info.unit})")
        default = DEFAULT_ALLOWABLES.get(q)
        mean = c.number(where + ".mean", t.get("mean", default.mean if default else None), gt=0)
        std = c.number(where + ".std", t.get("std", default.std if default else 0.0), ge=0)
        out[q] = (mean, std)
    return out


def _reliability(c: _Checker, table: Any) -> dict:
    t = c.table("reliability", table)
    for old, new in _RENAMED.items():
        if old in t:
            c.fail(join("reliability", old), t[old], f"renamed: the key is now {new} (the "
                   "name form clashed with the method FORM)",
                   f"reliability.{new} = one of {', '.join(map(repr, EVENTS))}")
    c.keys("reliability", t, _RELIABILITY, what="[reliability]")
    return {"methods": c.choices("reliability.methods", t.get("methods", ["fosm", "mc"]),
                                 tuple(study_methods())),
            "event": c.choice("reliability.event", t.get("event", "two-sided"), EVENTS),
            "n": c.sample_count("reliability.n", t.get("n", 256)),
            "rule": c.choice("reliability.rule", t.get("rule", "sobol"), SAMPLING_RULES),
            "seed": c.seed("reliability.seed", t.get("seed")),
            "pce_order": c.integer("reliability.pce_order", t.get("pce_order", 2), ge=1),
            "pce_max_evaluations": c.integer("reliability.pce_max_evaluations",
                                             t.get("pce_max_evaluations", MAX_EVALUATIONS),
                                             ge=1),
            "max_failure_fraction": c.fraction("reliability.max_failure_fraction",
                                               t.get("max_failure_fraction", 0.1))}


def _method_settings(c: _Checker, raw: Mapping) -> dict:
    """``[form]``, ``[sorm]``, ``[is]``, ``[subset]`` (every method with settings): each key
    checked by the registry's check of that setting, the message restated as
    ``SOURCE: TABLE.KEY = VALUE: PROBLEM; allowed: …``."""
    out = {}
    for key, method in _method_tables().items():
        known = study_settings(method)
        t = c.table(key, raw.get(key, {}), f"a table of {method.name} settings: "
                    + ", ".join(known))
        c.keys(key, t, tuple(known), what=f"[{key}] ({method.name})")
        given = {}
        for k, v in t.items():
            try:
                given[k] = known[k].check(join(key, k), v)
            except StudyError as exc:
                allowed = str(exc).partition("; allowed: ")[2] or None
                c.fail(join(key, k), v, f"not a valid {method.name} setting"
                       + (f" ({known[k].doc})" if known[k].doc else ""), allowed)
        out[key] = given
    return out


def _sensitivity(c: _Checker, table: Any) -> dict:
    t = c.table("sensitivity", table)
    c.keys("sensitivity", t, _SENSITIVITY, what="[sensitivity]")
    return {"n": c.sample_count("sensitivity.n", t.get("n", 256)),
            "seed": c.seed("sensitivity.seed", t.get("seed")),
            "max_failure_fraction": c.fraction("sensitivity.max_failure_fraction",
                                               t.get("max_failure_fraction", 0.05))}


def _inverse(c: _Checker, table: Any) -> dict:
    """``[inverse]``: the target reliability (absent: no inverse question) and its methods."""
    from ..uq.inverse import INVERSE_METHODS

    t = c.table("inverse", table, "a table with target (a reliability in (0, 1)) and methods")
    c.keys("inverse", t, _INVERSE, what="[inverse]")
    target = t.get("target")
    return {"target": None if target is None else c.fraction("inverse.target", target,
                                                              open_lo=True, open_hi=True),
            "methods": c.choices("inverse.methods", t.get("methods", ["auto"]),
                                 tuple(INVERSE_METHODS) + ("auto",))}


def _design_variables(design: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The ``[design]`` section's variables as :func:`mechrel.uq.design_for_reliability` takes
    them (a scene variable's ``paths`` become the model's input of its name)."""
    return {name: {k: v[k] for k in ("kind", "input", "lower", "upper", "start") if k in v}
            for name, v in design["variables"].items()}


def _scene_value(c: _Checker, where: str, paths: list[str], raw: Mapping) -> list[float]:
    """The scene's values at a scene variable's ``paths`` (a path ``-P``: minus P's value),
    each path checked: in the scene, and a number."""
    from ..scene.loader import get_value

    values = []
    for path in paths:
        try:
            value = get_value(raw, path.lstrip("-"))
        except SceneError as exc:
            problem, _, allowed = str(exc).partition("; allowed: ")
            c.fail(join(where, "paths"), paths, f"{path!r}: {problem.split(': ', 1)[-1]}",
                   allowed or None)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            c.fail(join(where, "paths"), paths, f"{path!r} holds {value!r}, not a number",
                   "dotted paths of numeric scene values (e.g. joints.C1.lubricant.viscosity)")
        values.append(-float(value) if path.startswith("-") else float(value))
    return values


def _design(c: _Checker, table: Any, inputs: Mapping, quantities: tuple[str, ...],
            scene: str, overrides: Mapping) -> dict | None:
    """``[design]``: design variables, cost, constraints, method and its settings (absent:
    None). Every field is checked here (names, types, ranges, the cost's language and its value
    at the start design, a constraint's quantity, the method's settings, a scene variable's
    paths in the scene, which give its base value when it has no ``start``), as
    :func:`mechrel.uq.design_for_reliability` will find them, so that a wrong field is
    reported when the study is read, not after the simulations have started."""
    from ..uq.design import DESIGN_METHODS
    from ..uq.design.core import VERIFY_METHODS, _verify_settings
    from ..uq.design.expression import CostExpression, check_finite
    from ..uq.design.space import (BASES, KINDS, SENSES, DesignSpace, as_constraints,
                                   as_variables)

    if table is None:
        return None
    if isinstance(table, Mapping) and not table:  # an unfinished section, not "no design"
        c.fail("design", table, "an empty [design] table", "a [design] table with variables, "
               "cost and constraints (docs/studies.md, 'Design for reliability'), or none")
    loaded: list = []  # the scene, loaded for the first scene variable (None: it does not load)
    base: dict[str, float] = {}  # the scene variables' values in the scene
    t = c.table("design", table, "a table with variables, cost and constraints")
    c.keys("design", t, _DESIGN + tuple(DESIGN_METHODS), required=("variables", "cost",
                                                                    "constraints"),
           what="[design]")
    variables = {}
    vt = c.table("design.variables", t["variables"], "[design.variables.NAME] tables")
    if not vt:
        c.fail("design.variables", vt, "no design variable", "[design.variables.NAME] tables "
               "with kind, input (or paths for kind 'scene'), lower and upper")
    for name, spec in vt.items():
        where = join("design.variables", name)
        if not str(name).isidentifier():
            c.fail(where, name, "not a name usable in the cost expression", "letters, digits "
                   "and _, not starting with a digit")
        spec = c.table(where, spec, "a table with kind, input, lower, upper and start")
        c.keys(where, spec, _DESIGN_VARIABLE, required=("kind", "lower", "upper"),
               what="a design variable")
        kind = c.choice(join(where, "kind"), spec["kind"], KINDS)
        v = {"kind": kind, "lower": c.number(join(where, "lower"), spec["lower"]),
             "upper": c.number(join(where, "upper"), spec["upper"])}
        if not v["upper"] > v["lower"]:
            c.fail(join(where, "upper"), spec["upper"], f"not above lower ({v['lower']!r})",
                   "upper > lower")
        if "start" in spec:
            v["start"] = c.number(join(where, "start"), spec["start"], ge=v["lower"],
                                  le=v["upper"])
        if kind == "scene":
            if "input" in spec or "paths" not in spec:
                c.fail(join(where, "paths" if "paths" not in spec else "input"),
                       spec.get("input", _MISSING), "a scene variable sets scene values, not an "
                       "uncertain input", "paths = [dotted scene paths] (e.g. "
                       "[\"joints.C1.lubricant.viscosity\"]) and no input")
            paths = spec["paths"]
            if isinstance(paths, str):
                paths = [paths]
            if not isinstance(paths, list) or not paths or \
                    not all(isinstance(p, str) and p for p in paths):
                c.fail(join(where, "paths"), spec["paths"], "not a list of scene paths",
                       "a non-empty list of dotted scene paths")
            if name in inputs:
                c.fail(where, name, "the name of an uncertain input", "a name of its own for a "
                       "scene variable")
            v["paths"] = tuple(paths)
            v["input"] = str(name)
            if not loaded:
                loaded.append(_scene_or_none(scene, overrides))
            if loaded[0] is not None:
                values = _scene_value(c, where, list(paths), loaded[0].raw)
                if "start" not in v and len(set(values)) > 1:
                    c.fail(join(where, "start"), _MISSING, "missing, and the paths hold different "
                           f"values in the scene ({', '.join(f'{x:g}' for x in values)}): no one "
                           "base value", "a start value within the bounds, or paths that hold "
                           "one value")
                base[str(name)] = values[0]
        else:
            if "paths" in spec:
                c.fail(join(where, "paths"), spec["paths"], f"kind {kind!r} sets an uncertain "
                       "input's distribution, not scene paths", "input = NAME of [inputs.NAME]")
            if "input" not in spec:
                c.fail(join(where, "input"), _MISSING, "missing required field",
                       "the name of an uncertain input: " + ", ".join(inputs))
            v["input"] = c.choice(join(where, "input"), spec["input"], tuple(inputs))
        variables[str(name)] = v
    try:
        cost = CostExpression(t["cost"], tuple(variables), where="design.cost").text
    except StudyError as exc:
        c.fail("design.cost", t["cost"], str(exc).split(": ", 1)[1].split("; allowed: ")[0],
               str(exc).partition("; allowed: ")[2])
    cons = t["constraints"]
    if isinstance(cons, (int, float)) and not isinstance(cons, bool):
        cons = [{"reliability": cons}]
    if isinstance(cons, Mapping):
        cons = [cons]
    if not isinstance(cons, list) or not cons:
        c.fail("design.constraints", cons, "no constraint", "a target reliability, or "
               "[[design.constraints]] tables with reliability, quantity and basis")
    constraints = []
    for i, con in enumerate(cons):
        where = f"design.constraints[{i}]"
        con = c.table(where, con, "a table with reliability, quantity and basis")
        c.keys(where, con, ("reliability", "quantity", "basis"), required=("reliability",),
               what="a constraint")
        constraints.append({
            "reliability": c.fraction(join(where, "reliability"), con["reliability"],
                                      open_lo=True, open_hi=True),
            "quantity": c.choice(join(where, "quantity"), con.get("quantity", "all"),
                                 ("all", *quantities)),
            "basis": c.choice(join(where, "basis"), con.get("basis", "whole-cycle"), BASES)})
    method = c.choice("design.method", t.get("method", "ak"), tuple(DESIGN_METHODS))
    settings = {}
    for key, entry in DESIGN_METHODS.items():
        st = c.table(join("design", key), t.get(key, {}),
                     f"a table of {entry.name} settings: " + ", ".join(entry.settings))
        known = {k: v for k, v in entry.settings.items() if v.check is not None}
        c.keys(join("design", key), st, tuple(known), what=f"[design.{key}] ({entry.name})")
        given = {}
        for k, v in st.items():
            try:
                given[k] = known[k].check(join(join("design", key), k), v)
            except StudyError as exc:
                c.fail(join(join("design", key), k), v, f"not a valid {entry.name} setting "
                       f"({known[k].doc})", str(exc).partition("; allowed: ")[2] or None)
        settings[key] = given
    verify = t.get("verify", "auto")
    if isinstance(verify, str):
        verify = {"method": verify}
    verify = dict(c.table("design.verify", verify, "a method name or a table with method, n, "
                          "n_per_level, p0"))
    c.keys("design.verify", verify, _VERIFY, what="[design.verify]")
    if "method" in verify:
        verify["method"] = c.choice("design.verify.method", verify["method"], VERIFY_METHODS)
    if "n" in verify:
        verify["n"] = c.sample_count("design.verify.n", verify["n"])
    scene_names = tuple(n for n, v in variables.items() if v["kind"] == "scene")
    try:  # what design_for_reliability checks on the whole set: one message naming the field
        as_constraints(constraints, "design.constraints")  # none repeated
        _verify_settings(verify, "design.verify")  # subset's n_per_level and p0
        checked = as_variables(_design_variables({"variables": variables}), "design.variables")
        uncertain = _uncertain_or_none(inputs)
        if uncertain is not None and len(base) == len(scene_names):
            # (a spread's lower bound > 0, one variable per role, half-width of a bounded input,
            # the start design, its cost)
            space = DesignSpace(checked, uncertain, (*inputs, *scene_names), base,
                                where="design.variables")
            check_finite(CostExpression(cost, tuple(variables), where="design.cost"),
                         space.as_dict(space.start), "the start design")
    except StudyError as exc:
        raise StudyError(str(exc), source=c.source) from None
    return {"variables": variables, "cost": cost,
            "sense": c.choice("design.sense", t.get("sense", "minimize"), SENSES),
            "constraints": constraints, "method": method, "settings": settings,
            "verify": verify,
            "tradeoff": c.integer("design.tradeoff", t.get("tradeoff", 7), ge=0),
            "seed": c.seed("design.seed", t.get("seed")),
            "max_failure_fraction": c.fraction("design.max_failure_fraction",
                                               t.get("max_failure_fraction", 0.1))}


def load_study(source, *, overrides: Mapping[str, Any] | None = None,
               scene_overrides: Mapping[str, Any] | None = None) -> Study:
    """Load and validate a study.

    Parameters
    ----------
    source : str, path or mapping
        An embedded study name, a TOML file, or the parsed mapping.
    overrides : mapping, optional
        ``{"dotted.field": value}`` set in the study before it is validated.
    scene_overrides : mapping, optional
        ``{"dotted.scene.path": value}`` applied to the scene after the study's own
        ``scene_overrides`` (what ``--set joints.C1.model=dry`` on the command line does);
        checked against the scene when :meth:`Study.model` builds it.

    Returns
    -------
    Study
        The validated study.

    Raises
    ------
    StudyError
        Naming the file, the field, the value and what is allowed.

    Examples
    --------
    >>> s = load_study("nine-bar-lubricated", overrides={"reliability.n": 64})
    >>> s.reliability["n"]
    64
    >>> load_study({"scene": "slider-crank-lubricated", "inputs": {}})
    Traceback (most recent call last):
    ...
    mechrel.errors.StudyError: ...inputs...
    """
    raw, label, base_dir = _read(source)
    overrides = dict(overrides or {})
    _apply_overrides(raw, overrides, label)
    c = _Checker(label, [(k, f"{k}={v!r}") for k, v in overrides.items()])
    c.table("", raw)
    c.keys("", raw, study_fields(), required=("scene", "inputs"), what="a study")
    default_name = "study" if isinstance(source, Mapping) else Path(str(source)).stem
    scene = _scene_source(c, c.string("scene", raw["scene"], _Checker.required_hints["scene"]),
                          base_dir, "scene" in overrides)
    output = raw.get("output")
    angle_step = c.angle_step("angle_step", raw.get("angle_step", 18.0))
    cycles = raw.get("cycles")
    specs, paths = _inputs(c, raw["inputs"])
    all_overrides = {**c.table("scene_overrides", raw.get("scene_overrides", {}),
                               "a table of dotted scene paths and values"),
                     **dict(scene_overrides or {})}
    if "quantities" in raw:
        quantities = c.choices("quantities", raw["quantities"], tuple(QUANTITY_INFO))
    else:  # the quantities of the study's output (its kind's), as MechanismModel's default
        quantities = _output_quantities(scene, output, all_overrides)
    allowable = _allowables(c, raw.get("allowable", {}))
    for q in quantities:
        if q not in allowable:
            c.fail(join("allowable", q), _MISSING, "missing: this quantity has no default "
                   "allowable", f"[allowable.{q}] with mean > 0 ({QUANTITY_INFO[q].unit}) "
                   "and std >= 0")
    study = Study(
        name=c.string("name", raw.get("name", default_name)),
        description=c.string("description", raw.get("description", "")),
        scene=scene, output=None if output is None else c.string("output", output),
        angle_step=angle_step, cycles=None if cycles is None else c.integer("cycles", cycles, ge=1),
        quantities=quantities,
        scene_overrides=all_overrides,
        inputs=specs, paths=paths,
        correlation=_correlation(c, raw.get("correlation"), tuple(specs)),
        allowable=allowable,
        reliability=_reliability(c, raw.get("reliability", {})),
        sensitivity=_sensitivity(c, raw.get("sensitivity", {})),
        reference=c.choice("reference", raw.get("reference", "nominal"), REFERENCES),
        method_settings=_method_settings(c, raw),
        inverse=_inverse(c, raw.get("inverse", {})),
        design=_design(c, raw.get("design"), specs, quantities, scene, all_overrides),
        source=label)
    try:  # the distributions, checked by chaospy/scipy with the input's name
        study.uncertain_inputs()
    except StudyError as exc:
        raise StudyError(f"{label}: {exc}") from None
    return study
