"""The analytic RNEA derivatives (compiler/tree/analytic.py) behind jac_id and jac_x.

Checked, compiled, against references that do not share its algorithm: central
differences of the compiled inverse_dynamics and rhs on random branching trees with
pins, sliders, balls and free joints (hypothesis), the tangent path of the same
functions (the code the analytic path replaces, itself checked against central
differences and Pinocchio), and Pinocchio's computeRNEADerivatives and
computeABADerivatives on real robots (on a floating base Pinocchio differentiates
along its Lie-group tangent: its d/dq is ours times K = dq'/du).  A SymPy tree whose loads
depend on the state (a joint spring) keeps the tangent path, still right; a URDF's joint
laws (soft limits) are the kernel's own terms.
"""
import warnings

import numpy as np
import pinocchio as pin
import pytest
import sympy as sm
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import eomc
from eomc.compiler.emit.symbolic import TANGENT_MIN_STATES
from eomc.compiler.tree.recognize import tree_of
from eomc.compiler.urdf import from_urdf
from eomc.errors import ModelError
from helpers import random_trees
from helpers.robots import PinRef, joints_of, relative_error, robot_path
from helpers.trees import add_joint_spring, cart_joints

FNS = ["rhs", "jac_x", "inverse_dynamics", "jac_id"]


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))


def analytic(model):
    return "_rnea_derivs(" in model.source_path.read_text()


def inputs_callers(model):
    """The functions whose body calls NAME_dyn_inputs, and how many bodies store an[0]
    (the kernels' inputs written once: jac_x and jac_id beside each other share them)."""
    text = model.source_path.read_text()
    call = f"{model.name}_dyn_inputs(t, x, p, r, an);"
    callers = [fn for fn in ("jac_x", "jac_id", "mass_matrix", "forcing", "inverse_dynamics")
               if f"int {model.name}_{fn}(" in text
               and call in text[text.index(f"int {model.name}_{fn}("):].split("\n}\n", 1)[0]]
    return callers, text.count("an[0] = ")


def central(f, x, nx):
    cols = []
    for k in range(nx):
        h = 1e-6 * max(1.0, abs(x[k]))
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        cols.append((f(up) - f(dn)) / (2 * h))
    return np.array(cols).T


def worst(model, seed, nstates=3):
    """Largest relative error of jac_id and jac_x against central differences."""
    rng = np.random.default_rng(seed)
    out = 0.0
    for _ in range(nstates):
        x, ud = rng.uniform(-1, 1, model.nx), rng.normal(size=model.nu)
        r = rng.normal(size=model.ninput) if model.ninput else None
        for J, ref in ((model.jac_id(0.0, x, ud, r=r),
                        central(lambda y: model.inverse_dynamics(0.0, y, ud, r=r), x, model.nx)),
                       (model.jac_x(0.0, x, r=r), central(lambda y: model.rhs(0.0, y, r=r), x, model.nx))):
            out = max(out, np.max(np.abs(J - ref)) / max(1.0, np.max(np.abs(ref))))
    return out


@settings(max_examples=6, deadline=None, derandomize=True, phases=(Phase.explicit, Phase.generate),
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=random_trees.tree(max_bodies=5, free=True), seed=st.integers(0, 2**32 - 1))
def test_random_trees_against_central_differences(spec, seed):
    """Loads between a body and its parent body only (a free root's load would act against the
    ground, a world-frame load: the tangent path's, tests/compiler/tree/test_inverse_derivatives.py)."""
    spec = [dict(b, load=b["load"] and b["kind"] != "free") for b in spec]
    system, inputs = random_trees.build(spec)
    try:
        model = eomc.compile(system, "ran", inputs=inputs, functions=FNS, formulation="recursive",
                             progress=False)
    except ModelError as exc:       # a speed nothing resists: refused (test_agreement)
        assert "no inertia" in str(exc)
        return
    # loads in body frames that do not depend on the state: the analytic path above
    # TANGENT_MIN_STATES states (a ball joint's torque is read as a world-frame load)
    body_loads = all(load.frame == "body" for load in tree_of(system).loads)
    assert analytic(model) == (model.nx > TANGENT_MIN_STATES and body_loads)
    assert worst(model, seed) < 1e-6


def test_small_models_keep_the_unrolled_columns():
    """At most TANGENT_MIN_STATES states the unrolled derivatives are faster: unchanged C."""
    system, _ = cart_joints(4, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, "acart4", functions=FNS, formulation="recursive", progress=False)
    assert model.nx <= TANGENT_MIN_STATES and not analytic(model)


