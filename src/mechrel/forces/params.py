"""Per-joint parameter vector of a clearance joint.

A clearance joint's parameters travel into the compiled force law as one ``float64`` vector
``p`` of length :data:`N_PARAMS`, indexed by the integer constants below. Build it with
:func:`pack_params` (pure Python, validates every field and raises
:class:`mechrel.errors.SceneError` naming the field and its allowed range).

All values are SI: m, m/s, Pa s, N/m^n.

Defaults where the paper (Chen, Wang & Gao 2022) is silent are collected in :data:`DEFAULTS`;
``docs/forces.md`` justifies each one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

# one text for a range across scenes, studies and force laws (the validation toolkit's)
from mechrel._checks import describe_number as describe_range
from mechrel.errors import SceneError
from mechrel.forces.models import (
    BEARING_FINITE, BEARING_LONG, BEARING_SHORT, BEARINGS, MODEL_DRY, MODEL_LUBRICATED,
    MODEL_TRANSITION, MODELS, PARAMS, model_by_code,
)

__all__ = [
    "MODEL_DRY", "MODEL_LUBRICATED", "MODEL_TRANSITION", "MODEL_NAMES", "BEARING_LONG",
    "BEARING_SHORT", "BEARING_FINITE", "FINITE_LD_RANGE", "BEARING_NAMES", "P_BEARING",
    "LIMITS", "describe_range", "P_CAVITATION", "P_SHEAR", "CAVITATION_NAMES",
    "CAVITATION_HALF_SOMMERFELD", "CAVITATION_REYNOLDS",
    "P_MODEL", "P_C", "P_RB", "P_RS", "P_L", "P_K", "P_N", "P_CE", "P_FLOOR", "P_CF",
    "P_V0", "P_V1", "P_MU", "P_LAMBDA", "P_EPS0", "P_E1", "P_EPSMAX", "N_PARAMS",
    "PARAM_NAMES", "DEFAULTS", "pack_params", "unpack_params",
]

# --- clearance models: codes and names come from the table of models ------------------------
MODEL_NAMES = {m.name: m.code for m in MODELS.values()}
"""Scene name → integer code of every clearance model of the package
(:data:`mechrel.forces.models.MODELS`)."""
BEARING_NAMES = {b.name: b.code for b in BEARINGS.values()}
"""Scene name → integer code of every film model (:data:`mechrel.forces.models.BEARINGS`)."""
CAVITATION_HALF_SOMMERFELD = 0
"""Gümbel film: the positive part of the full-film pressure (every film model)."""
CAVITATION_REYNOLDS = 1
"""Swift–Stieber film: p ≥ 0 with zero gradient at rupture (the finite film only)."""
CAVITATION_NAMES = {name: i for i, name in
                    enumerate(PARAMS[("lubricant", "cavitation")].choices or ())}
"""Scene name → integer code of every cavitation condition (``lubricant.cavitation``)."""
assert CAVITATION_NAMES == {"half-sommerfeld": CAVITATION_HALF_SOMMERFELD,
                            "reynolds": CAVITATION_REYNOLDS}

# --- the parameter vector: the joint's geometry, then the models' declared parameters ---------
_GEOMETRY = ("model", "clearance", "bearing_radius", "journal_radius", "length", "stiffness")
_SLOTTED = {prm.slot: prm for prm in PARAMS.values() if prm.slot is not None}

PARAM_NAMES = (*_GEOMETRY, *_SLOTTED)
"""Field name of each index, in index order (``PARAM_NAMES[P_K] == "stiffness"``): the
joint's geometry, then the slots of :data:`mechrel.forces.models.PARAMS` in order of
declaration."""
_SLOT = {name: i for i, name in enumerate(PARAM_NAMES)}
N_PARAMS = len(PARAM_NAMES)

P_MODEL = _SLOT["model"]            # model code (MODELS[...].code), stored as float
P_C = _SLOT["clearance"]            # radial clearance c = R_B - R_S (m)
P_RB = _SLOT["bearing_radius"]      # bearing (hole) radius R_B (m)
P_RS = _SLOT["journal_radius"]      # journal (pin) radius R_S = R_B - c (m)
P_L = _SLOT["length"]               # bearing length L (m)
P_K = _SLOT["stiffness"]            # contact stiffness K (N/m^n)
P_N = _SLOT["exponent"]             # contact force exponent n (-), 1.5 for Hertz contact
P_CE = _SLOT["restitution"]         # coefficient of restitution c_e (-), in (0, 1]
P_FLOOR = _SLOT["impact_speed_floor"]  # floor of the impact speed δ̇⁻ (m/s), > 0
P_CF = _SLOT["friction_coefficient"]   # friction coefficient c_f (-); 0: friction not evaluated
P_V0 = _SLOT["v0"]                  # c_d dead-band speed v0 (m/s)
P_V1 = _SLOT["v1"]                  # c_d full-friction speed v1 (m/s), > v0
P_MU = _SLOT["viscosity"]           # dynamic viscosity μ (Pa s)
P_LAMBDA = _SLOT["lam"]             # small-eccentricity correction exponent λ (-)
P_EPS0 = _SLOT["eps0"]              # small-eccentricity correction threshold ε0 (-)
P_E1 = _SLOT["e1"]                  # transition band width e1 (m)
P_EPSMAX = _SLOT["eps_max"]         # transition model: ε at which the film is clamped (-)
P_BEARING = _SLOT["bearing"]        # film model code (BEARINGS[...].code), as float
P_CAVITATION = _SLOT["cavitation"]  # film cavitation code (CAVITATION_NAMES), as float
P_SHEAR = _SLOT["shear_torque"]     # 1: apply the film's viscous shear torques, 0: not

DEFAULTS: dict[str, Any] = {name: prm.pack_default for name, prm in _SLOTTED.items()}
"""What :func:`pack_params` packs for a parameter not given (justified in docs/forces.md):
the scene's default (:class:`mechrel.forces.models.Param`), or its ``off`` value (no
friction, no film) where the model does not read the sub-table."""

LIMITS: dict[str, dict] = {
    "clearance": dict(gt=0, unit="m"),
    "length": dict(gt=0, unit="m"),
    "stiffness": dict(gt=0, unit="N/m^n"),
    **{name: dict(prm.limit, **({} if prm.unit == "-" else {"unit": prm.unit}))
       for name, prm in _SLOTTED.items() if prm.limit},
}
"""Allowed range of each force-law value (keywords ``gt``, ``ge``, ``lt``, ``le``, ``unit``).

