"""hess_id's analytic second-order kernel (compiler/tree/second_order.py): on a branching
tree of pins and sliders with joint inputs and on a floating tree with a ball joint, against
the forward-over-reverse path it replaces (exact to rounding) and central differences of
jac_id; on Go2 and G1 (floating bases) along Pinocchio's tangent against differences of
Pinocchio's first derivatives, and along eomc's coordinates against differences of jac_id;
an MJCF free root with a ball joint below it against differences of jac_id;
its finiteness check; which path a model gets, in its metadata.  (UR10 against Pinocchio:
test_hess_id.py.)"""
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.mjcf import MjcfModel
import eomc.compiler.tree.second_order as second_order
from eomc.runtime.errors import SimulationError
from helpers.random_trees import build
from helpers.urdf_arm import LAW_ARM

# two branches from body 0 (a pin): a slider then a pin, and a point mass on a pin then a slider;
# most joints carry an input (a load pair on child and parent)
TREE = [
    {'parent': -1, 'kind': 'pin', 'rotation': ('SPACE', 123), 'axis': (0, 1, 1), 'parent_point': (1, -1, 0),
     'child_point': (0, -1, 1), 'rigid': True, 'products': True, 'load': True},
    {'parent': 0, 'kind': 'slider', 'rotation': ('BODY', 313), 'axis': (1, 0, -1), 'parent_point': (-1, 1, 1),
     'child_point': (0, 1, -1), 'rigid': True, 'products': True, 'load': True},
    {'parent': 0, 'kind': 'pin', 'rotation': ('BODY', 123), 'axis': (1, 1, 0), 'parent_point': (0, 1, 1),
     'child_point': (1, 0, 0), 'rigid': False, 'products': False, 'load': False},
    {'parent': 1, 'kind': 'pin', 'rotation': ('SPACE', 231), 'axis': (0, 0, 1), 'parent_point': (1, 0, -1),
     'child_point': (1, 1, 1), 'rigid': True, 'products': True, 'load': True},
    {'parent': 2, 'kind': 'slider', 'rotation': ('SPACE', 123), 'axis': (1, 1, 1), 'parent_point': (0, 0, 1),
     'child_point': (1, 0, 1), 'rigid': True, 'products': False, 'load': True},
]


def _compile(cache, reverse=False, tree=TREE):
    system, inputs = build(tree)
    orig = second_order.second_order_plan
    if reverse:     # force the path the kernel replaces
        second_order.second_order_plan = lambda plan: (None, "forced by the test")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return eomc.compile(system, functions=["rhs", "inverse_dynamics", "jac_id", "hess_id"],
                                inputs=inputs, formulation="recursive", cache_dir=cache, progress=False)
    finally:
        second_order.second_order_plan = orig


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    return _compile(tmp_path_factory.mktemp("kernel")), _compile(tmp_path_factory.mktemp("reverse"), reverse=True)


def test_metadata_names_the_path(models):
    kernel, reverse = models
    assert kernel.metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    assert reverse.metadata["hess_id"].startswith("forward over reverse") and "forced by the test" in reverse.metadata["hess_id"]
    assert "rnea_hess" in (kernel.directory / f"{kernel.name}.c").read_text()
    assert "rnea_hess" not in (reverse.directory / f"{reverse.name}.c").read_text()


def test_against_reverse_path_and_differences_of_jac_id(models):
    assert len(list(_against_reverse_and_differences(*models, seed=11, states=3, spread=1.5))) == 3


