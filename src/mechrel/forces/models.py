"""The table of clearance models: one frozen descriptor per model, read by every layer.

A revolute clearance joint's ``model`` (scene key ``joints.NAME.model``) names one row of
:data:`MODELS`. The row says what the model is made of (metal contact, a lubricant film), how it
behaves numerically (stiff, chaotic), which scene sub-tables it requires and which it reads, and
which integrator it runs with by default. The scene validation (:mod:`mechrel.scene._validate`),
the parameter packing (:func:`mechrel.forces.packing.pack_joint`), the compiled system
(:mod:`mechrel.mechanics.system`), the simulation defaults (:mod:`mechrel.simulation`), the
integrators' failure advice (:mod:`mechrel.integrate.base`) and the accuracy study
(:mod:`mechrel.study.accuracy`) read this table instead of testing model names. The compiled
force law branches on the integer ``code`` (:func:`mechrel.forces.joint.clearance_force`).
The film of a lubricated or transition joint is chosen per joint in the lubricant sub-table
(``joints.NAME.lubricant.bearing``), one row of :data:`BEARINGS`.

A row declares its parameters (:class:`Param`: sub-table, key, default, range, unit, slot);
the parameter vector's slots and :func:`~mechrel.forces.params.pack_params`' defaults and
ranges (:mod:`mechrel.forces.params`), the scene's sub-table classes, their validation and the
scene hash derive from them, and the row says whether the model is smooth (FOSM warns on one
that is not). No model name is written outside this table.

Adding a model (see docs/forces.md, "Adding a clearance model"): write its force law beside
:mod:`mechrel.forces.film`, add one :class:`ClearanceModel` row here (a new ``code``) and one
branch on that code in :func:`mechrel.forces.joint.clearance_force`. A row that runs an
existing compiled law can be added at run time with :func:`register_model`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

__all__ = [
    "ClearanceModel", "BearingModel", "MODELS", "BEARINGS", "MODEL_DRY", "MODEL_LUBRICATED",
    "MODEL_TRANSITION", "BEARING_LONG", "BEARING_SHORT", "BEARING_FINITE", "DEFAULT_BEARING",
    "SUBTABLE_PARAMS", "SUBTABLES", "PARAMS", "Param",
    "model_by_code", "register_model", "unregister_model",
]

# Integer codes, read by the compiled force law (numba sees them as global constants).
MODEL_DRY = 0
"""Dry contact: Lankarani–Nikravesh normal force + modified Coulomb friction (eqs. 4–9)."""
MODEL_LUBRICATED = 1
"""Lubricant film only (no contact), film evaluated at the actual ε (capped at 1 − 1e-9)."""
MODEL_TRANSITION = 2
"""Blend of dry and lubricated over c ≤ |e| ≤ c + e1 (eq. 19, Flores et al. 2009)."""

BEARING_LONG = 0
"""Infinitely long (Pinkus–Sternlicht) bearing, Gümbel conditions: :mod:`mechrel.forces.film`."""
BEARING_SHORT = 1
"""Short (Ocvirk) bearing with rotation and squeeze, half-Sommerfeld film:
:func:`mechrel.forces.short_film.short_film_forces`."""
BEARING_FINITE = 2
"""Finite-length bearing, 0.25 ≤ L/D ≤ 4, from tabulated 2-D Reynolds solutions, half-Sommerfeld
film: :func:`mechrel.forces.finite_film.finite_film_forces`."""


@dataclass(frozen=True)
class BearingModel:
    """One film model of a lubricated or transition joint (``lubricant.bearing``).

    Parameters
    ----------
    name : str
        Scene name (``joints.NAME.lubricant.bearing``).
    code : int
        Integer code stored in ``p[P_BEARING]``.
    summary : str
        One line for messages and docs.
    source : str
        Where its equations come from.

    Examples
    --------
    >>> sorted(BEARINGS), BEARINGS["short"].code == BEARING_SHORT
    (['finite', 'long', 'short'], True)
    """

    name: str
    code: int
    summary: str
    source: str


_BEARINGS = (
    BearingModel(
        name="long", code=BEARING_LONG,
        summary="infinitely long bearing (Pinkus–Sternlicht), Gümbel conditions",
        source="Pinkus & Sternlicht (1961); paper eqs. (10)-(18) as corrected",
    ),
    BearingModel(
        name="short", code=BEARING_SHORT,
        summary="short bearing (Ocvirk), rotation and squeeze, half-Sommerfeld film",
        source="Ocvirk (1952) short-bearing Reynolds equation; Hamrock, Schmid & Jacobson "
               "(2004), Fundamentals of Fluid Film Lubrication, ch. 10",
    ),
    BearingModel(
        name="finite", code=BEARING_FINITE,
        summary="finite-length bearing (0.25 <= L/D <= 4), half-Sommerfeld film, the short "
                "bearing corrected by tabulated 2-D Reynolds solutions",
        source="own finite-volume Reynolds solutions (mechrel.forces.reynolds); reduction to "
               "an equivalent squeeze as in Childs, Moes & van der Helm (1977)",
    ),
)
BEARINGS: Mapping[str, BearingModel] = MappingProxyType({b.name: b for b in _BEARINGS})
"""The film models of a lubricated or transition joint by scene name."""
DEFAULT_BEARING = "long"
"""The paper's film: the infinitely long bearing."""


