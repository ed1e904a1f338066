"""Compiled model functions agree with SymPy's own mechanics classes at random states."""
import dataclasses

import numpy as np
import pytest
import sympy as sm
from sympy.physics import mechanics as me

from helpers import emit_support as es
from helpers import zoo
from eomc.compiler.emit import generate_c
from eomc.errors import ModelError

RNG = np.random.default_rng(20261122)


def _setup(formed, name, tmp_path_factory, **kw):
    gm = generate_c(formed, name, **kw)
    c = es.Compiled(gm, tmp_path_factory.mktemp(name))
    params = [s for s in formed.parameters]
    if kw.get("parameters"):
        params = list(kw["parameters"])
    return gm, c, es.Oracle(formed, params, formed.inputs)


@pytest.fixture(scope="module", params=[1, 2, 3, 4])
def cart(request, tmp_path_factory):
    n = request.param
    kane, spec = zoo.n_link_pendulum_on_cart(n, me)
    formed = es.kane_formed(kane, spec)
    return (n, kane, formed) + _setup(formed, f"cart{n}", tmp_path_factory)


def _random(formed, nsamp=5):
    for _ in range(nsamp):
        x = RNG.normal(size=formed.nq + formed.nu)
        p = RNG.uniform(0.5, 2.0, size=len(formed.parameters))
        r = RNG.normal(size=len(formed.inputs))
        yield RNG.uniform(-1, 1), x, p, r


def test_cart_rhs_matches_sympy(cart):
    n, kane, formed, gm, c, orc = cart
    assert gm.metadata["solver"] == "ldlt"
    for tv, x, p, r in _random(formed):
        status, xd = c.call("rhs", formed.nq + formed.nu, tv, x, p, r)
        assert status == 0
        assert es.rel_err(xd, orc.rhs(tv, x, p, r)) <= 1e-12


def test_cart_mass_forcing_inverse_dynamics(cart):
    n, kane, formed, gm, c, orc = cart
    nu = formed.nu
    for tv, x, p, r in _random(formed, 3):
        s1, M = c.call("mass_matrix", (nu, nu), tv, x, p, r)
        s2, f = c.call("forcing", nu, tv, x, p, r)
        a = (tv, x, p, r)
        assert s1 == s2 == 0
        assert es.rel_err(M, np.array(orc.A(*a), float)) <= 1e-12
        assert es.rel_err(f, np.array(orc.b(*a), float).ravel()) <= 1e-12
        udot = RNG.normal(size=nu)
        s3, tau = c.call("inverse_dynamics", nu, tv, x, p, r, extra=udot)
        assert s3 == 0
        assert es.rel_err(tau, M @ udot - f) <= 1e-12
        # inverse dynamics of the forward dynamics is zero
        s4, xd = c.call("rhs", 2 * nu, tv, x, p, r)
        s5, tau0 = c.call("inverse_dynamics", nu, tv, x, p, r, extra=xd[nu:])
        assert np.max(np.abs(tau0)) <= 1e-11 * max(1.0, np.max(np.abs(f)))


def _fd_jacobian(c, formed, tv, x, p, r, wrt="x", h=1e-6):
    nx = formed.nq + formed.nu
    base = x if wrt == "x" else r
    J = np.empty((nx, base.size))
    for k in range(base.size):
        e = np.zeros(base.size)
        e[k] = h
        args = [(x + e, r), (x - e, r)] if wrt == "x" else [(x, r + e), (x, r - e)]
        plus = c.call("rhs", nx, tv, args[0][0], p, args[0][1])[1]
        minus = c.call("rhs", nx, tv, args[1][0], p, args[1][1])[1]
        J[:, k] = (plus - minus) / (2 * h)
    return J


