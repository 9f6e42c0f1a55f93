"""A scene only pays for what it declares (docs/mechanics.md, docs/performance.md).

The compiled right-hand side reads the scene as arrays grouped per element type; the force
law of a clearance joint branches once on its model code. The claims are checked by
*poisoning*: the parameters a code path would read are set to NaN in the compiled System
(bypassing the validation of ``pack_params``); if that path ran, NaN would reach the result.

* a dry joint with c_f = 0 never evaluates friction (v0, v1 NaN → still finite);
* a dry joint never evaluates film code (μ, L, λ, ε0 NaN);
* a lubricated joint never evaluates contact code (K, n, c_e, floor, c_f NaN), even at
  ε ≥ 1, and has no history entry, no gap, no onset logic;
* a scene without clearance joints has empty clearance arrays, and a fully driven one is
  solved by kinematic analysis alone (no integrator, no right-hand side).
"""

from __future__ import annotations

import numpy as np
import pytest

from mechrel.forces.joint import clearance_force
from mechrel.forces.params import (P_C, P_CE, P_CF, P_EPS0, P_FLOOR, P_K, P_L, P_LAMBDA, P_MU,
                                   P_N, P_V0, P_V1)
from mechrel.mechanics.dynamics import N_WORK
from mechrel.mechanics.joints import gaps
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import make_integrator, simulate

FILM = (P_MU, P_L, P_LAMBDA, P_EPS0)
CONTACT = (P_K, P_N, P_CE, P_FLOOR, P_CF, P_V0, P_V1)
NO_FRICTION = {"joints.C1.friction.coefficient": 0.0, "joints.C2.friction.coefficient": 0.0}


def poisoned(scene, indices, overrides=None):
    sc = load_scene(scene, overrides={**(overrides or {}), "analysis.cycles": 0.1})
    cs = compile_scene(sc)
    for k in indices:
        cs.dynamic.cl_p[:, k] = np.nan
    return sc, cs


def integrate(sc, cs):
    """Integrate the (poisoned) dynamic system over the scene's span, as simulate() does."""
    from mechrel.mechanics.kinematics import assemble
    from mechrel.simulation import output_times

    sys = cs.dynamic
    q0, _ = assemble(cs.ideal, cs.q_guess, 0.0)
    qa, va = assemble(cs.assembly, q0, 0.0)
    y0 = np.concatenate([qa, va, np.zeros(N_WORK)])
    return make_integrator(sc).integrate(sys, y0, np.zeros(sys.n_contacts),
                                         output_times(sc, cs))


def sample_forces(p, radii):
    """Force law at journal offsets r·c in several directions and velocities."""
    rng = np.random.default_rng(1)
    out = []
    c = 5e-4 if np.isnan(p[P_C]) else p[P_C]
    for r in radii:
        for _ in range(20):
            a = rng.uniform(0, 2 * np.pi)
            e = r * c * np.array([np.cos(a), np.sin(a)])
            v = rng.normal(size=2) * 0.3
            wB, wS = rng.normal(size=2) * 30
            out.append(clearance_force(e[0], e[1], v[0], v[1], wB, wS, 0.0, p))
    return np.array(out)


def test_dry_without_friction_never_evaluates_friction():
    sc, cs = poisoned("nine-bar-dry", (P_V0, P_V1), NO_FRICTION)
    assert np.all(cs.dynamic.cl_p[:, P_CF] == 0.0)
    f = sample_forces(cs.dynamic.cl_p[0], (0.5, 1.001, 1.01))
    assert np.all(np.isfinite(f))
    assert np.all(f[:, 2:4] == 0.0)  # no friction moments
    res = integrate(sc, cs)
    assert res.stats.n_impacts > 0 and np.all(np.isfinite(res.y))
    # the same poison with friction declared does reach the result
    _, cs_f = poisoned("nine-bar-dry", (P_V0, P_V1))
    assert not np.all(np.isfinite(sample_forces(cs_f.dynamic.cl_p[0], (1.01,))))


