"""A straightforward NumPy/SciPy implementation of mechrel's equations: yardstick and
independent reference.

What it is
----------
The same model as mechrel (docs/mechanics.md, docs/reference.md and the force laws
documented in ``mechrel.forces``), written again the way a careful engineer would write it
first: a plain NumPy right-hand side (Python loops over the joints, dense Φ, Φ_q, γ, the
augmented system of the corrected eq. 24 solved with ``numpy.linalg.solve``) integrated with
``scipy.integrate.solve_ivp``. It does NOT call any compiled mechrel function: the only things
taken from mechrel are the scene loader and :func:`mechrel.mechanics.system.compile_scene`, i.e.
the arrays that say which body is which, where the joint points are and the packed joint
parameters, so that the geometry is identical. Everything else (constraints, Jacobian, γ,
Baumgarte, the dry / lubricated / transition force laws, the contact stiffness, assembly,
the ideal kinematic analysis, the slider outputs) is re-derived here from the equations.

Two uses:

* ``benchmarks/bench_lubricated_ninebar.py`` times it against mechrel (targets 1 and 2);
* ``tests/test_baseline_agreement.py`` checks that :meth:`Baseline.rhs` equals mechrel's
  compiled ``mechrel.mechanics.dynamics.rhs`` at random states of every scene type.

Force laws (as implemented here, written from docs/reference.md and the paper's eqs. 4–19)
---------------------------------------------------------------------------------------
e = r_S − r_B (journal centre − bearing centre), r = |e|, n = e/r, t = n rotated +90°,
δ = r − c, δ̇ = ė·n, γ̇ = (ė·t)/r, ε = r/c, ε̇ = δ̇/c, w = ω_S + ω_B − 2γ̇.

* Dry (LN + friction): F_N = max(0, K δ^n [1 + 3(1 − c_e²)/4 · δ̇/δ̇⁻]) for δ > 0, with
  δ̇⁻ = max(hist, floor) when an impact speed is recorded, else max(δ̇, floor);
  K = 4/(3(σ_B + σ_S)) sqrt(R_B R_S/(R_B − R_S)) (conformal; paper's sum on request);
  v_T = ė·t + ω_S R_S − ω_B R_B, c_d of eq. 8, F_T = −c_f c_d F_N sign(v_T);
  F (on the journal) = −F_N n + F_T t, M_S = R_S F_T, M_B = −R_B F_T.
* Lubricated (Pinkus–Sternlicht, Gumbel): the paper's branch form, eqs. 11–12 for ε̇ ≥ 0 and
  the sign-corrected eqs. 13–14 for ε̇ < 0, with k of eq. 15 never divided by ε̇ (docs/reference.md):
  κ = ε̇ k = sign(ε̇) sqrt((1 − ε²)(w²/4 + ε̇²/ε²)), 1.5/(k + 1.5) = 1.5 ε̇/(κ + 1.5 ε̇);
  the small-eccentricity factor (min(ε, ε0)/ε0)^λ (the continuous form of eqs. 16–17 that
  mechrel documents); ε clamped at ε_max in the transition model and only at the numerical
  guard 1 − 1e-9 in the lubricated model, whose film divergence at ε → 1 is the barrier that
  keeps the journal inside (w and ε̇ are not clamped); F = F_r n + F_t t (eq. 18);
  no film moment. At r = 0 the force is 0 (its limit for λ > 0).
* Transition (eq. 19): s = clip(δ/e1, 0, 1), F = s F_dry + (1 − s) F_lub (moments s M).

Run ``python benchmarks/baseline_numpy.py --help`` for a command-line simulation.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from mechrel.forces.params import PARAM_NAMES
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene

# Driver-law codes and parameter columns, as documented on mechrel.mechanics.system (data layout,
# not code: the laws themselves are written below from docs/scenes.md).
_LAWS = ("constant-speed", "constant-acceleration", "harmonic", "smooth-start")
_DCOL = ("angle0", "speed", "acceleration", "amplitude", "frequency", "phase", "ramp_time")
_MODELS = ("dry", "lubricated", "transition")


def driver(law: str, par: dict, t: float):
    """θ(t), θ̇(t), θ̈(t) of a driver (docs/scenes.md)."""
    th0, w = par["angle0"], par["speed"]
    if law == "constant-speed":
        return th0 + w * t, w, 0.0
    if law == "constant-acceleration":
        a = par["acceleration"]
        return th0 + w * t + 0.5 * a * t * t, w + a * t, a
    if law == "harmonic":
        A, Om, ph = par["amplitude"], par["frequency"], par["phase"]
        return (th0 + A * math.sin(Om * t + ph), A * Om * math.cos(Om * t + ph),
                -A * Om * Om * math.sin(Om * t + ph))
    # smooth-start: speed w·s(τ), s = 10τ³ − 15τ⁴ + 6τ⁵ (quintic smoothstep), τ = t/T ≤ 1.
    T = par["ramp_time"]
    if t >= T:
        return th0 + w * (t - T / 2.0), w, 0.0
    tau = t / T
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    ds = 30 * tau**2 - 60 * tau**3 + 30 * tau**4
    S = 2.5 * tau**4 - 3 * tau**5 + tau**6  # ∫_0^τ s
    return th0 + w * T * S, w * s, w * ds / T


def contact_stiffness(R_B, R_S, E_B, nu_B, E_S, nu_S, conformal=True):
    """Eq. (6): K = 4/(3(σ_B + σ_S)) sqrt(R*), R* = R_B R_S/(R_B ∓ R_S) (N/m^1.5)."""
    sig = (1 - nu_B**2) / E_B + (1 - nu_S**2) / E_S
    rstar = R_B * R_S / ((R_B - R_S) if conformal else (R_B + R_S))
    return 4.0 / (3.0 * sig) * math.sqrt(rstar)


def film(eps, eps_dot, w, mu, R_S, L, c, lam, eps0):
    """Pinkus–Sternlicht long-bearing forces (F_r, F_t) on the journal, eqs. 11–17 corrected."""
    C = 6.0 * mu * R_S**3 * L / c**2
    one = (1.0 - eps) * (1.0 + eps)  # 1 − ε², without cancellation near ε = 1
    sgn = 1.0 if eps_dot >= 0.0 else -1.0
    kappa = sgn * math.sqrt(one * (w * w / 4.0 + (eps_dot / eps) ** 2))  # ε̇ k
    den = kappa + 1.5 * eps_dot  # ε̇ (k + 1.5)
    q = 1.5 * eps_dot / den if den != 0.0 else 0.0  # 1.5/(k + 1.5); → 0 as ε̇ → 0
    if eps_dot >= 0.0:  # approach: eqs. (11), (12)
        Fr = -C / one**1.5 * (4.0 * kappa * eps**2 / (2.0 + eps**2) + math.pi * eps_dot * (1.0 + q))
        Ft = C * math.pi * eps * w / ((2.0 + eps**2) * math.sqrt(one)) * (1.0 + q)
    else:  # separation: eq. (13) with the corrected sign, eq. (14)
        Fr = C / one**1.5 * (4.0 * kappa * eps**2 / (2.0 + eps**2) - math.pi * eps_dot * (1.0 - q))
        Ft = C * math.pi * eps * w / ((2.0 + eps**2) * math.sqrt(one)) * (1.0 - q)
    f = (min(eps, eps0) / eps0) ** lam
    return f * Fr, f * Ft


@dataclass
class ClearanceJoint:
    name: str
    model: str
    b: int  # bearing body (−1 ground)
    j: int  # journal body
    sb: np.ndarray
    sj: np.ndarray
    p: dict  # parameters by name
    hist: int  # index into hist, −1 if none


@dataclass
class BaselineStats:
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    nsteps: int = 0
    wall: float = 0.0
    extra: dict = field(default_factory=dict)


class Baseline:
    """The equations of motion of a scene in plain NumPy.

    Parameters
    ----------
    scene : str or Scene
        Embedded scene name, path, or :class:`mechrel.scene.Scene`.
    overrides : mapping, optional
        Scene overrides (e.g. ``{"joints.C.model": "transition"}``).
    solve : {"augmented", "schur"}
        Solve the (n + m) augmented system of eq. 24 directly (default, the textbook form) or
        through the m × m Schur complement.
    """

    def __init__(self, scene, overrides=None, solve="augmented"):
        if isinstance(scene, str) or overrides:
            scene = load_scene(scene, overrides=overrides or {})
        self.scene = scene
        cs = compile_scene(scene)
        self.cs = cs
        self.solve_mode = solve
        d = cs.dynamic
        self.n = d.mass.shape[0]
        self.mass = d.mass.copy()
        self.g = d.gravity.copy()
        self.alpha, self.beta = (float(x) for x in d.baumgarte)
        self.dyn = self._constraint_set(d)
        self.ideal_set = self._constraint_set(cs.ideal)
        self.assembly_set = self._constraint_set(cs.assembly)
        self.joints = []
        for k, name in enumerate(cs.clearance_names):
            p = {nm: float(v) for nm, v in zip(PARAM_NAMES, d.cl_p[k])}
            jt = scene.joints[name]
            # The contact stiffness is recomputed from the scene's material data (eq. 6).
            con = jt.contact
            if con is not None:
                R_B = jt.bearing_radius
                p["stiffness"] = contact_stiffness(R_B, R_B - jt.clearance,
                                                   con.youngs_modulus_bearing, con.poisson_bearing,
                                                   con.youngs_modulus_journal, con.poisson_journal,
                                                   con.stiffness == "conformal")
            self.joints.append(ClearanceJoint(name, jt.model, int(d.cl_b[k]), int(d.cl_j[k]),
                                              d.cl_sb[k].copy(), d.cl_sj[k].copy(), p,
                                              int(d.cl_hist[k])))
        self.n_hist = sum(1 for j in self.joints if j.hist >= 0)
        self.mass_matrix = np.diag(self.mass)
        self.n_rhs = 0  # right-hand-side calls (SciPy's nfev omits its finite-difference Jacobians)

    # ------------------------------------------------------------------ constraints
    @staticmethod
    def _constraint_set(s):
        drivers = []
        for k in range(s.dr_i.shape[0]):
            drivers.append((int(s.dr_i[k]), _LAWS[int(s.dr_law[k])],
                            dict(zip(_DCOL, map(float, s.dr_par[k])))))
        return dict(
            rev=[(int(s.rev_i[k]), int(s.rev_j[k]), s.rev_si[k].copy(), s.rev_sj[k].copy(),
                  s.rev_off[k].copy(), s.rev_offdot[k].copy()) for k in range(s.rev_i.shape[0])],
            tr=[(int(s.tr_i[k]), s.tr_si[k].copy(), s.tr_p0[k].copy(), s.tr_n[k].copy(),
                 float(s.tr_angle[k])) for k in range(s.tr_i.shape[0])],
            fa=[(int(s.fa_i[k]), float(s.fa_angle[k])) for k in range(s.fa_i.shape[0])],
            ln=[(int(s.ln_i[k]), s.ln_si[k].copy(), int(s.ln_j[k]), s.ln_sj[k].copy(),
                 s.ln_n[k].copy()) for k in range(s.ln_i.shape[0])],
            ra=[(int(s.ra_i[k]), int(s.ra_j[k]), float(s.ra_angle[k]))
                for k in range(s.ra_i.shape[0])],
            dr=drivers,
        )

    @staticmethod
    def _rows(cset):
        return (2 * len(cset["rev"]) + 2 * len(cset["tr"]) + len(cset["fa"]) + len(cset["ln"])
                + len(cset["ra"]) + len(cset["dr"]))

    def _on_body(self, q, b, s):
        """(A s, B s) of body b, or (s, 0) for the ground (s then global)."""
        if b < 0:
            return np.asarray(s, dtype=float), np.zeros(2)
        ax, ay, bx, by = self._rot(q[3 * b + 2], s[0], s[1])
        return np.array([ax, ay]), np.array([bx, by])

    @staticmethod
    def _rot(th, sx, sy):
        """A(θ) s and B(θ) s = dA/dθ s as scalars (A = [[c, −s], [s, c]])."""
        c, s = math.cos(th), math.sin(th)
        return c * sx - s * sy, s * sx + c * sy, -s * sx - c * sy, c * sx - s * sy

    def constraints(self, q, t, cset=None):
        """Φ, Φ_t and Φ_q (Nikravesh's absolute-coordinate constraints)."""
        cset = self.dyn if cset is None else cset
        m = self._rows(cset)
        phi = np.zeros(m)
        phit = np.zeros(m)
        J = np.zeros((m, self.n))
        r = 0
        for i, j, si, sj, off, offdot in cset["rev"]:
            # r_i + A_i s_i − (r_j + A_j s_j) − off = 0 (s_j is a global point when j is ground)
            ax, ay, bx, by = self._rot(q[3 * i + 2], si[0], si[1])
            px, py = q[3 * i] + ax - off[0], q[3 * i + 1] + ay - off[1]
            J[r, 3 * i] = 1.0
            J[r + 1, 3 * i + 1] = 1.0
            J[r, 3 * i + 2] = bx
            J[r + 1, 3 * i + 2] = by
            if j >= 0:
                ax, ay, bx, by = self._rot(q[3 * j + 2], sj[0], sj[1])
                px -= q[3 * j] + ax
                py -= q[3 * j + 1] + ay
                J[r, 3 * j] = -1.0
                J[r + 1, 3 * j + 1] = -1.0
                J[r, 3 * j + 2] = -bx
                J[r + 1, 3 * j + 2] = -by
            else:
                px -= sj[0]
                py -= sj[1]
            phi[r], phi[r + 1] = px, py
            phit[r], phit[r + 1] = -offdot[0], -offdot[1]
            r += 2
        for i, si, p0, nrm, ang in cset["tr"]:
            ax, ay, bx, by = self._rot(q[3 * i + 2], si[0], si[1])
            phi[r] = nrm[0] * (q[3 * i] + ax - p0[0]) + nrm[1] * (q[3 * i + 1] + ay - p0[1])
            J[r, 3 * i] = nrm[0]
            J[r, 3 * i + 1] = nrm[1]
            J[r, 3 * i + 2] = nrm[0] * bx + nrm[1] * by
            phi[r + 1] = q[3 * i + 2] - ang
            J[r + 1, 3 * i + 2] = 1.0
            r += 2
        for i, ang in cset["fa"]:
            phi[r] = q[3 * i + 2] - ang
            J[r, 3 * i + 2] = 1.0
            r += 1
        for i, si, j, sj, nbar in cset["ln"]:
            # P = r_i + A_i s_i on the line through Q = r_j + A_j s_j, normal n = A_j n̄:
            # Φ = n·(P − Q); ∂Φ/∂r_i = n, ∂Φ/∂θ_i = n·B_i s_i, ∂Φ/∂r_j = −n,
            # ∂Φ/∂θ_j = (B_j n̄)·(P − Q) − n·B_j s_j (docs/mechanics.md)
            zi = np.zeros(2) if i < 0 else q[3 * i:3 * i + 2]
            zj = np.zeros(2) if j < 0 else q[3 * j:3 * j + 2]
            a_i, b_i = self._on_body(q, i, si)
            a_j, b_j = self._on_body(q, j, sj)
            n, dn = self._on_body(q, j, nbar) if j >= 0 else (nbar, np.zeros(2))
            P, Q = zi + a_i, zj + a_j
            phi[r] = n @ (P - Q)
            if i >= 0:
                J[r, 3 * i:3 * i + 2] = n
                J[r, 3 * i + 2] = n @ b_i
            if j >= 0:
                J[r, 3 * j:3 * j + 2] = -n
                J[r, 3 * j + 2] = dn @ (P - Q) - n @ b_j
            r += 1
        for i, j, ang in cset["ra"]:
            phi[r] = (q[3 * i + 2] if i >= 0 else 0.0) - (q[3 * j + 2] if j >= 0 else 0.0) - ang
            if i >= 0:
                J[r, 3 * i + 2] = 1.0
            if j >= 0:
                J[r, 3 * j + 2] = -1.0
            r += 1
        for i, law, par in cset["dr"]:
            th, w, _ = driver(law, par, t)
            phi[r] = q[3 * i + 2] - th
            phit[r] = -w
            J[r, 3 * i + 2] = 1.0
            r += 1
        return phi, phit, J

    def gamma(self, q, v, t, cset=None):
        """γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt."""
        cset = self.dyn if cset is None else cset
        m = self._rows(cset)
        g = np.zeros(m)
        r = 0
        for i, j, si, sj, _, _ in cset["rev"]:
            ax, ay, _, _ = self._rot(q[3 * i + 2], si[0], si[1])
            w2 = v[3 * i + 2] ** 2
            gx, gy = ax * w2, ay * w2
            if j >= 0:
                ax, ay, _, _ = self._rot(q[3 * j + 2], sj[0], sj[1])
                w2 = v[3 * j + 2] ** 2
                gx -= ax * w2
                gy -= ay * w2
            g[r], g[r + 1] = gx, gy
            r += 2
        for i, si, _, nrm, _ in cset["tr"]:
            ax, ay, _, _ = self._rot(q[3 * i + 2], si[0], si[1])
            g[r] = (nrm[0] * ax + nrm[1] * ay) * v[3 * i + 2] ** 2
            r += 2
        r += len(cset["fa"])
        for i, si, j, sj, nbar in cset["ln"]:
            # Φ̈ = n̈·D + 2 ṅ·Ḋ + n·D̈ with D = P − Q = r_i + A_i s_i − r_j − A_j s_j,
            # ṅ = ω_j B_j n̄, n̈ = α_j B_j n̄ − ω_j² n: its part without accelerations is
            # −n·A_i s_i ω_i² + n·A_j s_j ω_j² + 2 ω_j (B_j n̄)·Ḋ − ω_j² n·D; γ is its negative
            zi = np.zeros(2) if i < 0 else q[3 * i:3 * i + 2]
            zj = np.zeros(2) if j < 0 else q[3 * j:3 * j + 2]
            vi = np.zeros(2) if i < 0 else v[3 * i:3 * i + 2]
            vj = np.zeros(2) if j < 0 else v[3 * j:3 * j + 2]
            wi = 0.0 if i < 0 else v[3 * i + 2]
            wj = 0.0 if j < 0 else v[3 * j + 2]
            a_i, b_i = self._on_body(q, i, si)
            a_j, b_j = self._on_body(q, j, sj)
            n, dn = self._on_body(q, j, nbar) if j >= 0 else (nbar, np.zeros(2))
            d = zi + a_i - zj - a_j
            dd = vi + b_i * wi - vj - b_j * wj
            quad = (-n @ a_i * wi ** 2 + n @ a_j * wj ** 2 + 2 * wj * (dn @ dd)
                    - wj ** 2 * (n @ d))
            g[r] = -quad
            r += 1
        r += len(cset["ra"])
        for _, law, par in cset["dr"]:
            g[r] = driver(law, par, t)[2]
            r += 1
        return g

    # ------------------------------------------------------------------ clearance forces
    def _point(self, q, v, b, s):
        """Global position and velocity of body-frame point s of body b (ground: s itself)."""
        if b < 0:
            return s[0], s[1], 0.0, 0.0
        ax, ay, bx, by = self._rot(q[3 * b + 2], s[0], s[1])
        w = v[3 * b + 2]
        return q[3 * b] + ax, q[3 * b + 1] + ay, v[3 * b] + bx * w, v[3 * b + 1] + by * w

    def clearance_force(self, jt: ClearanceJoint, ex, ey, vx, vy, wB, wS, impact):
        """(F_x, F_y on the journal, M_S, M_B) of one clearance joint."""
        p = jt.p
        c = p["clearance"]
        r = math.hypot(ex, ey)
        if r == 0.0:
            return 0.0, 0.0, 0.0, 0.0  # centred journal: no contact, film force → 0
        nx, ny = ex / r, ey / r
        tx, ty = -ny, nx
        dd = vx * nx + vy * ny  # δ̇
        vt = vx * tx + vy * ty  # r γ̇
        delta = r - c
        if jt.model == "dry":
            s_dry = 1.0 if delta > 0 else 0.0
        elif jt.model == "lubricated":
            s_dry = 0.0
        else:
            s_dry = min(1.0, max(0.0, delta / p["e1"]))
        Fx = Fy = MS = MB = 0.0
        if s_dry > 0.0:
            floor = p["impact_speed_floor"]
            v_imp = max(impact, floor) if impact > 0 else max(dd, floor)
            ce = p["restitution"]
            FN = p["stiffness"] * delta ** p["exponent"] * (1 + 3 * (1 - ce**2) / 4 * dd / v_imp)
            FN = max(FN, 0.0)
            FT = 0.0
            if p["friction_coefficient"] > 0:
                vT = vt + wS * p["journal_radius"] - wB * p["bearing_radius"]
                v0, v1 = p["v0"], p["v1"]
                cd = 0.0 if abs(vT) < v0 else (1.0 if abs(vT) > v1 else (abs(vT) - v0) / (v1 - v0))
                FT = -p["friction_coefficient"] * cd * FN * (1.0 if vT > 0 else -1.0)
            Fx += s_dry * (-FN * nx + FT * tx)
            Fy += s_dry * (-FN * ny + FT * ty)
            MS += s_dry * p["journal_radius"] * FT
            MB -= s_dry * p["bearing_radius"] * FT
        if jt.model != "dry" and s_dry < 1.0:
            eps = min(r / c, p["eps_max"] if jt.model == "transition" else 1.0 - 1e-9)
            w = wS + wB - 2.0 * vt / r
            Fr, Ft = film(eps, dd / c, w, p["viscosity"], p["journal_radius"], p["length"], c,
                          p["lam"], p["eps0"])
            Fx += (1.0 - s_dry) * (Fr * nx + Ft * tx)
            Fy += (1.0 - s_dry) * (Fr * ny + Ft * ty)
        return Fx, Fy, MS, MB

    def applied(self, t, q, v, hist):
        """Generalised forces Q (gravity + clearance joints) and the clearance power."""
        Q = np.zeros(self.n)
        Q[0::3] = self.mass[0::3] * self.g[0]
        Q[1::3] = self.mass[0::3] * self.g[1]
        power = 0.0
        for jt in self.joints:
            bx, by, bvx, bvy = self._point(q, v, jt.b, jt.sb)
            sx, sy, svx, svy = self._point(q, v, jt.j, jt.sj)
            wB = v[3 * jt.b + 2] if jt.b >= 0 else 0.0
            wS = v[3 * jt.j + 2] if jt.j >= 0 else 0.0
            impact = hist[jt.hist] if jt.hist >= 0 else 0.0
            ex, ey, vx, vy = sx - bx, sy - by, svx - bvx, svy - bvy
            Fx, Fy, MS, MB = self.clearance_force(jt, ex, ey, vx, vy, wB, wS, impact)
            power += Fx * vx + Fy * vy + MS * wS + MB * wB
            if jt.j >= 0:  # journal body: F at the journal centre, plus M_S
                dx, dy = sx - q[3 * jt.j], sy - q[3 * jt.j + 1]
                Q[3 * jt.j] += Fx
                Q[3 * jt.j + 1] += Fy
                Q[3 * jt.j + 2] += dx * Fy - dy * Fx + MS
            if jt.b >= 0:  # bearing body: −F at the bearing centre, plus M_B
                dx, dy = bx - q[3 * jt.b], by - q[3 * jt.b + 1]
                Q[3 * jt.b] -= Fx
                Q[3 * jt.b + 1] -= Fy
                Q[3 * jt.b + 2] += -(dx * Fy - dy * Fx) + MB
        return Q, power

    # ------------------------------------------------------------------ dynamics
    def accelerations(self, t, y, hist=None):
        """q̈, λ, driver power, clearance power."""
        n = self.n
        hist = np.zeros(self.n_hist) if hist is None else hist
        q, v = y[:n], y[n:2 * n]
        Q, pcl = self.applied(t, q, v, hist)
        phi, phit, J = self.constraints(q, t)
        m = phi.shape[0]
        rhs_c = self.gamma(q, v, t) - 2 * self.alpha * (J @ v + phit) - self.beta**2 * phi
        if m == 0:
            a, lam = Q / self.mass, np.zeros(0)
        elif self.solve_mode == "augmented":
            K = np.zeros((n + m, n + m))
            K[:n, :n] = self.mass_matrix
            K[:n, n:] = J.T
            K[n:, :n] = J
            sol = np.linalg.solve(K, np.concatenate([Q, rhs_c]))
            a, lam = sol[:n], sol[n:]
        else:
            JM = J / self.mass
            lam = np.linalg.solve(JM @ J.T, JM @ Q - rhs_c)
            a = (Q - J.T @ lam) / self.mass
        nd = len(self.dyn["dr"])
        pin = -sum(lam[m - nd + k] * v[3 * i + 2] for k, (i, _, _) in enumerate(self.dyn["dr"]))
        return a, lam, pin, pcl

    def rhs(self, t, y, hist=None):
        """dy/dt for y = [q, q̇, W_in, W_cl] (mechrel's state layout)."""
        self.n_rhs += 1
        a, _, pin, pcl = self.accelerations(t, y, hist)
        return np.concatenate([y[self.n:2 * self.n], a, [pin, pcl]])

    # ------------------------------------------------------------------ kinematics
    def assemble(self, q_guess, t=0.0, cset=None, tol=1e-12, max_iter=50):
        """Newton with the minimum-norm correction; minimum-norm velocities."""
        q = np.array(q_guess, dtype=float)
        for _ in range(max_iter):
            phi, phit, J = self.constraints(q, t, cset)
            if np.max(np.abs(phi)) <= tol:
                break
            q -= J.T @ np.linalg.solve(J @ J.T, phi)
        phi, phit, J = self.constraints(q, t, cset)
        if np.max(np.abs(phi)) > tol:
            raise RuntimeError(f"assembly failed: max |Φ| = {np.max(np.abs(phi)):.3g}")
        v = J.T @ np.linalg.solve(J @ J.T, -phit)
        return q, v

    def initial_state(self):
        q0, _ = self.assemble(self.cs.q_guess, 0.0, self.ideal_set)
        qa, va = self.assemble(q0, 0.0, self.assembly_set)
        return np.concatenate([qa, va, [0.0, 0.0]]), q0

    def ideal_kinematics(self, q0, times):
        """Fully driven ideal counterpart: q by Newton, q̇ = −Φ_q⁻¹Φ_t, q̈ = Φ_q⁻¹γ."""
        Qs, Vs, As = [], [], []
        q = q0.copy()
        for t in times:
            q, _ = self.assemble(q, t, self.ideal_set)
            _, phit, J = self.constraints(q, t, self.ideal_set)
            v = np.linalg.solve(J, -phit)
            a = np.linalg.solve(J, self.gamma(q, v, t, self.ideal_set))
            Qs.append(q.copy()); Vs.append(v); As.append(a)
        return np.array(Qs), np.array(Vs), np.array(As)

    def output(self, Q, V, A, k=0):
        """Displacement, velocity, acceleration of output point k along its axis."""
        b = int(self.cs.out_body[k])
        s = self.cs.out_s[k]
        u = self.cs.out_axis[k]
        th, w, al = Q[:, 3 * b + 2], V[:, 3 * b + 2], A[:, 3 * b + 2]
        c, sn = np.cos(th), np.sin(th)
        ax, ay = c * s[0] - sn * s[1], sn * s[0] + c * s[1]
        pos = np.stack([Q[:, 3 * b] + ax, Q[:, 3 * b + 1] + ay], 1)
        vel = np.stack([V[:, 3 * b] - ay * w, V[:, 3 * b + 1] + ax * w], 1)
        acc = np.stack([A[:, 3 * b] - ay * al - ax * w * w,
                        A[:, 3 * b + 1] + ax * al - ay * w * w], 1)
        return pos @ u, vel @ u, acc @ u


def output_times(scene, cs, cycles=None):
    """The scene's output instants (sample_step_angle of the cycle driver over its cycles)."""
    a = scene.analysis
    cyc = a.cycles if cycles is None else cycles
    duration = a.duration if a.duration is not None else cyc * cs.period
    if a.sample_step is not None:
        step = a.sample_step
    else:
        step = a.sample_step_angle / abs(scene.drivers[a.cycle_driver].speed)
    n = int(math.floor(duration / step * (1 + 1e-12))) + 1
    return np.arange(n) * step


@dataclass
class BaselineResult:
    time: np.ndarray
    y: np.ndarray
    acceleration: np.ndarray  # slider acceleration (m/s²) along its axis
    ideal_acceleration: np.ndarray
    stats: BaselineStats

    @property
    def error(self):
        return self.acceleration - self.ideal_acceleration

    @property
    def peak_error(self):
        return float(np.max(np.abs(self.error)))


def simulate(scene="nine-bar-lubricated", *, method="LSODA", rtol=1e-7, atol=1e-10,
             overrides=None, cycles=None, solve="augmented", baseline=None) -> BaselineResult:
    """Simulate a scene without contact history (ideal or lubricated joints) with
    ``scipy.integrate.solve_ivp`` and the NumPy right-hand side; everything timed (model set-up,
    assembly, ideal kinematics, integration, outputs)."""
    start = time.perf_counter()
    bl = baseline or Baseline(scene, overrides, solve=solve)
    if bl.n_hist:
        raise NotImplementedError("the baseline simulates scenes without contact history "
                                  "(ideal or lubricated joints); its rhs covers all models")
    times = output_times(bl.scene, bl.cs, cycles)
    y0, q0 = bl.initial_state()
    bl.n_rhs = 0
    Qi, Vi, Ai = bl.ideal_kinematics(q0, times)
    a_ideal = bl.output(Qi, Vi, Ai)[2]
    t_int = time.perf_counter()
    sol = solve_ivp(bl.rhs, (times[0], times[-1]), y0, method=method, rtol=rtol, atol=atol,
                    dense_output=True)
    if sol.status != 0:
        raise RuntimeError(f"solve_ivp {method} failed: {sol.message}")
    Y = sol.sol(times).T
    t_int = time.perf_counter() - t_int
    n_rhs = bl.n_rhs
    YD = np.array([bl.rhs(t, y) for t, y in zip(times, Y)])
    n = bl.n
    acc = bl.output(Y[:, :n], Y[:, n:2 * n], YD[:, n:2 * n])[2]
    wall = time.perf_counter() - start
    stats = BaselineStats(nfev=n_rhs, njev=int(sol.njev), nlu=int(sol.nlu),
                          nsteps=int(sol.t.size - 1), wall=wall,
                          extra={"integration_wall": t_int, "method": method, "rtol": rtol,
                                 "atol": atol, "scipy_nfev": int(sol.nfev)})
    return BaselineResult(times, Y, acc, a_ideal, stats)


def _main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="nine-bar-lubricated")
    ap.add_argument("--method", default="LSODA",
                    choices=["LSODA", "Radau", "BDF", "RK45", "DOP853"])
    ap.add_argument("--rtol", type=float, default=1e-7)
    ap.add_argument("--atol", type=float, default=None, help="default rtol * 1e-3")
    ap.add_argument("--solve", default="augmented", choices=["augmented", "schur"])
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="scene override, e.g. joints.C1.clearance=0.4e-3")
    args = ap.parse_args(argv)
    from mechrel.scene import parse_override
    over = dict(parse_override(s) for s in args.set)
    atol = args.atol if args.atol is not None else args.rtol * 1e-3
    res = simulate(args.scene, method=args.method, rtol=args.rtol, atol=atol, overrides=over,
                   solve=args.solve)
    s = res.stats
    print(f"{args.scene}: {args.method} rtol={args.rtol:g} atol={atol:g}: wall {s.wall:.2f} s "
          f"(integration {s.extra['integration_wall']:.2f} s), steps {s.nsteps}, "
          f"rhs {s.nfev}, jac {s.njev}, lu {s.nlu}; peak |slider acceleration error| "
          f"{res.peak_error:.6g} m/s^2")


if __name__ == "__main__":
    _main()