@dataclass(frozen=True)
class Param:
    """One parameter of a clearance model: a key of a scene sub-table and its force-law slot.

    The rows of :data:`MODELS` declare their parameters with these; the parameter vector's
    slots (:mod:`mechrel.forces.params`), :func:`~mechrel.forces.params.pack_params`'s
    keywords, defaults and ranges, the scene's sub-table fields and their validation all derive
    from them.

    Parameters
    ----------
    sub : str
        The scene sub-table of a clearance joint it is written in (``joints.NAME.SUB``).
    key : str
        Its key there (``joints.NAME.SUB.KEY``).
    default
        The scene's default, used when the key is absent from the sub-table.
    unit : str, default "-"
        SI unit, for messages and docs.
    limit : mapping, default {}
        Allowed range of a number (keywords ``gt``, ``ge``, ``lt``, ``le``).
    choices : tuple of str, optional
        Allowed names of a choice; the slot stores the index of the name.
    boolean : bool, default False
        A true/false switch; the slot stores 1.0 or 0.0.
    slot : str, optional
        Name of its slot in the parameter vector and :func:`pack_params` keyword; None for a
        value that is not a force-law slot itself (the contact's moduli, from which the
        stiffness slot is computed).
    off : optional
        What :func:`pack_params` packs when the value is not given (e.g. no friction when no
        friction sub-table is read); None: the scene's ``default``.
    summary : str, default ""
        One line for the docs of the scene's sub-table.
    hashed_at_default : bool, default False
        Written into the scene's canonical raw mapping (and so its hash) even at its default.
        True for the parameters that existed when the hash started leaving out defaults
        (mechrel 0.33), so that the hashes of existing scenes did not move; a parameter added
        later leaves it False, so adding it moves no scene's hash.

    Examples
    --------
    >>> prm = PARAMS[("contact", "restitution")]
    >>> prm.default, prm.slot, prm.limit["le"]
    (0.9, 'restitution', 1)
    """

    sub: str
    key: str
    default: Any
    unit: str = "-"
    limit: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    choices: tuple[str, ...] | None = None
    boolean: bool = False
    slot: str | None = None
    off: Any = None
    summary: str = ""
    hashed_at_default: bool = False

    @property
    def pack_default(self) -> Any:
        """What :func:`~mechrel.forces.params.pack_params` packs when the value is not given.

        Returns
        -------
        object
            ``off`` if set, else ``default``.

        Examples
        --------
        >>> PARAMS[("friction", "coefficient")].pack_default   # no friction sub-table read
        0.0
        """
        return self.default if self.off is None else self.off