def _against_reverse_and_differences(kernel, reverse, seed, states, spread):
    """hess_id at random states equal to the reverse path's to 1e-12 and to central differences
    of jac_id to 1e-8 (of the largest entry); yields each (H, scale) for further checks."""
    rng = np.random.default_rng(seed)
    h = 1e-5
    for _ in range(states):
        x, ud = rng.uniform(-spread, spread, kernel.nx), rng.uniform(-1, 1, kernel.nu)
        r = rng.uniform(-1, 1, kernel.ninput)
        H, ref = kernel.hess_id(0.0, x, ud, r=r), reverse.hess_id(0.0, x, ud, r=r)
        scale = np.max(np.abs(ref))
        assert scale > 1.0
        assert np.max(np.abs(H - ref)) <= 1e-12 * scale
        fd = np.stack([(kernel.jac_id(0.0, x + h * e, ud, r=r) - kernel.jac_id(0.0, x - h * e, ud, r=r)) / (2 * h)
                       for e in np.eye(kernel.nx)], axis=2)
        assert np.max(np.abs(H - fd)) <= 1e-8 * scale
        yield H, scale


def test_overflow_is_an_error_not_a_silent_inf(models):
    """The kernel's own finiteness check (a bound, then v * 0 sums): speeds of 1e200 overflow v x* (I v)."""
    kernel, _ = models
    x = np.zeros(kernel.nx)
    x[kernel.nq:] = 1e200
    with pytest.raises(SimulationError, match="hess_id"):
        kernel.hess_id(0.0, x, np.zeros(kernel.nu), r=np.zeros(kernel.ninput))


# a URDF arm whose three joints all carry a law (soft limits, damping, Coulomb friction): the
# kernel adds the laws' own curvature to their rows' (q, u) entries (with_law_hessians)
ARM = LAW_ARM.replace('<robot name="arm">', '<robot name="lawarm">')
WIDTH = 3e-4    # joint_laws.WIDTH: the limit law's curvature lives within a few widths of a limit


def _compile_urdf(path, cache, reverse=False):
    orig = second_order.second_order_plan
    if reverse:
        second_order.second_order_plan = lambda plan: (None, "forced by the test")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return eomc.compile(str(path), functions=["rhs", "inverse_dynamics", "jac_id", "hess_id"],
                                cache_dir=cache, progress=False)
    finally:
        second_order.second_order_plan = orig


@pytest.fixture(scope="module")
def law_models(tmp_path_factory):
    d = tmp_path_factory.mktemp("laws")
    (d / "lawarm.urdf").write_text(ARM)
    return _compile_urdf(d / "lawarm.urdf", d / "kernel"), _compile_urdf(d / "lawarm.urdf", d / "reverse", True)


def test_joint_laws_take_the_kernel_and_match_reverse_path_and_differences(law_models):
    """Limits on (the URDF default), damping and friction: the kernel path, equal to the reverse
    path to rounding (1e-12 of the tensor's scale; measured <= 1.1e-15) and to central
    differences of jac_id (1e-6; measured <= 8e-8 with steps of 1e-7, 5e-10 with 1e-5), at a
    state inside the ranges and at states a fraction of a width to ten widths past the limits (where the law's curvature is
    ~1e7 and changes over a width: steps of 1e-7 there)."""
    kernel, reverse = law_models
    assert kernel.metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    nq, nx = kernel.nq, kernel.nx
    rng = np.random.default_rng(3)
    law = np.zeros((kernel.nu, nx, nx), bool)     # entries d/dx of jac_id's law columns (q_i, u_i of row i)
    for i in range(kernel.nu):
        law[i, [i, nq + i], :] = True
    zone = [None, (0.5, 1.0, 0.3), (2.0, 0.3, 1.0), (10.0, 5.0, 0.5)]   # widths past j1 upper, j2 lower, j3 upper
    for past in zone:
        x, ud = rng.uniform(-0.3, 0.3, nx), rng.uniform(-1, 1, kernel.nu)
        if past is None:    # inside the three ranges
            x[:3] = rng.uniform([-0.5, -1.0, -0.1], [0.8, 1.2, 0.05])
        else:
            x[:3] = 0.8 + past[0] * WIDTH, -1.0 - past[1] * WIDTH, 0.05 + past[2] * WIDTH
        H, ref = kernel.hess_id(0.0, x, ud), reverse.hess_id(0.0, x, ud)
        scale = np.max(np.abs(ref))
        assert np.max(np.abs(H - ref)) <= 1e-12 * scale
        for h, mask in ((1e-7, law), (1e-5, ~law)):
            fd = np.stack([(kernel.jac_id(0.0, x + h * e, ud) - kernel.jac_id(0.0, x - h * e, ud)) / (2 * h)
                           for e in np.eye(nx)], axis=2)
            part = np.max(np.abs(H[mask]))
            assert part > 0.1
            assert np.max(np.abs(H - fd)[mask]) <= 1e-6 * part, (past, h)
    # the laws' curvature is there: ten widths past j1's limit, its entry dwarfs the rigid-body ones
    assert abs(H[0, 0, 0]) > 1e3 * np.max(np.abs(H[~law]))