def test_cart_jacobians_match_finite_differences(cart):
    n, kane, formed, gm, c, orc = cart
    nx = formed.nq + formed.nu
    for tv, x, p, r in _random(formed, 2):
        sj, J = c.call("jac_x", (nx, nx), tv, x, p, r)
        sr, B = c.call("jac_r", (nx, 1), tv, x, p, r)
        assert sj == sr == 0
        assert es.rel_err(J, _fd_jacobian(c, formed, tv, x, p, r)) <= 1e-6
        assert es.rel_err(B, _fd_jacobian(c, formed, tv, x, p, r, "r")) <= 1e-6
        A2, B2 = np.full((nx, nx), np.nan), np.full((nx, 1), np.nan)
        ptr = c._ptr
        xs, ps, rs = (np.ascontiguousarray(v, float) for v in (x, p, r))
        sl = getattr(c.lib, f"{gm.name}_linearize")(tv, ptr(xs), ptr(ps), ptr(rs), ptr(A2), ptr(B2),
                                                     c.ffi.NULL)
        assert sl == 0 and np.array_equal(A2, J) and np.array_equal(B2, B)


def test_jacobian_matches_sympy_explicit_rhs_n1(tmp_path):
    kane, spec = zoo.n_link_pendulum_on_cart(1, me)
    formed = es.kane_formed(kane, spec)
    gm, c, _ = _setup(formed, "cart1j", _Factory(tmp_path))
    states = list(formed.coordinates) + list(formed.speeds)
    rhs = sm.Matrix.vstack(formed.kinematics, formed.dynamics_matrix.LUsolve(formed.dynamics_rhs))
    plain = sm.symbols("s0:4")
    F = spec[0]
    Fs = sm.Symbol("Fs")
    sub = dict(zip(states, plain))
    sub[F] = Fs
    J = rhs.xreplace(sub).jacobian(plain)
    Jr = rhs.xreplace(sub).jacobian([Fs])
    fJ = sm.lambdify([plain, list(formed.parameters), Fs], J)
    fB = sm.lambdify([plain, list(formed.parameters), Fs], Jr)
    for tv, x, p, r in _random(formed, 4):
        _, Jc = c.call("jac_x", (4, 4), tv, x, p, r)
        _, Bc = c.call("jac_r", (4, 1), tv, x, p, r)
        assert es.rel_err(Jc, np.array(fJ(x, p, r[0]), float)) <= 1e-12
        assert es.rel_err(Bc, np.array(fB(x, p, r[0]), float)) <= 1e-12


class _Factory:
    def __init__(self, path):
        self.path = path

    def mktemp(self, name):
        d = self.path / name
        d.mkdir()
        return d


@pytest.mark.parametrize("n", [1, 3])
def test_lagrange_cart_matches_kane(n, tmp_path):
    lm, spec = zoo.n_link_pendulum_on_cart_lagrange(n, me)
    formed = es.lagrange_formed(lm, spec)
    gm, c, orc = _setup(formed, f"lcart{n}", _Factory(tmp_path))
    assert gm.metadata["state_names"][n + 1] == "q0'"
    for tv, x, p, r in _random(formed, 4):
        status, xd = c.call("rhs", 2 * n + 2, tv, x, p, r)
        assert status == 0
        assert es.rel_err(xd, orc.rhs(tv, x, p, r)) <= 1e-12


def test_particle_on_sphere_with_multiplier(tmp_path):
    lm = es.particle_on_sphere()
    formed = es.lagrange_formed(lm)
    assert formed.multipliers
    gm, c, orc = _setup(formed, "sphere", _Factory(tmp_path))
    meta = gm.metadata
    assert meta["solver"] == "lu" and meta["nhol"] == 1 and meta["nvel"] == 1
    R, g, m = 1.3, 9.81, 0.7
    pmap = {"R": R, "g": g, "m": m}
    p = np.array([pmap[s.name] for s in formed.parameters])
    for _ in range(5):
        x = es.random_sphere_state(RNG, R)
        status, xd = c.call("rhs", 6, 0.0, x, p)
        assert status == 0
        assert es.rel_err(xd, orc.rhs(0.0, x, p)) <= 1e-12
        # closed form: a = -g e_z + λ r, with λ fixing r·a + v·v = 0
        r, v = x[:3], x[3:]
        lam = (g * r[2] - v @ v) / (r @ r)
        assert es.rel_err(xd[3:], -g * np.array([0, 0, 1.0]) + lam * r) <= 1e-12
        sc, con = c.call("constraints", 2, 0.0, x, p)
        assert sc == 0 and np.max(np.abs(con)) <= 1e-12
        sj, CJ = c.call("constraints_jac", (2, 6), 0.0, x, p)
        assert sj == 0
        assert es.rel_err(CJ[0], np.concatenate([2 * r, np.zeros(3)])) <= 1e-12