def test_dry_never_evaluates_film_code():
    sc, cs = poisoned("nine-bar-dry", FILM)
    assert np.all(np.isfinite(sample_forces(cs.dynamic.cl_p[0], (0.0, 0.5, 0.999, 1.01))))
    res = integrate(sc, cs)
    assert res.stats.n_impacts > 0 and np.all(np.isfinite(res.y))


def test_lubricated_never_evaluates_contact_code():
    sc, cs = poisoned("nine-bar-lubricated", CONTACT)
    sys = cs.dynamic
    # even beyond the wall (a state the film does not let the journal reach)
    assert np.all(np.isfinite(sample_forces(sys.cl_p[0], (0.0, 0.5, 0.99, 1.0, 1.2))))
    assert sys.n_contacts == 0 and np.all(sys.cl_hist == -1)
    assert gaps(0.0, np.zeros(2 * sys.mass.size + 2), sys)[0].size == 0
    res = integrate(sc, cs)
    assert np.all(np.isfinite(res.y))
    assert res.stats.n_impacts == 0 and res.stats.n_onset_rejections == 0


def test_transition_runs_both_and_only_its_contact_joints_have_history():
    sc = load_scene("nine-bar", overrides={"joints.C1.model": "transition",
                                           "joints.C2.model": "lubricated"})
    sys = compile_scene(sc).dynamic
    assert sys.cl_hist.tolist() == [0, -1] and sys.n_contacts == 1
    # the transition joint reads both parameter sets: poisoning either reaches the force
    for group in (FILM, (P_K,)):
        p = sys.cl_p[0].copy()
        p[list(group)] = np.nan
        assert not np.all(np.isfinite(sample_forces(p, (0.5, 1.01))))


def test_the_energy_bookkeeping_evaluates_force_laws_only_for_joints_that_can_touch():
    # the elastic energy is metal contact's: where no joint can touch, post_process gives 0
    # without a force law (the film's parameters poisoned: still 0, and T, V unchanged);
    # with a joint that can touch it is the sum the force laws return, bit for bit
    from mechrel.mechanics.applied import applied_forces
    from mechrel.mechanics.post import post_process

    for name, overrides, film_poisoned in (
            ("nine-bar-lubricated", None, True),
            ("nine-bar", {"joints.C1.model": "transition", "joints.C2.model": "lubricated"},
             False)):
        sc = load_scene(name, overrides={**(overrides or {}), "analysis.cycles": 0.1})
        cs = compile_scene(sc)
        sys = cs.dynamic
        res = integrate(sc, cs)
        Y = np.ascontiguousarray(res.y)
        j = int(sys.cl_j[0] if sys.cl_j[0] >= 0 else sys.cl_b[0])
        Y[-1, 3 * j] += 2.0 * sys.cl_p[0, P_C]  # a state beyond the wall too (|e| >= c)
        *_, T, V, E = post_process(res.t, Y, sys)
        n = sys.mass.size
        expect = np.array([applied_forces(t, y[:n], y[n:2 * n], np.zeros(sys.n_contacts), sys,
                                          np.zeros(n))[1] for t, y in zip(res.t, Y)])
        assert np.array_equal(E, expect)
        if film_poisoned:
            assert sys.n_contacts == 0 and np.all(E == 0.0)
            sys.cl_p[:, list(FILM)] = np.nan
            *_, T2, V2, E2 = post_process(res.t, Y, sys)
            assert np.all(E2 == 0.0) and np.array_equal(T2, T) and np.array_equal(V2, V)
        else:
            assert sys.n_contacts == 1 and E.max() > 0.0


@pytest.mark.parametrize("scene", ["nine-bar", "slider-crank"])
def test_ideal_driven_scene_is_kinematics_only(scene):
    cs = compile_scene(load_scene(scene))
    for arr in (cs.dynamic.cl_b, cs.dynamic.cl_p, cs.dynamic.cl_hist):
        assert arr.shape[0] == 0
    res = simulate(load_scene(scene))
    assert res.method == "kinematics"
    assert res.stats["integrator"] == "kinematic-analysis"
    assert "n_rhs" not in res.stats and res.energy == {} and res.orbits == {}
