"""The Whipple bicycle (examples/whipple_bicycle.py) against the published benchmark.

Oracle: Meijaard, Papadopoulos, Ruina & Schwab (2007), "Linearized dynamics
equations for the balance and steer of a bicycle: a benchmark and review",
Proc. R. Soc. A 463:1955-1982 -- the coefficient matrices of its eq. (5.3)
M q'' + v C1 q' + (g K0 + v^2 K2) q = 0 (q = [lean, steer]), the eigenvalues
of its Table 2 and its weave and capsize speeds.  The numbers below are the
paper's, as printed (14 decimals); the model agrees with them to ~1e-13.

The model has a dependent coordinate (rear frame pitch, fixed by the front
wheel touching the ground) and three dependent speeds (yaw, pitch and front
wheel rates, from the front contact being at rest).  The linear model is
taken from the compiled equations: the Jacobian of the rhs over all ten
states, restricted to perturbations that keep the linearized constraints
(the tangent space of the constraint manifold), at upright straight-ahead
rolling.  The compiled rhs is checked against the symbolic equations first,
and the reduced mass matrix straight from the symbolic Kane equations.
"""
import pathlib
import runpy

import numpy as np
import pytest
import sympy as sm
from scipy.optimize import brentq

import eomc

EXAMPLE = pathlib.Path(__file__).resolve().parents[3] / "examples" / "whipple_bicycle.py"
G = 9.81

M_PAPER = np.array([[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]])
C1_PAPER = np.array([[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]])
K0_PAPER = np.array([[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]])
K2_PAPER = np.array([[0.0, 76.59734589573222], [0.0, 2.65431523794604]])
WEAVE_SPEED = 4.29238253634111
CAPSIZE_SPEED = 6.02426201538837

# Table 2 (b), (c): eigenvalues at v = 0, 1, ..., 10 m/s.  At v = 0: ±3.131..., ±5.530...;
# from v = 1 on: the capsize (real), weave (complex pair) and castering (real) modes.
_CAPSIZE = [-3.13423125066578, -3.07158645641514, -2.63366137253667, -1.42944427361326,
            -0.32286642900409, -0.00406690076970, 0.10268170574766, 0.14327879765713,
            0.15790184030917, 0.16105338653172]
_WEAVE = [(3.52696170990070, 0.80774027519930), (2.68234517512745, 1.68066296590675),
          (1.70675605663975, 2.31582447384325), (0.41325331521125, 3.07910818603206),
          (-0.77534188219585, 4.46486771378823), (-1.52644486584142, 5.87673060598709),
          (-2.13875644258362, 7.19525913329805), (-2.69348683581097, 8.46037971396931),
          (-3.21675402252485, 9.69377351531791), (-3.72016840437287, 10.90681139476287)]
_CASTER = [-7.11008014637442, -8.67387984831735, -10.35101467245920, -12.15861426576450,
           -14.07838969279820, -16.08537123098030, -18.15788466125262, -20.27940894394569,
           -22.43788559040858, -24.62459635017404]
TABLE2 = {0: [-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393]}
TABLE2.update({v: [_CAPSIZE[v - 1], complex(*_WEAVE[v - 1]), complex(_WEAVE[v - 1][0], -_WEAVE[v - 1][1]),
                   _CASTER[v - 1]] for v in range(1, 11)})


@pytest.fixture(scope="module")
def example():
    return runpy.run_path(str(EXAMPLE))


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    return eomc.compile(EXAMPLE, cache_dir=tmp_path_factory.mktemp("whipple_cache"), progress=False,
                        functions="rhs,jac_x,constraints,constraints_jac,outputs,events")


def _index(model):
    names = model.state_names
    assert names == ("psi", "phi", "delta", "theta", "u2", "u4", "u5", "u1", "u3", "u6")
    dependent = [names.index(n) for n in ("theta", "u1", "u3", "u6")]
    independent = [i for i in range(model.nx) if i not in dependent]
    return independent, dependent


def _upright(model, v):
    """Upright straight-ahead rolling at forward speed v (all constraints hold exactly)."""
    x = np.zeros(model.nx)
    names = model.state_names
    x[names.index("u5")] = -v / 0.3        # rR
    x[names.index("u6")] = -v / 0.35       # rF
    return x


