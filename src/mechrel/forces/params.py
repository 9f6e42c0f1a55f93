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
from typing import Any

import numpy as np

# one text for a range across scenes, studies and force laws (the validation toolkit's)
from mechrel._checks import describe_number as describe_range
from mechrel.errors import SceneError
from mechrel.forces.models import (
    BEARING_FINITE, BEARING_LONG, BEARING_SHORT, BEARINGS, DEFAULT_BEARING, MODEL_DRY,
    MODEL_LUBRICATED, MODEL_TRANSITION, MODELS,
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
"""Scene name → integer code of every clearance model (:data:`mechrel.forces.models.MODELS`)."""
BEARING_NAMES = {b.name: b.code for b in BEARINGS.values()}
CAVITATION_HALF_SOMMERFELD = 0
"""Gümbel film: the positive part of the full-film pressure (every film model)."""
CAVITATION_REYNOLDS = 1
"""Swift–Stieber film: p ≥ 0 with zero gradient at rupture (the finite film only)."""
CAVITATION_NAMES = {"half-sommerfeld": CAVITATION_HALF_SOMMERFELD,
                    "reynolds": CAVITATION_REYNOLDS}
"""Scene name → integer code of every film model (:data:`mechrel.forces.models.BEARINGS`)."""

# --- indices into the parameter vector ---------------------------------------------------------
P_MODEL = 0     # model code (MODEL_DRY / MODEL_LUBRICATED / MODEL_TRANSITION), stored as float
P_C = 1         # radial clearance c = R_B - R_S (m)
P_RB = 2        # bearing (hole) radius R_B (m)
P_RS = 3        # journal (pin) radius R_S = R_B - c (m)
P_L = 4         # bearing length L (m)
P_K = 5         # contact stiffness K (N/m^n)
P_N = 6         # contact force exponent n (-), 1.5 for Hertz line/point contact as in the paper
P_CE = 7        # coefficient of restitution c_e (-), in (0, 1]
P_FLOOR = 8     # floor of the impact speed δ̇⁻ used in the LN damping term (m/s), > 0
P_CF = 9        # friction coefficient c_f (-); 0 means friction is not evaluated at all
P_V0 = 10       # c_d dead-band speed v0 (m/s)
P_V1 = 11       # c_d full-friction speed v1 (m/s), > v0
P_MU = 12       # dynamic viscosity μ (Pa s)
P_LAMBDA = 13   # small-eccentricity correction exponent λ (-)
P_EPS0 = 14     # small-eccentricity correction threshold ε0 (-), in (0, 1]
P_E1 = 15       # transition band width e1 (m)
P_EPSMAX = 16   # transition model: ε at which the film is clamped, ε_max (-), in (0, 1)
P_BEARING = 17  # film model code (BEARING_LONG / BEARING_SHORT / BEARING_FINITE), as float
P_CAVITATION = 18  # film cavitation code (CAVITATION_HALF_SOMMERFELD / CAVITATION_REYNOLDS)
P_SHEAR = 19    # 1: apply the film's viscous shear torques to journal and bearing, 0: not
N_PARAMS = 20

PARAM_NAMES = (
    "model", "clearance", "bearing_radius", "journal_radius", "length", "stiffness",
    "exponent", "restitution", "impact_speed_floor", "friction_coefficient", "v0", "v1",
    "viscosity", "lam", "eps0", "e1", "eps_max", "bearing", "cavitation", "shear_torque",
)
"""Field name of each index, in index order (``PARAM_NAMES[P_K] == "stiffness"``)."""

DEFAULTS: dict[str, float] = {
    "exponent": 1.5,
    "impact_speed_floor": 1e-3,
    "friction_coefficient": 0.0,
    "v0": 1e-4,
    "v1": 1e-2,
    "viscosity": 0.0,
    "lam": 1.0,
    "eps0": 0.1,
    "e1": 1e-5,
    "eps_max": 0.99,
}
"""Defaults of :func:`pack_params` where the paper gives no value (justified in docs/forces.md)."""

LIMITS: dict[str, dict] = {
    "clearance": dict(gt=0, unit="m"),
    "length": dict(gt=0, unit="m"),
    "stiffness": dict(gt=0, unit="N/m^n"),
    "exponent": dict(ge=1, le=3),
    "restitution": dict(gt=0, le=1),
    "impact_speed_floor": dict(gt=0, unit="m/s"),
    "friction_coefficient": dict(ge=0),
    "v0": dict(ge=0, unit="m/s"),
    "v1": dict(gt=0, unit="m/s"),
    "viscosity": dict(ge=0, unit="Pa s"),
    "lam": dict(ge=0),
    "eps0": dict(gt=0, le=1),
    "e1": dict(gt=0, unit="m"),
    "eps_max": dict(gt=0, lt=1),
}
"""Allowed range of each force-law value (keywords ``gt``, ``ge``, ``lt``, ``le``, ``unit``).

The one statement of these ranges: :func:`pack_params` checks them, and the scene validation
checks the same entries for the scene keys that feed them
(:data:`mechrel.forces.models.SUBTABLE_PARAMS`), so that a scene and a direct call accept
exactly the same values. Cross-field rules (R_S > 0, v1 > v0, viscosity > 0 for a film model)
are checked by :func:`pack_params` and restated by the scene validation with scene paths."""


FINITE_LD_RANGE = (0.25, 4.0)
"""L/D = length / (2 R_S) range of the finite-length film's table (-)."""


def _in_range(x: float, gt=None, ge=None, lt=None, le=None, unit=None) -> bool:
    return ((gt is None or x > gt) and (ge is None or x >= ge)
            and (lt is None or x < lt) and (le is None or x <= le))


def _limited(field: str, value: Any) -> float:
    x = _real(field, value)
    spec = LIMITS[field]
    _check(field, value, _in_range(x, **spec), describe_range(**spec))
    return x


def _check(field: str, value: Any, ok: bool, allowed: str) -> None:
    if not ok:
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
    exponent: float = DEFAULTS["exponent"],
    restitution: float,
    impact_speed_floor: float = DEFAULTS["impact_speed_floor"],
    friction_coefficient: float = DEFAULTS["friction_coefficient"],
    v0: float = DEFAULTS["v0"],
    v1: float = DEFAULTS["v1"],
    viscosity: float = DEFAULTS["viscosity"],
    lam: float = DEFAULTS["lam"],
    eps0: float = DEFAULTS["eps0"],
    e1: float = DEFAULTS["e1"],
    eps_max: float = DEFAULTS["eps_max"],
    bearing: str = DEFAULT_BEARING,
    cavitation: str = "half-sommerfeld",
    shear_torque: bool = False,
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
    exponent : float, default 1.5
        Contact force exponent n (-), in [1, 3].
    restitution : float
        Coefficient of restitution c_e (-), in (0, 1].
    impact_speed_floor : float, default 1e-3
        Floor of the impact speed δ̇⁻ (m/s) in the Lankarani–Nikravesh damping term, > 0.
    friction_coefficient : float, default 0
        Coulomb friction coefficient c_f (-), ≥ 0; 0 switches friction off entirely.
    v0, v1 : float, default 1e-4, 1e-2
        Speeds of Ambrósio's dynamic correction c_d (m/s), 0 ≤ v0 < v1.
    viscosity : float, default 0
        Dynamic viscosity μ (Pa s); > 0 for the lubricated and transition models.
    lam : float, default 1
        Exponent λ (-) of the small-eccentricity film correction (ε/ε0)^λ, ≥ 0.
    eps0 : float, default 0.1
        Threshold ε0 (-) of that correction, in (0, 1].
    e1 : float, default 1e-5
        Width of the transition band c ≤ |e| ≤ c + e1 (m), > 0.
    eps_max : float, default 0.99
        Eccentricity ratio at which the film force is clamped in the transition model (-),
        in (0, 1). The lubricated model does not clamp (its film keeps ε < 1; see
        :func:`mechrel.forces.joint.clearance_force`).
    bearing : {"long", "short", "finite"}, default "long"
        Film model of the lubricated and transition models
        (:data:`mechrel.forces.models.BEARINGS`); not read by the dry model.
    cavitation : {"half-sommerfeld", "reynolds"}, default "half-sommerfeld"
        Cavitation condition of the film; "reynolds" (Swift–Stieber) needs bearing "finite"
        (the long and short films are half-Sommerfeld closed forms).
    shear_torque : bool, default False
        Apply the film's viscous shear torques to journal and bearing
        (:func:`mechrel.forces.joint.film_shear_torques`); off by default, as in the paper.

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
    if not isinstance(model, str) or model.lower() not in MODEL_NAMES:
        raise SceneError(
            f"model = {model!r} is invalid: allowed one of {sorted(MODEL_NAMES)}", path="model"
        )
    row = MODELS[model.lower()]
    code = row.code
    if not isinstance(bearing, str) or bearing.lower() not in BEARING_NAMES:
        raise SceneError(
            f"bearing = {bearing!r} is invalid: allowed one of {sorted(BEARING_NAMES)}",
            path="bearing")
    bcode = BEARING_NAMES[bearing.lower()]
    if not isinstance(cavitation, str) or cavitation.lower() not in CAVITATION_NAMES:
        raise SceneError(
            f"cavitation = {cavitation!r} is invalid: allowed one of "
            f"{sorted(CAVITATION_NAMES)}", path="cavitation")
    ccode = CAVITATION_NAMES[cavitation.lower()]
    _check("shear_torque", shear_torque, isinstance(shear_torque, (bool, np.bool_)),
           "true or false")
    if row.has_film:
        _check("cavitation", cavitation,
               ccode == CAVITATION_HALF_SOMMERFELD or bcode == BEARING_FINITE,
               f"'half-sommerfeld' for bearing {bearing!r} (closed form); 'reynolds' needs "
               "bearing 'finite'")

    c = _limited("clearance", clearance)
    RB = _real("bearing_radius", bearing_radius)
    _check("bearing_radius", bearing_radius, RB > c,
           f"> clearance = {c!r} (the journal radius R_S = bearing_radius - clearance "
           "must be > 0, m)")
    RS = RB - c
    L = _limited("length", length)
    K = _limited("stiffness", stiffness)
    n = _limited("exponent", exponent)
    ce = _limited("restitution", restitution)
    floor = _limited("impact_speed_floor", impact_speed_floor)
    cf = _limited("friction_coefficient", friction_coefficient)
    a0 = _limited("v0", v0)
    a1 = _limited("v1", v1)
    _check("v1", v1, a1 > a0, f"> v0 = {a0!r} (m/s)")
    mu = _limited("viscosity", viscosity)
    if row.has_film:
        _check("viscosity", viscosity, mu > 0.0, f"> 0 (Pa s) for model {model!r}")
    lm = _limited("lam", lam)
    e0 = _limited("eps0", eps0)
    w1 = _limited("e1", e1)
    em = _limited("eps_max", eps_max)
    if row.has_film and bcode == BEARING_FINITE:
        from mechrel.forces.finite_film import TABLES_PRESENT
        cav = cavitation.lower()
        _check("bearing", bearing, TABLES_PRESENT[cav],
               f"a bearing for which a table is installed: the {cav} table of the finite film "
               "is missing; build it with python -m mechrel.forces.finite_table")
        lo, hi = FINITE_LD_RANGE
        ld = L / (2.0 * RS)
        _check("length", length, lo * (1 - 1e-12) <= ld <= hi * (1 + 1e-12),
               f"L/D = length / (2 journal radius) in [{lo:g}, {hi:g}] for bearing 'finite' "
               f"(here L/D = {ld:.4g}); use bearing 'long' above, 'short' below")

    p = np.empty(N_PARAMS, dtype=np.float64)
    p[P_MODEL] = code
    p[P_C] = c
    p[P_RB] = RB
    p[P_RS] = RS
    p[P_L] = L
    p[P_K] = K
    p[P_N] = n
    p[P_CE] = ce
    p[P_FLOOR] = floor
    p[P_CF] = cf
    p[P_V0] = a0
    p[P_V1] = a1
    p[P_MU] = mu
    p[P_LAMBDA] = lm
    p[P_EPS0] = e0
    p[P_E1] = w1
    p[P_EPSMAX] = em
    p[P_BEARING] = bcode
    p[P_CAVITATION] = ccode
    p[P_SHEAR] = 1.0 if shear_torque else 0.0
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
    names = {v: k for k, v in MODEL_NAMES.items()}
    out["model"] = names[int(arr[P_MODEL])]
    out["bearing"] = {v: k for k, v in BEARING_NAMES.items()}[int(arr[P_BEARING])]
    out["cavitation"] = {v: k for k, v in CAVITATION_NAMES.items()}[int(arr[P_CAVITATION])]
    out["shear_torque"] = bool(arr[P_SHEAR])
    return out