def test_rolling_disc_nonholonomic(tmp_path):
    kane, spec = zoo.rolling_disc(me)
    formed = es.kane_formed(kane, spec)
    assert formed.n_dependent_speeds == 3
    gm, c, orc = _setup(formed, "disc", _Factory(tmp_path))
    assert gm.metadata["solver"] == "lu" and gm.metadata["nvel"] == 3
    nx = formed.nq + formed.nu
    for tv, x, p, r in _random(formed, 5):
        status, xd = c.call("rhs", nx, tv, x, p, r)
        assert status == 0
        assert es.rel_err(xd, orc.rhs(tv, x, p, r)) <= 1e-12
    tv, x, p, r = next(_random(formed, 1))
    sj, J = c.call("jac_x", (nx, nx), tv, x, p, r)
    assert sj == 0 and es.rel_err(J, _fd_jacobian(c, formed, tv, x, p, r)) <= 1e-6


def test_singular_mass_matrix_is_reported(cart, tmp_path):
    n, kane, formed, gm, c, orc = cart
    names = [s.name for s in formed.parameters]
    p = np.ones(len(names))
    p[names.index(f"m{n}")] = 0.0          # massless last link: M has a zero row
    x = RNG.normal(size=formed.nq + formed.nu)
    for fn, shape in (("rhs", x.size), ("jac_x", (x.size, x.size)), ("jac_r", (x.size, 1))):
        status, _ = c.call(fn, shape, 0.0, x, p, np.zeros(1))
        assert status == 1, fn            # EOMC_SINGULAR_MASS_MATRIX
    p[:] = np.nan
    status, _ = c.call("rhs", x.size, 0.0, x, p, np.zeros(1))
    assert status == 3                    # EOMC_NONFINITE, never a silent NaN


def test_outputs_fold_and_parameter_order(tmp_path):
    kane, spec = zoo.n_link_pendulum_on_cart(1, me)
    formed = es.kane_formed(kane, spec)
    g, l0, m0, m1 = sm.symbols("g l0 m0 m1")
    q = formed.coordinates
    u = formed.speeds
    outs = {"height": l0 * sm.cos(q[1]), "qdot1": q[1].diff(me.dynamicsymbols._t) * m1}
    params = {m1: 2.0, l0: 0.5, g: 9.81, m0: 1.5}
    gm = generate_c(formed, "outs", parameters=params, outputs=outs)
    assert gm.metadata["param_names"] == ["m1", "l0", "g", "m0"]
    assert gm.metadata["param_defaults"] == [2.0, 0.5, 9.81, 1.5]
    assert gm.metadata["output_names"] == ["height", "qdot1"]
    c = es.Compiled(gm, tmp_path)
    x = np.array([0.1, 0.4, -0.2, 0.7])
    p = np.array([2.0, 0.5, 9.81, 1.5])
    st, out = c.call("outputs", 2, 0.0, x, p, np.zeros(1))
    assert st == 0 and np.allclose(out, [0.5 * np.cos(0.4), 0.7 * 2.0], rtol=1e-14)
    folded = generate_c(formed, "outsf", parameters=params, fold_parameters=True)
    assert folded.metadata["nparam"] == 0 and "p[" not in folded.c_source
    assert folded.metadata["folded_parameters"]["g"] == 9.81
    (tmp_path / "f").mkdir()
    cf = es.Compiled(folded, tmp_path / "f")
    _, a = c.call("rhs", 4, 0.0, x, p, np.array([0.3]))
    _, b = cf.call("rhs", 4, 0.0, x, np.zeros(0), np.array([0.3]))
    assert es.rel_err(a, b) <= 1e-13
    assert u  # speeds exist