def test_cart_and_kernel_is_one_function():
    """The kernel is emitted once, and its text does not grow with the number of links:
    only its tables and the straight-line inputs do."""
    sizes = {}
    for n in (12, 18):         # both deep enough for the articulated solve (analytic.choose_solver)
        system, _ = cart_joints(n, rigid=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(system, f"acart{n}", functions=FNS, formulation="recursive", progress=False)
        text = model.source_path.read_text()
        assert text.count(f"static void acart{n}_rnea_derivs(") == 1
        assert text.count(f"acart{n}_rnea_derivs(an, ") == 2          # jac_x and jac_id
        start = text.index(f"static void acart{n}_rnea_derivs(")
        sizes[n] = text[start:text.index("\n}\n", start)].count("\n")
        assert worst(model, seed=n) < 1e-7
    assert sizes[12] == sizes[18]


def test_state_dependent_loads_keep_the_tangent_path():
    """A joint spring and damper (a load in q and u): the tangent path, still right."""
    system, _ = cart_joints(7, rigid=True)
    add_joint_spring(system, 1, *sm.symbols("k_s c_s"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, "aspring", functions=FNS, formulation="recursive", progress=False)
    assert not analytic(model)
    assert worst(model, seed=7) < 1e-7


def test_joint_laws_take_the_analytic_path():
    """A URDF read with its limits on (the default): every joint's soft limit (and Panda's
    fingers' slides) is a joint law, a load in its own q and u; the kernel takes its value as
    a constant load and adds its own derivative on its row (analytic._joint_laws).  Checked
    against central differences at states far past the limits (|q| up to 3 rad; the fingers
    open 0..0.04 m) and inside them, jac_x and jac_id, inputs nonzero."""
    from eomc.compiler.urdf.model import with_options
    source, _ = with_options(str(robot_path("panda")), None, floating_base=False)
    model = eomc.compile(source, "panda_laws", functions=FNS, progress=False)
    text = model.source_path.read_text()
    assert analytic(model) and "the joint laws:" in text
    rng = np.random.default_rng(41)
    p = dict(zip(model.param_names, model.param_defaults))
    joints = [n.removeprefix("q_") for n in model.state_names[:model.nq]]
    lo = np.array([p.get(f"limit_lo_{j}", -np.inf) for j in joints])
    hi = np.array([p.get(f"limit_hi_{j}", np.inf) for j in joints])
    past = 0
    for scale in (3.0, 0.5):
        x, ud, r = rng.uniform(-scale, scale, model.nx), rng.normal(size=model.nu), rng.normal(size=model.ninput)
        past += int(np.sum((x[:model.nq] < lo) | (x[:model.nq] > hi)))
        for J, ref in ((model.jac_x(0.0, x, r=r), central(lambda y: model.rhs(0.0, y, r=r), x, model.nx)),
                       (model.jac_id(0.0, x, ud, r=r),
                        central(lambda y: model.inverse_dynamics(0.0, y, ud, r=r), x, model.nx))):
            assert np.max(np.abs(J - ref)) / max(1.0, np.max(np.abs(ref))) < 1e-7
    assert past >= 2        # joints past their limits, where the laws act


def test_law_slopes_are_sympys_derivatives():
    """analytic._law_slopes differentiates one law per shape and renames the symbols back:
    for laws of every kind (two-sided, one-sided, unilateral with its smooth push, held,
    damping and friction, each with its own joint's symbols) the result is the very
    expression sm.diff gives, and laws of one shape share one differentiation, also when
    they differ in a Float coefficient (the held laws' (G - 1)·w, MJCF's per joint)."""
    from eomc.compiler.tree.analytic import _law_slopes
    from eomc.compiler.tree.joint_laws import JointLaw, joint_torque
    kinds = [dict(lower=-1.0, upper=1.0), dict(lower=-1.0, upper=1.0), dict(upper=0.5, damping=0.2),
             dict(lower=-0.3, upper=0.4, unilateral=True, friction=0.1), dict(lower=0.0, upper=2.0, hold=(3.0, 0.01)),
             dict(lower=-0.5, upper=1.5, hold=(4.5, 0.02)), dict(damping=0.5, friction=0.3)]
    memo = {}
    for j, kw in enumerate(kinds):
        q, u = sm.symbols(f"x_{j} x_{40 + j}", real=True)
        tau = joint_torque(q, u, JointLaw(f"j{j}", **kw),
                           lambda name, v, keep=False: sm.Symbol(f"p_{name}", real=True), f"j{j}", 0.3)
        dq, du = _law_slopes(tau, q, u, memo)
        assert dq == sm.diff(tau, q) and du == sm.diff(tau, u)
        assert (dq != 0) == ("lower" in kw or "upper" in kw)
    assert len(memo) == len(kinds) - 2          # the first two laws have one shape, the held two another


def test_named_law_slopes_expand_to_sympys_derivatives():
    """With a recorder's ``let`` (how the default build asks, analytic.analytic_plan), each
    law's slopes come back, once asked for (the plan being sure), as names; their recorded
    definitions, substituted back, are the very expressions sm.diff gives, and the common
    subexpressions are searched once per shape (one sympy.cse for the two laws of one shape),
    each law's own names from the recorder."""
    from eomc.compiler.tree.analytic import _law_slopes
    from eomc.compiler.tree.joint_laws import JointLaw, joint_torque
    from eomc.compiler.tree.recorder import Recorder
    kinds = [dict(lower=-1.0, upper=1.0), dict(lower=-2.0, upper=0.5), dict(upper=0.5, damping=0.2),
             dict(lower=-0.3, upper=0.4, unilateral=True, friction=0.1), dict(lower=0.0, upper=2.0, hold=(3.0, 0.01)),
             dict(lower=-0.5, upper=1.5, hold=(4.5, 0.02))]
    memo, rec = {}, Recorder()
    for j, kw in enumerate(kinds):
        q, u = sm.symbols(f"x_{j} x_{40 + j}", real=True)
        tau = joint_torque(q, u, JointLaw(f"j{j}", **kw),
                           lambda name, v, keep=False: sm.Symbol(f"p_{name}", real=True), f"j{j}", 0.3)
        before = len(rec.assignments)
        named = _law_slopes(tau, q, u, memo, rec.let)
        assert len(rec.assignments) == before           # nothing recorded until the plan asks
        dq, du = named()
        mine = rec.assignments[before:]
        assert {dq, du} <= {t for t, _ in mine}         # names, defined by this law
        back = {}
        for t, e in mine:       # each reads the law's symbols and the names before it
            assert e.free_symbols <= tau.free_symbols | set(back)
            back[t] = e.xreplace(back)
        assert back[dq] == sm.diff(tau, q) and back[du] == sm.diff(tau, u)
    assert sum(1 for k in memo if k[-1] == "cse") == len(kinds) - 2     # the first two laws have one shape, the held two another


ROBOTS = {"panda": False, "solo12": True}     # UR5 (12 states) keeps the unrolled columns


@pytest.mark.parametrize("name", list(ROBOTS))
def test_jac_x_against_pinocchio_aba_derivatives(name):
    floating = ROBOTS[name]
    path = robot_path(name)
    system = from_urdf(path, floating_base=floating, limits=False)
    model = eomc.compile(system, f"{name}_ad", functions=FNS, formulation="recursive", progress=False)
    assert analytic(model)
    assert inputs_callers(model) == (["jac_x", "jac_id"], 1)      # one copy of an[] for both
    alone = eomc.compile(system, f"{name}_ad1", functions=["rhs", "jac_x"], formulation="recursive",
                         progress=False)
    assert inputs_callers(alone) == ([], 1)                       # alone: its own copy, as before
    ref = PinRef(path, joints_of(system), floating=floating)
    nq, nu = model.nq, model.nu
    rng = np.random.default_rng(31)
    for _ in range(4):
        q = rng.uniform(-np.pi, np.pi, nq)
        if floating:
            q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
        v = rng.normal(size=nu)
        x = np.concatenate([q, v])
        J = model.jac_x(0.0, x)                  # zero inputs, as Pinocchio's zero torques
        pin.computeABADerivatives(ref.model, ref.data, ref.q(q), ref.v(v), np.zeros(ref.model.nv))
        iv = ref.iv
        dq, dv = ref.data.ddq_dq[np.ix_(iv, iv)], ref.data.ddq_dv[np.ix_(iv, iv)]
        K = J[:nq, nq:nq + nu]
        assert relative_error(J[nq:nq + nu, nq:nq + nu], dv) < 1e-11
        assert relative_error(J[nq:nq + nu, :nq] @ K, dq) < 1e-11


@pytest.mark.parametrize("solver", ["aba", "ltdl"])
def test_both_solves_of_jac_x(solver, tmp_path, monkeypatch):
    """jac_x's M⁻¹ runs articulated on deep trees, LᵀDL on shallow ones (analytic.choose_solver):
    both forced on Panda (fixed links: hand, flange; two fingers on one body) against Pinocchio,
    and on a cart with a free-jointed body (a 6-dof joint) against central differences."""
    from eomc.compiler.tree import analytic as an
    monkeypatch.setattr(an, "ABA_DEPTH", 0 if solver == "aba" else 10 ** 6)
    path = robot_path("panda")
    system = from_urdf(path, floating_base=False, limits=False)
    model = eomc.compile(system, f"panda_{solver}", functions=FNS, formulation="recursive", progress=False,
                         cache_dir=tmp_path / solver)
    text = model.source_path.read_text()
    assert ("_rd_bw(" in text) == (solver == "aba") and ("_rd_axpy(" in text) == (solver == "ltdl")
    ref = PinRef(path, joints_of(system), floating=False)
    nq, nu = model.nq, model.nu
    rng = np.random.default_rng(32)
    for _ in range(3):
        q, v = rng.uniform(-np.pi, np.pi, nq), rng.normal(size=nu)
        J = model.jac_x(0.0, np.concatenate([q, v]))
        pin.computeABADerivatives(ref.model, ref.data, ref.q(q), ref.v(v), np.zeros(ref.model.nv))
        iv = ref.iv
        assert relative_error(J[nq:, nq:], ref.data.ddq_dv[np.ix_(iv, iv)]) < 1e-11
        assert relative_error(J[nq:, :nq], ref.data.ddq_dq[np.ix_(iv, iv)]) < 1e-11
    base = dict(rotation=("BODY", 123), axis=(0, 1, 1), parent_point=(1, 0, -1), child_point=(0, 1, 1),
                products=True)
    spec = [dict(base, kind="free", parent=-1, rigid=True, load=False),
            dict(base, kind="pin", parent=0, rigid=True, load=True),
            dict(base, kind="slider", parent=1, rigid=False, load=True, axis=(1, 0, 0)),
            dict(base, kind="ball", parent=0, rigid=True, load=False),
            dict(base, kind="pin", parent=3, rigid=False, load=True, axis=(0, 0, 1))]
    system, inputs = random_trees.build(spec)
    model = eomc.compile(system, f"tree_{solver}", inputs=inputs, functions=FNS, formulation="recursive",
                         progress=False, cache_dir=tmp_path / solver)
    assert analytic(model)
    assert worst(model, seed=5) < 1e-6


@pytest.mark.parametrize("solver", ["aba", "ltdl"])
def test_quaternion_joints_take_the_analytic_path(solver, tmp_path, monkeypatch):
    """A quaternion free or ball joint has 4 coordinates on 3 angular speeds: its block of K is
    4 x 3, and the kernel maps ∂τ/∂ξ to ∂τ/∂q by K⁺ = (KᵀK)⁻¹Kᵀ (analytic.py; until session 28
    such a model took the tangent path, its jac_x ~2x the Euler build's).  test_narrow's limbs
    (two free joints, a ball joint, a hinge; capsules and spheres) on a floor, with their
    body-body pairs through the table, orientation="quaternion": jac_x and jac_id against the
    tangent path's (analytic_plan refused) and against central differences of the rhs and
    inverse dynamics, at states with quaternions of length 0.5-2 (the rhs does not see the
    length, so neither may the derivatives: ∂f/∂q · q = 0), some touching the floor and each
    other.  hess_id keeps its tangent path (second_order refuses the plan)."""
    from eomc.compiler.mjcf.model import MjcfModel
    from eomc.compiler.tree import analytic as an
    from eomc.compiler.tree.second_order import second_order_plan
    from tests.compiler.contact.test_narrow import LIMBS
    monkeypatch.setattr(an, "ABA_DEPTH", 0 if solver == "aba" else 10 ** 6)
    path = tmp_path / "limbs.xml"
    path.write_text(LIMBS.replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="5 5 0.1"/>', 1))
    fns = FNS + ["outputs"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, orientation="quaternion", pairs=True), f"qlimbs_{solver}",
                             functions=fns, progress=False, cache_dir=tmp_path / "a")
        plan = an.analytic_plan
        monkeypatch.setattr(an, "analytic_plan", lambda *a, **k: (None, []))
        tangent = eomc.compile(MjcfModel(path, orientation="quaternion", pairs=True), f"qlimbs_t_{solver}",
                               functions=fns, progress=False, cache_dir=tmp_path / "t")
        monkeypatch.setattr(an, "analytic_plan", plan)
    assert len(model.quaternions) == 3
    assert analytic(model) and not analytic(tangent)
    text = model.source_path.read_text()
    assert ("_rd_bw(" in text) == (solver == "aba") and "(K^T K)^-1 K^T" in text
    names = list(model.output_names)
    floor = [i for i, n in enumerate(names) if n.startswith("depth_") and "__" not in n]
    pairs = [i for i, n in enumerate(names) if n.startswith("Fn_") and "__" in n]
    assert floor and len(pairs) >= 6
    rng = np.random.default_rng(11)
    X = rng.normal(scale=0.6, size=(300, model.nx))
    X[:, 2] += 0.3
    for i in model.quaternions:
        X[:, i:i + 4] *= rng.uniform(0.5, 2.0, (300, 1)) / np.linalg.norm(X[:, i:i + 4], axis=1)[:, None]
    out = np.array([list(model.outputs(0.0, x).values()) for x in X], dtype=float)
    on_floor, pressed = (out[:, floor] > 0).any(axis=1), (out[:, pairs] > 0).any(axis=1)
    picked = [*np.flatnonzero(pressed)[:3], *np.flatnonzero(on_floor & ~pressed)[:3],
              *np.flatnonzero(~on_floor & ~pressed)[:2]]
    assert len(picked) == 8, (pressed.sum(), on_floor.sum())
    for x in X[picked]:
        ud = rng.normal(size=model.nu)
        for J, T, ref in ((model.jac_x(0.0, x), tangent.jac_x(0.0, x), central(lambda y: model.rhs(0.0, y), x, model.nx)),
                          (model.jac_id(0.0, x, ud), tangent.jac_id(0.0, x, ud),
                           central(lambda y: model.inverse_dynamics(0.0, y, ud), x, model.nx))):
            scale = max(1.0, np.max(np.abs(T)))
            assert np.max(np.abs(J - T)) <= 1e-11 * scale
            assert np.max(np.abs(J - ref)) <= 1e-6 * scale
    assert second_order_plan(_quaternion_plan()) == (None, "quaternion coordinates: not covered yet")


def _quaternion_plan():
    """An AnalyticPlan with a quaternion joint (kcols set), for second_order_plan."""
    from eomc.compiler.tree.analytic import AnalyticPlan
    return AnalyticPlan(1, 6, (-1,), (0,), (6,), tuple(range(6)), tuple(range(6)), ((0, 6, 0),), False, {}, 0,
                        kcols=(tuple(range(7)),))


def test_finiteness_check_of_the_kernels_outputs():
    """jac_x and jac_id on the kernel report EOMC_NONFINITE exactly when an output is not
    finite (NAME_rd_finite, analytic.finite_lines: sums of v * 0, not an isfinite loop): the C
    functions called directly, at finite inputs whose outputs overflow (u' = 1e308) and at
    ordinary ones; a NaN among them is caught too (fails if the check always passed)."""
    import ctypes
    system, _ = cart_joints(12, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, "fcart", functions=FNS, formulation="recursive", progress=False)
    assert analytic(model) and "fcart_rd_finite(out, " in model.source_path.read_text()
    lib = ctypes.CDLL(str(model.directory / "libfcart.so"))
    dp = ctypes.POINTER(ctypes.c_double)
    ptr = lambda a: a.ctypes.data_as(dp)
    nx, nu = model.nx, model.nu
    p = np.array(model.param_defaults, dtype=float)
    r = np.zeros(max(model.ninput, 1))
    x = np.random.default_rng(4).uniform(-1, 1, nx)

    def call(fn, ud, x=x):
        out = np.full(nx * nx, 7.0)
        args = [ctypes.c_double(0.0), ptr(x)] + ([ptr(ud)] if fn == "jac_id" else []) + [ptr(p), ptr(r), ptr(out), None]
        return getattr(lib, f"fcart_{fn}")(*args), out[:(nu if fn == "jac_id" else nx) * nx]
    status, out = call("jac_id", np.full(nu, 1e308))
    assert not np.all(np.isfinite(out)) and status == 3     # EOMC_NONFINITE
    status, out = call("jac_id", np.ones(nu))
    assert np.all(np.isfinite(out)) and status == 0
    status, out = call("jac_x", None)
    assert np.all(np.isfinite(out)) and status == 0
    bad = x.copy()
    bad[nx - 1] = np.nan
    status, out = call("jac_x", None, bad)
    assert np.isnan(out).any() and status == 3