def _consistent(model, x):
    """x with its dependent speeds solved from the (linear in u) velocity constraints."""
    _, dependent = _index(model)
    dep_u = dependent[1:]
    x = np.array(x, dtype=float)
    x[dep_u] = 0.0
    rows = slice(model.nhol, model.nhol + model.nvel)
    jac = model.constraints_jacobian(0.0, x)[rows][:, dep_u]
    x[dep_u] = np.linalg.solve(jac, -model.constraints(0.0, x)[rows])
    return x


def _reduced(model, v):
    """Linear model in the independent states: rhs Jacobian on the constraints' tangent space."""
    independent, dependent = _index(model)
    x = _upright(model, v)
    assert np.abs(model.constraints(0.0, x)).max() < 1e-14
    gjac = model.constraints_jacobian(0.0, x)
    T = np.zeros((model.nx, len(independent)))
    T[independent] = np.eye(len(independent))
    T[dependent] = -np.linalg.solve(gjac[:, dependent], gjac[:, independent])
    return model.jacobian(0.0, x)[independent] @ T


def _lean_steer(model, v):
    """The 4x4 state matrix in [lean, steer, lean rate, steer rate]; yaw and speed decouple."""
    A = _reduced(model, v)             # independent states: psi, phi, delta, u2, u4, u5
    keep, drop = [1, 2, 3, 4], [0, 5]
    assert np.abs(A[np.ix_(keep, drop)]).max() < 1e-12
    return A[np.ix_(keep, keep)]


def _paper_lean_steer(v):
    Minv = np.linalg.inv(M_PAPER)
    return np.block([[np.zeros((2, 2)), np.eye(2)],
                     [-Minv @ (G * K0_PAPER + v**2 * K2_PAPER), -v * Minv @ C1_PAPER]])


def test_reduced_mass_matrix_from_the_kane_equations_is_the_papers(example):
    """M at upright: Kane's rows for lean and steer rate, with the dependent u' eliminated."""
    km, P = example["system"], example["parameters"]
    point = {k: sm.Float(v, 30) for k, v in P.items()}
    point.update({s: 0 for s in list(km.q) + list(km.u)})
    u = list(km.u)
    dep = [u.index(s) for s in km.u if s.name in ("u1", "u3", "u6")]
    ind = [i for i in range(len(u)) if i not in dep]
    full = np.array(km.mass_matrix.xreplace(point).evalf(30), dtype=float)   # (6, 6)
    # u'_dep = A_rs u'_ind at upright (the constraint rows), so M_red = K_d [I; A_rs].
    k_d, con = full[:len(ind)], full[len(ind):]
    ars = -np.linalg.solve(con[:, dep], con[:, ind])
    m_red = k_d[:, ind] + k_d[:, dep] @ ars
    lean_steer = [ind.index(u.index(s)) for s in km.u if s.name in ("u2", "u4")]
    np.testing.assert_allclose(m_red[np.ix_(lean_steer, lean_steer)], M_PAPER, rtol=1e-12, atol=1e-13)


def test_compiled_rhs_matches_the_symbolic_equations(example, model):
    km, P = example["system"], example["parameters"]
    rng = np.random.default_rng(2007)
    states = list(km.q) + list(km.u)
    params = {k: sm.Float(v, 30) for k, v in P.items()}
    Msym, Fsym = km.mass_matrix, km.forcing
    kin = km.formed().kinematics
    for _ in range(3):
        x = rng.uniform(-0.5, 0.5, model.nx)
        point = {**params, **{s: sm.Float(float(v), 30) for s, v in zip(states, x)}}
        udot = Msym.xreplace(point).evalf(30).LUsolve(Fsym.xreplace(point).evalf(30))
        want = np.array([float(e.xreplace(point)) for e in kin] + [float(e) for e in udot])
        got = model.rhs(0.0, x)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("v", [0.0, 1.0, 3.0, 4.5, 5.0, 6.5, 10.0])
def test_lean_steer_state_matrix_matches_the_paper(model, v):
    np.testing.assert_allclose(_lean_steer(model, v), _paper_lean_steer(v), rtol=1e-12, atol=1e-12)


