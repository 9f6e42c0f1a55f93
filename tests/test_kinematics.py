"""Kinematic analysis against closed forms and the nine-bar reference positions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechrel.errors import AssemblyError
from mechrel.mechanics.kinematics import assemble
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import simulate

R, L = 0.05, 0.12
OMEGA = 5000 * 2 * math.pi / 60


def slider_closed_form(theta, omega):
    """x(θ) = r cos θ + sqrt(l² − r² sin² θ) and its time derivatives at constant ω."""
    s, c = np.sin(theta), np.cos(theta)
    S = np.sqrt(L**2 - R**2 * s**2)
    x = R * c + S
    dx = -R * s - R**2 * s * c / S
    ddx = -R * c - R**2 * np.cos(2 * theta) / S - R**4 * s**2 * c**2 / S**3
    return x, omega * dx, omega**2 * ddx


def test_slider_crank_kinematics_matches_closed_form():
    # 1° sampling over one revolution: 361 crank angles (≥ 50 required).
    res = simulate(load_scene("slider-crank"))
    assert res.method == "kinematics"
    assert res.time.size >= 50
    theta = OMEGA * res.time
    x, v, a = slider_closed_form(theta, OMEGA)
    out = res.outputs["slider"]
    # Newton converges to |Φ| ≤ 1e-12 m (assembly_tolerance) and the velocity/acceleration
    # solves are exact up to round-off (cond(Φ_q) ~ 10): 1e-9 relative is far above both.
    # Velocity and acceleration pass through zero, so they are compared relative to their
    # amplitude over the cycle.
    assert np.max(np.abs(out["displacement"] - x) / np.abs(x)) <= 1e-9
    assert np.max(np.abs(out["velocity"] - v)) / np.max(np.abs(v)) <= 1e-9
    assert np.max(np.abs(out["acceleration"] - a)) / np.max(np.abs(a)) <= 1e-9
    assert res.stats["max_position_violation"] <= 1e-12
    # crank angle column: rotation of the cycle driver in degrees
    assert np.allclose(res.crank_angle, np.degrees(theta), atol=1e-9)


NINE_BAR_JOINTS_MM = {  # docs/reference.md, joint positions at t = 0
    ("crank1", "A"): (22.309, 39.081), ("crank2", "B"): (54.339, -501.745),
    ("plate", "P"): (324.059, -84.300), ("plate", "Q"): (704.225, -17.439),
    ("plate", "R"): (605.366, -247.063), ("slider", "S"): (670.000, -575.769),
}


def _point(scene, compiled, q, body, point):
    k = compiled.body_index[body]
    sx, sy = scene.bodies[body].points[point]
    th = q[3 * k + 2]
    return (q[3 * k] + math.cos(th) * sx - math.sin(th) * sy,
            q[3 * k + 1] + math.sin(th) * sx + math.cos(th) * sy)


def test_nine_bar_assembly_matches_reference_positions():
    scene = load_scene("nine-bar")
    compiled = compile_scene(scene)
    q, _ = assemble(compiled.ideal, compiled.q_guess, 0.0)
    for (body, point), (x, y) in NINE_BAR_JOINTS_MM.items():
        px, py = _point(scene, compiled, q, body, point)
        # docs/reference.md prints positions to 1 µm (3 decimals in mm): the round-off is 0.5e-6 m,
        # within the 1e-6 m the foundation issue asks for.
        assert abs(px - x * 1e-3) <= 1e-6 and abs(py - y * 1e-3) <= 1e-6, (body, point, px, py)


def test_nine_bar_full_cycle_stroke_and_violation():
    res = simulate(load_scene("nine-bar"))
    assert res.method == "kinematics"
    assert res.crank_angle[-1] == pytest.approx(360.0)
    assert res.stats["max_position_violation"] <= 1e-8
    d = res.outputs["slider"]["displacement"]
    # docs/reference.md: stroke about 68.6 mm; sampled every 1°, the extremes are within
    # (ω Δt)² x''/8 ≈ 1e-6 m of the true ones.
    assert (d.max() - d.min()) * 1e3 == pytest.approx(68.6, abs=0.1)


def test_nine_bar_full_cycle_with_forward_dynamics():
    res = simulate(load_scene("nine-bar"), method="dynamics", integrator="dopri5",
                   rtol=1e-10, atol=1e-12)
    ref = simulate(load_scene("nine-bar"))
    assert res.stats["max_position_violation"] <= 1e-8
    d, dr = res.outputs["slider"]["displacement"], ref.outputs["slider"]["displacement"]
    assert np.max(np.abs(d - dr)) <= 1e-6 * np.max(np.abs(dr))


def test_unassemblable_geometry_names_the_violated_constraints():
    # A 2 mm rod on a crank that starts vertical (tip 50 mm above the slider line): the rod
    # cannot reach the line, the mechanism cannot close.
    scene = load_scene("slider-crank", overrides={"bodies.rod.points.B": [0.001, 0.0],
                                                  "bodies.rod.points.A": [-0.001, 0.0],
                                                  "drivers.crank.angle0": math.pi / 2})
    with pytest.raises(AssemblyError, match=r"cannot be assembled.*joints\.") as err:
        simulate(scene)
    assert "|Φ| =" in str(err.value)



# ------------------------------------------------------------- compiled sparse LU kinematics

def _numpy_gamma(q, v, t, system):
    """γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt written plainly (Nikravesh 1988, §6.2): a revolute
    joint's two rows (A_i s_i) ω_i² − (A_j s_j) ω_j², a point on a line n·(A_i s_i) ω_i² and
    zero for its angle row, zero for a fixed angle, a driver's angular acceleration."""
    from mechrel.mechanics.drivers import driver_law

    def rotated(body, s):
        c, sn = math.cos(q[3 * body + 2]), math.sin(q[3 * body + 2])
        return np.array([c * s[0] - sn * s[1], sn * s[0] + c * s[1]])

    rows = []
    for i, j, si, sj in zip(system.rev_i, system.rev_j, system.rev_si, system.rev_sj):
        g = rotated(i, si) * v[3 * i + 2] ** 2
        if j >= 0:
            g = g - rotated(j, sj) * v[3 * j + 2] ** 2
        rows += list(g)
    for i, si, nrm in zip(system.tr_i, system.tr_si, system.tr_n):
        rows += [float(nrm @ rotated(i, si)) * v[3 * i + 2] ** 2, 0.0]
    rows += [0.0] * system.fa_i.shape[0]
    rows += [driver_law(law, par, t)[2] for law, par in zip(system.dr_law, system.dr_par)]
    return np.array(rows)