def _nan_filled_call(model, x, ud, r=None):
    """hess_id's C into an output filled with NaN first: (status, output)."""
    t, x, p, r = model._args(0.0, x, None, r)
    out = np.full(model.nu * model.nx * model.nx, np.nan)
    status = model._kernel("hess_id")(t, x, np.asarray(ud, float), p, r, out, model._work()[1])
    return status, out.reshape(model.nu, model.nx, model.nx)


def _zeroed(cache, tree=TREE):
    """``tree`` built with second_order.ZERO set: its hess_id zeroes the whole output every call
    (by default the entries off the support paths are left as the caller zeroed them)."""
    orig = second_order.ZERO
    second_order.ZERO = True
    try:
        return _compile(cache, tree=tree)
    finally:
        second_order.ZERO = orig


@pytest.fixture(scope="module")
def zeroed_models(tmp_path_factory):
    return _zeroed(tmp_path_factory.mktemp("zeroed")), _zeroed(tmp_path_factory.mktemp("zeroed_floating"), FLOATING_TREE)


def test_every_entry_is_written(zeroed_models, law_models):
    """With second_order.ZERO set the output is zeroed first unless the triple loop writes every
    entry itself (the dofs on one path, _covers_all): the branching tree is zeroed, the 3-joint
    arm (a chain, default build) is not, and from an output filled with NaN both give every
    entry, equal to hess_id's."""
    tree, arm = zeroed_models[0], law_models[0]
    c_tree = (tree.directory / f"{tree.name}.c").read_text()
    c_arm = (arm.directory / f"{arm.name}.c").read_text()
    assert f"out[k] = 0.0;" in c_tree.split("_rnea_hess(const double")[1].split("\n}\n")[0]
    assert f"out[k] = 0.0;" not in c_arm.split("_rnea_hess(const double")[1].split("\n}\n")[0]
    assert "the caller zeroes out once" not in c_arm
    rng = np.random.default_rng(5)
    for model, r in ((tree, rng.uniform(-1, 1, tree.ninput)), (arm, None)):
        x, ud = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.nu)
        status, out = _nan_filled_call(model, x, ud, r)
        assert status == 0 and np.all(np.isfinite(out))
        assert np.array_equal(out, model.hess_id(0.0, x, ud, r=r))


def test_output_left_to_the_caller_gives_the_same_bits(models, floating_models, zeroed_models):
    """By default (second_order.ZERO off, Pinocchio's contract: the caller zeroes the output once)
    the kernel writes only the entries on the support paths.  On the branching tree and the floating
    tree (free root, ball joint below it: the change to the coordinates reads and writes whole
    rows and columns) the C has no zeroing, from an output zeroed once the bits equal the zeroing
    build's (ZERO set) at every state, and so does ``model.hess_id`` (a new zeroed array each
    call); from an output filled with NaN the NaN left are entries the zeroing build returns as 0
    (most of the output: the two branches' cross terms), every other entry its bits."""
    rng = np.random.default_rng(9)
    for left, full, spec in ((models[0], zeroed_models[0], TREE), (floating_models[0], zeroed_models[1], FLOATING_TREE)):
        c = (left.directory / f"{left.name}.c").read_text()
        assert "the caller zeroes out once" in c
        assert "out[k] = 0.0;" not in c.split("_rnea_hess(const double")[1].split("\n}\n")[0]
        once = np.zeros(left.nu * left.nx * left.nx)
        for _ in range(3):
            x, ud, r = rng.uniform(-1, 1, left.nx), rng.uniform(-1, 1, left.nu), rng.uniform(-1, 1, left.ninput)
            H = full.hess_id(0.0, x, ud, r=r)
            t, xc, p, rc = left._args(0.0, x, None, r)
            status = left._kernel("hess_id")(t, xc, ud, p, rc, once, left._work()[1])
            assert status == 0 and np.array_equal(once.reshape(H.shape), H)
            assert np.array_equal(left.hess_id(0.0, x, ud, r=r), H)
            status, out = _nan_filled_call(left, x, ud, r)
            nan = np.isnan(out)
            assert status == 0 and np.all(H[nan] == 0.0) and np.array_equal(out[~nan], H[~nan])
            assert nan.sum() == _off_path_entries(spec)