def test_a_contacts_gap_events_are_generated_whatever_functions_were_asked():
    """Issue 29: a contact's penetration event is its switching function and its verdict; a
    build whose functions left out ``events`` had none, and Radau's grown step carried a
    sphere through the floor with status 0.  The gaps (contact_<name>) are always emitted,
    only they when ``events`` was not asked for; a model without contacts is unchanged."""
    kane, spec = zoo.n_link_pendulum_on_cart(1, me)
    formed = es.kane_formed(kane, spec)
    q = formed.coordinates
    gap, own = {"contact_cart": 0.1 - q[0]}, {"passing": q[1]}
    events = lambda gm: [e["name"] for e in gm.metadata.get("events", ())]  # noqa: E731
    reduced = generate_c(formed, "gaps", functions=("rhs",), events={**own, **gap})
    assert reduced.metadata["functions"] == ["rhs", "events"]
    assert events(reduced) == ["contact_cart"]          # the gaps only: O(contacts)
    asked = generate_c(formed, "gaps", functions=("rhs", "events"), events={**own, **gap})
    assert events(asked) == ["passing", "contact_cart"]
    assert events(generate_c(formed, "gaps", events={**own, **gap})) == ["passing", "contact_cart"]
    plain = generate_c(formed, "plain", functions=("rhs",), events=own)
    assert plain.metadata["functions"] == ["rhs"] and "events" not in plain.metadata
    assert "plain_events" not in plain.c_source


def test_bad_requests_name_the_problem():
    kane, spec = zoo.n_link_pendulum_on_cart(1, me)
    formed = es.kane_formed(kane, spec)
    with pytest.raises(ModelError, match="bogus"):
        generate_c(formed, "x", functions=["rhs", "bogus"])
    with pytest.raises(ModelError, match="zeta"):
        generate_c(formed, "x", parameters={sm.Symbol("zeta"): 1.0})
    with pytest.raises(ModelError, match="C identifier"):
        generate_c(formed, "3bad")
    with pytest.raises(ModelError, match="F"):
        generate_c(formed, "x", inputs=[])
    with pytest.raises(ModelError, match="k_spring"):
        generate_c(formed, "x", outputs={"e": sm.Symbol("k_spring") * formed.coordinates[0]})


@pytest.mark.parametrize("n", [2])
def test_eomc_front_end_formed_system(n, tmp_path):
    """eomc's own KanesMethod.formed() lowers to the same dynamics as SymPy's KanesMethod."""
    import eomc.mechanics as em
    ours, spec_o = zoo.n_link_pendulum_on_cart(n, em)
    theirs, spec_t = zoo.n_link_pendulum_on_cart(n, me)
    formed = ours.formed()
    gm = generate_c(formed, f"ecart{n}", functions=["rhs"])
    c = es.Compiled(gm, tmp_path)
    ref = es.kane_formed(theirs, spec_t)
    orc = es.Oracle(ref, list(ref.parameters), ref.inputs)
    assert [s.name for s in formed.parameters] == [s.name for s in ref.parameters]
    for tv, x, p, r in _random(ref, 4):
        status, xd = c.call("rhs", x.size, tv, x, p, r)
        assert status == 0
        assert es.rel_err(xd, orc.rhs(tv, x, p, r)) <= 1e-12


def _saddle_formed():
    """A·[u'; λ] = b with A = [[10 m, 1], [1, 0]]: nonsingular for every m, even m = 0,
    but the compile-time row order (10 m > 1 at the random point) has a zero pivot at m = 0."""
    from eomc.compiler.mechanics.formed import FormedSystem
    q, u = me.dynamicsymbols("q u")
    lam = me.dynamicsymbols("lam")
    m, k, c = sm.symbols("m k c")
    return FormedSystem(
        method="lagrange", coordinates=(q,), speeds=(u,), n_dependent_coordinates=0,
        n_dependent_speeds=0, kinematics=sm.Matrix([u]),
        dynamics_matrix=sm.Matrix([[10 * m, 1], [1, 0]]), dynamics_rhs=sm.Matrix([-k * q, c * u]),
        multipliers=(lam,), holonomic_constraints=sm.zeros(0, 1),
        velocity_constraints=sm.Matrix([u]), inputs=(), parameters=(c, k, m))


