"""Extra first-order states (``states = {z: dz/dt}``) in both formulations, against SymPy.

The oracle: the same System formed by sympy.physics.mechanics (Kane), its
``mass_matrix_full``/``forcing_full`` and the states' rates lambdified, at random
states.  The mechanics depends on the states (joint torques k·z) and the states'
rates on q, u, z, q' and the inputs, so every block of jac_x and jac_r is exercised:
the rows of z' against SymPy's symbolic Jacobian, the whole matrix against central
differences of rhs and across the two formulations.  n = 2 unrolls jac_x; n = 5 has
16 states, so jac_x runs its tangent program per column (the z columns in the
speeds' block).
"""
import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as sme

import eomc
import eomc.mechanics as em
from helpers.state_models import torque_chain

RNG = np.random.default_rng(22)


def _sympy_oracle(n):
    """(f(x, r), dzdx(x, r), dzdr(x, r), names) from SymPy's own Kane equations."""
    d = torque_chain(n, sme)
    system = d["system"]
    system.form_eoms()
    q, u, z, e = d["q"], d["u"], d["z"], d["e"]
    p = d["parameters"]
    qd = {qi.diff(): ui for qi, ui in zip(q, u)}
    rates = sm.Matrix([sm.sympify(d["states"][zi]).xreplace(qd) for zi in z]).xreplace(p)
    M = system.mass_matrix_full.xreplace(p)
    F = system.forcing_full.xreplace(p)
    x = list(q) + list(u) + list(z)
    mf = sm.lambdify((x, e), (M, F), cse=True)
    zf = sm.lambdify((x, e), (rates, rates.jacobian(x), rates.jacobian(e)), cse=True)

    def f(xv, rv):
        Mv, Fv = mf(xv, rv)
        zd = zf(xv, rv)[0]
        return np.concatenate([np.linalg.solve(np.asarray(Mv, float), np.asarray(Fv, float)).ravel(),
                               np.asarray(zd, float).ravel()])

    def jz(xv, rv):
        _, jx, jr = zf(xv, rv)
        return np.asarray(jx, float), np.asarray(jr, float)
    return f, jz, [str(s).replace("(t)", "") for s in x]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    out = {}
    for n in (2, 5):
        d = torque_chain(n, em)
        for form in ("kane", "recursive"):
            out[n, form] = eomc.compile(d["system"], parameters=d["parameters"], inputs=d["inputs"],
                                        states=d["states"], formulation=form, cache_dir=cache,
                                        name=f"chain{n}_{form}")
        out[n, "sympy"] = _sympy_oracle(n)
    return out


def _fd(fun, x, h=1e-6):
    cols = []
    for k in range(x.size):
        e = np.zeros(x.size)
        e[k] = h
        cols.append((fun(x + e) - fun(x - e)) / (2 * h))
    return np.array(cols).T


