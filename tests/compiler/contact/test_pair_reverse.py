"""Reverse sweeps and second derivatives through body–body contact pairs (issues 30 and 33): the
routines' ``_bar`` / ``_bar_dot`` variants (compiler/contact/narrow.py), the pair table's reverse
twin ``eomc_pairs_bar`` and its tangent (compiler/contact/table.py), the adjoint pass's rule for
called routines (compiler/passes/adjoint.py).  vjp against jac_xᵀ·w and jac_pᵀ·w, hvp against
central differences of jac_x, hess_id against central differences of jac_id, at states of a tree's
limbs (capsule and sphere self-pairs, the humanoid's kinds) of which some are pressed (depth > 0
asserted), through the table; vjp through the called narrow and law routines and the inlined
schemes; and the adjoint gradient of a run through pressed contacts against its forward
sensitivities."""
import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco")

import eomc  # noqa: E402
import eomc.compiler.contact.pairs as pairs  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel  # noqa: E402

# a chain's limbs (one tree: self-pairs) and a free ball: capsule–capsule, sphere–capsule,
# capsule–sphere and sphere–sphere pairs
from .test_narrow import LIMBS  # noqa: E402

SECOND = ("rhs", "jac_x", "jac_p", "vjp", "hvp", "jac_id", "hess_id", "outputs")


def _build(tmp_path, monkeypatch, tag, functions, **switches):
    monkeypatch.setattr(pairs, "TABLE_FROM", 1)         # the table for any number of pairs
    for name, value in switches.items():
        monkeypatch.setattr(pairs, name, value)
    path = tmp_path / "limbs.xml"
    path.write_text(LIMBS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path, pairs=True), "limbs", functions=functions,
                            cache_dir=tmp_path / tag, progress=False)


@pytest.fixture(scope="module")
def table_limbs(tmp_path_factory):
    """(model, its C): the limbs through the pair table (TABLE_FROM 1) with every function the table's
    tests read -- one build for three tests (CI time: each build of it is ~10 s of gcc)."""
    tmp = tmp_path_factory.mktemp("table")
    with pytest.MonkeyPatch.context() as mp:
        model = _build(tmp, mp, "table", SECOND + ("jvp",), PAIR_TABLE=True)
    return model, next((tmp / "table").rglob("limbs.c")).read_text()


def _states(model, n):
    """n states, the first of them with some self-pair pressed (asserted), the rest random."""
    names = list(model.output_names)
    depths = [i for i, k in enumerate(names) if k.startswith("depth_") and "__" in k]
    X = np.random.default_rng(5).normal(scale=0.6, size=(400, model.nx))
    X[:, 2] += 0.3
    d = np.array([np.array(list(model.outputs(0.0, x).values()))[depths] for x in X])
    pressed = X[(d > 0).any(axis=1)]
    assert len(pressed) >= n
    return np.vstack([pressed[:n], X[(d <= 0).all(axis=1)][:n]])


def _check_vjp(model, x, rng):
    w = rng.standard_normal(model.nx)
    xdot, gx, gp = model.vjp(0.0, x, w)
    J, Jp = model.jac_x(0.0, x), model.jac_p(0.0, x)
    assert np.abs(xdot - model.rhs(0.0, x)).max() <= 1e-12 * (1 + np.abs(xdot).max())
    assert np.abs(gx - J.T @ w).max() <= 1e-11 * np.abs(J.T @ w).max()     # measured ≤ 1.3e-13
    assert np.abs(gp - Jp.T @ w).max() <= 1e-11 * np.abs(Jp.T @ w).max()   # measured ≤ 6e-16


def _differences(f, x, v, h=1e-4):
    """d f(x + s v)/ds at 0 by central differences with Richardson's step (error O(h⁴)), h large
    so that rounding stays small: with the contacts' stiff entries (jac_x ~3e8 pressed), plain
    differences at h = 1e-6 were 1.6e-6 relative off hvp (test_few_pairs...); these, ≤ 4.4e-8."""
    def central(step):
        return (f(x + step * v) - f(x - step * v)) / (2 * step)
    return (4 * central(h / 2) - central(h)) / 3