def _p(sub: str, key: str, default: Any, unit: str = "-", summary: str = "", *,
       slot: str | None = None, **kw: Any) -> Param:
    # the parameters of mechrel 0.33 only: their defaults stay in the scene hash, as before
    # (Param.hashed_at_default). Declare a new parameter with Param(...), which leaves it out
    # of the hash at its default (tests/test_forces_models_registry.py holds the list).
    if "limit" in kw:
        kw["limit"] = MappingProxyType(kw["limit"])
    return Param(sub, key, default, unit, summary=summary, slot=slot, hashed_at_default=True,
                 **kw)


_NU = dict(gt=-1, lt=0.5)
_CONTACT = (
    _p("contact", "youngs_modulus_bearing", 206e9, "Pa", "Young's modulus of the bearing "
       "(steel)", limit=dict(gt=0)),
    _p("contact", "youngs_modulus_journal", 206e9, "Pa", "Young's modulus of the journal "
       "(steel)", limit=dict(gt=0)),
    _p("contact", "poisson_bearing", 0.3, "-", "Poisson's ratio of the bearing", limit=_NU),
    _p("contact", "poisson_journal", 0.3, "-", "Poisson's ratio of the journal", limit=_NU),
    _p("contact", "restitution", 0.9, "-", "coefficient of restitution c_e",
       slot="restitution", limit=dict(gt=0, le=1)),
    _p("contact", "exponent", 1.5, "-", "contact force exponent n (1.5: Hertz)",
       slot="exponent", limit=dict(ge=1, le=3)),
    _p("contact", "stiffness", "conformal", "-", "radius combination of the stiffness: the "
       "journal inside its bearing ('conformal') or the paper's sum of radii ('paper'), "
       ":func:`mechrel.forces.contact.contact_stiffness`", choices=("conformal", "paper")),
    _p("contact", "impact_speed_floor", 1e-3, "m/s", "floor of the impact speed in the "
       "damping term (docs/forces.md)", slot="impact_speed_floor", limit=dict(gt=0)),
)
_FRICTION = (
    _p("friction", "coefficient", 0.05, "-", "Coulomb coefficient c_f (0: no friction)",
       slot="friction_coefficient", off=0.0, limit=dict(ge=0)),
    _p("friction", "v0", 1e-4, "m/s", "dead-band slip speed of the dynamic correction",
       slot="v0", limit=dict(ge=0)),
    _p("friction", "v1", 1e-2, "m/s", "full-friction slip speed of the dynamic correction "
       "(> v0)", slot="v1", limit=dict(gt=0)),
)
_LUBRICANT = (
    _p("lubricant", "viscosity", 0.1, "Pa s", "dynamic viscosity μ (100 cP = 0.1 Pa s)",
       slot="viscosity", off=0.0, limit=dict(ge=0)),
    _p("lubricant", "lam", 1.0, "-", "exponent λ of the small-eccentricity correction",
       slot="lam", limit=dict(ge=0)),
    _p("lubricant", "eps0", 0.1, "-", "threshold ε0 of that correction", slot="eps0",
       limit=dict(gt=0, le=1)),
    _p("lubricant", "bearing", DEFAULT_BEARING, "-", "the film model, a key of "
       ":data:`mechrel.forces.models.BEARINGS`", slot="bearing",
       choices=tuple(b.name for b in _BEARINGS)),
    _p("lubricant", "cavitation", "half-sommerfeld", "-", "cavitation condition; "
       "'reynolds' (Swift–Stieber) with the finite bearing only", slot="cavitation",
       choices=("half-sommerfeld", "reynolds")),
    _p("lubricant", "shear_torque", False, "-", "apply the film's shear torques to journal "
       "and bearing (not in the paper)", slot="shear_torque", boolean=True),
)
_TRANSITION = (
    _p("transition", "e1", 1e-5, "m", "width of the blend band c <= |e| <= c + e1",
       slot="e1", limit=dict(gt=0)),
    _p("transition", "eps_max", 0.99, "-", "eccentricity ratio at which the film is clamped",
       slot="eps_max", limit=dict(gt=0, lt=1)),
)