def test_coefficient_matrices_match_the_paper(model):
    """C1, K0, K2 recovered from the state matrices at v = 0, 1 with the paper's M."""
    A0, A1 = _lean_steer(model, 0.0)[2:], _lean_steer(model, 1.0)[2:]
    K0 = -M_PAPER @ A0[:, :2] / G
    K2 = -M_PAPER @ A1[:, :2] - G * K0
    C1 = -M_PAPER @ A1[:, 2:]
    for got, want in ((K0, K0_PAPER), (K2, K2_PAPER), (C1, C1_PAPER)):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def _sorted(eigs):
    return sorted(np.asarray(eigs, dtype=complex), key=lambda z: (round(z.real, 6), z.imag))


@pytest.mark.parametrize("v", sorted(TABLE2))
def test_eigenvalues_match_table_2(model, v):
    got = _sorted(np.linalg.eigvals(_lean_steer(model, float(v))))
    want = _sorted(TABLE2[v])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_weave_and_capsize_speeds(model):
    """Upright running is self-stable between the weave and capsize speeds (the paper's §5)."""
    def abscissa(v):
        return np.linalg.eigvals(_lean_steer(model, v)).real.max()

    weave = brentq(abscissa, 4.0, 5.0, xtol=1e-14)
    capsize = brentq(abscissa, 5.5, 6.5, xtol=1e-14)
    assert weave == pytest.approx(WEAVE_SPEED, abs=1e-12)
    assert capsize == pytest.approx(CAPSIZE_SPEED, abs=1e-12)
    assert abscissa(5.0) < 0 < abscissa(3.0) and abscissa(7.0) > 0
    # Table 2 (a): at the weave speed the weave pair is ±3.43503384866144 i; at the
    # bifurcation speed 0.68428307889246 m/s two real eigenvalues meet at 3.78290405129320.
    at_weave = np.linalg.eigvals(_lean_steer(model, WEAVE_SPEED))
    pair = at_weave[np.abs(at_weave.imag) > 1]
    np.testing.assert_allclose(np.sort(pair.imag), [-3.43503384866144, 3.43503384866144], rtol=1e-12)
    assert np.abs(pair.real).max() < 1e-12
    at_bifurcation = np.linalg.eigvals(_lean_steer(model, 0.68428307889246))
    double = at_bifurcation[at_bifurcation.real > 0]
    # a double root: 1e-14 in v moves it by ~1e-7 off the real axis
    np.testing.assert_allclose(double.real, [3.78290405129320] * 2, rtol=1e-12)
    assert np.abs(double.imag).max() < 1e-6


def _lean_after_kick(model, v, t_final):
    x0 = _upright(model, v)
    x0[model.state_names.index("u2")] = 0.05          # lean-rate kick, rad/s
    x0 = _consistent(model, x0)
    res = model.simulate(x0, (0.0, t_final), method="dop853", rtol=1e-10, atol=1e-12, n_points=201)
    constraint = float(np.max(res.constraint_residual))
    return np.asarray(res["phi"]), res, constraint


def test_kicked_bicycle_recovers_at_5_m_s(model):
    lean, res, constraint = _lean_after_kick(model, 5.0, 12.0)
    t = np.asarray(res.t)
    assert np.abs(lean).max() < 0.05
    assert np.abs(lean[t > 10.0]).max() < 0.05 * np.abs(lean).max()
    assert constraint < 1e-8
    energy = np.asarray(res.outputs["energy"])
    assert np.ptp(energy) < 1e-8 * np.abs(energy).max()


def test_kicked_bicycle_falls_at_2_m_s(model):
    lean, res, _ = _lean_after_kick(model, 2.0, 2.0)
    assert np.abs(lean[-1]) > 10 * np.abs(lean[:20]).max()