The one statement of these ranges (the joint's geometry here, the models' parameters in
:data:`mechrel.forces.models.PARAMS`): :func:`pack_params` checks them, and the scene
validation checks the same declarations for the scene keys, so that a scene and a direct call
accept exactly the same values. Cross-field rules (R_S > 0, v1 > v0, viscosity > 0 for a film
model) are checked by :func:`pack_params` and restated by the scene validation with scene
paths."""


FINITE_LD_RANGE = (0.25, 4.0)
"""L/D = length / (2 R_S) range of the finite-length film's table (-)."""


#: :data:`LIMITS` as ``(gt, ge, lt, le)`` per field (None: no such bound), for the check.
_BOUNDS = {field: tuple(spec.get(k) for k in ("gt", "ge", "lt", "le"))
           for field, spec in LIMITS.items()}


def _limited(field: str, value: Any) -> float:
    x = _real(field, value)
    gt, ge, lt, le = _BOUNDS[field]
    if not ((gt is None or x > gt) and (ge is None or x >= ge)
            and (lt is None or x < lt) and (le is None or x <= le)):
        _check(field, value, False, describe_range(**LIMITS[field]))
    return x


def _check(field: str, value: Any, ok: bool, allowed: str | Callable[[], str]) -> None:
    """Raise the force law's error for ``field`` unless ``ok``; ``allowed`` (or what it
    returns: the text is worded only for a message) says what the field admits."""
    if not ok:
        if callable(allowed):
            allowed = allowed()
        err = SceneError(f"{field} = {value!r} is invalid: allowed {allowed}", path=field)
        err.value, err.allowed = value, allowed  # for the scene loader's message
        raise err


