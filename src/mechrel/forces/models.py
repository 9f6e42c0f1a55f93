"""The table of clearance models: one frozen descriptor per model, read by every layer.

A revolute clearance joint's ``model`` (scene key ``joints.NAME.model``) names one row of
:data:`MODELS`. The row says what the model is made of (metal contact, a lubricant film), how it
behaves numerically (stiff, chaotic), which scene sub-tables it requires and which it reads, and
which integrator it runs with by default. The scene validation (:mod:`mechrel.scene._validate`),
the parameter packing (:func:`pack_joint`), the compiled system (:mod:`mechrel.mechanics.system`),
the simulation defaults (:mod:`mechrel.simulation`), the integrators' failure advice
(:mod:`mechrel.integrate.base`) and the accuracy study (:mod:`mechrel.study.accuracy`) read
this table instead of testing model names. The compiled force law branches on the integer
``code`` (:func:`mechrel.forces.joint.clearance_force`).

The film of a lubricated or transition joint is chosen per joint in the lubricant sub-table
(``joints.NAME.lubricant.bearing``), one row of :data:`BEARINGS`.

Adding a model (see docs/forces.md, "Adding a clearance model"): write its force law beside
:mod:`mechrel.forces.film`, add one :class:`ClearanceModel` row here (a new ``code``) and one
branch on that code in :func:`mechrel.forces.joint.clearance_force`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

__all__ = [
    "ClearanceModel", "BearingModel", "MODELS", "BEARINGS", "MODEL_DRY", "MODEL_LUBRICATED",
    "MODEL_TRANSITION", "BEARING_LONG", "BEARING_SHORT", "BEARING_FINITE", "DEFAULT_BEARING",
    "SUBTABLE_PARAMS",
    "model_by_code", "pack_joint",
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

SUBTABLE_PARAMS: Mapping[str, Mapping[str, str]] = MappingProxyType({
    "contact": MappingProxyType({"restitution": "restitution", "exponent": "exponent",
                                 "impact_speed_floor": "impact_speed_floor"}),
    "friction": MappingProxyType({"coefficient": "friction_coefficient", "v0": "v0",
                                  "v1": "v1"}),
    "lubricant": MappingProxyType({"viscosity": "viscosity", "lam": "lam", "eps0": "eps0",
                                   "bearing": "bearing", "cavitation": "cavitation",
                                   "shear_torque": "shear_torque"}),
    "transition": MappingProxyType({"e1": "e1", "eps_max": "eps_max"}),
})
"""Scene sub-table key → :func:`mechrel.forces.params.pack_params` keyword, per sub-table.

The contact sub-table also gives the stiffness K, computed from its moduli by
:func:`mechrel.forces.contact.contact_stiffness`; its other keys (moduli, Poisson ratios,
``stiffness`` formula) are not force-law parameters."""


@dataclass(frozen=True)
class ClearanceModel:
    """One clearance model: what it is made of, what it needs, how it is integrated.

    Parameters
    ----------
    name : str
        Scene name (``joints.NAME.model``).
    code : int
        Integer code stored in ``p[P_MODEL]``; the compiled force law branches on it.
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
    requires : tuple of str
        Scene sub-tables the model needs; an absent one is filled with its defaults.
    reads : tuple of str
        Scene sub-tables whose values are packed into the parameter vector (a sub-table given
        but not read, e.g. friction on a lubricated joint, is validated and ignored).
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
    requires: tuple[str, ...]
    reads: tuple[str, ...]
    solver: tuple[str, Mapping[str, float]]
    precedence: int

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


_MODELS = (
    ClearanceModel(
        name="dry", code=MODEL_DRY,
        summary="Lankarani–Nikravesh contact with modified Coulomb friction",
        has_contact=True, has_film=False, stiff=False, chaotic=True,
        requires=("contact",), reads=("contact", "friction"),
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
        requires=("lubricant",), reads=("contact", "lubricant"),
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
        requires=("contact", "lubricant", "transition"),
        reads=("contact", "friction", "lubricant", "transition"),
        # the film of a transition joint makes it stiff like a lubricated one: on the nine-bar
        # radau needs 15x (100 cP, no impact), 4x (10 cP, 5 impacts) and 1.2x (1 cP, 16 impacts)
        # fewer rhs evaluations than DOPRI5 (docs/performance.md)
        solver=("radau", MappingProxyType({"rtol": 1e-7, "atol": 1e-10})),
        precedence=2,
    ),
)

MODELS: Mapping[str, ClearanceModel] = MappingProxyType({m.name: m for m in _MODELS})
"""The clearance models by scene name (``"ideal"`` is not a clearance model)."""

_BY_CODE = {m.code: m for m in _MODELS}
assert len(_BY_CODE) == len(_MODELS), "clearance model codes must be distinct"

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


def pack_joint(joint: Any) -> Any:
    """Pack a scene clearance joint's force-law parameters by its model's row.

    Every force-law value goes through :func:`mechrel.forces.params.pack_params`, the one
    validator of force-law ranges. The contact stiffness is computed from the contact
    sub-table (defaults when absent: a film-only joint never reads it, but its slot is filled
    so that every parameter vector is complete).

    Parameters
    ----------
    joint : mechrel.scene.model.Joint
        A revolute joint whose ``model`` is a key of :data:`MODELS`.

    Returns
    -------
    numpy.ndarray
        The parameter vector (:data:`mechrel.forces.params.N_PARAMS` floats).

    Raises
    ------
    mechrel.errors.SceneError
        The joint has no bearing radius or length, or a force-law value is out of range.

    Examples
    --------
    The first clearance joint of the embedded dry slider-crank:

    >>> from mechrel.forces.params import P_C, P_K, P_MODEL
    >>> from mechrel.scene import load_scene
    >>> joint = load_scene("slider-crank-dry").clearance_joints[0]
    >>> p = pack_joint(joint)
    >>> model_by_code(p[P_MODEL]).name, bool(p[P_C] == joint.clearance), bool(p[P_K] > 0)
    ('dry', True, True)
    """
    from ..errors import SceneError
    from ..scene.model import Contact
    from .contact import contact_stiffness
    from .params import pack_params

    model = MODELS[joint.model]
    path = f"joints.{joint.name}"
    if joint.bearing_radius is None or joint.length is None:
        raise SceneError(f"{path}: a '{joint.model}' clearance joint needs bearing_radius and "
                         f"length (m); got bearing_radius={joint.bearing_radius!r}, "
                         f"length={joint.length!r}", path=path)
    R_B = joint.bearing_radius
    R_S = R_B - joint.clearance
    kw: dict[str, Any] = dict(model=model.name, clearance=joint.clearance, bearing_radius=R_B,
                              length=joint.length)
    c = joint.contact or Contact()
    kw["stiffness"] = contact_stiffness(R_B, R_S, c.youngs_modulus_bearing, c.poisson_bearing,
                                        c.youngs_modulus_journal, c.poisson_journal,
                                        c.stiffness == "conformal")
    for sub in model.reads:
        table = getattr(joint, sub) if sub != "contact" else c
        if table is None:
            continue
        kw.update({param: getattr(table, key) for key, param in SUBTABLE_PARAMS[sub].items()})
    return pack_params(**kw)

