"""Identify all inertial parameters of a fixed-base arm (UR5: 6 links x 10) from a simulated run.

A robotics user identifying an arm fits, per link, the mass m, the first moments m·c and
the six entries of the inertia about the link frame (pi, Pinocchio's order, 60 numbers for
UR5) to measured joint motion under known torques.  Motion sees only linear combinations
of them (the base parameters), so the example

1. finds the identifiable combinations numerically: the SVD of the inverse-dynamics
   regressor Y(q, v, a) (``functions=["regressor"]``, tau = Y pi) stacked over random
   states, in parameters scaled by the prior; its row space is what any motion can
   reveal, its null space what none can.  The rank of the fit's own Jacobian (w.r.t. all
   60 pi) says whether this trajectory excites every identifiable combination;
2. fits only the identifiable part, pi = pi_prior + D V_r T z (T whitens), from a start (= the prior)
   with every parameter off by up to +-30 % (physically consistent per link), so the
   unidentifiable directions stay at the prior exactly (a projection, reported);
3. reports the base parameters (QR with column pivoting: beta = pi_1 + K pi_2, the
   classical "independent parameter + what folds into it") before and after, the
   unidentifiable dimension, and each link's physical consistency (m > 0, the inertia
   about the mass centre positive with its triangle inequalities: the 4x4 pseudo-inertia
   positive definite, Wensing et al. 2017).

The experiment: a digital computed-torque controller built on the prior model tracks a
sum of sines per joint (five harmonics of 0.25 Hz, Swevers-style), its torque held
constant over each 10 ms sample (zero-order hold, as a real drive applies it); the
plant is the true robot, RK4 with dt = 2 ms.  Recorded: q and v every step, the torque
of every sample.  The fit simulates each sample interval from its measured start under
its recorded torque (short windows: the fit stays well posed from a 30 % start); the
residuals are the window's q and v errors scaled to accelerations (2/s^2, 1/s).

Derivatives (both eomc's, both exact for the RK4 trajectory):
- ``"gauss-newton"``: scipy.optimize.least_squares (method="lm") with the Jacobian from
  forward sensitivities (``simulate(..., sensitivities=[...])``, the generated jvp);
- ``"adjoint"``: L-BFGS-B on the cost's gradient from ``eomc.gradient`` (forward run,
  backward run with the generated vjp, per window).
benchmarks/bench_identification.py --arm measures both against finite differences
(same optimizers).  Run: ``python examples/identify_arm.py [--adjoint]``.
"""
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import eomc
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.adjoint import simulate_grid

KEYS = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")  # the regressor's order
FUNCTIONS = ["rhs", "jac_x", "jac_p", "jvp", "vjp", "regressor"]
_SYM = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))   # Ixx, Ixy, Iyy, Ixz, Iyz, Izz


def ur5_path():
    from importlib.metadata import distribution
    root = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    return root / "ur_description/urdf/ur5_robot.urdf"


@dataclass
class Experiment:
    """The excitation and the sampling (defaults: the UR5 example)."""
    T: float = 4.0                 # s of motion
    dt: float = 0.002              # RK4 step of plant and fit
    hold: int = 5                  # RK4 steps per controller sample (10 ms)
    f0: float = 0.25               # Hz, the sum of sines' base frequency
    harmonics: int = 5
    amplitude: float = 0.6         # rad, each joint's reference spans about this much
    kp: float = 100.0              # computed-torque gains (1/s^2, 1/s)
    kd: float = 20.0
    q0: tuple = None               # mean pose (default: zeros but for joint 2 (elbow) at 1.0)
    start_error: float = 0.3       # the prior: each parameter off by up to this fraction
    seed: int = 0
    samples: int = 400             # random states for the structural regressor SVD