@pytest.mark.parametrize("mval", [1.3, 1e-3, 1e-30, 0.0])
def test_unrolled_lu_falls_back_to_pivoting(mval, tmp_path):
    formed = _saddle_formed()
    gm = generate_c(formed, "saddle", functions=["rhs", "jac_x"])
    assert gm.metadata["solver"] == "lu"
    assert "U[0] = F[0];" in gm.c_source          # unrolled path pivots on 10 m first
    c = es.Compiled(gm, tmp_path)
    x, p = np.array([0.4, -0.7]), np.array([0.9, 2.0, mval])      # c, k, m
    status, xd = c.call("rhs", 2, 0.0, x, p)
    assert status == 0
    # u' = c·u exactly (second row), whatever m is
    assert xd[0] == x[1] and abs(xd[1] - 0.9 * -0.7) <= 1e-15
    status, J = c.call("jac_x", (2, 2), 0.0, x, p)
    assert status == 0 and np.allclose(J, [[0, 1], [0, 0.9]], rtol=0, atol=1e-15)


def test_unrolled_lu_reports_singular(tmp_path):
    formed = _saddle_formed()
    A = sm.Matrix([[sm.Symbol("m"), 1], [sm.Symbol("m"), 1]])   # rank one for every m
    formed = type(formed)(**{**formed.__dict__, "dynamics_matrix": A})
    c = es.Compiled(generate_c(formed, "sing", functions=["rhs"]), tmp_path)
    status, _ = c.call("rhs", 2, 0.0, np.array([0.4, -0.7]), np.array([0.9, 2.0, 1.5]))
    assert status == 1


@pytest.mark.parametrize("build", [
    lambda: zoo.heavy_top(me),
    lambda: zoo.four_bar(me),
    lambda: zoo.spring_damper_chain(3, me),
], ids=["heavy_top", "four_bar", "spring_damper_chain"])
def test_zoo_rhs_and_constraints(build, tmp_path):
    kane, spec = build()
    formed = es.kane_formed(kane, spec)
    gm, c, orc = _setup(formed, "zoo", _Factory(tmp_path))
    nx = formed.nq + formed.nu
    ncon = len(formed.holonomic_constraints) + len(formed.velocity_constraints)
    con = sm.lambdify([es.t, orc.plain, list(formed.parameters)],
                      sm.Matrix.vstack(formed.holonomic_constraints, formed.velocity_constraints)
                      .xreplace(dict(zip(list(formed.coordinates) + list(formed.speeds), orc.plain))))
    for tv, x, p, r in _random(formed, 3):
        status, xd = c.call("rhs", nx, tv, x, p, r)
        assert status == 0
        assert es.rel_err(xd, orc.rhs(tv, x, p, r)) <= 1e-12
        if ncon:
            sc, res = c.call("constraints", ncon, tv, x, p, r)
            assert sc == 0
            assert es.rel_err(res, np.array(con(tv, x, p), float).ravel()) <= 1e-12
    tv, x, p, r = next(_random(formed, 1))
    sj, J = c.call("jac_x", (nx, nx), tv, x, p, r)
    assert sj == 0 and es.rel_err(J, _fd_jacobian(c, formed, tv, x, p, r)) <= 1e-6


@pytest.mark.parametrize("n, build", [
    (1, lambda: zoo.n_link_pendulum_on_cart(1, me)),
    (3, lambda: zoo.n_link_pendulum_on_cart(3, me)),
    ("top", lambda: zoo.heavy_top(me)),
    ("fourbar", lambda: zoo.four_bar(me)),
])
def test_tangent_loop_jacobian(n, build, tmp_path, monkeypatch):
    """Above TANGENT_MIN_STATES jac_x loops tangent programs (one for the coordinates'
    columns, one for the speeds') over columns; same values as the unrolled form."""
    from eomc.compiler.emit import symbolic
    kane, spec = build()
    formed = es.kane_formed(kane, spec)
    unrolled = generate_c(formed, f"unr{n}", functions=["jac_x", "rhs"])
    monkeypatch.setattr(symbolic, "TANGENT_MIN_STATES", 0)
    looped = generate_c(formed, f"loop{n}", functions=["jac_x", "rhs"])
    assert "dx[k] = 1.0;" in looped.c_source and "dx[" not in unrolled.c_source
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    cu, cl = es.Compiled(unrolled, tmp_path / "a"), es.Compiled(looped, tmp_path / "b")
    nx = formed.nq + formed.nu
    for tv, x, p, r in _random(formed, 3):
        su, Ju = cu.call("jac_x", (nx, nx), tv, x, p, r)
        sl, Jl = cl.call("jac_x", (nx, nx), tv, x, p, r)
        assert su == sl == 0
        assert es.rel_err(Jl, Ju) <= 1e-12
        assert es.rel_err(Jl, _fd_jacobian(cl, formed, tv, x, p, r)) <= 1e-6