def _off_path_entries(tree):
    """The number of entries (row dof, column state, column state) of hess_id whose three dofs
    are not on one root-to-leaf path (each column a dof's q or u: 4 per triple of dofs), from
    the tree's parents alone (a free joint 6 dofs, a ball 3, the rest 1)."""
    parent = [b["parent"] for b in tree]
    def up(b):
        return {b} | (up(parent[b]) if parent[b] >= 0 else set())
    dof = [b for b, spec in enumerate(tree) for _ in range({"free": 6, "ball": 3}.get(spec["kind"], 1))]
    def related(a, b):
        return a in up(b) or b in up(a)
    return 4 * sum(not (related(i, a) and related(i, b) and related(a, b)) for i in dof for a in dof for b in dof)


def test_large_finite_outputs_pass_the_bound_by_the_full_check(models):
    """The kernel's finiteness test is a bound on the numbers its outputs are made of (BOUND);
    past it (speeds of 1e90: outputs ~1e180, finite) the output is checked entry by entry, and
    a finite one is returned, equal to the reverse path's."""
    kernel, reverse = models
    x = np.zeros(kernel.nx)
    x[kernel.nq:] = 1e90
    ud, r = np.zeros(kernel.nu), np.zeros(kernel.ninput)
    H, ref = kernel.hess_id(0.0, x, ud, r=r), reverse.hess_id(0.0, x, ud, r=r)
    scale = np.max(np.abs(ref))
    assert 1e170 < scale < 1e200 and np.all(np.isfinite(H))
    assert np.max(np.abs(H - ref)) <= 1e-12 * scale


# a free-jointed root (eomc's free joint: body XYZ Euler angles, body-frame speeds) carrying a pin,
# a slider and a ball joint (a k-speed joint inside the tree: rows above it) with a pin below it
_BASE = dict(rotation=("BODY", 123), axis=(0, 1, 1), parent_point=(1, 0, -1), child_point=(0, 1, 1), products=True)
FLOATING_TREE = [dict(_BASE, kind="free", parent=-1, rigid=True, load=False),
                 dict(_BASE, kind="pin", parent=0, rigid=True, load=True),
                 dict(_BASE, kind="slider", parent=1, rigid=False, load=True, axis=(1, 0, 0)),
                 dict(_BASE, kind="ball", parent=0, rigid=True, load=False),
                 dict(_BASE, kind="pin", parent=3, rigid=False, load=True, axis=(0, 0, 1))]


@pytest.fixture(scope="module")
def floating_models(tmp_path_factory):
    d = tmp_path_factory.mktemp("floating")
    return _compile(d / "k", tree=FLOATING_TREE), _compile(d / "r", reverse=True, tree=FLOATING_TREE)


def test_free_and_ball_joints_take_the_kernel(floating_models):
    """Joints of several speeds: the kernel runs along their tangent (Pinocchio's treatment:
    every dof of a joint is in the support of every other) and changes to their coordinates
    (K^-1 and dK/dq, _tangent_lines); equal to the reverse path to rounding (measured ~1e-15)
    and to central differences of jac_id (measured ~4e-11), symmetric in its two state indices."""
    kernel, reverse = floating_models
    assert kernel.metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    for H, scale in _against_reverse_and_differences(kernel, reverse, seed=12, states=2, spread=1.0):
        assert np.max(np.abs(H - H.transpose(0, 2, 1))) <= 1e-12 * scale