def _check_hvp(model, x, rng):
    w, v = rng.standard_normal(model.nx), rng.standard_normal(model.nx)
    fd = _differences(lambda y: model.jac_x(0.0, y), x, v).T @ w
    hv = model.hvp(0.0, x, w, v)
    assert np.abs(hv - fd).max() <= 1e-6 * np.abs(fd).max()      # measured ≤ 4.4e-8


def _check_hess_id(model, x, rng):
    a = rng.standard_normal(model.nu)
    H = model.hess_id(0.0, x, a)
    fd = np.stack([_differences(lambda y: model.jac_id(0.0, y, a), x, e) for e in np.eye(model.nx)], axis=2)
    assert np.abs(H - fd).max() <= 1e-6 * np.abs(fd).max()        # measured ≤ 7e-8


def test_through_the_pair_table(table_limbs):
    """The table (the default for MJCF self-pairs): vjp by eomc_pairs_bar, hvp and hess_id by its
    tangent eomc_pairs_bar_dot, at pressed and apart states."""
    model, source = table_limbs
    assert "eomc_pairs_bar(" in source and "eomc_pairs_bar_dot(" in source
    assert "eomc_narrow_capsule_capsule_bar(" in source and "eomc_pair_law_bar_dot(" in source
    rng = np.random.default_rng(0)
    for x in _states(model, 3):
        _check_vjp(model, x, rng)
        _check_hvp(model, x, rng)
        _check_hess_id(model, x, rng)


# two limbs that reach the trunk: 2 self-pairs (capsule–capsule, sphere–capsule), fewer points than
# pairs.TABLE_FROM: inlined by default
ARM = """<mujoco model="arm"><worldbody>
<body name="base" pos="0 0 0.3"><freejoint/><geom name="trunk" type="capsule" fromto="-0.1 0 0 0.1 0 0" size="0.04"/>
 <body name="l1" pos="0.1 0 0"><joint name="j1" type="ball"/><geom name="arm1" type="capsule" fromto="0 0 0 0.1 0.1 0" size="0.03"/>
  <body name="l2" pos="0.1 0.1 0"><joint name="j2" type="hinge" axis="0 0 1"/><geom name="arm2" type="capsule" fromto="0 0 0 -0.15 0 0" size="0.03"/>
   <geom name="hand" type="sphere" pos="-0.15 0 0" size="0.035"/></body></body></body>
</worldbody></mujoco>"""


