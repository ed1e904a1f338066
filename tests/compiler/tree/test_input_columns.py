"""jac_r's columns written directly for joint-torque inputs (compiler/tree/lower._input_columns),
and the zero runs of the Jacobians' and mass matrix's stores (compiler/tree/emit.stores_zeroing_runs).

A URDF robot's inputs are its joints' torques: each acts on the child about the axis with
its reaction on the parent, the generalized force e_k·τ_k.  Checked, compiled, on a small
branching robot with a floating base (the root carries reactions) and soft limits (joint
laws in the same torques), at states inside and far past the limits:
- jac_r against central differences of the rhs in the inputs, and linearize's B is jac_r;
- M·(jac_r's speed rows) is the input matrix (1 on each actuated joint's row, 0 elsewhere):
  the mass matrix (its zero runs) and jac_r agree with each other and with the physics;
- jac_x against central differences (its coordinate rows are zero runs);
- the residual columns in the C are constants (no differentiated recursion left);
- forcing and inverse_dynamics (the loop kernel, compiler/tree/dynamics_kernel.py, joint laws
  and inputs in its loads) agree with the rhs's ABA: M u' = forcing, τ = M u' - forcing.
"""
import re

import numpy as np
import pytest

import eomc
from eomc.compiler.tree import lower
from eomc.compiler.urdf.model import with_options

LINK = ('<link name="{n}"><inertial><origin xyz="0.01 0.02 0.05"/><mass value="{m}"/>'
        '<inertia ixx="2e-3" iyy="3e-3" izz="2e-3" ixy="1e-4" ixz="0" iyz="2e-4"/></inertial></link>')
JOINT = ('<joint name="{n}" type="{t}"><parent link="{p}"/><child link="{c}"/><origin xyz="0.02 0 0.1" rpy="0.1 0 0.2"/>'
         '<axis xyz="{a}"/><limit lower="-0.6" upper="0.8" effort="10" velocity="5"/></joint>')


def robot_text():
    """A trunk with two 3-joint legs and a slider: 7 actuated joints, 20 states with the base."""
    links = [LINK.format(n="trunk", m=3.0)]
    joints = []
    for side in ("l", "r"):
        parent = "trunk"
        for k, axis in enumerate(("1 0 0", "0 1 0", "0 0 1")):
            name = f"{side}{k}"
            links.append(LINK.format(n=name, m=0.5))
            joints.append(JOINT.format(n=f"j_{name}", t="revolute", p=parent, c=name, a=axis))
            parent = name
    links.append(LINK.format(n="slide", m=0.2))
    joints.append(JOINT.format(n="j_slide", t="prismatic", p="trunk", c="slide", a="0 0.6 0.8"))
    return '<?xml version="1.0"?>\n<robot name="legs">\n' + "\n".join(links + joints) + "\n</robot>\n"


def central(f, x, step=1e-6):
    cols = []
    for k in range(len(x)):
        h = step * max(1.0, abs(x[k]))
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        cols.append((f(up) - f(dn)) / (2 * h))
    return np.array(cols).T


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    d = tmp_path_factory.mktemp("legs")
    path = d / "legs.urdf"
    path.write_text(robot_text())
    source, _ = with_options(str(path), None, floating_base=True)
    # the loop kernel for all three (joint laws and inputs in its loads), though the compiler
    # would keep a tree this small straight-line (lower.dynamics_kernel_functions)
    saved = lower.DYN_KERNEL_MIN_PAIRS
    lower.DYN_KERNEL_MIN_PAIRS = dict.fromkeys(saved, 0)
    try:
        model = eomc.compile(source, "legs", progress=False, formulation="recursive", cache_dir=d / "cache")
    finally:
        lower.DYN_KERNEL_MIN_PAIRS = saved
    assert "legs_dyn(an, " in model.source_path.read_text()
    return model


