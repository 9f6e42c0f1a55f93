"""The reduced formulation (mechrel.mechanics.reduced): only the clearance joints' eccentricities
are integrated, the bodies' motion is recovered from the constraints.

What is asserted, and why the tolerances:

* Kinematics: at ``z = ż = 0`` the reduced position and velocity solves are the kinematic
  analysis of the ideal mechanism (same square constraint system): agreement to 1e-12 m
  (both Newton iterations run to |Φ| ≤ 1e-14, near round-off of coordinates of order 1 m;
  the Jacobian's condition number ~10-100 turns that into ≤ 1e-12).
* ``R = ∂q/∂z`` against central differences of the position solve: the error of a central
  difference falls as h² (ratio 4 per halving of h until round-off).
* Projection: at a consistent state the reduced accelerations are those of the absolute
  formulation's right-hand side (the same equations of motion, the constraint forces
  eliminated instead of solved for; the Baumgarte terms vanish on the constraints): to 1e-8
  relative (conditioning of the two linear solves at the film's stiffness).
* Whole runs: the reduced and absolute runs of the same scene at the same tolerance differ by
  no more than the integration error each one makes (bounds stated at each test).
* A clear error for what the reduced path cannot treat.
"""

from __future__ import annotations

import numpy as np
import pytest

from mechrel.errors import SimulationError
from mechrel.mechanics import problem
from mechrel.mechanics.kinematics import assemble, kinematic_analysis
from mechrel.mechanics.reduced import (make_reduced_workspace, reduced_rhs_into, reduced_system,
                                       solve_positions)
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import simulate


def _setup(name):
    scene = load_scene(name)
    compiled = compile_scene(scene)
    q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0)
    qa, va = assemble(compiled.assembly, q0, 0.0)
    return scene, compiled, reduced_system(scene, compiled, qa), qa, va


@pytest.mark.parametrize("name", ["nine-bar-lubricated", "slider-crank-lubricated",
                                  "four-bar"])
def test_centred_journals_give_the_ideal_kinematics(name):
    scene, compiled, rs, qa, _ = _setup(name)
    times = np.linspace(0.0, 0.05, 6)
    # both Newton iterations to near round-off (the default assembly tolerance, 1e-12, would
    # leave the kinematic analysis ~1e-12 rad off)
    Qi, Vi, _, _ = kinematic_analysis(compiled.ideal, qa, times, tol=1e-14)
    rw = make_reduced_workspace(rs)
    x = np.zeros(rs.n_states)
    out = np.empty_like(x)
    for k, t in enumerate(times):
        reduced_rhs_into(t, x, np.zeros(compiled.dynamic.n_contacts), rs, rw, out)
        d = rw.q - Qi[k]
        # angles modulo 2π: from a predictor 0.01 s away (2 rad of crank at the slider-crank's
        # speed) Newton may land on the same configuration one turn away
        d[2::3] = (d[2::3] + np.pi) % (2 * np.pi) - np.pi
        assert np.max(np.abs(d)) <= 1e-12
        np.testing.assert_allclose(rw.v, Vi[k], rtol=0, atol=1e-10)  # m/s at ω ≈ 10 rad/s


def test_R_is_the_derivative_of_the_positions():
    scene, compiled, rs, qa, _ = _setup("nine-bar-lubricated")
    rw = make_reduced_workspace(rs)
    c = 5e-4  # the nine-bar's clearance (m)
    z = np.array([0.3, -0.2, 0.1, 0.4]) * c
    x = np.concatenate([z, np.zeros(len(z)), np.zeros(2)])
    out = np.empty_like(x)
    t = 0.1
    reduced_rhs_into(t, x, np.zeros(0), rs, rw, out)
    R = rw.R.copy()

    def q_of(zz):
        w = make_reduced_workspace(rs)
        w.qc[:] = rw.q
        assert solve_positions(t, zz, rs, w) <= 1e-13
        return w.q.copy()

    errs = []
    for h in (4e-6, 2e-6, 1e-6):
        D = np.empty_like(R)
        for col in range(len(z)):
            dz = np.zeros(len(z))
            dz[col] = h
            D[:, col] = (q_of(z + dz) - q_of(z - dz)) / (2 * h)
        errs.append(np.max(np.abs(D - R)))
    # central differences: O(h²), the ratio 4 per halving (3 allows for round-off, ~1e-16/h)
    assert errs[0] / errs[1] > 3 and errs[1] / errs[2] > 3 or errs[-1] < 1e-9, errs


