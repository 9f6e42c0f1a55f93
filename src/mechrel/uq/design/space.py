"""What a design changes: the design variables, the constraints, and the map from a design to
the model's inputs.

A design variable is one of four kinds:

``"mean"``
    an input's mean (a nominal size, e.g. the nominal clearance): the input's distribution is
    *moved*, its spread and shape kept, x = x₀ + (d − μ₀);
``"std"``
    an input's standard deviation (a tolerance): the distribution is *scaled about its mean*,
    x = μ₀ + (d/σ₀)(x₀ − μ₀), truncation bounds included (a tolerance class widened in
    proportion);
``"half_width"``
    the half-width of a bounded input's range, (upper − lower)/2 (a tolerance written as ±t):
    the same scaling, x = μ₀ + (d/h₀)(x₀ − μ₀), h₀ the base half-width;
``"scene"``
    a fixed scene value (a lubricant's viscosity grade, a speed): an input of the model that is
    not uncertain, set to d.

Here x₀ is a value of the input as the study gives it (the *base* design, mean μ₀, std σ₀) and
μ₀ stays the centre of the scaling, so that a mean and a spread variable of one input combine
to x = d_mean + s (x₀ − μ₀). Each map is affine in x₀, so x₀ = F₀⁻¹(Φ(u)) from standard-normal
draws u gives, for every design, the same draws mapped through that design's inputs: **common
random numbers**. The estimates of two designs then differ by the designs, not by the draws,
and the constraint is a continuous function of the design, which an optimiser needs.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from mechrel.errors import StudyError

from ..._checks import ARGS

__all__ = ["DesignVariable", "ReliabilityConstraint", "DesignSpace", "KINDS", "BASES",
           "SENSES", "as_variables", "as_constraints"]

KINDS = ("mean", "std", "half_width", "scene")
"""The kinds of design variable (module docstring)."""

BASES = ("whole-cycle", "per-angle")
"""What a reliability constraint holds over: the whole cycle (every quantity it names within
its allowable at every instant of the analysed cycle, judged at the cycle's extremes), or each
analysis angle on its own (the tolerance-allocation literature's constraint)."""

SENSES = ("minimize", "maximize")

_SCALE_KINDS = ("std", "half_width")


@dataclass(frozen=True)
class DesignVariable:
    """One design variable (module docstring).

    Parameters
    ----------
    name : str
        Its name in the cost expression (a Python identifier).
    kind : {"mean", "std", "half_width", "scene"}
        What it sets.
    input : str
        The uncertain input whose mean or spread it sets; for ``"scene"``, the model's input
        that carries the scene value (not an uncertain input).
    lower, upper : float
        Its bounds (the input's SI unit), lower < upper; > 0 for ``"std"`` and
        ``"half_width"``.
    start : float, optional
        Where the optimiser starts (within the bounds); default: the base design's value
        (the input's mean, std or half-width; the model's nominal scene value), clipped to
        the bounds.

    Examples
    --------
    >>> DesignVariable("t_crank", "std", "crank", 5e-6, 1e-4)
    DesignVariable(name='t_crank', kind='std', input='crank', lower=5e-06, upper=0.0001, start=None)
    """

    name: str
    kind: str
    input: str
    lower: float
    upper: float
    start: float | None = None

    def checked(self, where: str) -> DesignVariable:
        """The variable with its fields checked (one :class:`StudyError` naming the field).

        Parameters
        ----------
        where : str
            How the variable is named in messages (``design.variables.NAME``).

        Returns
        -------
        DesignVariable

        Raises
        ------
        StudyError
            A field of the wrong type or out of range (naming it).

        Examples
        --------
        >>> DesignVariable("t", "std", "x", 0.0, 1.0).checked("t")
        Traceback (most recent call last):
        ...
        mechrel.errors.StudyError: t.lower = 0.0: must be > 0; allowed: a finite number > 0 (a std or half-width is positive)
        """
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise StudyError(f"{where}: name {self.name!r} is not an identifier; allowed: a "
                             "name of letters, digits and _ (not starting with a digit), usable "
                             "in the cost expression")
        ARGS.choice(f"{where}.kind", self.kind, KINDS)
        ARGS.string(f"{where}.input", self.input)
        lo = ARGS.number(f"{where}.lower", self.lower)
        if self.kind in _SCALE_KINDS and not lo > 0:
            raise StudyError(f"{where}.lower = {lo!r}: must be > 0; allowed: a finite number "
                             "> 0 (a std or half-width is positive)")
        hi = ARGS.number(f"{where}.upper", self.upper, gt=lo)
        start = None if self.start is None else ARGS.number(f"{where}.start", self.start,
                                                            ge=lo, le=hi)
        return DesignVariable(self.name, self.kind, self.input, lo, hi, start)


@dataclass(frozen=True)
class ReliabilityConstraint:
    """A reliability constraint of a design: R ≥ ``reliability``.

    Parameters
    ----------
    reliability : float
        The target reliability R_t, in (0, 1).
    quantity : str, default "all"
        ``"all"``: every quantity of the model at once (one event: all of them within their
        allowables); or one quantity.
    basis : {"whole-cycle", "per-angle"}, default "whole-cycle"
        Over the whole cycle (judged at the cycle's extremes), or at each analysis angle on its
        own (the literature's constraint: every angle's reliability ≥ R_t, which lets the whole
        cycle's fall below it).

    Examples
    --------
    >>> ReliabilityConstraint(0.999).label
    'all (whole-cycle) R >= 0.999'
    """

    reliability: float
    quantity: str = "all"
    basis: str = "whole-cycle"

    @property
    def label(self) -> str:
        """A short name of the constraint, for tables and messages.

        Returns
        -------
        str

        Examples
        --------
        >>> ReliabilityConstraint(0.99, "velocity", "per-angle").label
        'velocity (per-angle) R >= 0.99'
        """
        return f"{self.quantity} ({self.basis}) R >= {self.reliability:g}"


def as_variables(variables: Any, where: str = "variables") -> tuple[DesignVariable, ...]:
    """Design variables from :class:`DesignVariable` objects or ``{name: {field: value}}``.

    Parameters
    ----------
    variables : sequence of DesignVariable, or mapping
        ``{name: {"kind", "input", "lower", "upper", "start"}}`` (the form of a study file's
        ``[design.variables.NAME]`` tables).
    where : str, default "variables"
        How the variables are named in messages (``design.variables`` in a study file).

    Returns
    -------
    tuple of DesignVariable
        Checked, names unique.

    Raises
    ------
    StudyError
        A missing or bad field, a repeated name.

    Examples
    --------
    >>> as_variables({"c": {"kind": "mean", "input": "clearance", "lower": 3e-4,
    ...                     "upper": 6e-4}})[0].kind
    'mean'
    """
    out = []
    if isinstance(variables, Mapping):
        for name, spec in variables.items():
            at = f"{where}.{name}"
            if isinstance(spec, DesignVariable):
                out.append(spec)
                continue
            if not isinstance(spec, Mapping):
                raise StudyError(f"{at} = {spec!r}: not a table; allowed: a table with kind, "
                                 "input, lower, upper and optionally start")
            unknown = sorted(set(spec) - {"kind", "input", "lower", "upper", "start"})
            if unknown:
                raise StudyError(f"{at}: unknown field {unknown[0]!r}; allowed: fields kind, "
                                 "input, lower, upper, start")
            missing = [k for k in ("kind", "input", "lower", "upper") if k not in spec]
            if missing:
                raise StudyError(f"{at}.{missing[0]}: missing required field; allowed: "
                                 + {"kind": "one of " + ", ".join(KINDS),
                                    "input": "the name of an uncertain input (scene: of the "
                                             "model's input carrying the value)",
                                    "lower": "a finite number", "upper": "a finite number"
                                    }[missing[0]])
            out.append(DesignVariable(str(name), spec["kind"], spec["input"], spec["lower"],
                                      spec["upper"], spec.get("start")))
    elif isinstance(variables, (list, tuple)) and variables:
        out = list(variables)
    else:
        raise StudyError(f"{where} = {variables!r}: no design variables; allowed: a non-empty "
                         "sequence of DesignVariable or a mapping {name: {kind, input, lower, "
                         "upper}}")
    checked = []
    for v in out:
        if not isinstance(v, DesignVariable):
            raise StudyError(f"{where}: {v!r} is not a DesignVariable; allowed: "
                             "DesignVariable(name, kind, input, lower, upper, start=None)")
        checked.append(v.checked(f"{where}.{v.name}"))
    names = [v.name for v in checked]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise StudyError(f"{where}: the name {dup[0]!r} is used twice; allowed: distinct names")
    seen: dict[tuple[str, str], str] = {}
    for v in checked:
        role = "spread" if v.kind in _SCALE_KINDS else v.kind
        key = (v.input, role)
        if key in seen:
            raise StudyError(f"{where}.{v.name}.input = {v.input!r}: already has a {role} "
                             f"variable ({seen[key]}); allowed: at most one mean and one std or "
                             "half_width variable per input, one scene variable per model input")
        seen[key] = v.name
    return tuple(checked)


def as_constraints(constraints: Any, where: str = "constraints"
                   ) -> tuple[ReliabilityConstraint, ...]:
    """Reliability constraints from a number, :class:`ReliabilityConstraint` objects or mappings.

    Parameters
    ----------
    constraints : float, ReliabilityConstraint, mapping or sequence of them
        A number R_t is the whole-cycle constraint of all quantities at R_t; a mapping has
        ``reliability``, ``quantity`` and ``basis`` (the form of a study file's
        ``[[design.constraints]]``).
    where : str, default "constraints"
        How the constraints are named in messages (``design.constraints`` in a study file).

    Returns
    -------
    tuple of ReliabilityConstraint
        Checked (reliability in (0, 1), basis one of :data:`BASES`), none repeated.

    Raises
    ------
    StudyError
        A bad field.

    Examples
    --------
    >>> as_constraints(0.999)
    (ReliabilityConstraint(reliability=0.999, quantity='all', basis='whole-cycle'),)
    """
    if isinstance(constraints, (ReliabilityConstraint, Mapping)) or (
            isinstance(constraints, (int, float)) and not isinstance(constraints, bool)):
        constraints = [constraints]
    if not isinstance(constraints, (list, tuple)) or not constraints:
        raise StudyError(f"{where} = {constraints!r}: no constraint; allowed: a target "
                         "reliability in (0, 1), or a non-empty sequence of "
                         "ReliabilityConstraint or {reliability, quantity, basis}")
    out = []
    for i, c in enumerate(constraints):
        at = f"{where}[{i}]"
        if isinstance(c, Mapping):
            unknown = sorted(set(c) - {"reliability", "quantity", "basis"})
            if unknown:
                raise StudyError(f"{at}: unknown field {unknown[0]!r}; allowed: fields "
                                 "reliability, quantity, basis")
            if "reliability" not in c:
                raise StudyError(f"{at}.reliability: missing required field; allowed: a "
                                 "reliability in (0, 1)")
            c = ReliabilityConstraint(c["reliability"], c.get("quantity", "all"),
                                      c.get("basis", "whole-cycle"))
        elif isinstance(c, (int, float)) and not isinstance(c, bool):
            c = ReliabilityConstraint(float(c))
        if not isinstance(c, ReliabilityConstraint):
            raise StudyError(f"{at} = {c!r}: not a constraint; allowed: a reliability, a "
                             "ReliabilityConstraint or {reliability, quantity, basis}")
        r = ARGS.fraction(f"{at}.reliability", c.reliability, open_lo=True, open_hi=True)
        q = ARGS.string(f"{at}.quantity", c.quantity)
        b = ARGS.choice(f"{at}.basis", c.basis, BASES)
        out.append(ReliabilityConstraint(r, q, b))
    keys = [(c.quantity, c.basis) for c in out]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise StudyError(f"{where}: quantity {dup[0][0]!r} ({dup[0][1]}) is constrained "
                         "twice; allowed: one constraint per quantity and basis")
    return tuple(out)


def _base_half_width(marginal, name: str, where: str) -> float:
    lo, hi = (float(v) for v in marginal.scipy().support())
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise StudyError(f"{where}.kind = 'half_width': needs a bounded input, but {name!r} is "
                         f"{marginal!r} (range [{lo:g}, {hi:g}]); allowed: kind 'std', or a "
                         "bounded distribution (uniform, truncnormal, beta)")
    return 0.5 * (hi - lo)


class DesignSpace:
    """The design variables of a model and its uncertain inputs, and how a design sets the
    model's inputs (module docstring).

    Parameters
    ----------
    variables : sequence of DesignVariable
        Checked (:func:`as_variables`).
    inputs : UncertainInputs
        The uncertain inputs at the base design.
    model_names : sequence of str
        The model's inputs: those of ``inputs`` and one per ``"scene"`` variable.
    nominal : mapping, optional
        ``{model input: value}``: the base design's scene values (default start of a
        ``"scene"`` variable).
    where : str, default "variables"
        How the variables are named in messages (``design.variables`` in a study file).

    Raises
    ------
    StudyError
        A variable naming an input that does not exist or of the wrong kind, a model input that
        is neither uncertain nor a scene variable, a scene variable without a start value.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
    >>> s = DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0),
    ...                  DesignVariable("t", "std", "x", 0.01, 1.0)], inputs, ["x"])
    >>> s.start.tolist()
    [1.0, 0.1]
    >>> s.physical([2.0, 0.2], np.array([[1.1], [0.9]])).tolist()   # 2 + 2 (x0 − 1)
    [[2.2], [1.8]]
    """

    def __init__(self, variables: Sequence[DesignVariable], inputs: Any,
                 model_names: Sequence[str], nominal: Mapping[str, float] | None = None,
                 where: str = "variables"):
        self.variables = tuple(variables)
        self.inputs = inputs
        self.model_names = tuple(model_names)
        random = tuple(inputs.names)
        scene = [v for v in self.variables if v.kind == "scene"]
        scene_names = [v.input for v in scene]
        for v in self.variables:
            at = f"{where}.{v.name}"
            if v.kind == "scene":
                if v.input in random:
                    raise StudyError(f"{at}.input = {v.input!r}: an uncertain input, not a "
                                     "fixed scene value; allowed: kind 'mean', 'std' or "
                                     "'half_width' for an uncertain input, 'scene' for a model "
                                     "input that is not uncertain")
                if v.input not in self.model_names:
                    raise StudyError(f"{at}.input = {v.input!r}: not an input of the model "
                                     f"({', '.join(self.model_names)}); allowed: the model's "
                                     "input carrying the scene value")
            elif v.input not in random:
                raise StudyError(f"{at}.input = {v.input!r}: not an uncertain input; "
                                 f"allowed: one of {', '.join(random)}")
        extra = [n for n in self.model_names if n not in random and n not in scene_names]
        if extra:
            raise StudyError(f"model inputs {extra} are neither uncertain inputs nor scene "
                             "design variables; allowed: a model whose inputs are the uncertain "
                             "inputs and one per design variable of kind 'scene'")
        missing = [n for n in random if n not in self.model_names]
        if missing:
            raise StudyError(f"inputs {missing} are not inputs of the model "
                             f"({', '.join(self.model_names)}); allowed: the model's inputs")
        self.random_names = random
        self.mu0 = np.asarray(inputs.mean, dtype=float)
        self.sd0 = np.asarray(inputs.std, dtype=float)
        base = []
        for v in self.variables:
            if v.kind == "scene":
                value = (nominal or {}).get(v.input, v.start)
                if value is None:
                    raise StudyError(f"{where}.{v.name}.start: missing: the model does not "
                                     f"give the base value of {v.input!r}; allowed: a start "
                                     "value within the bounds")
                base.append(float(value))
                continue
            j = random.index(v.input)
            if v.kind == "mean":
                base.append(float(self.mu0[j]))
            elif v.kind == "std":
                base.append(float(self.sd0[j]))
            else:
                base.append(_base_half_width(inputs.marginals[j], v.input,
                                             f"{where}.{v.name}"))
        self.base = np.asarray(base)
        self.lower = np.array([v.lower for v in self.variables])
        self.upper = np.array([v.upper for v in self.variables])
        self.start = np.array([v.start if v.start is not None else
                               min(max(b, v.lower), v.upper)
                               for v, b in zip(self.variables, self.base)])
        self.log = np.array([v.kind in _SCALE_KINDS for v in self.variables])
        self._col = {n: i for i, n in enumerate(self.model_names)}

    @property
    def names(self) -> tuple[str, ...]:
        """The design variables' names.

        Returns
        -------
        tuple of str

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0)], inputs, ["x"]).names
        ('m',)
        """
        return tuple(v.name for v in self.variables)

    @property
    def m(self) -> int:
        """The number of design variables.

        Returns
        -------
        int

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> s = DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0),
        ...                  DesignVariable("t", "std", "x", 0.01, 1.0)], inputs, ["x"])
        >>> s.m
        2
        """
        return len(self.variables)

    # ---------------------------------------------------------------- optimiser coordinates
    def to_unit(self, d: ArrayLike) -> np.ndarray:
        """Design → the optimiser's coordinates in [0, 1]: linear in a mean or scene value,
        logarithmic in a std or half-width (tolerances span decades; equal steps are equal
        ratios).

        Parameters
        ----------
        d : array_like, shape (m,)
            A design within the bounds.

        Returns
        -------
        ndarray, shape (m,)

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> s = DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0),
        ...                  DesignVariable("t", "std", "x", 0.01, 1.0)], inputs, ["x"])
        >>> np.round(s.to_unit([1.25, 0.1]), 12).tolist()    # mid-span; one decade of two
        [0.5, 0.5]
        """
        d = np.asarray(d, dtype=float)
        lo, hi = self.lower, self.upper
        lin = (d - lo) / (hi - lo)
        with np.errstate(divide="ignore", invalid="ignore"):
            lg = (np.log(d) - np.log(lo)) / (np.log(hi) - np.log(lo))
        return np.where(self.log, lg, lin)

    def from_unit(self, eta: ArrayLike) -> np.ndarray:
        """The optimiser's coordinates → design (inverse of :meth:`to_unit`), clipped to the
        bounds.

        Parameters
        ----------
        eta : array_like, shape (m,)
            Coordinates in [0, 1] (clipped).

        Returns
        -------
        ndarray, shape (m,)

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> s = DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0),
        ...                  DesignVariable("t", "std", "x", 0.01, 1.0)], inputs, ["x"])
        >>> np.round(s.from_unit([0.5, 1.5]), 12).tolist()
        [1.25, 1.0]
        """
        eta = np.clip(np.asarray(eta, dtype=float), 0.0, 1.0)
        lo, hi = self.lower, self.upper
        lin = lo + eta * (hi - lo)
        lg = np.exp(np.log(lo) + eta * (np.log(hi) - np.log(lo)))
        return np.clip(np.where(self.log, lg, lin), lo, hi)

    # ---------------------------------------------------------------- the map
    def affine(self, d: ArrayLike) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
        """The design's map of the uncertain inputs, x = loc + scale (x₀ − μ₀) per input, and
        its scene values.

        Parameters
        ----------
        d : sequence of float
            The design, in the order of :attr:`names`.

        Returns
        -------
        loc, scale : ndarray, shape (r,)
            Per uncertain input.
        scene : dict
            ``{model input: value}`` of the scene variables.

        Raises
        ------
        StudyError
            ``d`` of the wrong length.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> s = DesignSpace([DesignVariable("t", "std", "x", 0.01, 1.0)], inputs, ["x"])
        >>> [np.round(a, 12).tolist() for a in s.affine([0.3])[:2]]
        [[1.0], [3.0]]
        """
        x = np.asarray(d, dtype=float).reshape(-1)
        if x.size != self.m:
            raise StudyError(f"design: expected {self.m} values ({', '.join(self.names)}), "
                             f"got {x.size}")
        loc = self.mu0.copy()
        scale = np.ones_like(self.mu0)
        scene = {}
        for v, value, b in zip(self.variables, x, self.base):
            if v.kind == "scene":
                scene[v.input] = float(value)
                continue
            j = self.random_names.index(v.input)
            if v.kind == "mean":
                loc[j] = value
            else:
                scale[j] = value / b
        return loc, scale, scene

    def physical(self, d: ArrayLike, X0: ArrayLike) -> np.ndarray:
        """The model's input points at design ``d`` from base points ``X0``.

        Parameters
        ----------
        d : sequence of float
            The design.
        X0 : array_like, shape (n, r)
            Points of the uncertain inputs at the base design (in the order of
            ``inputs.names``).

        Returns
        -------
        ndarray, shape (n, len(model_names))
            In the order of the model's inputs.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> s = DesignSpace([DesignVariable("g", "scene", "nu", 0.05, 0.2, start=0.1)], inputs,
        ...                 ["x", "nu"])
        >>> s.physical([0.07], np.array([[1.2]])).tolist()
        [[1.2, 0.07]]
        """
        loc, scale, scene = self.affine(d)
        return apply_affine(np.atleast_2d(np.asarray(X0, dtype=float)), loc, scale, self.mu0,
                            self._random_cols(), self._scene_cols(scene), len(self.model_names))

    def _random_cols(self) -> np.ndarray:
        return np.array([self._col[n] for n in self.random_names])

    def _scene_cols(self, scene: Mapping[str, float]) -> tuple[tuple[int, float], ...]:
        return tuple((self._col[n], v) for n, v in scene.items())

    def as_dict(self, d: ArrayLike) -> dict[str, float]:
        """The ``{name: value}`` of a design.

        Parameters
        ----------
        d : sequence of float
            The design.

        Returns
        -------
        dict

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0)], inputs, ["x"]).as_dict([1.5])
        {'m': 1.5}
        """
        return {n: float(v) for n, v in zip(self.names, np.asarray(d, dtype=float).reshape(-1))}

    def describe(self) -> list[dict]:
        """The variables, for provenance.

        Returns
        -------
        list of dict
            One per variable: name, kind, input, lower, upper, start, base.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 0.1)})
        >>> s = DesignSpace([DesignVariable("m", "mean", "x", 0.5, 2.0),
        ...                  DesignVariable("t", "std", "x", 0.01, 1.0)], inputs, ["x"])
        >>> s.describe()[1]["base"]
        0.1
        """
        return [{"name": v.name, "kind": v.kind, "input": v.input, "lower": v.lower,
                 "upper": v.upper, "start": float(s), "base": float(b)}
                for v, s, b in zip(self.variables, self.start, self.base)]


def apply_affine(X0: np.ndarray, loc: np.ndarray, scale: np.ndarray, mu0: np.ndarray,
                 random_cols: np.ndarray, scene_cols: tuple, n_cols: int) -> np.ndarray:
    """The map x = loc + scale (x₀ − μ₀) per uncertain input, placed with the scene values in the
    model's input order (:meth:`DesignSpace.physical`, :class:`AtDesign`)."""
    Z = np.empty((X0.shape[0], n_cols))
    Z[:, random_cols] = loc + scale * (X0 - mu0)
    for c, v in scene_cols:
        Z[:, c] = v
    return Z


class AtDesign:
    """A model at one design: its inputs are the uncertain inputs at the base design, mapped
    through the design before the model is evaluated (a :class:`~mechrel.uq.Model`).

    A forward estimator (:func:`~mechrel.uq.monte_carlo`, :func:`~mechrel.uq.subset_simulation`)
    with the study's base inputs then estimates the design's reliability: the verification of
    an optimum. Picklable (plain arrays and the model).

    Parameters
    ----------
    model : Model
        The model of the uncertain inputs and the scene design variables.
    space : DesignSpace
        The design space.
    design : sequence of float
        The design.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> space = DesignSpace([DesignVariable("t", "std", "x", 0.1, 10.0)], inputs, ["x"])
    >>> m = AtDesign(linear_model([0.0], [[1.0]], ["x"]), space, [3.0])
    >>> m.evaluate(np.array([0.5])).tolist()    # x = 3 × 0.5
    [1.5]
    """

    def __init__(self, model: Any, space: DesignSpace, design: ArrayLike):
        self.model = model
        self.design = tuple(float(v) for v in np.asarray(design, dtype=float).reshape(-1))
        loc, scale, scene = space.affine(self.design)
        self._args = (loc, scale, space.mu0.copy(), space._random_cols(),
                      space._scene_cols(scene), len(space.model_names))
        self.input_names = space.random_names
        self.output_index = model.output_index
        self.vectorized = bool(getattr(model, "vectorized", False))
        self._design_record = {"variables": space.as_dict(self.design),
                               "loc": loc.tolist(), "scale": scale.tolist(), "scene": scene}

    def _z(self, X: np.ndarray) -> np.ndarray:
        return apply_affine(np.atleast_2d(np.asarray(X, dtype=float)), *self._args)

    def evaluate(self, x: np.ndarray) -> np.ndarray:
        """The model's outputs at base point ``x`` mapped through the design.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(1.0, 1.0)})
        >>> space = DesignSpace([DesignVariable("m", "mean", "x", 0.0, 5.0)], inputs, ["x"])
        >>> AtDesign(linear_model([0.0], [[1.0]], ["x"]), space, [3.0]).evaluate([1.5]).tolist()
        [3.5]
        """
        return np.asarray(self.model.evaluate(self._z(x)[0]), dtype=float)

    def evaluate_batch(self, X: np.ndarray) -> np.ndarray:
        """The outputs at the rows of ``X`` (one call of the model's ``evaluate_batch``)."""
        Z = self._z(X)
        if self.vectorized:
            return np.asarray(self.model.evaluate_batch(Z), dtype=float)
        return np.stack([self.model.evaluate(z) for z in Z]) if len(Z) else \
            np.empty((0, len(self.output_index)))

    def cache_key(self) -> str:
        """The model's key with the design (so that designs never share cached rows).

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> space = DesignSpace([DesignVariable("t", "std", "x", 0.1, 10.0)], inputs, ["x"])
        >>> model = linear_model([0.0], [[1.0]], ["x"])
        >>> AtDesign(model, space, [1.0]).cache_key() != AtDesign(model, space, [2.0]).cache_key()
        True
        """
        payload = json.dumps({"model": self.model.cache_key(), "design": self._design_record},
                             sort_keys=True)
        return hashlib.sha256(payload.encode()).hexdigest()

    def describe(self) -> dict:
        """The model's description with the design."""
        from ..problem.model import describe_model

        return {**describe_model(self.model), "design": self._design_record}

    def __getattr__(self, name):
        # scene, nonsmooth, output_noise, ... of the model (not the protocol's members)
        if name.startswith("__") or name in ("model", "_args", "design"):
            raise AttributeError(name)
        return getattr(self.model, name)
