"""Limit states: failure is g ≤ 0.

A :class:`LimitState` turns the outputs of a model (the rows of ``Y``, labelled by the model's
``output_index``) and, optionally, random allowables into one safety margin g per sample:
g > 0 safe, g ≤ 0 failed. It knows nothing about mechanisms: it addresses outputs by their
labels, so it works with any model that names its outputs.

Building blocks
---------------
``LimitState.margin(output)``
    The output *is* the margin: g = y (a Python function g(x) wrapped as a one-output
    :class:`~mechrel.uq.FunctionModel`; ``output=None`` takes the model's only output).
``LimitState.exceedance(outputs, allowable, kind=...)``
    An output (or a group of outputs) against an allowable a:
    ``kind="abs"``   g = a − max_k |y_k|  (failure: some |y_k| ≥ a; a tolerance on the magnitude),
    ``kind="upper"`` g = a − max_k y_k    (failure: some y_k ≥ a),
    ``kind="lower"`` g = min_k y_k − a    (failure: some y_k ≤ a).
    A group of outputs is the series system of its members, so listing every crank angle of a
    quantity (or a model's cycle-extreme output) gives the whole-cycle (first-passage) event.
``LimitState.from_function(func)``
    g = func(Y) for any vectorised function of the output matrix Y (n, n_out) → (n,).
``LimitState.series(*states)`` / ``LimitState.parallel(*states)``
    g = min over components (failure when any component fails) / max over components (failure
    when all fail).

Allowables
----------
A number is a fixed allowable. A marginal (any of :data:`mechrel.uq.problem.inputs.MARGINAL_TYPES`:
``Normal``, ``LogNormal``, ``Gumbel``, ``Weibull``, ...) is a random allowable: an extra uncertain input,
independent of the model's inputs (the paper's interference model), named
``"allowable[<component name>]"``. The reliability estimators append it to the inputs; it never
reaches the model, so the model is not re-run for a change of the allowable alone.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from .inputs import MARGINAL_TYPES, Normal  # noqa: F401 (Normal: the doctests' allowable)

__all__ = ["LimitState", "Component", "KINDS", "SYSTEMS", "BoundLimitState"]

KINDS = ("margin", "abs", "upper", "lower")
SYSTEMS = ("series", "parallel")
_MARGINALS = MARGINAL_TYPES


def _check_allowable(name: str, allowable: Any):
    if isinstance(allowable, _MARGINALS):
        return allowable.validated(f"allowable[{name}]")
    if isinstance(allowable, (bool, np.bool_)) or not isinstance(allowable, (int, float, np.integer, np.floating)):
        raise StudyError(
            f"LimitState: allowable[{name}] = {allowable!r}: not a number or a marginal; "
            "allowed: a finite float (fixed) or a marginal (random): "
            + "/".join(t.__name__ for t in _MARGINALS)
        )
    a = float(allowable)
    if not np.isfinite(a):
        raise StudyError(f"LimitState: allowable[{name}] = {allowable!r}: not finite; allowed: a finite float")
    return a


@dataclass(frozen=True)
class Component:
    """One failure mode of a limit state: a margin g_c computed from a group of outputs.

    Built by the constructors of :class:`LimitState`, not directly.

    Parameters
    ----------
    name : str
        Its name (unique within a limit state).
    kind : {"margin", "abs", "upper", "lower"}
        ``"margin"``: g_c = min of the outputs; ``"abs"``: g_c = a − max |y|; ``"upper"``:
        g_c = a − max y; ``"lower"``: g_c = min y − a (a the allowable, in the outputs' unit).
    outputs : tuple, default (None,)
        The output labels of the group (``(None,)``: the model's only output).
    allowable : float or marginal, optional
        A fixed allowable, or a marginal (:class:`~mechrel.uq.Normal`, ...) for a random one.
    func : callable, optional
        ``func(Y) -> g`` for a component given by a function of all the outputs.

    Examples
    --------
    >>> LimitState.exceedance(["y"], Normal(3.0, 0.1), kind="upper").components[0].kind
    'upper'
    """

    name: str
    kind: str
    outputs: tuple = (None,)
    allowable: Any = None
    func: Callable | None = None

    @property
    def random(self) -> bool:
        """Whether the allowable is random (a marginal, an extra uncertain input).

        Returns
        -------
        bool
            True for a marginal allowable.

        Examples
        --------
        >>> Component("c", "upper", ("y",), Normal(3.0, 0.1)).random
        True
        """
        return isinstance(self.allowable, _MARGINALS)


@dataclass(frozen=True)
class LimitState:
    """A limit state g(x) (failure: g ≤ 0), a series or parallel system of components.

    Build it with :meth:`margin`, :meth:`exceedance`, :meth:`from_function`, :meth:`series`
    or :meth:`parallel` rather than from its fields.

    Parameters
    ----------
    components : tuple of Component
        The component limit states (each a margin, an exceedance of an allowable, or a function
        of the outputs).
    system : {"series", "parallel"}, default "series"
        Failure when any component fails (g = min) or when all do (g = max).
    name : str, default "g"
        Its name in tables (the index of a rare-event result).

    Examples
    --------
    Failure when the output ``y`` exceeds a fixed allowable 3:

    >>> import numpy as np
    >>> from mechrel.uq import FunctionModel, LimitState, Normal, UncertainInputs, form
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> model = FunctionModel(lambda X: X[:, 0], ["x"], ["y"], vectorized=True)
    >>> ls = LimitState.exceedance(["y"], 3.0, kind="upper", name="y > 3")
    >>> round(form(model=model, inputs=inputs, limit_state=ls).beta, 6)
    3.0
    """

    components: tuple[Component, ...]
    system: str = "series"
    name: str = "g"

    def __post_init__(self):
        if self.system not in SYSTEMS:
            raise StudyError(f"LimitState: system = {self.system!r}: unknown; allowed: {list(SYSTEMS)}")
        comps = tuple(self.components)
        if not comps or not all(isinstance(c, Component) for c in comps):
            raise StudyError("LimitState: components = (): needs at least one Component; "
                             "allowed: LimitState.margin/exceedance/from_function/series/parallel")
        names = [c.name for c in comps]
        if len(set(names)) != len(names):
            raise StudyError(f"LimitState: component names = {names}: duplicated; allowed: unique names "
                             "(pass name= to each component)")
        object.__setattr__(self, "components", comps)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def margin(cls, output: Any = None, *, name: str | None = None) -> LimitState:
        """A limit state whose margin g is one output of the model.

        Parameters
        ----------
        output : hashable, optional
            The output label (None: the model's only output).
        name : str, optional
            Its name (default: the label, or ``"g"``).

        Returns
        -------
        LimitState
            One ``"margin"`` component.

        Examples
        --------
        >>> LimitState.margin("y").name
        'y'
        """
        nm = str(name if name is not None else ("g" if output is None else output))
        return cls((Component(nm, "margin", (output,)),), "series", nm)

    @classmethod
    def exceedance(cls, outputs: Any, allowable: Any, *, kind: str = "abs", name: str | None = None) -> LimitState:
        """A limit state: an output, or a group of outputs (their series system), against an allowable.

        Parameters
        ----------
        outputs : hashable or list
            An output label or a list of labels.
        allowable : float or marginal
            The allowable, in the outputs' unit: a finite float (fixed) or a marginal
            (:class:`~mechrel.uq.Normal`, :class:`~mechrel.uq.Weibull`, ..., any of
            :data:`~mechrel.uq.problem.inputs.MARGINAL_TYPES`; random, an extra uncertain input).
        kind : {"abs", "upper", "lower"}, default "abs"
            Failure when max |y| > a, max y > a, or min y < a.
        name : str, optional
            Its name (default: from the labels).

        Returns
        -------
        LimitState
            One component.

        Raises
        ------
        StudyError
            If ``kind`` is unknown, ``outputs`` is empty or the allowable is not a finite number or a
            marginal.

        Examples
        --------
        >>> ls = LimitState.exceedance(["a", "b"], 1.0)
        >>> ls.name, ls.components[0].outputs
        ('a..b', ('a', 'b'))
        """
        if kind not in KINDS[1:]:
            raise StudyError(f"LimitState.exceedance: kind = {kind!r}: unknown; allowed: {list(KINDS[1:])}")
        outs = tuple(outputs) if isinstance(outputs, (list, pd.Index, np.ndarray)) else (outputs,)
        if len(outs) == 0:
            raise StudyError("LimitState.exceedance: outputs = []: empty; allowed: one label or a list of labels")
        nm = str(name if name is not None else (outs[0] if len(outs) == 1 else f"{outs[0]}..{outs[-1]}"))
        return cls((Component(nm, kind, outs, _check_allowable(nm, allowable)),), "series", nm)

    @classmethod
    def from_function(cls, func: Callable[[np.ndarray], Any], *, name: str = "g") -> LimitState:
        """A limit state whose margin is a function of the output matrix.

        Parameters
        ----------
        func : callable
            ``func(Y) -> g``: Y the (n, n_out) outputs, g of shape (n,) (failure: g <= 0).
        name : str, default "g"
            Its name.

        Returns
        -------
        LimitState
            One component given by ``func``.

        Raises
        ------
        StudyError
            If ``func`` is not callable.

        Examples
        --------
        >>> ls = LimitState.from_function(lambda Y: 1.0 - Y.sum(axis=1))
        >>> ls.bind(pd.RangeIndex(2))(np.array([[0.25, 0.5]])).tolist()
        [0.25]
        """
        if not callable(func):
            raise StudyError(f"LimitState.from_function: func = {func!r}: not callable; allowed: a function Y -> g")
        return cls((Component(str(name), "margin", (None,), None, func),), "series", str(name))

    @classmethod
    def series(cls, *states: LimitState, name: str = "series") -> LimitState:
        """A series system: failure when any of ``states`` fails (g = min).

        Parameters
        ----------
        *states : LimitState
            The limit states (single components or series systems).
        name : str, default "series"
            Its name.

        Returns
        -------
        LimitState
            Their components in one series system.

        Raises
        ------
        StudyError
            If a state is not a :class:`LimitState`, a parallel system is nested, or none is given.

        Examples
        --------
        >>> ls = LimitState.series(LimitState.margin("a"), LimitState.margin("b"))
        >>> ls.bind(pd.Index(["a", "b"]))(np.array([[1.0, -2.0]])).tolist()
        [-2.0]
        """
        return cls(_flatten(states, "series"), "series", name)

    @classmethod
    def parallel(cls, *states: LimitState, name: str = "parallel") -> LimitState:
        """A parallel system: failure when all of ``states`` fail (g = max).

        Parameters
        ----------
        *states : LimitState
            The limit states (single components or parallel systems).
        name : str, default "parallel"
            Its name.

        Returns
        -------
        LimitState
            Their components in one parallel system.

        Raises
        ------
        StudyError
            If a state is not a :class:`LimitState`, a series system is nested, or none is given.

        Examples
        --------
        >>> ls = LimitState.parallel(LimitState.margin("a"), LimitState.margin("b"))
        >>> ls.bind(pd.Index(["a", "b"]))(np.array([[1.0, -2.0]])).tolist()
        [1.0]
        """
        return cls(_flatten(states, "parallel"), "parallel", name)

    # ------------------------------------------------------------------ use
    @property
    def random_allowables(self) -> dict:
        """The random allowables, the extra uncertain inputs they add.

        Returns
        -------
        dict
            ``{"allowable[COMPONENT]": marginal}``, in component order.

        Examples
        --------
        >>> LimitState.exceedance("y", Normal(3.0, 0.1), name="y").random_allowables
        {'allowable[y]': Normal(mean=3.0, std=0.1)}
        """
        return {f"allowable[{c.name}]": c.allowable for c in self.components if c.random}

    def bind(self, output_index: pd.Index) -> BoundLimitState:
        """Resolve the output labels against a model's output index.

        Parameters
        ----------
        output_index : pandas.Index
            The model's output labels.

        Returns
        -------
        BoundLimitState
            The limit state with output positions, callable on output matrices.

        Raises
        ------
        StudyError
            If a label is not in ``output_index``, or ``output=None`` is used with a model of
            several outputs.

        Examples
        --------
        >>> LimitState.exceedance("b", 1.0).bind(pd.Index(["a", "b"])).positions[0].tolist()
        [1]
        """
        pos = []
        for c in self.components:
            if c.func is not None:
                pos.append(None)
                continue
            if c.outputs == (None,):
                if len(output_index) != 1:
                    raise StudyError(
                        f"LimitState: output = None for component {c.name!r}, but the model has "
                        f"{len(output_index)} outputs; allowed: one of {output_index[:4].tolist()}..."
                    )
                pos.append(np.array([0]))
                continue
            p = []
            for lbl in c.outputs:
                try:
                    loc = output_index.get_loc(lbl)
                except (KeyError, TypeError):
                    loc = None
                if isinstance(loc, slice):
                    loc = np.arange(len(output_index))[loc]
                elif isinstance(loc, np.ndarray):
                    loc = np.flatnonzero(loc)
                if loc is None or np.size(loc) == 0:
                    raise StudyError(
                        f"LimitState: output = {lbl!r} (component {c.name!r}): not a label of the "
                        f"model's output_index; allowed: e.g. {output_index[:4].tolist()}"
                    )
                p.extend(np.atleast_1d(loc).tolist())
            pos.append(np.array(p, dtype=int))
        return BoundLimitState(self, tuple(pos), output_index)

    def describe(self) -> dict:
        """A JSON-friendly description of the limit state, for provenance.

        Returns
        -------
        dict
            ``name``, ``system`` and per component its name, kind, outputs, allowable and function.

        Examples
        --------
        >>> LimitState.margin("y").describe()["components"][0]["kind"]
        'margin'
        """
        return {"name": self.name, "system": self.system,
                "components": [{"name": c.name, "kind": c.kind, "outputs": [repr(o) for o in c.outputs],
                                "allowable": repr(c.allowable),
                                "func": None if c.func is None else getattr(c.func, "__qualname__", repr(c.func))}
                               for c in self.components]}


def _flatten(states: Sequence[LimitState], system: str) -> tuple[Component, ...]:
    out: list[Component] = []
    for s in states:
        if not isinstance(s, LimitState):
            raise StudyError(f"LimitState.{system}: got {type(s).__name__}; allowed: LimitState objects")
        if len(s.components) > 1 and s.system != system:
            raise StudyError(
                f"LimitState.{system}: a {s.system} system {s.name!r} cannot be nested in a {system} system; "
                "allowed: one level (a group of outputs in one component is already a series system)"
            )
        out.extend(s.components)
    if not out:
        raise StudyError(f"LimitState.{system}: no states given; allowed: one or more LimitState")
    return tuple(out)


@dataclass(frozen=True)
class BoundLimitState:
    """A :class:`LimitState` with its output positions resolved for one model.

    Made by :meth:`LimitState.bind`; calling it on outputs ``Y`` (and random allowables ``A``)
    gives the system margin g, of shape (n,).

    Parameters
    ----------
    state : LimitState
        The limit state.
    positions : tuple
        Per component, the output positions (None for a function component).
    output_index : pandas.Index, optional
        The model's output labels (for :meth:`member_proxies`).

    Examples
    --------
    >>> g = LimitState.exceedance("y", 2.0, kind="upper").bind(pd.Index(["y"]))
    >>> g(np.array([[1.5], [2.5]])).tolist()
    [0.5, -0.5]
    """

    state: LimitState
    positions: tuple
    output_index: Any = None

    def components(self, Y: np.ndarray, A: np.ndarray | None = None) -> np.ndarray:
        """The component margins.

        Parameters
        ----------
        Y : ndarray, shape (n, n_out)
            The model's outputs.
        A : ndarray, shape (n, n_random), optional
            The random allowables, in the order of :attr:`LimitState.random_allowables`.

        Returns
        -------
        ndarray, shape (n, n_components)
            g_c per row and component (failure: g_c <= 0), in the outputs' unit.

        Raises
        ------
        StudyError
            If a function component returns a wrong shape.

        Examples
        --------
        >>> ls = LimitState.series(LimitState.exceedance("y", 2.0, kind="upper"),
        ...                        LimitState.exceedance("y", 0.0, kind="lower", name="low"))
        >>> ls.bind(pd.Index(["y"])).components(np.array([[1.5]])).tolist()
        [[0.5, 1.5]]
        """
        Y = np.asarray(Y, dtype=float)
        n = Y.shape[0]
        out = np.empty((n, len(self.state.components)))
        ia = 0
        for k, (c, p) in enumerate(zip(self.state.components, self.positions)):
            if c.func is not None:
                g = np.asarray(c.func(Y), dtype=float).reshape(-1)
                if g.shape != (n,):
                    raise StudyError(f"LimitState {c.name!r}: func returned shape {g.shape} for {n} rows; allowed: ({n},)")
                out[:, k] = g
                continue
            if c.random:
                a = A[:, ia]
                ia += 1
            else:
                a = c.allowable
            y = Y[:, p]
            if c.kind == "margin":
                out[:, k] = y.min(axis=1)
            elif c.kind == "abs":
                out[:, k] = a - np.abs(y).max(axis=1)
            elif c.kind == "upper":
                out[:, k] = a - y.max(axis=1)
            else:
                out[:, k] = y.min(axis=1) - a
        return out

    def __call__(self, Y: np.ndarray, A: np.ndarray | None = None) -> np.ndarray:
        """(n,) system margin g."""
        G = self.components(Y, A)
        with np.errstate(invalid="ignore"):
            return G.min(axis=1) if self.state.system == "series" else G.max(axis=1)

    @property
    def members(self) -> pd.DataFrame:
        """The elementary failure modes (members) of the limit state, one row each.

        A component over a group of outputs is the series system of its outputs, and a
        two-sided (``"abs"``) one is the series system of an upper and a lower exceedance, so
        that every component margin is the minimum of its members' margins:

        ========  =====================  ============================
        kind      members per output y   member margin
        ========  =====================  ============================
        margin    one                    y
        upper     one (sign ``+``)       a − y
        lower     one (sign ``−``)       y − a
        abs       two (``+`` and ``−``)  a − y  and  y + a
        function  one for the component  func(Y)
        ========  =====================  ============================

        The system margin is then ``min`` over every member (series), or ``max`` over
        components of the ``min`` over each component's members (parallel), bitwise equal to
        :meth:`__call__`. The rare-event methods search a design point per member that matters
        (:func:`~mechrel.uq.form`): the whole cycle of a mechanism is a series system of many
        such members (per quantity, cycle sector and sign).

        Returns
        -------
        pandas.DataFrame
            Columns ``component`` (its position), ``name`` (component name), ``output`` (the
            output label, None for a function), ``sign`` (``"+"``: failure when y is large,
            ``"−"``: when y is small, ``""``: a margin), and ``opaque`` (True when the member's
            margin is a whole function or model output: its structure is hidden, so it may hide
            several design points).

        Examples
        --------
        >>> ls = LimitState.exceedance(["a", "b"], 1.0, kind="abs", name="q")
        >>> ls.bind(pd.Index(["a", "b"])).members[["output", "sign"]].values.tolist()
        [['a', '+'], ['a', '-'], ['b', '+'], ['b', '-']]
        """
        return self._members()[0]

    def _members(self):
        rows, spec = [], []
        for k, (c, p) in enumerate(zip(self.state.components, self.positions)):
            if c.func is not None:
                rows.append((k, c.name, None, "", True))
                spec.append((k, -1, 0.0))
                continue
            labels = c.outputs if c.outputs != (None,) else (None,)
            if len(labels) != len(p):  # a partial label (a quantity) selects several outputs
                labels = tuple([None] * len(p))
            for lbl, pos in zip(labels, p):
                signs = {"margin": ("",), "upper": ("+",), "lower": ("-",), "abs": ("+", "-")}[c.kind]
                for sg in signs:
                    rows.append((k, c.name, lbl, sg, c.kind == "margin"))
                    spec.append((k, int(pos), {"": 0.0, "+": 1.0, "-": -1.0}[sg]))
        frame = pd.DataFrame(rows, columns=["component", "name", "output", "sign", "opaque"])
        return frame, spec

    def member_values(self, Y: np.ndarray, A: np.ndarray | None = None,
                      index: pd.Index | None = None) -> np.ndarray:
        """The margins of the members (:attr:`members`).

        Parameters
        ----------
        Y : ndarray, shape (n, n_out)
            The model's outputs.
        A : ndarray, shape (n, n_random), optional
            The random allowables, in the order of :attr:`LimitState.random_allowables`.
        index : pandas.Index, optional
            Not used; accepted for symmetry with :meth:`bind`.

        Returns
        -------
        ndarray, shape (n, n_members)
            Each member's margin (failure: ≤ 0), in its output's unit.

        Raises
        ------
        StudyError
            If a function component returns a wrong shape.

        Examples
        --------
        >>> b = LimitState.exceedance(["a", "b"], 1.0, kind="abs").bind(pd.Index(["a", "b"]))
        >>> b.member_values(np.array([[0.25, -2.0]])).tolist()
        [[0.75, 1.25, 3.0, -1.0]]
        """
        Y = np.asarray(Y, dtype=float)
        n = Y.shape[0]
        frame, spec = self._members()
        out = np.empty((n, len(spec)))
        # the allowable of each random component, in order
        col, ia = {}, 0
        for k, c in enumerate(self.state.components):
            if c.random:
                col[k] = ia
                ia += 1
        for m, (k, pos, sign) in enumerate(spec):
            c = self.state.components[k]
            if pos < 0:
                g = np.asarray(c.func(Y), dtype=float).reshape(-1)
                if g.shape != (n,):
                    raise StudyError(f"LimitState {c.name!r}: func returned shape {g.shape} for {n} rows; "
                                     f"allowed: ({n},)")
                out[:, m] = g
                continue
            y = Y[:, pos]
            a = A[:, col[k]] if c.random else c.allowable
            if sign == 0.0:
                out[:, m] = y
            elif c.kind == "lower":
                out[:, m] = y - a
            elif sign > 0:
                out[:, m] = a - y
            else:
                out[:, m] = y + a
        return out

    def member_proxies(self) -> list[np.ndarray]:
        """Per member, the outputs whose margins stand in for its own in a linearisation.

        A sector extreme (``(quantity, "max[lo,hi]")``, :func:`~mechrel.uq.problem.allowables.sector_label`)
        is a maximum over the sector: where the error is zero at the nominal design (geometric
        tolerances alone), the maximum has a kink there and its finite-difference gradient is
        not a derivative. The errors at the analysis angles of the same quantity in [lo, hi]
        are smooth and bound it from below, so their linearisations stand in for the member's
        when the rare-event methods rank the members (:func:`~mechrel.uq.form`).

        Returns
        -------
        list of ndarray of int
            Output positions per member (empty: no proxy).

        Examples
        --------
        >>> idx = pd.MultiIndex.from_tuples([("v", 0.0), ("v", 18.0), ("v", 36.0),
        ...                                  ("v", "max[0,18]"), ("v", "max[18,36]")],
        ...                                 names=["quantity", "crank_angle"])
        >>> b = LimitState.exceedance([("v", "max[0,18]"), ("v", "max[18,36]")], 1.0,
        ...                           kind="upper").bind(idx)
        >>> [p.tolist() for p in b.member_proxies()]
        [[0, 1], [1, 2]]
        """
        from .allowables import parse_sector

        frame, spec = self._members()
        idx = self.output_index
        out = [np.empty(0, dtype=int) for _ in spec]
        if not (isinstance(idx, pd.MultiIndex) and "crank_angle" in idx.names
                and "quantity" in idx.names):
            return out
        qs = idx.get_level_values("quantity")
        angles = idx.get_level_values("crank_angle")
        for m, (_k, pos, _sign) in enumerate(spec):
            if pos < 0:
                continue
            sec = parse_sector(angles[pos])
            if sec is None:
                continue
            _stat, lo, hi = sec
            out[m] = np.array([i for i in range(len(idx)) if qs[i] == qs[pos]
                               and not isinstance(angles[i], str)
                               and lo - 1e-9 <= float(angles[i]) <= hi + 1e-9], dtype=int)
        return out

    def proxy_values(self, Y: np.ndarray, A: np.ndarray | None, member: int,
                     positions: np.ndarray) -> np.ndarray:
        """The margin of ``member`` with each output of ``positions`` in place of its own.

        Parameters
        ----------
        Y : ndarray, shape (n, n_out)
            The model's outputs.
        A : ndarray, shape (n, n_random), optional
            The random allowables.
        member : int
            The member (a row of :attr:`members`).
        positions : array of int
            Output positions (:meth:`member_proxies`).

        Returns
        -------
        ndarray, shape (n, len(positions))
            The margins.

        Examples
        --------
        >>> b = LimitState.exceedance(["a"], 1.0, kind="upper").bind(pd.Index(["a", "b"]))
        >>> b.proxy_values(np.array([[0.25, 0.5]]), None, 0, np.array([1])).tolist()
        [[0.5]]
        """
        _frame, spec = self._members()
        k, _pos, sign = spec[member]
        c = self.state.components[k]
        y = np.asarray(Y, dtype=float)[:, np.asarray(positions, dtype=int)]
        if c.random:
            col = sum(1 for j in range(k) if self.state.components[j].random)
            a = np.asarray(A)[:, col][:, None]
        else:
            a = c.allowable
        if sign == 0.0:
            return y
        if c.kind == "lower":
            return y - a
        return a - y if sign > 0 else y + a

    def system_from_members(self, Gm: np.ndarray) -> np.ndarray:
        """The system margin from the members' margins (:meth:`member_values`).

        Parameters
        ----------
        Gm : ndarray, shape (n, n_members)
            The members' margins.

        Returns
        -------
        ndarray, shape (n,)
            ``min`` over members (series), or ``max`` over components of their members'
            ``min`` (parallel): equal to :meth:`__call__` on the same outputs.

        Examples
        --------
        >>> b = LimitState.exceedance(["a", "b"], 1.0, kind="abs").bind(pd.Index(["a", "b"]))
        >>> Y = np.array([[0.25, -2.0]])
        >>> b.system_from_members(b.member_values(Y)).tolist() == b(Y).tolist()
        True
        """
        Gm = np.asarray(Gm, dtype=float)
        comp = self._members()[0]["component"].to_numpy()
        with np.errstate(invalid="ignore"):
            if self.state.system == "series":
                return Gm.min(axis=1)
            per = np.column_stack([Gm[:, comp == k].min(axis=1)
                                   for k in range(len(self.state.components))])
            return per.max(axis=1)