@pytest.mark.parametrize("name", ["nine-bar-lubricated", "slider-crank-lubricated"])
def test_projection_matches_the_absolute_dynamics(name):
    scene, compiled, rs, qa, _ = _setup(name)
    n = qa.size
    rw = make_reduced_workspace(rs)
    c = float(rs.jac_floor[0])
    rng = np.random.default_rng(1)
    for t in (0.0, 0.07, 0.21):
        nz = 2 * len(rs.cl_row)
        z = rng.uniform(-0.6, 0.6, nz) * c
        zd = rng.uniform(-1, 1, nz) * c * 10
        x = np.concatenate([z, zd, [0.0, 0.0]])
        out = np.empty_like(x)
        reduced_rhs_into(t, x, np.zeros(compiled.dynamic.n_contacts), rs, rw, out)
        y = np.concatenate([rw.q, rw.v, [0.0, 0.0]])
        f = problem.rhs(t, y, np.zeros(compiled.dynamic.n_contacts), compiled.dynamic)
        scale = np.max(np.abs(f[n:2 * n]))
        np.testing.assert_allclose(rw.a, f[n:2 * n], rtol=0, atol=1e-8 * scale)
        np.testing.assert_allclose(out[-2:], f[-2:], rtol=1e-8, atol=1e-8 * abs(f[-2]))


def test_errors_for_what_the_reduced_path_cannot_treat():
    with pytest.raises(SimulationError, match="no clearance joint"):
        simulate(load_scene("nine-bar"), formulation="reduced", method="dynamics",
                 integrator="radau")
    with pytest.raises(SimulationError, match="formulation = 'bogus'.*allowed"):
        simulate(load_scene("nine-bar-lubricated"), formulation="bogus")
    with pytest.raises(SimulationError, match="integrator 'dopri5'.*allowed: integrator 'radau'"):
        simulate(load_scene("nine-bar-lubricated"), formulation="reduced", integrator="dopri5")
    import tomllib
    from importlib.resources import files
    raw = tomllib.loads(files("mechrel.scene").joinpath("data/four-bar.toml").read_text())
    raw.pop("drivers")
    raw["analysis"] = {"duration": 0.01, "sample_step": 1e-3}
    undriven = load_scene(raw)
    with pytest.raises(SimulationError, match=r"1 ideal degree\(s\) of freedom are not driven"):
        simulate(undriven, formulation="reduced", integrator="radau")