@dataclass(frozen=True)
class ClearanceModel:
    """One clearance model: what it is made of, what it needs, how it is integrated.

    Parameters
    ----------
    name : str
        Scene name (``joints.NAME.model``).
    code : int
        Integer code stored in ``p[P_MODEL]``: the compiled force law
        (:func:`mechrel.forces.joint.clearance_force`) branches on it. A row that reuses the
        compiled law of another (other parameters, defaults or properties) shares its code.
    summary : str
        One line for messages and docs.
    has_contact : bool
        The journal can touch the bearing (contact force, a contact-history slot, onset events).
    has_film : bool
        The joint carries a lubricant film (the lubricant sub-table, viscosity > 0).
    stiff : bool
        The film makes the equations stiff: an implicit integrator is the default.
    chaotic : bool
        Impacts make trajectories chaotic: accuracy is measured on ensemble statistics.
    smooth : bool
        The joint's force is a smooth function of the state and parameters (no impacts, no
        switch between laws), so that the outputs' derivatives exist: FOSM and FORM are
        reliable on it. A non-smooth model makes FOSM warn
        (:meth:`mechrel.uq.problem.mechanism.MechanismModel.smoothness_warning`).
    requires : tuple of str
        Scene sub-tables the model needs; an absent one is filled with its defaults.
    params : tuple of Param
        The parameters it reads (:class:`Param`: sub-table, key, default, range, unit, slot);
        the sub-tables they live in are :attr:`reads`. A sub-table given but not read (e.g.
        friction on a lubricated joint) is validated and ignored.
    solver : tuple (str, mapping)
        Default integrator and settings (``solver.integrator = "auto"``); the reasons are in
        the comment of each row and in docs/performance.md.
    precedence : int
        When a scene mixes models, the one with the highest precedence sets the scene's kind
        (its default solver, its accuracy measure).

    Examples
    --------
    >>> m = MODELS["transition"]
    >>> m.code == MODEL_TRANSITION, m.has_contact, m.has_film, m.solver[0]
    (True, True, True, 'radau')
    """

    name: str
    code: int
    summary: str
    has_contact: bool
    has_film: bool
    stiff: bool
    chaotic: bool
    smooth: bool
    requires: tuple[str, ...]
    params: tuple[Param, ...]
    solver: tuple[str, Mapping[str, float]]
    precedence: int

    @property
    def reads(self) -> tuple[str, ...]:
        """The scene sub-tables whose values are packed into the parameter vector.

        Returns
        -------
        tuple of str
            The sub-tables of :attr:`params`, in order of declaration.

        Examples
        --------
        >>> MODELS["dry"].reads
        ('contact', 'friction')
        """
        return tuple(dict.fromkeys(prm.sub for prm in self.params))

    @property
    def film_only(self) -> bool:
        """A film and no contact: only the film's divergence as ε → 1 keeps the journal in.

        Returns
        -------
        bool
            ``has_film and not has_contact``.

        Examples
        --------
        >>> MODELS["lubricated"].film_only, MODELS["transition"].film_only
        (True, False)
        """
        return self.has_film and not self.has_contact