def test_root_free_joint_changes_coordinates_inside_the_loop(floating_models):
    """The free joint at the root takes the folded change to its coordinates (the triple loop's
    dots along q_k read its columns of K combined by K^-1 once per path, then its own (q, q)
    block per row), not the pass over its rows and columns (19-26 % of hess_id on Go2, G1,
    Talos); the values are the test above's."""
    kernel, _ = floating_models
    c = (kernel.directory / f"{kernel.name}.c").read_text()
    assert "joint 0: S K^-1 by K^-1's diagonal blocks" in c
    assert "rows q_a: sum_d K^-1[d, a] G[d, .]" not in c


def _switched(cache, tree, **switches):
    """``tree`` compiled with second_order's switches set (ROOT_DOTS, TANGENT), restored after."""
    old = {k: getattr(second_order, k) for k in switches}
    for k, v in switches.items():
        setattr(second_order, k, v)
    try:
        return _compile(cache, tree=tree)
    finally:
        for k, v in old.items():
            setattr(second_order, k, v)


def test_root_joint_dots_in_its_frame_equal_the_lane_dots(floating_models, tmp_path):
    """The pairs (i, j) with j in the root free joint take the root dots (second_order._root_dot_lines):
    the kernel runs in the root body's frame (_root_frame: gravity rotated into it, the bodies' loads
    placed from it), where the joint's axes are its constant body-frame axes (unit vectors and the
    angular ones' offsets), so those dots are a few terms each.  Along the coordinates and along the
    tangent (TANGENT: Pinocchio's quantities), equal to the same kernel in the world frame with the
    lane dots for every j (ROOT_DOTS off, the kernel before session 18) to 1e-13 relative at states
    of size 3 (measured ~1e-15), and the off build has neither the root frame nor the root dots."""
    kernel, _ = floating_models
    c = (kernel.directory / f"{kernel.name}.c").read_text()
    assert "j in root joint 0: its dots in the root's frame" in c and "the root's own frame (_root_frame)" in c
    off = _switched(tmp_path / "off", FLOATING_TREE, ROOT_DOTS=False)
    c = (off.directory / f"{off.name}.c").read_text()
    assert "_root_dot_lines" not in c and "_root_frame" not in c
    xi = _switched(tmp_path / "xi", FLOATING_TREE, TANGENT=True)
    xi_off = _switched(tmp_path / "xi_off", FLOATING_TREE, TANGENT=True, ROOT_DOTS=False)
    assert "j in root joint 0: its dots in the root's frame" in (xi.directory / f"{xi.name}.c").read_text()
    rng = np.random.default_rng(18)
    for _ in range(4):
        x, ud, r = rng.uniform(-3, 3, kernel.nx), rng.uniform(-3, 3, kernel.nu), rng.uniform(-3, 3, kernel.ninput)
        for a, b in ((kernel, off), (xi, xi_off)):
            H, ref = a.hess_id(0.0, x, ud, r=r), b.hess_id(0.0, x, ud, r=r)
            assert np.max(np.abs(H - ref)) <= 1e-13 * np.max(np.abs(ref))