def build(path=None, cache_dir=None):
    """The arm with every link's 10 inertial entries as parameters (zeros in the file
    included: UrdfModel(all_inertial_parameters=True)), joint limits off (the regressor
    then carries the whole dynamics), recursive formulation."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(UrdfModel(Path(path or ur5_path()), all_inertial_parameters=True, limits=False),
                            formulation="recursive", functions=FUNCTIONS, progress=False, cache_dir=cache_dir)


# --- pi (link-frame barycentric parameters) <-> the model's m, c, inertia about c ---------------

def _link_values(path):
    """{body name: (m, c, I about c)} as eomc reads the file (fixed links merged)."""
    from eomc.compiler.urdf import build_tree, read_urdf
    from eomc.compiler.urdf.tree import identifier
    tree = build_tree(read_urdf(Path(path)))
    return {identifier(tree.bodies[j.child].name): tree.bodies[j.child] for j in tree.joints}


def pi_of(m, c, Ic):
    """(m, m c, I about the link origin) in KEYS order."""
    c = np.asarray(c, dtype=float)
    Io = np.asarray(Ic, dtype=float) + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([m, *(m * c), *(Io[i, j] for i, j in _SYM)])


def mci_of(pi):
    """Inverse of :func:`pi_of`: (m, c, I about c)."""
    m, h = pi[0], np.asarray(pi[1:4])
    Io = np.zeros((3, 3))
    for k, (i, j) in enumerate(_SYM):
        Io[i, j] = Io[j, i] = pi[4 + k]
    return m, h / m, Io - (h @ h * np.eye(3) - np.outer(h, h)) / m


def pseudo_inertia(pi):
    """The 4x4 pseudo-inertia [[Sigma, h], [h', m]], Sigma = tr(Io)/2 E - Io: positive definite
    iff the link is physically consistent (m > 0, inertia about c with its triangle inequalities)."""
    m, h = pi[0], np.asarray(pi[1:4])
    Io = np.zeros((3, 3))
    for k, (i, j) in enumerate(_SYM):
        Io[i, j] = Io[j, i] = pi[4 + k]
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(Io) * np.eye(3) - Io
    J[:3, 3] = J[3, :3] = h
    J[3, 3] = m
    return J


def consistency(pi, bodies):
    """Per link: (name, m, principal moments about c, smallest triangle margin, smallest
    eigenvalue of the pseudo-inertia, consistent)."""
    rows = []
    for b, name in enumerate(bodies):
        p = pi[10 * b:10 * b + 10]
        m, _, Ic = mci_of(p)
        lam = np.linalg.eigvalsh(Ic)
        margin = min(lam[0] + lam[1] - lam[2], lam[0] + lam[2] - lam[1], lam[1] + lam[2] - lam[0])
        ev = np.linalg.eigvalsh(pseudo_inertia(p))[0]
        rows.append((name, m, lam, margin, ev, bool(m > 0 and lam[0] > 0 and margin > -1e-12 * lam[2] and ev > 0)))
    return rows


class Arm:
    """The model and the map pi (10 per body) -> its parameter vector, with the Jacobian."""

    def __init__(self, model, path=None):
        self.model = model
        self.bodies = tuple(model.metadata["regressor_bodies"])
        self.names = model.regressor_columns
        links = _link_values(path or ur5_path())
        self.pi_file = np.concatenate([pi_of(links[b].mass, links[b].com, links[b].inertia) for b in self.bodies])
        index = {n: i for i, n in enumerate(model.param_names)}
        # per body: the model's indices of m, cx, cy, cz and the inertia entries it kept
        self.slots = []
        for b in self.bodies:
            mc = [index.get(f"{k}_{b}") for k in ("m", "cx", "cy", "cz")]
            inert = [index.get(f"I{k}_{b}") for k in ("xx", "xy", "yy", "xz", "yz", "zz")]
            self.slots.append((mc, inert))
        self.columns = sorted(i for mc, inert in self.slots for i in mc + inert if i is not None)

    def params(self, pi):
        """The model's parameter vector for pi (others at their defaults)."""
        p = np.array(self.model.param_defaults, dtype=float)
        for b, (mc, inert) in enumerate(self.slots):
            m, c, Ic = mci_of(pi[10 * b:10 * b + 10])
            for i, v in zip(mc, (m, *c)):
                if i is not None:
                    p[i] = v
            for i, (r, s) in zip(inert, _SYM):
                if i is not None:
                    p[i] = Ic[r, s]
        return p

    def dparams(self, pi):
        """d params / d pi, (nparam, 10 * bodies), exact."""
        P = np.zeros((self.model.nparam, pi.size))
        for b, (mc, inert) in enumerate(self.slots):
            m, h = pi[10 * b], pi[10 * b + 1:10 * b + 4]
            col = 10 * b
            rows = np.zeros((10, 10))                  # d (m, c, Ic entries) / d pi of this body
            rows[0, 0] = 1.0
            rows[1:4, 0] = -h / m ** 2
            rows[1:4, 1:4] = np.eye(3) / m
            S = h @ h * np.eye(3) - np.outer(h, h)     # Ic = Io - S / m
            for k, (r, s) in enumerate(_SYM):
                rows[4 + k, 4 + k] = 1.0
                rows[4 + k, 0] = S[r, s] / m ** 2
                for a in range(3):
                    dS = 2 * h[a] * (r == s) - ((r == a) * h[s] + h[r] * (s == a))
                    rows[4 + k, 1 + a] = -dS / m
            for k, i in enumerate(mc + inert):
                if i is not None:
                    P[i, col:col + 10] = rows[k]
        return P


# --- the experiment ---------------------------------------------------------------------------

def _scales(pi, bodies):
    """Per-parameter scale: |value|, floored at 1 cm·m for first moments and at 1 % of the
    link's largest inertia entry for inertia entries (zeros in the file have a size too)."""
    s = np.abs(pi).copy()
    for b in range(len(bodies)):
        p = pi[10 * b:10 * b + 10]
        s[10 * b + 1:10 * b + 4] = np.maximum(s[10 * b + 1:10 * b + 4], 0.01 * abs(p[0]))
        big = np.max(np.abs(p[4:]))
        s[10 * b + 4:10 * b + 10] = np.maximum(s[10 * b + 4:10 * b + 10], 0.01 * big)
    return s


def perturbed(pi_true, bodies, fraction, rng):
    """pi_true with every entry moved by up to +-fraction of its scale, redrawn per link until
    the link is physically consistent (the prior a user would hold)."""
    s = _scales(pi_true, bodies)
    out = pi_true.copy()
    for b in range(len(bodies)):
        sl = slice(10 * b, 10 * b + 10)
        for _ in range(1000):
            cand = pi_true[sl] + fraction * rng.uniform(-1, 1, 10) * s[sl]
            if np.linalg.eigvalsh(pseudo_inertia(cand))[0] > 0:
                out[sl] = cand
                break
        else:
            raise RuntimeError(f"no consistent perturbation of {bodies[b]}")
    return out


@dataclass
class Data:
    t: np.ndarray            # (N + 1,) grid
    X: np.ndarray            # (N + 1, nx) measured states (q, v)
    R: np.ndarray            # (samples, nu) held torques
    hold: int
    dt: float
    extra: dict = field(default_factory=dict)


def run_experiment(arm, pi_true, pi_prior, ex):
    """The true plant under the prior-model computed-torque controller tracking the sum of sines."""
    model, nq = arm.model, arm.model.nq
    rng = np.random.default_rng(ex.seed + 1)
    w = 2 * np.pi * ex.f0 * np.arange(1, ex.harmonics + 1)
    a = rng.uniform(-1, 1, (nq, ex.harmonics)) * ex.amplitude / ex.harmonics
    b = rng.uniform(-1, 1, (nq, ex.harmonics)) * ex.amplitude / ex.harmonics
    q0 = np.zeros(nq) if ex.q0 is None else np.asarray(ex.q0, float)
    if ex.q0 is None and nq > 2:
        q0[2] = 1.0

    def ref(t):    # q, v, a of the reference (a finite Fourier series, Swevers et al. 1997)
        s, c = np.sin(w * t), np.cos(w * t)
        return (q0 + a @ s + b @ (1 - c)), a @ (w * c) + b @ (w * s), a @ (-w * w * s) + b @ (w * w * c)

    p_true = arm.params(pi_true)
    n = int(round(ex.T / (ex.dt * ex.hold)))
    x = np.concatenate([q0, np.zeros(model.nu)])
    X, R = [x], []
    for k in range(n):
        qr, vr, ar = ref(k * ex.hold * ex.dt)
        q, v = x[:nq], x[nq:]
        acc = ar + ex.kp * (qr - q) + ex.kd * (vr - v)
        tau = model.regressor(q, v, acc) @ pi_prior        # computed torque with the prior model
        _, Xk = simulate_grid(model, x, ex.hold * ex.dt, dt=ex.dt, p=p_true, r=tau)
        X.extend(Xk[1:])
        R.append(tau)
        x = Xk[-1]
    X = np.array(X)
    return Data(np.arange(len(X)) * ex.dt, X, np.array(R), ex.hold, ex.dt)


# --- identifiability --------------------------------------------------------------------------

@dataclass
class Identifiable:
    scale: np.ndarray        # D: pi = pi_prior + D (V_r z + V_0 w)
    V_r: np.ndarray          # orthonormal basis of the identifiable directions (scaled)
    V_0: np.ndarray          # ... and of the unidentifiable ones
    singular: np.ndarray     # of the stacked, scaled regressor
    pivots: np.ndarray       # QR column pivoting: the base parameters' leading entries
    K: np.ndarray            # beta = pi[pivots[:r]] + K pi[pivots[r:]] (physical units)

    @property
    def rank(self):
        return self.V_r.shape[1]

    def base(self, pi):
        r = self.rank
        return pi[self.pivots[:r]] + self.K @ pi[self.pivots[r:]]


def identifiable(arm, pi_prior, samples=400, seed=0, rtol=1e-9):
    """The identifiable combinations from the regressor stacked over random states (q in
    [-pi, pi], v and a in [-3, 3]), scaled by the prior's parameter scales."""
    from scipy.linalg import qr
    model = arm.model
    rng = np.random.default_rng(seed + 2)
    D = _scales(pi_prior, arm.bodies)
    Y = np.vstack([model.regressor(rng.uniform(-np.pi, np.pi, model.nq), rng.uniform(-3, 3, model.nu),
                                   rng.uniform(-3, 3, model.nu)) for _ in range(samples)]) * D
    _, sv, Vt = np.linalg.svd(Y, full_matrices=True)
    r = int(np.sum(sv > rtol * sv[0]))
    _, Rq, piv = qr(Y, mode="economic", pivoting=True)
    Ks = np.linalg.solve(Rq[:r, :r], Rq[:r, r:])        # scaled: beta~ = pi~_1 + Ks pi~_2
    K = Ks * D[piv[:r]][:, None] / D[piv[r:]][None, :]
    return Identifiable(D, Vt[:r].T, Vt[r:].T, sv, piv, K)


# --- the fit ----------------------------------------------------------------------------------

class Fit:
    """Residuals, their Jacobian (forward sensitivities) and the cost's gradient (adjoint) in
    the identifiable coordinates z; counts simulations."""

    def __init__(self, arm, data, ident, pi_prior):
        self.arm, self.data, self.ident, self.pi_prior = arm, data, ident, pi_prior
        model = arm.model
        tau = data.dt * np.arange(1, data.hold + 1)
        self.W = np.empty((data.hold, model.nx))               # q errors -> 2/tau^2, v errors -> 1/tau
        self.W[:, :model.nq] = (2 / tau ** 2)[:, None]
        self.W[:, model.nq:] = (1 / tau)[:, None]
        self.sens_names = [model.param_names[i] for i in arm.columns]
        self.simulations = 0
        self.window_t = tau
        self.basis = ident.V_r @ self._whitening()     # pi = pi_prior + D basis z

    def _whitening(self):
        """z's axes: the identifiable directions whitened by the regressor at the measured
        states (accelerations from central differences of the measured speeds), the classical
        linear least-squares problem's.  The residuals are close to M^-1 Y dpi, so this takes
        the fit's condition number from 1.3e4 to 2.5e2 on UR5 (first-order methods need it)."""
        d, nq = self.data, self.arm.model.nq
        acc = (d.X[2:, nq:] - d.X[:-2, nq:]) / (2 * d.dt)
        Y = np.vstack([self.arm.model.regressor(d.X[k, :nq], d.X[k, nq:], acc[k - 1])
                       for k in range(1, len(d.X) - 1, 2)])
        _, sv, Vt = np.linalg.svd(Y * self.ident.scale @ self.ident.V_r, full_matrices=False)
        return Vt.T / sv * sv[-1]        # a unit step in z moves the scaled pi by at most 1

    def pi(self, z):
        return self.pi_prior + self.ident.scale * (self.basis @ z)

    def _windows(self):
        d = self.data
        for k in range(d.R.shape[0]):
            yield d.X[k * d.hold], d.R[k], d.X[k * d.hold + 1:(k + 1) * d.hold + 1]

    def residuals(self, z):
        return self.residuals_pi(self.pi(z))

    def residuals_pi(self, pi):
        p = self.arm.params(pi)
        out = []
        for x0, r, Xm in self._windows():
            _, X = simulate_grid(self.arm.model, x0, self.data.hold * self.data.dt, dt=self.data.dt, p=p, r=r)
            out.append(((X[1:] - Xm) * self.W).ravel())
        self.simulations += self.data.R.shape[0]
        return np.concatenate(out)

    def cost(self, z):
        e = self.residuals(z)
        return 0.5 * float(e @ e)

    def cost_pi(self, pi):
        e = self.residuals_pi(pi)
        return 0.5 * float(e @ e)

    def _chain(self, pi):
        """d params[columns] / d z."""
        return self.arm.dparams(pi)[self.arm.columns] @ (self.ident.scale[:, None] * self.basis)

    def jacobian_pi(self, z):
        """d residuals / d pi~ (all scaled pi: the rank test of the data)."""
        pi = self.pi(z)
        return self._sensitivities(pi) @ (self.arm.dparams(pi)[self.arm.columns] * self.ident.scale)

    def jacobian(self, z):
        pi = self.pi(z)
        return self._sensitivities(pi) @ self._chain(pi)

    def _sensitivities(self, pi):
        p, d, rows = self.arm.params(pi), self.data, []
        for x0, r, _ in self._windows():
            res = self.arm.model.simulate(x0, (0.0, d.hold * d.dt), p=p, r=r, method="rk4", dt=d.dt,
                                          t_eval=np.concatenate([[0.0], self.window_t]),
                                          sensitivities=self.sens_names)
            rows.append((res.dx_dp[1:] * self.W[:, :, None]).reshape(-1, len(self.sens_names)))
        self.simulations += d.R.shape[0]
        return np.vstack(rows)

    def cost_and_gradient(self, z):
        """The cost and dJ/dz, one eomc.gradient (forward + adjoint run) per window."""
        pi = self.pi(z)
        p, d, W2 = self.arm.params(pi), self.data, self.W ** 2
        total, g = 0.0, np.zeros(self.arm.model.nparam)
        for x0, r, Xm in self._windows():
            def cost(t, X, Xm=Xm):
                e = X[1:] - Xm
                G = np.zeros_like(X)
                G[1:] = e * W2
                return 0.5 * float(np.sum(e * e * W2)), G
            res = eomc.gradient(self.arm.model, x0, d.hold * d.dt, dt=d.dt, cost=cost, p=p, r=r)
            total += res.value
            g += res.dp
        self.simulations += d.R.shape[0]
        return total, g[self.arm.columns] @ self._chain(pi)


def fit_gauss_newton(fit, jac=None, max_nfev=100):
    """least_squares (Levenberg-Marquardt) from z = 0 (the prior); ``jac``: None = forward
    sensitivities, or scipy's "2-point" / "3-point" differences of whole windowed runs."""
    from scipy.optimize import least_squares
    z0 = np.zeros(fit.ident.rank)
    return least_squares(fit.residuals, z0, jac=fit.jacobian if jac is None else jac, method="lm",
                         xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=max_nfev)


def fit_lbfgs(fit, jac=None, maxiter=3000):
    """L-BFGS-B from z = 0 on the cost; ``jac``: None = the adjoint gradient, or "3-point"."""
    from scipy.optimize import minimize
    z0 = np.zeros(fit.ident.rank)
    if jac is None:
        return minimize(fit.cost_and_gradient, z0, jac=True, method="L-BFGS-B",
                        options={"maxiter": maxiter, "ftol": 1e-30, "gtol": 1e-14, "maxcor": 30})
    return minimize(fit.cost, z0, jac=jac, method="L-BFGS-B",
                    options={"maxiter": maxiter, "ftol": 1e-30, "gtol": 1e-14, "maxcor": 30})


def make_consistent(fit, pi, margin=1e-3):
    """pi moved only along the unidentifiable directions (the trajectory cannot tell) and as
    little as possible (scaled) to make every link physically consistent: the smallest
    eigenvalue of each pseudo-inertia at least ``margin`` times the prior's (SLSQP).  The
    truth is one such point, so the set is not empty.  Returns (pi, moved: |w|)."""
    from scipy.optimize import minimize
    nb, B = len(fit.arm.bodies), fit.ident.scale[:, None] * fit.ident.V_0
    need = [margin * np.linalg.eigvalsh(pseudo_inertia(fit.pi_prior[10 * b:10 * b + 10]))[0] for b in range(nb)]
    if all(np.linalg.eigvalsh(pseudo_inertia(pi[10 * b:10 * b + 10]))[0] >= need[b] for b in range(nb)):
        return pi, 0.0
    basis = [pseudo_inertia(np.eye(10)[i]) for i in range(10)]       # J is linear in pi

    def smallest(w, b):
        lam, vec = np.linalg.eigh(pseudo_inertia((pi + B @ w)[10 * b:10 * b + 10]))
        grad = np.array([vec[:, 0] @ A @ vec[:, 0] for A in basis]) @ B[10 * b:10 * b + 10]
        return lam[0] - need[b], grad

    cons = [{"type": "ineq", "fun": lambda w, b=b: smallest(w, b)[0], "jac": lambda w, b=b: smallest(w, b)[1]}
            for b in range(nb)]
    sol = minimize(lambda w: (0.5 * w @ w, w), np.zeros(B.shape[1]), jac=True, method="SLSQP",
                   constraints=cons, options={"maxiter": 500, "ftol": 1e-14})
    out = pi + B @ sol.x
    if not all(np.linalg.eigvalsh(pseudo_inertia(out[10 * b:10 * b + 10]))[0] > 0 for b in range(nb)):
        raise RuntimeError(f"no physically consistent point found along the unidentifiable directions: {sol.message}")
    return out, float(np.linalg.norm(sol.x))


# --- the report -------------------------------------------------------------------------------

@dataclass
class Outcome:
    pi: np.ndarray
    base_error: float        # max over base parameters of |beta - beta_true| / max(|beta_true|, scale)
    base_error_norm: float   # |V_r'(pi~ - pi~_true)| / |V_r' pi~_true|
    null_shift: float        # |V_0' D^-1 (pi - pi_prior)|: 0 = unidentifiable part at the prior
    null_error: float        # |V_0' D^-1 (pi - pi_true)|: what no motion can correct
    single_error: float      # max |pi - pi_true| / scale over the single parameters
    consistent: int          # links physically consistent
    cost: float


def outcome(fit, pi, pi_true):
    ident, D = fit.ident, fit.ident.scale
    beta, beta_true = ident.base(pi), ident.base(pi_true)
    denom = np.maximum(np.abs(beta_true), D[ident.pivots[:ident.rank]])
    Vr, V0 = ident.V_r, ident.V_0
    return Outcome(pi, float(np.max(np.abs(beta - beta_true) / denom)),
                   float(np.linalg.norm(Vr.T @ ((pi - pi_true) / D)) / np.linalg.norm(Vr.T @ (pi_true / D))),
                   float(np.linalg.norm(V0.T @ ((pi - fit.pi_prior) / D))),
                   float(np.linalg.norm(V0.T @ ((pi - pi_true) / D))),
                   float(np.max(np.abs(pi - pi_true) / D)),
                   sum(row[-1] for row in consistency(pi, fit.arm.bodies)), fit.cost_pi(pi))


def setup(path=None, ex=None, cache_dir=None):
    """(arm, ex, pi_true, pi_prior, data, ident, fit): everything up to the fit."""
    ex = ex or Experiment()
    arm = Arm(build(path, cache_dir), path)
    pi_true = arm.pi_file
    pi_prior = perturbed(pi_true, arm.bodies, ex.start_error, np.random.default_rng(ex.seed))
    data = run_experiment(arm, pi_true, pi_prior, ex)
    ident = identifiable(arm, pi_prior, ex.samples, ex.seed)
    return arm, ex, pi_true, pi_prior, data, ident, Fit(arm, data, ident, pi_prior)


def data_rank(fit):
    """(rank, condition) of the trajectory's Jacobian w.r.t. all scaled pi at the prior."""
    sv = np.linalg.svd(fit.jacobian_pi(np.zeros(fit.ident.rank)), compute_uv=False)
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    return rank, sv[0] / sv[rank - 1]


ROWS = (("cost", "cost", "{:10.3e}"),
        ("max rel. error of the base parameters", "base_error", "{:10.2e}"),
        ("rel. error, identifiable part (norm)", "base_error_norm", "{:10.2e}"),
        ("unidentifiable part moved from prior", "null_shift", "{:10.2e}"),
        ("unidentifiable part off the truth", "null_error", "{:10.2e}"),
        ("max error of single parameters / scale", "single_error", "{:10.2e}"),
        ("physically consistent links", "consistent", "{:10d}"))


def print_report(arm, ident, fit, pi_true, columns):
    """columns: [(label, Outcome)]."""
    nb = len(arm.bodies)
    rank, cond = data_rank(fit)
    print(f"{10 * nb} inertial parameters ({nb} links x 10), {ident.rank} identifiable combinations "
          f"(regressor SVD over random states; singular values {ident.singular[ident.rank - 1]:.2e} | "
          f"{ident.singular[ident.rank]:.2e} at the cut), {10 * nb - ident.rank} unidentifiable")
    print(f"the trajectory's Jacobian w.r.t. all {10 * nb}: rank {rank} "
          f"(condition in the identifiable directions {cond:.2e})\n")
    print(f"{'':38s}" + "".join(f" {label:>12s}" for label, _ in columns))
    for text, key, fmt in ROWS:
        print(f"{text:38s}" + "".join(f" {fmt.format(getattr(o, key)):>12s}" for _, o in columns))
    end = columns[-1][1]
    print(f"\nper link ({columns[-1][0]}): mass, principal moments about the mass centre, triangle margin, "
          "min eig of the pseudo-inertia")
    for name, m, lam, margin, ev, ok in consistency(end.pi, arm.bodies):
        print(f"  {name:16s} m {m:8.4f}  I_c {lam[0]:9.3e} {lam[1]:9.3e} {lam[2]:9.3e}  "
              f"margin {margin:9.2e}  eig {ev:9.2e}  {'consistent' if ok else 'NOT consistent'}")
    beta_t, beta_f = ident.base(pi_true), ident.base(end.pi)
    print("\nbase parameters (leading entry + what folds into it): true, fit")
    for k in range(ident.rank):
        print(f"  {arm.names[ident.pivots[k]]:22s} {beta_t[k]: .10e} {beta_f[k]: .10e}")


def identify(fit, method="gauss-newton"):
    """(pi fitted, pi made consistent, how far that moved it, CPU s, optimizer result)."""
    fit.simulations = 0
    t0 = time.thread_time()
    sol = fit_lbfgs(fit) if method == "adjoint" else fit_gauss_newton(fit)
    pi = fit.pi(sol.x)
    consistent, moved = make_consistent(fit, pi)
    return pi, consistent, moved, time.thread_time() - t0, sol


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    t0 = time.process_time()
    arm, ex, pi_true, pi_prior, data, ident, fit = setup()
    print(f"built and simulated in {time.process_time() - t0:.1f} s CPU: {data.X.shape[0] - 1} RK4 steps, "
          f"{data.R.shape[0]} torque samples")
    method = "adjoint" if "--adjoint" in argv else "gauss-newton"
    pi, consistent, moved, seconds, sol = identify(fit, method)
    label = ("L-BFGS-B on the adjoint gradient" if method == "adjoint"
             else "Levenberg-Marquardt on forward sensitivities")
    steps = f"{sol.nit} iterations" if method == "adjoint" else f"{sol.nfev} residual evaluations, {sol.njev} Jacobians"
    print(f"{label}: {seconds:.2f} s CPU, {steps}, {fit.simulations} window simulations; {sol.message}")
    print(f"physical consistency: the unidentifiable part moved by {moved:.3g} (scaled) to make every link "
          "consistent" if moved else "physical consistency: every link consistent as fitted")
    print_report(arm, ident, fit, pi_true, [("start", outcome(fit, pi_prior, pi_true)),
                                            ("fit", outcome(fit, pi, pi_true)),
                                            ("consistent", outcome(fit, consistent, pi_true))])


if __name__ == "__main__":
    main()