def _numpy_kinematics(system, q0, times, tol):
    """The kinematic analysis written plainly with NumPy: the same Taylor predictor and Newton
    iteration as the compiled kernel, every linear system by np.linalg.solve (LAPACK) on the
    dense Φ_q from constraints() (the compiled kernel works on the sparse rows of
    constraint_terms()), γ from :func:`_numpy_gamma`."""
    from mechrel.mechanics.constraints import constraints

    n = q0.size
    Q, V, A = (np.empty((times.size, n)) for _ in range(3))
    q, v, a = q0.copy(), np.zeros(n), np.zeros(n)
    conds = []
    tprev = times[0]
    for k, t in enumerate(times):
        dt = t - tprev
        q = q + v * dt + 0.5 * a * dt * dt
        for _ in range(50):
            phi, phit, J = constraints(q, t, system)
            if np.max(np.abs(phi)) <= tol:
                break
            q = q - np.linalg.solve(J, phi)
        else:
            raise AssertionError(f"reference Newton did not converge at t = {t}")
        v = np.linalg.solve(J, -phit)
        a = np.linalg.solve(J, _numpy_gamma(q, v, t, system))
        Q[k], V[k], A[k] = q, v, a
        conds.append(np.linalg.cond(J))
        tprev = t
    return Q, V, A, max(conds)


def _newton_kinematics(system, q0, times, tol):
    """The compiled Newton–Raphson analysis itself (``kinematic_analysis`` places these
    scenes in closed form instead: tests/test_construction.py)."""
    from mechrel.mechanics.kinematics import _kinematics

    Q, V, A, viol, done = _kinematics(q0, np.ascontiguousarray(times), system, tol, 50)
    assert done == times.size
    return Q, V, A, viol