def test_few_pairs_inlined_and_through_the_table_for_second_derivatives(tmp_path):
    """A few pairs (fewer points than pairs.TABLE_FROM) stay inlined for vjp (the schemes' |x|
    clamps through the adjoint pass: sign's derivative taken 0), and go through the table when hvp
    or hess_id is asked (inlined, the law's δ₊^{3/2} has a NaN second derivative out of contact)."""
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    built = {}
    for tag, functions in (("first", ("rhs", "jac_x", "jac_p", "vjp", "outputs")), ("second", SECOND)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            built[tag] = eomc.compile(MjcfModel(path, pairs=True), "arm", functions=functions,
                                      cache_dir=tmp_path / tag, progress=False)
    first = next((tmp_path / "first").rglob("arm.c")).read_text()
    second = next((tmp_path / "second").rglob("arm.c")).read_text()
    assert "eomc_pairs(" not in first and "eomc_narrow_" not in first
    assert "eomc_pairs_bar_dot(" in second
    model = built["second"]
    names = list(model.output_names)
    depths = [i for i, k in enumerate(names) if k.startswith("depth_") and "__" in k]
    assert len(depths) == 2
    rng = np.random.default_rng(3)
    X = rng.normal(scale=0.8, size=(600, model.nx))
    X[:, 2] += 0.3
    d = np.array([np.array(list(model.outputs(0.0, x).values()))[depths] for x in X])
    pressed = X[(d > 0).any(axis=1)]
    assert len(pressed) >= 2
    for x in list(pressed[:2]) + list(X[(d <= 0).all(axis=1)][:2]):
        _check_vjp(built["first"], x, rng)
        _check_vjp(model, x, rng)
        _check_hvp(model, x, rng)
        _check_hess_id(model, x, rng)


@pytest.mark.parametrize("switches", [{"INLINE_NARROW": False}, {"LAW_ROUTINES": True}],
                         ids=["narrow_routines", "law_routines"])
def test_vjp_through_called_routines(tmp_path, monkeypatch, switches):
    """Without the table: each pair a call of its narrow routine, also with the law routine: vjp by
    their ``_bar`` variants (NarrowBar)."""
    model = _build(tmp_path, monkeypatch, "called", ("rhs", "jac_x", "jac_p", "vjp", "outputs"),
                   PAIR_TABLE=False, **switches)
    source = next((tmp_path / "called").rglob("limbs.c")).read_text()
    assert "eomc_narrow_capsule_capsule_bar(" in source and "eomc_pairs" not in source
    assert ("eomc_pair_law_bar(" in source) == ("LAW_ROUTINES" in switches)
    rng = np.random.default_rng(1)
    for x in _states(model, 2):
        _check_vjp(model, x, rng)


def test_adjoint_gradient_through_contacts_is_the_sensitivities(table_limbs):
    """eomc.gradient (vjp through the table) of a terminal cost wᵀx(T) equals the forward
    sensitivities' dx(T)/dx0ᵀ w (1e-14 measured), on an RK4 run whose limbs press each other at
    every step (from the shallowest pressed state of _states', speeds scaled by 0.1: deeper, the
    stiff contact needs a smaller step than 1e-5 s)."""
    from eomc.runtime.adjoint import simulate_grid
    model = table_limbs[0]
    names = list(model.output_names)
    depths = [i for i, k in enumerate(names) if k.startswith("depth_") and "__" in k]

    def deepest(x):
        return np.array(list(model.outputs(0.0, x).values()))[depths].max()
    X = _states(model, 20)[:20]
    x0 = X[np.argmin([deepest(x) for x in X])].copy()
    x0[model.nq:] *= 0.1
    w = np.random.default_rng(2).standard_normal(model.nx)
    T, dt = 0.01, 1e-5

    def cost(t, X):
        G = np.zeros_like(X)
        G[-1] = w
        return float(w @ X[-1]), G
    g = eomc.gradient(model, x0, T, dt=dt, cost=cost)
    assert all(deepest(x) > 0 for x in simulate_grid(model, x0, T, dt=dt)[1])
    res = model.simulate(x0, (0.0, T), method="rk4", dt=dt, sensitivities="x0", t_eval=[0.0, T], events=False)
    want = res.dx_dx0[-1].T @ w
    assert np.abs(g.dx0 - want).max() <= 1e-10 * np.abs(want).max()


@pytest.mark.parametrize("table", [True, False])
def test_jvp_through_pairs_builds_and_is_the_jacobians_product(tmp_path, monkeypatch, request, table):
    """jvp (forward sensitivities' call) on a tree with self-pairs, through the table and inlined:
    its C compiled (it did not before: the lanes over directions dropped the table tangent's output
    array, the parameter columns' function took that array and a compound literal's type for
    arguments), and J·d + Jp·dp at pressed and apart states, 1, 3 and 5 directions (the lanes'
    groups and a lone direction)."""
    if table:
        model, source = request.getfixturevalue("table_limbs")
    else:
        monkeypatch.setattr(pairs, "TABLE_FROM", 10 ** 6)
        path = tmp_path / "limbs.xml"
        path.write_text(LIMBS)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(MjcfModel(path, pairs=True), "limbs",
                                 functions=("rhs", "jac_x", "jac_p", "jvp", "outputs"), cache_dir=tmp_path / "c",
                                 progress=False)
        source = next((tmp_path / "c").rglob("limbs.c")).read_text()
    assert ("eomc_pairs_dot(" in source) == table
    rng = np.random.default_rng(3)
    for x in _states(model, 3):
        J, Jp = model.jac_x(0.0, x), model.jac_p(0.0, x)
        for k in (1, 3, 5):
            D = rng.standard_normal((k, model.nx + model.nparam))
            D[:, model.nx:] *= rng.random((k, model.nparam)) < 0.2          # a few parameters per direction
            xdot, out = model.jvp(0.0, x, D)
            ref = D[:, :model.nx] @ J.T + D[:, model.nx:] @ Jp.T
            assert np.abs(xdot - model.rhs(0.0, x)).max() <= 1e-12 * (1 + np.abs(xdot).max())
            assert np.abs(out - ref).max() <= 1e-11 * np.abs(ref).max()