def test_fall_at_2_m_s_is_stopped_by_the_model_files_event(model):
    """The example's terminal event 'fallen' (lean^2 = (pi/4)^2, rising) ends the run where the
    lean reaches 45 degrees; the same run without events, to that time, agrees there (and,
    left to go on, ends with a singular mass matrix as the frame lies flat)."""
    x0 = _upright(model, 2.0)
    x0[model.state_names.index("u2")] = 0.05
    x0 = model.consistent_state(x0)
    i = model.state_names.index("phi")
    res = model.simulate(x0, (0.0, 10.0), rtol=1e-10, atol=1e-12, n_points=101)
    assert res.event_stop == "fallen" and 0.5 < res.t_final < 5.0
    assert abs(res.x_final[i]) == pytest.approx(np.pi / 4, abs=1e-12)
    plain = model.simulate(x0, (0.0, res.t_final), rtol=1e-10, atol=1e-12, events=False,
                           t_eval=[0.0, res.t_final])
    assert abs(plain.x[-1, i]) == pytest.approx(np.pi / 4, abs=1e-8)
    np.testing.assert_allclose(x0, _consistent(model, x0), rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("v", [3.0, 5.0])
def test_linearize_reduced_gives_the_papers_lean_steer_matrix(model, v):
    lin = model.linearize_reduced(0.0, _upright(model, v))
    assert lin.states == ("psi", "phi", "delta", "u2", "u4", "u5")
    keep = [1, 2, 3, 4]
    np.testing.assert_allclose(lin.A[np.ix_(keep, keep)], _paper_lean_steer(v), rtol=1e-12,
                               atol=1e-12)


def test_model_file_initial_state_is_consistent_and_rolls_at_5_m_s(example, model):
    x0 = model.initial_state
    assert np.abs(model.constraints(0.0, x0)).max() < 1e-14
    out = model.outputs(0.0, x0)
    assert out["forward_speed"] == pytest.approx(5.0, rel=1e-14)
    assert out["lean"] == out["steer"] == out["pitch"] == 0.0
    assert WEAVE_SPEED < out["forward_speed"] < CAPSIZE_SPEED
    # the model file's own helper agrees with the compiled constraints away from upright
    km = example["system"]
    x = _upright(model, 3.0)
    x[[1, 2, 4, 5]] = [0.1, 0.2, -0.3, 0.4]          # lean, steer, lean rate, steer rate
    helper = example["consistent_speeds"]({**dict(zip(km.q, x[:4])), **dict(zip(km.u[:3], x[4:7]))})
    want = _consistent(model, x)
    np.testing.assert_allclose([helper[s] for s in km.u[3:]], want[7:], rtol=1e-12,
                               atol=1e-12 * np.abs(want[7:]).max())


def test_sympy_style_linearize_with_dependent_coordinate_and_speeds(example):
    """KanesMethod.linearize with SymPy's keywords (eomc's FastLinearizer; SymPy's results).

    The benchmark parameters ride in the operating point (``msubs`` semantics:
    any symbol may be given a value there), v stays a symbol.  Cramer's rule as
    in SymPy's own bicycle test: the default LU divides by a coefficient that
    is zero upright and gives NaN.  Both of SymPy's return forms are checked.
    """
    km, P = example["system"], example["parameters"]
    num = {k: sm.Float(v, 20) for k, v in P.items()}
    v = sm.Symbol("v")
    by_name = {s.name: s for s in km.u}
    op = {s: 0 for s in list(km.q) + list(km.u)}
    op.update({by_name["u5"]: -v / num[sm.Symbol("rR")], by_name["u6"]: -v / num[sm.Symbol("rF")]})
    op.update({s.diff(): 0 for s in km.u})
    op.update(num)
    M, A, B, r = km.linearize(op_point=op, linear_solver="CRAMER")
    assert A.free_symbols == {v} and not M.free_symbols and B.shape == (0, 0) and len(r) == 0
    A_expl, _, _ = km.linearize(op_point=op, A_and_B=True, linear_solver="CRAMER")
    fM, fA, fX = (sm.lambdify(v, X, "numpy") for X in (M, A, A_expl))
    rows = [1, 2, 4, 5]     # phi, delta, u2, u4 of [psi, phi, delta, theta, u2, u4, u5, u1, u3, u6]
    cols = [1, 2, 3, 4]     # phi, delta, u2, u4 of the independent [psi, phi, delta, u2, u4, u5]
    for speed in (0.0, 1.0, 5.0, 10.0):
        full = np.linalg.solve(np.array(fM(speed), dtype=float), np.array(fA(speed), dtype=float))
        np.testing.assert_allclose(full[np.ix_(rows, cols)], _paper_lean_steer(speed), rtol=1e-12, atol=1e-12)
        explicit = np.array(fX(speed), dtype=float)       # [psi, phi, delta, u2, u4, u5] rows
        np.testing.assert_allclose(explicit[np.ix_([1, 2, 3, 4], cols)], _paper_lean_steer(speed),
                                   rtol=1e-12, atol=1e-12)