@pytest.mark.parametrize("n", [2, 5])
@pytest.mark.parametrize("form", ["kane", "recursive"])
def test_rhs_and_jacobians_match_sympy(built, n, form):
    model = built[n, form]
    f, jz, names = built[n, "sympy"]
    assert model.state_names == tuple(names)
    assert model.nx == 3 * n + 1 and model.nq == n and model.nu == n
    first_z = 2 * n
    for _ in range(3):
        x = RNG.uniform(-1.0, 1.0, model.nx)
        r = RNG.uniform(-1.0, 1.0, model.ninput)
        want = f(x, r)
        got = model.rhs(0.0, x, r=r)
        assert np.max(np.abs(got - want)) <= 1e-12 * max(1.0, np.max(np.abs(want)))
        J, B = model.linearize(0.0, x, r=r)
        np.testing.assert_array_equal(J, model.jacobian(0.0, x, r=r))
        jx, jr = jz(x, r)     # z' rows: SymPy's symbolic Jacobian
        np.testing.assert_allclose(J[first_z:], jx, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(B[first_z:], jr, rtol=1e-12, atol=1e-12)
        scale = max(1.0, np.max(np.abs(J)))
        Jfd = _fd(lambda xx: f(xx, r), x)
        assert np.max(np.abs(J - Jfd)) <= 1e-6 * scale
        assert np.max(np.abs(J[:, first_z:])) > 0.1   # the mechanics does depend on z
        Bfd = _fd(lambda rr: f(x, rr), r)
        assert np.max(np.abs(B - Bfd)) <= 1e-6 * max(1.0, np.max(np.abs(B)))


@pytest.mark.parametrize("n", [2, 5])
def test_formulations_agree_on_jacobians(built, n):
    x = RNG.uniform(-1.0, 1.0, built[n, "kane"].nx)
    r = RNG.uniform(-1.0, 1.0, built[n, "kane"].ninput)
    Jk, Bk = built[n, "kane"].linearize(0.0, x, r=r)
    Jr, Br = built[n, "recursive"].linearize(0.0, x, r=r)
    assert np.max(np.abs(Jk - Jr)) <= 1e-11 * max(1.0, np.max(np.abs(Jk)))
    assert np.max(np.abs(Bk - Br)) <= 1e-11 * max(1.0, np.max(np.abs(Bk)))


def test_metadata_and_header_name_the_states(built):
    model = built[2, "kane"]
    header = (model.directory / f"{model.name}.h").read_text()
    assert "then nz = 3 extra first-order states" in header
    assert "[4] z1" in header and "[6] s" in header
    assert model.input_names == ("e1", "e2")
    assert {"tau1", "tau2", "c"} <= set(model.param_names)


@pytest.mark.parametrize("form", ["kane", "recursive"])
def test_generated_c_is_strict_c99_and_deterministic(built, form, tmp_path):
    """The C with extra states compiles with -Wall -Wextra -Werror, and the same input
    generates the same bytes (no cache: generated twice)."""
    import subprocess
    from eomc.compiler.driver import generate
    from helpers.emit_support import HEADER_DIR, STRICT
    model = built[2, form]
    source = model.directory / f"{model.name}.c"
    proc = subprocess.run(["cc", *STRICT, "-I", HEADER_DIR, "-I", str(model.directory), "-c",
                           str(source), "-o", str(tmp_path / "m.o")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    d = torque_chain(2, em)
    texts = [generate(d["system"], "twice", parameters=d["parameters"], inputs=d["inputs"],
                      states=d["states"], formulation=form, use_cache=False)[1].c_source
             for _ in range(2)]
    assert texts[0] == texts[1] and "xdot[6]" in texts[0]


LAGRANGE = '''
import sympy as sm
from eomc.mechanics import *
q = dynamicsymbols("q"); qd = q.diff()
z, e = dynamicsymbols("z e")
m, l, g, k, tau = sm.symbols("m l g k tau")
N = ReferenceFrame("N"); A = N.orientnew("A", "Axis", [q, N.z]); A.set_ang_vel(N, qd * N.z)
O = Point("O"); O.set_vel(N, 0); P = O.locatenew("P", l * A.x); P.v2pt_theory(O, N, A)
bob = Particle("bob", P, m); bob.potential_energy = m * g * P.pos_from(O).dot(N.y)
lm = LagrangesMethod(Lagrangian(N, bob), [q], forcelist=[(A, k * z * N.z)], frame=N)
lm.form_lagranges_equations()
system = lm
parameters = {m: 1.0, l: 0.5, g: 9.81, k: 2.0, tau: 0.1}
inputs = [e]
states = {z: (e - z) / tau + qd}        # a Lagrange speed is q': allowed in z'
'''


def test_lagrange_model_with_a_state_matches_closed_form(tmp_path):
    path = tmp_path / "lag_z.py"
    path.write_text(LAGRANGE)
    model = eomc.compile(path, cache_dir=tmp_path / "cache")
    assert model.state_names == ("q", "q'", "z")
    x, r = np.array([0.3, 0.7, 0.2]), [1.0]
    want = [0.7, (-9.81 * 0.5 * np.cos(0.3) + 2.0 * 0.2) / 0.25, (1.0 - 0.2) / 0.1 + 0.7]
    np.testing.assert_allclose(model.rhs(0.0, x, r=r), want, rtol=1e-14)
    J = model.jacobian(0.0, x, r=r)
    np.testing.assert_allclose(J[2], [0.0, 1.0, -10.0], atol=1e-14)
    np.testing.assert_allclose(J[1], [9.81 * 0.5 * np.sin(0.3) / 0.25, 0.0, 2.0 / 0.25], rtol=1e-13)