_MODELS = (
    ClearanceModel(
        name="dry", code=MODEL_DRY,
        summary="Lankarani–Nikravesh contact with modified Coulomb friction",
        has_contact=True, has_film=False, stiff=False, chaotic=True,
        smooth=False, requires=("contact",), params=_CONTACT + _FRICTION,
        # 1e-7 was shown biased by the ensemble measure (nine-bar-dry, R = 32, two seeds:
        # velocity statistics 5 % and acceleration statistics 13-21 % off the DOPRI5 1e-11
        # reference; slider-crank-dry velocity statistics 4 %); from 1e-8 on no setting is shown
        # to exceed 1 %, for 1.4x the evaluations (docs/performance.md, "What accuracy costs")
        solver=("dopri5", MappingProxyType({"rtol": 1e-8, "atol": 1e-11})),
        precedence=1,
    ),
    ClearanceModel(
        name="lubricated", code=MODEL_LUBRICATED,
        summary="lubricant film only (no metal contact)",
        has_contact=False, has_film=True, stiff=True, chaotic=False,
        smooth=True, requires=("lubricant",), params=_CONTACT + _LUBRICANT,
        # compiled Radau IIA: 8x faster than LSODA at the same tolerances on the lubricated
        # nine-bar (0.023 vs 0.18 s, 6.5k vs 13.6k rhs evaluations per cycle, no Python per
        # step), peak slider acceleration within 2e-4 m/s² of a tight reference
        # (docs/performance.md)
        solver=("radau", MappingProxyType({"rtol": 1e-7, "atol": 1e-10})),
        precedence=3,
    ),
    ClearanceModel(
        name="transition", code=MODEL_TRANSITION,
        summary="film away from the wall, blended into dry contact over c <= |e| <= c + e1",
        has_contact=True, has_film=True, stiff=True, chaotic=True,
        smooth=False, requires=("contact", "lubricant", "transition"),
        params=_CONTACT + _FRICTION + _LUBRICANT + _TRANSITION,
        # the film of a transition joint makes it stiff like a lubricated one: on the nine-bar
        # radau needs 15x (100 cP, no impact), 4x (10 cP, 5 impacts) and 1.2x (1 cP, 16 impacts)
        # fewer rhs evaluations than DOPRI5 (docs/performance.md)
        solver=("radau", MappingProxyType({"rtol": 1e-7, "atol": 1e-10})),
        precedence=2,
    ),
)

_REGISTRY: dict[str, ClearanceModel] = {}
MODELS: Mapping[str, ClearanceModel] = MappingProxyType(_REGISTRY)
"""The clearance models by scene name (``"ideal"`` is not a clearance model); extended by
:func:`register_model`."""

_BY_CODE: dict[int, ClearanceModel] = {}
_IMPORTED = False

PARAMS: Mapping[tuple[str, str], Param] = MappingProxyType({})
"""Every parameter of a clearance model by ``(sub-table, key)``, in order of declaration."""
SUBTABLES: tuple[str, ...] = ()
"""The scene sub-tables of a clearance joint, in order of declaration."""
SUBTABLE_PARAMS: Mapping[str, Mapping[str, str]] = MappingProxyType({})
"""Scene sub-table key → :func:`mechrel.forces.params.pack_params` keyword, per sub-table.

The contact sub-table also gives the stiffness K, computed from its moduli by
:func:`mechrel.forces.contact.contact_stiffness`; its other keys (moduli, Poisson ratios,
``stiffness`` formula) are not force-law slots."""


def _derive(rows: tuple[ClearanceModel, ...]) -> None:
    """The parameter tables of the rows (one declaration per (sub-table, key))."""
    global PARAMS, SUBTABLES, SUBTABLE_PARAMS
    params: dict[tuple[str, str], Param] = {}
    for row in rows:
        for prm in row.params:
            known = params.setdefault((prm.sub, prm.key), prm)
            if known != prm:
                raise ValueError(f"model {row.name!r}: parameter {prm.sub}.{prm.key} is "
                                 f"declared differently by another model ({known} != {prm})")
    PARAMS = MappingProxyType(params)
    SUBTABLES = tuple(dict.fromkeys(sub for sub, _ in params))
    SUBTABLE_PARAMS = MappingProxyType({
        sub: MappingProxyType({prm.key: prm.slot for prm in params.values()
                               if prm.sub == sub and prm.slot is not None})
        for sub in SUBTABLES})