def test_lane_and_scalar_pair_vectors_give_the_same_bits(floating_models, tmp_path):
    """The pair vectors run on four lanes when the C is built with AVX2 (NAME_H2_LANES 4: the
    machine build on an AVX2 x86-64) and one by one otherwise (portable); both sum every term in
    the same order, so a portable build of the same tree returns the same bits (on a machine
    without AVX2 both builds take the scalar form, and the test holds trivially).  The root free
    joint's (q, q) block reads T dK^-1/dq_b only for its angles (dK/dq_b of its position is 0)."""
    kernel, _ = floating_models
    system, inputs = build(FLOATING_TREE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        portable = eomc.compile(system, functions=["rhs", "inverse_dynamics", "jac_id", "hess_id"], inputs=inputs,
                                formulation="recursive", cache_dir=tmp_path, progress=False, portable=True)
    c = (kernel.directory / f"{kernel.name}.c").read_text()
    assert f"#if {kernel.name.upper()}_H2_LANES == 4" in c and "static const int bz[3] = {3, 4, 5};" in c
    rng = np.random.default_rng(21)
    for _ in range(3):
        x, ud, r = rng.uniform(-1, 1, kernel.nx), rng.uniform(-1, 1, kernel.nu), rng.uniform(-1, 1, kernel.ninput)
        H = kernel.hess_id(0.0, x, ud, r=r)
        assert np.all(np.isfinite(H)) and np.array_equal(H, portable.hess_id(0.0, x, ud, r=r))


def test_floating_overflow_is_an_error(floating_models):
    """Speeds of 1e200 overflow v x* (I v): an error naming hess_id, not a silent inf, through
    the change to the coordinates too (its own v * 0 check)."""
    kernel, _ = floating_models
    x = np.zeros(kernel.nx)
    x[kernel.nq:] = 1e200
    with pytest.raises(SimulationError, match="hess_id"):
        kernel.hess_id(0.0, x, np.zeros(kernel.nu), r=np.zeros(kernel.ninput))


FLOATING_ROBOTS = {"go2": "go2_description/urdf/go2.urdf", "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf"}


@pytest.mark.parametrize("name", list(FLOATING_ROBOTS))
def test_floating_robots_against_pinocchio_and_differences(name, tmp_path):
    """Go2 and G1 with eomc's free joint: built along the free joint's tangent
    (second_order.TANGENT), hess_id is Pinocchio's ComputeRNEASecondOrderDerivatives's
    quantity, checked against central differences of Pinocchio's computeRNEADerivatives along
    pin.integrate (its Python bindings lack the second order; the C++ comparison is
    benchmarks/bench_second_order.py's, ~1e-15); built as eomc builds it, hess_id is along the
    Euler angles, checked against central differences of its own jac_id."""
    import pinocchio as pin
    from eomc.compiler.urdf import from_urdf
    from helpers.robots import PinRef, joints_of, robot_path
    path = robot_path(FLOATING_ROBOTS[name])
    system = from_urdf(path, floating_base=True, limits=False)
    fns = ["rhs", "inverse_dynamics", "jac_id", "hess_id"]
    models = {}
    for tangent in (False, True):
        second_order.TANGENT = tangent
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                models[tangent] = eomc.compile(system, name + ("_xi" if tangent else ""), functions=fns,
                                               formulation="recursive", cache_dir=tmp_path / str(tangent),
                                               progress=False)
        finally:
            second_order.TANGENT = False
        assert models[tangent].metadata["hess_id"].startswith("analytic second-order RNEA kernel")
    model, xi = models[False], models[True]
    ref = PinRef(path, joints_of(system), floating=True)
    nq, nu, nv = model.nq, model.nu, ref.model.nv
    cols = list(ref.iv) + [nv + i for i in ref.iv]      # Pinocchio's (q, v) columns in eomc's order
    rng = np.random.default_rng(8)
    q = rng.uniform(-np.pi, np.pi, nq)
    q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
    v, a = rng.normal(size=nu), rng.normal(size=nu)
    x = np.concatenate([q, v])
    Q, V, A = ref.q(q), ref.v(v), ref.v(a)

    def first(Qs, Vs):      # Pinocchio's [d tau/dq (tangent), d tau/dv]
        pin.computeRNEADerivatives(ref.model, ref.data, Qs, Vs, A)
        return np.hstack([ref.data.dtau_dq, ref.data.dtau_dv])

    h = 1e-6
    fd = np.zeros((nv, 2 * nv, 2 * nv))       # [i, j, k] = d/dxi_k of Pinocchio's d tau_i/dxi_j
    for k in range(2 * nv):
        d = np.zeros(nv)
        d[k % nv] = h
        if k < nv:
            up, dn = first(pin.integrate(ref.model, Q, d), V), first(pin.integrate(ref.model, Q, -d), V)
        else:
            up, dn = first(Q, V + d), first(Q, V - d)
        fd[:, :, k] = (up - dn) / (2 * h)
    fd = fd[np.ix_(ref.iv, cols, cols)]
    Hx = xi.hess_id(0.0, x, a)
    assert np.max(np.abs(fd)) > 1.0
    assert np.max(np.abs(Hx - fd)) <= 1e-7 * np.max(np.abs(fd))       # measured ~3e-10 (Go2)
    H = model.hess_id(0.0, x, a)
    h = 1e-5
    fd = np.stack([(model.jac_id(0.0, x + h * e, a) - model.jac_id(0.0, x - h * e, a)) / (2 * h)
                   for e in np.eye(model.nx)], axis=2)
    assert np.max(np.abs(H - fd)) <= 1e-8 * np.max(np.abs(fd))        # measured ~2.5e-11 (Go2)
    assert not np.allclose(H[:, 3:6, 3:6], Hx[:, 3:6, 3:6], rtol=1e-3)   # the two conventions differ there


FREE_AND_BALL_MJCF = """<mujoco model="free_and_ball">
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="3"/>
      <body name="upper" pos="0.2 0 0" euler="10 20 30">
        <joint name="shoulder" type="ball"/>
        <geom type="capsule" fromto="0 0 0 0.1 0.05 -0.3" size="0.03" mass="1"/>
        <body name="lower" pos="0.1 0.05 -0.3">
          <joint name="elbow" type="hinge" axis="0 1 0.2"/>
          <geom type="box" size="0.04 0.05 0.1" pos="0 0 -0.1" mass="0.5"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_ball_joint_below_a_free_root_against_differences(tmp_path):
    """Two joints of several speeds and different sizes (MuJoCo's free root, 6, and a ball joint
    below it, 3: one joint each in the tree, unlike the helper's ball): the root takes the folded
    change of coordinates, the ball the pass over its rows, whose dK/dq offsets depend on both
    sizes (session 8's offsets were wrong here: 5-9 % off the differences).  hess_id against
    central differences of jac_id to 1e-8."""
    pytest.importorskip("mujoco")
    path = tmp_path / "free_and_ball.xml"
    path.write_text(FREE_AND_BALL_MJCF)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # this test is about the joints' analytic second-order kernel (compiler/tree/second_order.py),
        # which holds no body–body pair: with its grandparent–grandchild self-pair (in by default
        # since session 11) hess_id differentiates RNEA's trace through the pair table's reverse
        # twin instead (tests/compiler/contact/test_pair_reverse.py), so build it without
        # orientation="euler": the kernel asserted (S K^-1, dK/dq) is the body-XYZ angles' change
        # of coordinates
        model = eomc.compile(MjcfModel(path, pairs="trees", orientation="euler"), "free_and_ball",
                             functions=["rhs", "jac_id", "hess_id"], cache_dir=tmp_path / "c", progress=False)
    c = (model.directory / f"{model.name}.c").read_text()
    assert "joint 0: S K^-1 by K^-1's diagonal blocks" in c and "rows q_a: sum_d K^-1[d, a] G[d, .]" in c
    rng, h = np.random.default_rng(3), 1e-5
    for _ in range(2):
        x, ud, r = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.nu), np.zeros(model.ninput)
        H = model.hess_id(0.0, x, ud, r=r)
        fd = np.stack([(model.jac_id(0.0, x + h * e, ud, r=r) - model.jac_id(0.0, x - h * e, ud, r=r)) / (2 * h)
                       for e in np.eye(model.nx)], axis=2)
        assert np.max(np.abs(H - fd)) <= 1e-8 * np.max(np.abs(fd))


def test_output_written_by_halves_gives_the_same_bits(zeroed_models, law_models, tmp_path):
    """Large outputs (second_order.HALF_FROM numbers, cart40 and longer) are written by halves:
    the triple loop stores the entries whose row's dof is the deeper one, and each row's mirror
    images are copied once the row is complete.  Forced on for the branching tree (several
    paths, output zeroed first: second_order.ZERO set) and the 3-joint arm with its joint laws (one path, not zeroed):
    the C has the copy, every entry of an output filled with NaN is written, and the bits equal
    the default build's (which writes both halves in the loop)."""
    orig = second_order.HALF_FROM
    second_order.HALF_FROM = 0
    try:
        tree = _zeroed(tmp_path / "tree")
        (tmp_path / "lawarm.urdf").write_text(ARM)
        arm = _compile_urdf(tmp_path / "lawarm.urdf", tmp_path / "arm")
    finally:
        second_order.HALF_FROM = orig
    rng = np.random.default_rng(8)
    for half, full in ((tree, zeroed_models[0]), (arm, law_models[0])):
        c = (half.directory / f"{half.name}.c").read_text()
        assert "row i's mirror images" in c
        assert "row i's mirror images" not in (full.directory / f"{full.name}.c").read_text()
        for _ in range(3):
            x, ud = rng.uniform(-1.5, 1.5, half.nx), rng.uniform(-1, 1, half.nu)
            r = rng.uniform(-1, 1, half.ninput) if half.ninput else None
            status, out = _nan_filled_call(half, x, ud, r)
            assert status == 0 and np.all(np.isfinite(out))
            assert np.array_equal(out, full.hess_id(0.0, x, ud, r=r))


# a chain of 9 joints in order (dof a's parent is a - 1): its mirror images are triangular transposes
CHAIN = [{'parent': i - 1, 'kind': ('pin', 'slider', 'pin')[i % 3], 'rotation': (('BODY', 123), ('SPACE', 231))[i % 2],
          'axis': ((0, 1, 1), (1, 0, -1), (0, 0, 1))[i % 3], 'parent_point': (1, -1, i % 2), 'child_point': (0, 1, 1),
          'rigid': i % 2 == 0, 'products': i % 3 == 0, 'load': i % 4 == 0} for i in range(9)]


def test_chain_mirrors_by_tiled_transposes_give_the_same_bits(tmp_path):
    """A chain in order written by halves (second_order.HALF_FROM forced to 0) copies row i's
    mirror images as four triangular transposes in 4 x 4 tiles (NAME_h2_trt; 9 dofs: full tiles,
    diagonal tiles and a last row), on vector registers in the machine build with AVX2 and
    entry by entry in the portable one, after copying the rows k < j's stores out of row i's
    scratch (second_order._scratch, NAME_h2_trs): from an output filled with NaN every entry is
    written, and both give the bits of the default build (both halves written in the loop)."""
    orig = second_order.HALF_FROM
    second_order.HALF_FROM = 0
    try:
        half = _compile(tmp_path / "half", tree=CHAIN)
        system, inputs = build(CHAIN)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            portable = eomc.compile(system, functions=["rhs", "inverse_dynamics", "jac_id", "hess_id"], inputs=inputs,
                                    formulation="recursive", cache_dir=tmp_path / "portable", progress=False, portable=True)
    finally:
        second_order.HALF_FROM = orig
    full = _compile(tmp_path / "full", tree=CHAIN)
    c = (half.directory / f"{half.name}.c").read_text()
    assert "row i's mirror images" in c and f"{half.name}_h2_trt(Oi + " in c and f"{half.name.upper()}_H2_SHUF(" in c
    assert f"{half.name}_h2_trs(Oi + " in c and "Hj[" in c
    assert "_h2_trt" not in (full.directory / f"{full.name}.c").read_text()
    rng = np.random.default_rng(9)
    for _ in range(3):
        x, ud, r = rng.uniform(-1.5, 1.5, half.nx), rng.uniform(-1, 1, half.nu), rng.uniform(-1, 1, half.ninput)
        ref = full.hess_id(0.0, x, ud, r=r)
        for model in (half, portable):
            status, out = _nan_filled_call(model, x, ud, r)
            assert status == 0 and np.all(np.isfinite(out))
            assert np.array_equal(out, ref)