@pytest.mark.parametrize("name", ["nine-bar", "slider-crank", "four-bar"])
def test_compiled_newton_kinematic_analysis_matches_numpy_reference(name):
    from mechrel.simulation import output_times

    scene = load_scene(name)
    compiled = compile_scene(scene)
    times = output_times(scene, compiled)  # one cycle at 1°
    tol = scene.solver.assembly_tolerance
    q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol)
    Q, V, A, viol = _newton_kinematics(compiled.ideal, q0, times, tol)
    Qr, Vr, Ar, cond = _numpy_kinematics(compiled.ideal, q0, times, tol)
    # Both solve the same systems by LU with partial pivoting, in a different order of
    # operations: a backward-stable solve has a normwise relative error of order
    # cond(Φ_q) × machine epsilon, here <= 65 × 2.2e-16 ≈ 1.5e-14 (checked below), so 1e-12
    # leaves a margin of ~70. The positions come out of the same Newton iterates, so they
    # differ by as little. Normwise (per instant, relative to the largest component) because
    # that is what the bound is about: single components pass through zero.
    eps = np.finfo(float).eps
    assert cond * eps < 1e-13
    for got, ref in ((Q, Qr), (V, Vr), (A, Ar)):
        err = np.max(np.abs(got - ref), axis=1) / np.max(np.abs(ref), axis=1)
        assert np.max(err) <= 1e-12, np.max(err)
    assert viol <= tol


def test_ideal_accelerations_do_not_depend_on_the_baumgarte_parameters():
    # The kinematic analysis takes γ out of the right-hand side's stabilised
    # c = γ − 2α Φ̇ − β² Φ and adds the Baumgarte terms back. With β = 1e6 (β² = 1e12) a
    # residual |Φ| of 1e-16 m left by Newton would move q̈ by 1e-4 m/s² (1e-6 of the
    # nine-bar's accelerations) if they were not; added back, what is left is their round-off,
    # eps × |β² Φ| ≈ 1e-20 m/s², and 2α Φ̇ ≈ 2e6 × 1e-16 m/s. The positions and velocities
    # see α and β only through q̈ in the next instant's Taylor predictor (q̈ dt²/2, dt = 1.5 ms
    # at 1°), so they stay within a few ulp: 1e-14 relative. (The closed form, which
    # kinematic_analysis uses for the nine-bar, reads only Φ of constraint_terms.)
    from mechrel.scene import with_overrides
    from mechrel.simulation import output_times

    base = load_scene("nine-bar")
    runs = []
    for ab in (None, 1e6):
        scene = base if ab is None else with_overrides(
            base, {"solver.baumgarte_alpha": ab, "solver.baumgarte_beta": ab})
        compiled = compile_scene(scene)
        tol = scene.solver.assembly_tolerance
        q0, _ = assemble(compiled.ideal, compiled.q_guess, 0.0, tol=tol)
        runs.append(_newton_kinematics(compiled.ideal, q0, output_times(scene, compiled),
                                       tol))
    (Q1, V1, A1, _), (Q2, V2, A2, _) = runs
    for got, ref, bound in ((Q2, Q1, 1e-14), (V2, V1, 1e-14), (A2, A1, 1e-12)):
        err = np.max(np.abs(got - ref), axis=1) / np.max(np.abs(ref), axis=1)
        assert np.max(err) <= bound, (np.max(err), bound)


def test_redundant_driver_makes_the_jacobian_singular():
    # The crank's driver moved to the slider: the slider's angle is held twice (translational
    # joint and driver, two identical Jacobian rows) and the crank is free, so Φ_q is square
    # but exactly singular. The compiled LU must report it like np.linalg.solve does, and
    # kinematic_analysis must turn that into an AssemblyError.
    from mechrel.mechanics.kinematics import kinematic_analysis
    from mechrel.simulation import output_times

    base = load_scene("slider-crank")
    compiled_base = compile_scene(base)
    q0, _ = assemble(compiled_base.ideal, compiled_base.q_guess, 0.0)
    times = output_times(base, compiled_base)
    scene = load_scene("slider-crank", overrides={"drivers.crank.body": "slider"})
    compiled = compile_scene(scene)
    assert compiled.ideal.n_constraints == q0.size
    with pytest.raises(AssemblyError, match="singular constraint Jacobian") as err:
        kinematic_analysis(compiled.ideal, q0, times)
    assert isinstance(err.value.__cause__, np.linalg.LinAlgError)
    with pytest.raises(AssemblyError, match="singular"):
        simulate(scene)


def _sparse_matrix(rng, n, per_row):
    A = np.zeros((n, n))
    for i in range(n):
        cols = rng.choice(n, size=per_row, replace=False)
        A[i, cols] = rng.uniform(-2.0, 2.0, per_row)
    A[np.arange(n), rng.permutation(n)] += 1.0  # a transversal: structurally non-singular
    return A