@pytest.mark.parametrize("name", ["nine-bar-lubricated", "four-bar"])
def test_fast_jacobian_is_the_clearance_forces_share(name):
    """The fast part of the reduced Jacobian (``reduced_clearance_jacobian``) against central
    differences of the right-hand side minus those of the same mechanism without clearance
    forces. What the fast part leaves out (R and the lever arms turning with the state, in
    proportion to the forces) is of relative size c / L (5e-4 m / 0.7 m on the nine-bar):
    bound 1e-2 of the largest entry. The differences use h = 1e-3 c (error O(h²) relative)."""
    from mechrel.mechanics.reduced import reduced_clearance_jacobian
    from mechrel.mechanics.system import without_clearance_forces
    scene, compiled, rs, qa, _ = _setup(name)
    smooth = rs._replace(dyn=without_clearance_forces(rs.dyn))
    nh = compiled.dynamic.n_contacts
    nc = len(rs.cl_row)
    nz = 2 * nc
    c = rs.jac_floor[:nz]
    # a state inside the film / in contact: ε = 0.9 at joint 0, rates of c ω
    z = np.zeros(nz)
    z[0] = 0.9 * c[0]
    z[2:] = 0.5 * c[2:] if nz > 2 else z[2:]
    zd = 0.3 * rs.jac_floor[nz:]
    x = np.concatenate([z, zd, [0.0, 0.0]])
    hist = np.full(nh, 0.05)
    t = 0.05
    rw = make_reduced_workspace(rs)
    f = np.empty_like(x)
    JS = np.zeros((x.size, x.size))
    reduced_clearance_jacobian(t, x, hist, rs, rw, f, JS)

    def fd(system):
        D = np.empty((nz, 2 * nz))
        w = make_reduced_workspace(system)
        out_p = np.empty_like(x)
        out_m = np.empty_like(x)
        for u in range(2 * nz):
            h = 1e-3 * (c[u % nz] if u < nz else rs.jac_floor[u])
            xp, xm = x.copy(), x.copy()
            xp[u] += h
            xm[u] -= h
            reduced_rhs_into(t, xp, hist, system, w, out_p)
            reduced_rhs_into(t, xm, hist, system, w, out_m)
            D[:, u] = (out_p[nz:2 * nz] - out_m[nz:2 * nz]) / (2 * h)
        return D

    fast = fd(rs) - fd(smooth)
    err = np.max(np.abs(JS[nz:2 * nz, :2 * nz] - fast))
    assert err <= 1e-2 * np.max(np.abs(fast)), (err, np.max(np.abs(fast)))


# Bounds of |reduced − absolute| relative to each output's range over the run, radau rtol 1e-6
# for both: each run's own integration error at this setting is ≤ 1.3e-4 of the peak in the
# acceleration on the nine-bar and ≈ 5e-4 on the slider-crank (docs/performance.md, integrator
# tables), an order of magnitude less in the velocity and less again in the displacement (the
# integrated quantities); the difference of two runs is at most the sum of their errors.
AGREE = {"displacement": 1e-5, "velocity": 1e-4, "acceleration": 1e-3}


@pytest.mark.parametrize("name", ["nine-bar-lubricated", "slider-crank-lubricated"])
def test_reduced_and_absolute_runs_agree_within_the_tolerance(name):
    scene = load_scene(name)
    kw = dict(integrator="radau", rtol=1e-6, atol=1e-9, extremes=True)
    a = simulate(scene, formulation="absolute", **kw)
    b = simulate(scene, formulation="reduced", **kw)
    assert b.stats["max_position_violation"] <= 1e-13  # the Newton residual, m
    for out in a.outputs:
        for q, bound in AGREE.items():
            x, y = a.outputs[out][q], b.outputs[out][q]
            rng = np.ptp(x)
            assert np.max(np.abs(x - y)) <= bound * rng, (out, q)
            assert np.sqrt(np.mean((x - y) ** 2)) <= 0.25 * bound * rng, (out, q)
    # the journal orbits (m) and the energy balance (J) of the same motion
    for k in a.orbits:
        c = np.max(np.hypot(a.orbits[k]["ex"], a.orbits[k]["ey"]))
        assert np.max(np.abs(a.orbits[k]["ex"] - b.orbits[k]["ex"])) <= 1e-3 * c
    work = np.max(np.abs(a.energy["input_work"]))
    assert np.max(np.abs(b.energy["balance"])) <= 1e-4 * work  # no Baumgarte work, exact
    # the cycle extremes from the solution log (expanded to the bodies' coordinates)
    fa, fb = a.extremes_frame(), b.extremes_frame()
    assert len(fa) == len(fb)
    for col in ("max", "min", "max_abs"):  # of the error curves, within 1e-3 of their peak
        d = np.abs(fa[col].to_numpy(float) - fb[col].to_numpy(float))
        assert np.all(d <= 1e-3 * fa["max_abs"].to_numpy(float)), (col, d)
