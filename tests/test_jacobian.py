"""The fast part of the Jacobian (``mechrel.mechanics.jacobian.clearance_jacobian``) that the
compiled Radau refreshes between full finite-difference Jacobians.

The force laws are linear in one parameter at a fixed state: the film force in the viscosity
μ (Pinkus–Sternlicht, eq. 13), the dry contact force (and the friction proportional to it) in
the stiffness K (eq. 5). At a fixed state, ``J(2p) − J(p)`` is then exactly the part of the
Jacobian that is proportional to the clearance forces: the force laws' derivatives through
the joint kinematics, the turning lever arms, and the constraint geometry's share through λ
and q̈ (which carry the forces). ``clearance_jacobian`` claims to compute all of that, so
``JS(2p) − JS(p)`` must equal ``J(2p) − J(p)``, with J by central differences. Expected
agreement: the forward differences of the force law inside ``clearance_jacobian`` have a
relative error of about √u · c / (c (1 − ε)) ≈ 1.5e-8 / 0.02 ≈ 7.5e-7 at ε = 0.98 (the film
varies on the scale c (1 − ε)); the central differences of the test, with h = 1e-8 |y|
(1e-9 m), about (h / (c (1 − ε)))² ≈ 1e-8, plus round-off u |f| / h ≪ that. Measured:
7.0e-7 (nine-bar, lubricated, ε = 0.980), 4.8e-7 (slider-crank, lubricated, ε = 0.971),
4.8e-8 (slider-crank, dry, 53 µm into contact); the bound 1e-5 is ten times the estimate.
Leaving out the lever-arm or the constraint-geometry term fails it (checked by mutation).
"""

import numpy as np
import pytest

from mechrel.forces.params import P_K, P_MU
from mechrel.mechanics.dynamics import make_workspace, rhs
from mechrel.mechanics.jacobian import clearance_jacobian
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import simulate


def central_jacobian(t, y, hist, sys, n):
    J = np.zeros((y.size, y.size))
    for j in range(2 * n):
        h = 1e-8 * max(abs(y[j]), 1e-3)
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        J[:, j] = (rhs(t, yp, hist, sys) - rhs(t, ym, hist, sys)) / (2 * h)
    return J


def state_at_peak_eccentricity(name):
    res = simulate(load_scene(name))
    eps = next(iter(res.orbits.values()))["eps"]
    k = int(np.argmax(eps))
    y = np.concatenate([res.q[k], res.v[k], [0.0, 0.0]])
    return res.time[k], y, res.q.shape[1], eps[k]


def force_linear_part(name, column, hist):
    """(J(2p) − J(p), JS(2p) − JS(p)) in the rows n… and columns < 2n."""
    t, y, n, eps = state_at_peak_eccentricity(name)
    base = compile_scene(load_scene(name)).dynamic
    p1 = base.cl_p.copy()
    p2 = base.cl_p.copy()
    p2[:, column] *= 2.0
    s1, s2 = base._replace(cl_p=p1), base._replace(cl_p=p2)
    Jd = (central_jacobian(t, y, hist, s2, n) - central_jacobian(t, y, hist, s1, n))[n:, :2 * n]
    JS = []
    for s_ in (s2, s1):
        ws = make_workspace(s_)
        J = np.zeros((y.size, y.size))
        f = np.empty(y.size)
        clearance_jacobian(t, y, hist, s_, ws, f, J)
        assert np.array_equal(f, rhs(t, y, hist, s_))  # f(t, y) comes back too
        JS.append(J[n:, :2 * n])
    return Jd, JS[0] - JS[1], n, eps


@pytest.mark.parametrize("name, column, n_hist, eps_min", [
    ("nine-bar-lubricated", P_MU, 0, 0.97),
    ("slider-crank-lubricated", P_MU, 0, 0.95),
    ("slider-crank-dry", P_K, 1, 1.0),  # in contact: ε > 1
])
def test_clearance_jacobian_is_the_force_law_part(name, column, n_hist, eps_min):
    hist = np.full(n_hist, 0.5)  # a recorded impact speed (m/s) for the contact's damping
    Jd, JS, n, eps = force_linear_part(name, column, hist)
    assert eps > eps_min  # a thin film / a contact: the stiff regime the update is for
    rel = np.linalg.norm(Jd - JS) / np.linalg.norm(JS)
    assert rel < 1e-5
    # both work rows too (driver power through λ, clearance power)
    rel_w = np.linalg.norm(Jd[n:] - JS[n:]) / np.linalg.norm(JS[n:])
    assert rel_w < 1e-5