def _real(field: str, value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{field} = {value!r} is not a number", path=field) from None
    if not math.isfinite(x):
        raise SceneError(f"{field} = {value!r} is invalid: allowed a finite number", path=field)
    return x


def pack_params(
    *,
    model: str,
    clearance: float,
    bearing_radius: float,
    length: float,
    stiffness: float,
    **params: Any,
) -> np.ndarray:
    """Validate a clearance joint's parameters and pack them into the vector the force law reads.

    Parameters
    ----------
    model : {"dry", "lubricated", "transition"}
        Clearance model, a key of :data:`mechrel.forces.models.MODELS`.
    clearance : float
        Radial clearance c = R_B − R_S (m), > 0.
    bearing_radius : float
        Bearing (hole) radius R_B (m); the journal radius R_S = R_B − c must be > 0.
    length : float
        Bearing length L (m), > 0 (used by the film only).
    stiffness : float
        Contact stiffness K (N/m^n), > 0; see :func:`mechrel.forces.contact.contact_stiffness`.
    **params
        The models' parameters by slot name (:data:`PARAM_NAMES` after the geometry; each
        declared by a :class:`mechrel.forces.models.Param`, whose unit, range and default
        apply). Not given: :data:`DEFAULTS`. The built-in ones: ``restitution`` c_e (-) in
        (0, 1], default 0.9; ``exponent`` n (-) in [1, 3], default 1.5;
        ``impact_speed_floor`` (m/s) > 0, default 1e-3; ``friction_coefficient`` c_f (-)
        ≥ 0, default 0 (friction off); ``v0``, ``v1`` (m/s), 0 ≤ v0 < v1, defaults 1e-4,
        1e-2; ``viscosity`` μ (Pa s), default 0, > 0 for a model with a film; ``lam`` λ (-)
        ≥ 0, default 1, and ``eps0`` ε0 (-) in (0, 1], default 0.1, of the small-eccentricity
        film correction (ε/ε0)^λ; ``bearing`` {"long", "short", "finite"}, default "long"
        (:data:`mechrel.forces.models.BEARINGS`); ``cavitation``
        {"half-sommerfeld", "reynolds"}, default "half-sommerfeld" ("reynolds" needs bearing
        "finite"); ``shear_torque`` (bool), default False
        (:func:`mechrel.forces.joint.film_shear_torques`); ``e1`` (m) > 0, default 1e-5, the
        width of the transition band; ``eps_max`` (-) in (0, 1), default 0.99, where the
        transition model clamps the film (the lubricated model does not clamp, see
        :func:`mechrel.forces.joint.clearance_force`).

    Returns
    -------
    numpy.ndarray
        ``float64`` vector of length :data:`N_PARAMS`, indexed by the ``P_*`` constants.

    Raises
    ------
    mechrel.errors.SceneError
        A value is not a finite number or is outside its allowed range; the message names the
        field, the value and the allowed range, and ``err.path`` is the field name.

    Examples
    --------
    >>> p = pack_params(model="dry", clearance=0.5e-3, bearing_radius=15e-3, length=20e-3,
    ...                 stiffness=9.9536e10, restitution=0.9)
    >>> p.shape == (N_PARAMS,), bool(p[P_RS] == 15e-3 - 0.5e-3), float(p[P_N])
    (True, True, 1.5)
    >>> pack_params(model="dry", clearance=0.5e-3, bearing_radius=15e-3, length=20e-3,
    ...             stiffness=9.9536e10, restitution=1.5)
    Traceback (most recent call last):
    ...
    mechrel.errors.SceneError: restitution = 1.5 is invalid: allowed a finite number in (0, 1]
    """
    if not isinstance(model, str) or model.lower() not in MODELS:
        raise SceneError(
            f"model = {model!r} is invalid: allowed one of {sorted(MODELS)}", path="model"
        )
    unknown = sorted(set(params) - set(_SLOTTED))
    if unknown:
        raise TypeError(f"pack_params() got unexpected keyword arguments {unknown}; allowed: "
                        f"{sorted(_SLOTTED)}")
    row = MODELS[model.lower()]
    values: dict[str, float] = {}
    for name, prm in _SLOTTED.items():
        value = params.get(name, DEFAULTS[name])
        if prm.choices is not None:
            ok = isinstance(value, str) and value.lower() in prm.choices
            if not ok:
                raise SceneError(f"{name} = {value!r} is invalid: allowed one of "
                                 f"{sorted(prm.choices)}", path=name)
            values[name] = float(prm.choices.index(value.lower()))
        elif prm.boolean:
            _check(name, value, isinstance(value, (bool, np.bool_)), "true or false")
            values[name] = 1.0 if value else 0.0
        else:
            values[name] = _limited(name, value) if name in LIMITS else _real(name, value)
    bearing = str(params.get("bearing", DEFAULTS["bearing"]))
    bcode = int(values["bearing"])
    ccode = int(values["cavitation"])
    if row.has_film:
        _check("cavitation", params.get("cavitation", DEFAULTS["cavitation"]),
               ccode == CAVITATION_HALF_SOMMERFELD or bcode == BEARING_FINITE,
               lambda: f"'half-sommerfeld' for bearing {bearing!r} (closed form); 'reynolds' needs "
               "bearing 'finite'")

    c = _limited("clearance", clearance)
    RB = _real("bearing_radius", bearing_radius)
    _check("bearing_radius", bearing_radius, RB > c,
           lambda: f"> clearance = {c!r} (the journal radius R_S = bearing_radius - clearance "
           "must be > 0, m)")
    RS = RB - c
    L = _limited("length", length)
    K = _limited("stiffness", stiffness)
    _check("v1", params.get("v1", DEFAULTS["v1"]), values["v1"] > values["v0"],
           lambda: f"> v0 = {values['v0']!r} (m/s)")
    if row.has_film:
        _check("viscosity", params.get("viscosity", DEFAULTS["viscosity"]),
               values["viscosity"] > 0.0, lambda: f"> 0 (Pa s) for model {model!r}")
    if row.has_film and bcode == BEARING_FINITE:
        from mechrel.forces.finite_film import TABLES_PRESENT
        cav = str(params.get("cavitation", DEFAULTS["cavitation"])).lower()
        _check("bearing", bearing, TABLES_PRESENT[cav],
               lambda: f"a bearing for which a table is installed: the {cav} table of the finite "
               "film is missing; build it with python -m mechrel.forces.finite_table")
        lo, hi = FINITE_LD_RANGE
        ld = L / (2.0 * RS)
        _check("length", length, lo * (1 - 1e-12) <= ld <= hi * (1 + 1e-12),
               lambda: f"L/D = length / (2 journal radius) in [{lo:g}, {hi:g}] for bearing "
               f"'finite' (here L/D = {ld:.4g}); use bearing 'long' above, 'short' below")

    p = np.empty(N_PARAMS, dtype=np.float64)
    p[P_MODEL] = row.code
    p[P_C] = c
    p[P_RB] = RB
    p[P_RS] = RS
    p[P_L] = L
    p[P_K] = K
    for name, x in values.items():
        p[_SLOT[name]] = x
    return p


def unpack_params(p: np.ndarray) -> dict[str, Any]:
    """Inverse of :func:`pack_params` for reports and debugging: ``{field name: value}``.

    The model and the bearing are returned by name (``"dry"``, ``"long"``, ...).

    Parameters
    ----------
    p : numpy.ndarray
        A parameter vector of length :data:`N_PARAMS`.

    Returns
    -------
    dict
        ``{field name: value}``, lengths in m, stiffness in N/m^n, viscosity in Pa s.

    Raises
    ------
    ValueError
        ``p`` does not have shape ``(N_PARAMS,)``.

    Examples
    --------
    >>> p = pack_params(model="dry", clearance=0.5e-3, bearing_radius=15e-3, length=20e-3,
    ...                 stiffness=9.9536e10, restitution=0.9)
    >>> d = unpack_params(p)
    >>> d["model"], d["bearing"], d["restitution"], round(d["journal_radius"], 6)
    ('dry', 'long', 0.9, 0.0145)
    """
    arr = np.asarray(p, dtype=np.float64)
    if arr.shape != (N_PARAMS,):
        raise ValueError(f"parameter vector must have shape ({N_PARAMS},), got {arr.shape}")
    out: dict[str, Any] = {name: float(arr[i]) for i, name in enumerate(PARAM_NAMES)}
    out["model"] = model_by_code(int(arr[P_MODEL])).name
    for name, prm in _SLOTTED.items():
        if prm.choices is not None:
            out[name] = prm.choices[int(arr[_SLOT[name]])]
        elif prm.boolean:
            out[name] = bool(arr[_SLOT[name]])
    return out