def test_loop_ldlt_for_large_dense_mass_matrices(tmp_path, monkeypatch):
    """Above UNROLL_MAX_DENSE a dense M is factored by loops; same values, same errors."""
    from eomc.compiler.emit import linsolve
    monkeypatch.setattr(linsolve, "UNROLL_MAX_DENSE", 0)
    kane, spec = zoo.n_link_pendulum_on_cart(3, me)
    formed = es.kane_formed(kane, spec)
    gm, c, orc = _setup(formed, "ldlloop", _Factory(tmp_path))
    assert "for (j = 0; j < 4; j++)" in gm.c_source
    nx = formed.nq + formed.nu
    for tv, x, p, r in _random(formed, 3):
        status, xd = c.call("rhs", nx, tv, x, p, r)
        assert status == 0 and es.rel_err(xd, orc.rhs(tv, x, p, r)) <= 1e-12
        sj, J = c.call("jac_x", (nx, nx), tv, x, p, r)
        assert sj == 0 and es.rel_err(J, _fd_jacobian(c, formed, tv, x, p, r)) <= 1e-6
    names = [s.name for s in formed.parameters]
    p = np.ones(len(names))
    p[names.index("m3")] = 0.0
    assert c.call("rhs", nx, 0.0, np.ones(nx), p, np.zeros(1))[0] == 1


def test_jac_r_when_the_mass_matrix_depends_on_an_input(tmp_path):
    """A payload mass given as an input enters M: jac_r must use dA/dr and the solved u'."""
    x, th = me.dynamicsymbols("x th")
    v, w = me.dynamicsymbols("v w")
    payload, push = me.dynamicsymbols("payload push")
    m, l, k, g = sm.symbols("m l k g", positive=True)
    N = me.ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    B.set_ang_vel(N, w * N.z)
    O = me.Point("O")
    O.set_vel(N, 0)
    cart = O.locatenew("C", x * N.x)
    cart.set_vel(N, v * N.x)
    bob = cart.locatenew("P", l * B.y)
    bob.v2pt_theory(cart, N, B)
    bodies = [me.Particle("cart", cart, m), me.Particle("bob", bob, m + payload)]
    loads = [(cart, (push - k * x) * N.x), (bob, -(m + payload) * g * N.y)]
    kane = me.KanesMethod(N, [x, th], [v, w], kd_eqs=[x.diff() - v, th.diff() - w])
    kane.kanes_equations(bodies, loads)
    formed = es.kane_formed(kane, [payload, push])
    # SymPy's Fr* differentiates the momentum (m + payload) v; a payload changing in
    # time is not this test's point, so its rate is dropped: M(q, r) u' = f(q, u, r)
    formed = dataclasses.replace(formed, dynamics_rhs=formed.dynamics_rhs.subs(payload.diff(), 0))
    assert formed.dynamics_matrix.has(payload)
    gm, c, _ = _setup(formed, "payload", _Factory(tmp_path), functions=["rhs", "jac_r"])
    for tv, xs, p, r in _random(formed, 3):
        r = np.array([0.5 + abs(r[0]), r[1]])      # a payload, not a negative mass
        status, B_ = c.call("jac_r", (4, 2), tv, xs, p, r)
        assert status == 0
        assert es.rel_err(B_, _fd_jacobian(c, formed, tv, xs, p, r, "r")) <= 1e-6