def register_model(row: ClearanceModel) -> ClearanceModel:
    """Add a clearance model to :data:`MODELS`: the one registration of a model.

    Scene validation (``joints.NAME.model`` and the row's sub-tables), parameter packing,
    the compiled system, the default solver, the orbit checks, the failure advice, the
    accuracy study and FOSM's smoothness warning read the row. The rows of the package are
    registered when this module is imported; a row registered later may use only the
    parameters already declared (their slots are compiled into the force law) and the code of
    a compiled law (:func:`mechrel.forces.joint.clearance_force` has one branch per code).

    Parameters
    ----------
    row : ClearanceModel
        The model's row; its name must be new.

    Returns
    -------
    ClearanceModel
        ``row``.

    Raises
    ------
    ValueError
        The name is taken, a parameter is declared differently than by an existing model, a
        sub-table the row requires is none of its parameters', or (after import) the row
        declares a new parameter or a code without a compiled branch.

    Examples
    --------
    A dry contact without friction that FOSM should treat as smooth (an illustration, not
    registered here):

    >>> import dataclasses
    >>> row = dataclasses.replace(MODELS["dry"], name="my-dry", params=MODELS["dry"].params[:8])
    >>> row.reads, row.code == MODEL_DRY
    (('contact',), True)
    """
    if row.name in _REGISTRY or row.name == "ideal":
        raise ValueError(f"clearance model {row.name!r} is already registered")
    unread = [s for s in row.requires if s not in row.reads]
    if unread:
        raise ValueError(f"model {row.name!r} requires sub-tables {unread} but declares no "
                         "parameter in them")
    if _IMPORTED:  # after import: only what the compiled law already reads
        new = [f"{p.sub}.{p.key}" for p in row.params if (p.sub, p.key) not in PARAMS]
        if new:
            raise ValueError(f"model {row.name!r}: new parameters {new} need slots in the "
                             "compiled force law: declare the row in mechrel.forces.models")
        if row.code not in _BY_CODE:
            raise ValueError(f"model {row.name!r}: code {row.code} has no branch in the "
                             "compiled force law (mechrel.forces.joint.clearance_force); "
                             f"allowed: one of {sorted(_BY_CODE)}")
    _derive((*_REGISTRY.values(), row))
    _REGISTRY[row.name] = row
    _BY_CODE.setdefault(row.code, row)
    return row


def unregister_model(name: str) -> None:
    """Remove a model added by :func:`register_model` after import (tests, notebooks).

    Parameters
    ----------
    name : str
        The model's name; a row of the package cannot be removed.

    Raises
    ------
    ValueError
        ``name`` is a model of the package or is not registered.

    Examples
    --------
    >>> unregister_model("dry")
    Traceback (most recent call last):
    ...
    ValueError: 'dry' is a clearance model of the package: it cannot be removed
    """
    if name in _PACKAGE_MODELS:
        raise ValueError(f"{name!r} is a clearance model of the package: it cannot be removed")
    if name not in _REGISTRY:
        raise ValueError(f"{name!r} is not a registered clearance model")
    del _REGISTRY[name]
    _derive(tuple(_REGISTRY.values()))


for _row in _MODELS:
    register_model(_row)
assert len(_BY_CODE) == len(_MODELS), "the package's clearance models have distinct codes"
assert PARAMS[("lubricant", "bearing")].choices == tuple(BEARINGS), "slot code = BEARINGS code"
assert all(b.code == i for i, b in enumerate(_BEARINGS))
_PACKAGE_MODELS = frozenset(_REGISTRY)
_IMPORTED = True


def model_by_code(code: int) -> ClearanceModel:
    """The row of :data:`MODELS` with integer code ``code``.

    Parameters
    ----------
    code : int
        A clearance model code, as stored in ``p[P_MODEL]`` (a float there is accepted).

    Returns
    -------
    ClearanceModel
        Its row.

    Raises
    ------
    KeyError
        No model has that code.

    Examples
    --------
    >>> model_by_code(float(MODEL_DRY)).name
    'dry'
    """
    return _BY_CODE[int(code)]

