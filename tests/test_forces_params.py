"""pack_params: layout, defaults and error messages."""

from __future__ import annotations

import numpy as np
import pytest

from mechrel.errors import SceneError
from mechrel.forces import params as P
from mechrel.forces import BEARINGS, MODELS, pack_params, unpack_params

BASE = dict(model="transition", clearance=5e-4, bearing_radius=0.015, length=0.04,
            stiffness=1e10, restitution=0.9, friction_coefficient=0.05, viscosity=0.1)


def test_layout_and_round_trip():
    p = pack_params(**BASE)
    assert p.dtype == np.float64 and p.shape == (P.N_PARAMS,)
    idx = [P.P_MODEL, P.P_C, P.P_RB, P.P_RS, P.P_L, P.P_K, P.P_N, P.P_CE, P.P_FLOOR, P.P_CF,
           P.P_V0, P.P_V1, P.P_MU, P.P_LAMBDA, P.P_EPS0, P.P_E1, P.P_EPSMAX, P.P_BEARING,
           P.P_CAVITATION, P.P_SHEAR]
    assert sorted(idx) == list(range(P.N_PARAMS)) and len(P.PARAM_NAMES) == P.N_PARAMS
    assert p[P.P_MODEL] == P.MODEL_TRANSITION
    assert p[P.P_RS] == 0.015 - 5e-4
    d = unpack_params(p)
    assert d["model"] == "transition" and d["stiffness"] == 1e10
    for k, v in P.DEFAULTS.items():
        if k not in BASE:
            assert d[k] == v, k
    assert pack_params(**{**BASE, "model": "dry", "viscosity": 0.0})[P.P_MODEL] == P.MODEL_DRY
    assert pack_params(**{**BASE, "model": "Lubricated"})[P.P_MODEL] == P.MODEL_LUBRICATED
    assert d["bearing"] == "long" and p[P.P_BEARING] == P.BEARING_LONG
    assert d["cavitation"] == "half-sommerfeld" and p[P.P_CAVITATION] == 0
    q = pack_params(**{**BASE, "bearing": "short"})
    assert q[P.P_BEARING] == P.BEARING_SHORT and unpack_params(q)["bearing"] == "short"
    # eps0 = 1 (the printed form of the paper's correction) is allowed, as in a scene
    assert pack_params(**{**BASE, "eps0": 1.0})[P.P_EPS0] == 1.0


@pytest.mark.parametrize(
    "change, field, allowed",
    [
        ({"clearance": -1e-4}, "clearance", "> 0"),
        ({"clearance": 0.0}, "clearance", "> 0"),
        ({"bearing_radius": 5e-4}, "bearing_radius",
         "R_S = bearing_radius - clearance must be > 0"),
        ({"bearing_radius": 1e-4}, "bearing_radius", "> clearance"),
        ({"restitution": 0.0}, "restitution", "(0, 1]"),
        ({"restitution": 1.2}, "restitution", "(0, 1]"),
        ({"model": "wet"}, "model", str(sorted(MODELS))[1:-1]),  # the table, sorted
        ({"model": 1}, "model", "one of"),
        ({"length": 0.0}, "length", "> 0"),
        ({"stiffness": -1.0}, "stiffness", "> 0"),
        ({"impact_speed_floor": 0.0}, "impact_speed_floor", "> 0"),
        ({"friction_coefficient": -0.1}, "friction_coefficient", ">= 0"),
        ({"v0": 0.1, "v1": 0.01}, "v1", "> v0"),
        ({"viscosity": 0.0}, "viscosity", "> 0"),
        ({"eps0": 0.0}, "eps0", "(0, 1]"),
        ({"eps_max": 1.0}, "eps_max", "(0, 1)"),
        ({"e1": 0.0}, "e1", "> 0"),
        ({"lam": -1.0}, "lam", ">= 0"),
        ({"exponent": 0.5}, "exponent", "[1, 3]"),
        ({"clearance": float("nan")}, "clearance", "finite"),
        ({"length": "long"}, "length", "not a number"),
        ({"bearing": "finite-ish"}, "bearing", str(sorted(BEARINGS))[1:-1]),
        ({"bearing": 2}, "bearing", "one of"),
        ({"cavitation": "jfo"}, "cavitation", "'half-sommerfeld', 'reynolds'"),
        ({"cavitation": "reynolds"}, "cavitation", "needs bearing 'finite'"),
    ],
)
def test_errors_name_field_and_range(change, field, allowed):
    with pytest.raises(SceneError) as info:
        pack_params(**{**BASE, **change})
    msg = str(info.value)
    assert msg.startswith(field)
    assert allowed in msg
    assert info.value.path == field