def test_residual_columns_are_written_directly(model):
    text = model.source_path.read_text()
    start = text.index("int legs_jac_r(")
    body = text[start:text.index("\n}\n", start)]
    parts = re.findall(r"static EOMC_NOINLINE void (legs_jac_r_part\w+)\(", text)
    for name in parts:          # the sub-functions the body calls, too
        s = text.index(f"void {name}(")
        body += text[s:text.index("\n}\n", s)]
    # B's entries stored straight into out's rows, M⁻¹ by NAME_msolve (compiler/tree/input_jacobian.py)
    assert re.search(r"status = legs_msolve\(an, out, 7, \d+, 7\);", body), body[-400:]
    stores = re.findall(r"out\[\d+\] = ([^;]+);", body)
    assert stores and all(re.fullmatch(r"-?\d+\.\d+", v) for v in stores), stores[:5]
    assert sorted(float(v) for v in stores if float(v) != 0.0) == [1.0] * 7     # one motor per input
    assert "for (k = " in body        # the zeros as loops


@pytest.mark.parametrize("scale", [0.3, 2.0])
def test_jac_r_mass_matrix_and_jac_x_agree(model, scale):
    rng = np.random.default_rng(int(scale * 10))
    nq, nu = model.nq, model.nu
    for _ in range(2):
        x, r = rng.uniform(-scale, scale, model.nx), rng.normal(size=model.ninput)
        Jr = model.jac_r(0.0, x, r=r)
        # the rhs is affine in the inputs: a large step has no truncation error and keeps the
        # rounding of rhs values near 1e3 (past the stiff limits) from swamping the difference
        ref = central(lambda rr: model.rhs(0.0, x, r=rr), r, step=0.1)
        assert np.max(np.abs(Jr - ref)) / max(1.0, np.max(np.abs(ref))) < 1e-7
        A, B = model.linearize(0.0, x, r=r)
        assert np.array_equal(B, Jr)
        Jx = model.jac_x(0.0, x, r=r)
        refx = central(lambda y: model.rhs(0.0, y, r=r), x)
        assert np.max(np.abs(Jx - refx)) / max(1.0, np.max(np.abs(refx))) < 1e-6
        assert np.array_equal(A, Jx)
        M = model.mass_matrix(0.0, x)
        assert np.allclose(M, M.T, rtol=0, atol=1e-15)
        selection = M @ Jr[nq:nq + nu]       # M M⁻¹ B = B: 1 where input k drives speed i
        expect = np.zeros((nu, model.ninput))
        for k, name in enumerate(model.input_names):
            expect[list(model.state_names[nq:]).index("u_" + name.removeprefix("tau_")), k] = 1.0
        assert np.max(np.abs(selection - expect)) < 1e-9
        f = model.forcing(0.0, x, r=r)          # the loop kernel's RNEA (laws, inputs) vs the rhs's ABA
        assert np.max(np.abs(M @ model.rhs(0.0, x, r=r)[nq:nq + nu] - f)) < 1e-10 * max(1.0, np.max(np.abs(f)))
        ud = rng.normal(size=nu)
        assert np.max(np.abs(model.inverse_dynamics(0.0, x, ud, r=r) - (M @ ud - f))) < 1e-10 * max(1.0, np.max(np.abs(f)))


def test_msolve_agrees_with_the_straight_line_solve(model, tmp_path, monkeypatch):
    """jac_r by NAME_msolve (compiler/tree/input_jacobian.py) against the same model built with
    the straight-line articulated solve per column (the path it replaced): same values to
    1e-12 at random states, in and far past the limits, floating base included."""
    monkeypatch.setattr(lower, "uses_input_solve", lambda *a: False)
    path = tmp_path / "legs.urdf"
    path.write_text(robot_text())
    source, _ = with_options(str(path), None, floating_base=True)
    old = eomc.compile(source, "legs", progress=False, formulation="recursive", cache_dir=tmp_path / "cache")
    assert "legs_msolve" not in old.source_path.read_text() and "legs_msolve" in model.source_path.read_text()
    rng = np.random.default_rng(7)
    nq = model.nq
    for scale in (0.3, 1.0, 2.5):
        for _ in range(4):
            x, r = rng.uniform(-scale, scale, model.nx), rng.normal(size=model.ninput)
            new, ref = model.jac_r(0.0, x, r=r), old.jac_r(0.0, x, r=r)
            assert np.max(np.abs(new - ref)) <= 1e-12 * max(1.0, np.max(np.abs(ref)))
            assert not np.any(new[:nq])         # the coordinate rows: inputs do not move q' directly