def test_sparse_lu_refactorisation_against_numpy():
    from mechrel.mechanics.kinematics import (_lu_factor, _lu_refactor, _lu_solve,
                                              _lu_workspace)

    rng = np.random.default_rng(7)
    n = 14
    A = _sparse_matrix(rng, n, 3)
    f = _lu_workspace(n)
    assert not _lu_refactor(A.copy(), f)  # no plan yet
    _lu_factor(A.copy(), f)
    b = rng.standard_normal(n)
    x = b.copy()
    _lu_solve(f, x)
    ref = np.linalg.solve(A, b)
    # normwise relative error of a backward-stable solve: O(cond(A) × eps)
    tol = 100 * np.linalg.cond(A) * np.finfo(float).eps
    assert np.max(np.abs(x - ref)) <= tol * np.max(np.abs(ref))

    # the same pattern with slightly different values: the plan is replayed
    B = A * (1.0 + 1e-6 * rng.standard_normal((n, n)))
    assert _lu_refactor(B.copy(), f)
    x = b.copy()
    _lu_solve(f, x)
    ref = np.linalg.solve(B, b)
    assert np.max(np.abs(x - ref)) <= tol * np.max(np.abs(ref))

    # values that change the pivot order: the replay refuses, a new plan is made
    C = A.copy()
    k = int(np.argmax(np.abs(A[:, 0])))
    others = np.flatnonzero(A[:, 0])
    others = others[others != k]
    assert others.size  # column 0 has another entry that can become the pivot
    C[others[0], 0] = 10.0 * np.max(np.abs(A[:, 0]))
    assert not _lu_refactor(C.copy(), f)
    _lu_factor(C.copy(), f)
    x = b.copy()
    _lu_solve(f, x)
    ref = np.linalg.solve(C, b)
    tol = 100 * np.linalg.cond(C) * np.finfo(float).eps
    assert np.max(np.abs(x - ref)) <= tol * np.max(np.abs(ref))

    # a non-zero outside the planned pattern: the replay refuses
    D = C.copy()
    i, j = np.argwhere(D == 0.0)[0]
    D[i, j] = 0.5
    assert not _lu_refactor(D.copy(), f)

    # an exactly singular matrix (a zero column: a zero pivot whatever the rounding) raises
    # LinAlgError like np.linalg.solve, from both the planning and the replaying factorisation
    S = A.copy()
    S[:, 3] = 0.0
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.solve(S, b)
    with pytest.raises(np.linalg.LinAlgError):
        _lu_factor(S.copy(), _lu_workspace(n))
    _lu_factor(A.copy(), f)
    with pytest.raises(np.linalg.LinAlgError):
        _lu_refactor(S.copy(), f)


@pytest.mark.parametrize("name", ["nine-bar-lubricated", "slider-crank-dry"])
def test_violations_at_is_the_numpy_formula_bitwise(name):
    # the violation a run reports (max |Φ|, max |Φ_q q̇ + Φ_t|) in one compiled call: the same
    # bits as the NumPy formulas it replaced (J·q̇ by BLAS in both), on every output instant of
    # a dynamic run; a row with a non-finite entry is skipped; coordinates alone give
    # the position violation and 0 for the velocity
    from mechrel.mechanics.constraints import constraints, violations_at

    scene = load_scene(name)
    c = compile_scene(scene)
    r = simulate(scene)
    n = c.q_guess.size
    Y = np.concatenate([r.q, r.v], axis=1)
    rows = np.arange(0, Y.shape[0], 5)
    pos = vel = 0.0
    for k in rows:
        phi, phit, J = constraints(Y[k, :n], float(r.time[k]), c.dynamic)
        p = float(np.max(np.abs(phi), initial=0.0))
        v = float(np.max(np.abs(J @ Y[k, n:2 * n] + phit), initial=0.0))
        assert violations_at(Y, r.time, np.array([k]), c.dynamic) == (p, v)
        pos, vel = max(pos, p), max(vel, v)
    assert violations_at(Y, r.time, rows, c.dynamic) == (pos, vel)
    assert violations_at(np.ascontiguousarray(Y[:, :n]), r.time, rows, c.dynamic) == (pos, 0.0)
    bad = Y.copy()
    bad[rows[1:], -1] = np.nan  # only the first row left finite
    assert violations_at(bad, r.time, rows, c.dynamic) == violations_at(Y, r.time, rows[:1],
                                                                         c.dynamic)
    assert violations_at(Y, r.time, np.zeros(0, dtype=np.int64), c.dynamic) == (0.0, 0.0)
