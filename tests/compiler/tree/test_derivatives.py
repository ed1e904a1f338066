"""The recursive formulation's jac_x, jac_r and linearize (compiler/tree/derivatives.py).

They differentiate inverse dynamics at the solved u' and apply M⁻¹ by the
articulated-body recursion.  Checked, compiled, at random states, against two
independent references: the Kane formulation's Jacobians (symbolic derivatives
of Kane's A, b and an LDLᵀ solve) and central finite differences of the compiled
recursive rhs.  Both code paths are covered: columns unrolled (few states) and
one tangent program looped over the columns (more than 12 states).
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import eomc
import eomc.mechanics as em
from eomc.compiler.emit.symbolic import TANGENT_MIN_STATES
from eomc.errors import EomcError, ModelError
from helpers import random_trees
from helpers.trees import cart_joints, cart_relative

FUNCTIONS = ["rhs", "jac_x", "jac_r", "linearize", "mass_matrix"]


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))


def _fd(model, x, p, r, wrt):
    """Central differences of the compiled rhs along every state (wrt="x") or input ("r")."""
    base = x if wrt == "x" else r
    cols = []
    for k in range(base.size):
        h = 1e-6 * max(1.0, abs(base[k]))
        up, dn = base.copy(), base.copy()
        up[k] += h
        dn[k] -= h
        if wrt == "x":
            f1, f0 = model.rhs(0.0, up, p=p, r=r), model.rhs(0.0, dn, p=p, r=r)
        else:
            f1, f0 = model.rhs(0.0, x, p=p, r=up), model.rhs(0.0, x, p=p, r=dn)
        cols.append((f1 - f0) / (2 * h))
    return np.array(cols).T


def _scaled(a, b):
    """Largest difference relative to the larger of 1 and b's largest entry."""
    return np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))


def check_jacobians(kane, rec, seed, nstates=3):
    """(worst vs Kane, worst vs finite differences) of jac_x and jac_r at random states,
    after checking that linearize returns the same two matrices."""
    assert rec.metadata["formulation"] == "recursive" and kane.metadata["formulation"] == "kane"
    rng = np.random.default_rng(seed)
    names = sorted(set(kane.metadata["param_names"]) | set(rec.metadata["param_names"]))
    worst_kane = worst_fd = 0.0
    checked = 0
    for _ in range(50):
        vals = {k: rng.uniform(0.5, 1.5) for k in names}
        pk = np.array([vals[k] for k in kane.metadata["param_names"]])
        pr = np.array([vals[k] for k in rec.metadata["param_names"]])
        x = rng.uniform(-1.0, 1.0, rec.nx)
        r = rng.uniform(-1.0, 1.0, rec.ninput)
        if np.linalg.cond(kane.mass_matrix(0.0, x, p=pk, r=r)) > 1e4:
            continue      # stiff M: differences would measure its conditioning
        A, B = rec.linearize(0.0, x, p=pr, r=r)
        assert np.array_equal(A, rec.jacobian(0.0, x, p=pr, r=r))
        assert np.array_equal(B, rec.input_jacobian(0.0, x, p=pr, r=r))
        Ak, Bk = kane.jacobian(0.0, x, p=pk, r=r), kane.input_jacobian(0.0, x, p=pk, r=r)
        worst_kane = max(worst_kane, _scaled(A, Ak), _scaled(B, Bk) if B.size else 0.0)
        worst_fd = max(worst_fd, _scaled(A, _fd(rec, x, pr, r, "x")))
        if B.size:
            worst_fd = max(worst_fd, _scaled(B, _fd(rec, x, pr, r, "r")))
        checked += 1
        if checked == nstates:
            break
    assert checked == nstates
    return worst_kane, worst_fd


def _pair(system_or_kane, name, inputs, fresh=None):
    rec = eomc.compile(system_or_kane, f"{name}_r", inputs=inputs, functions=FUNCTIONS,
                       progress=False, formulation="recursive")
    kane = eomc.compile(fresh if fresh is not None else system_or_kane, f"{name}_k", inputs=inputs,
                        functions=FUNCTIONS, progress=False, formulation="kane")
    return kane, rec


@pytest.mark.parametrize("n", [2, 6])
def test_relative_cart_with_torques(n):
    """n = 2: 6 states, columns unrolled; n = 6: 14 states, the looped tangent.  Inputs: the
    cart force and a torque at every pin (jac_r has n + 1 columns)."""
    kane, inputs = cart_relative(n, em, torques=True)
    mk, mr = _pair(kane, f"cart{n}", inputs)
    assert (2 * (n + 1) > TANGENT_MIN_STATES) == (n == 6)
    assert mr.ninput == n + 1
    vs_kane, vs_fd = check_jacobians(mk, mr, seed=n)
    assert vs_kane < 1e-12
    assert vs_fd < 1e-7


def test_ball_joints_with_a_load():
    """A ball-jointed body, a pendulum on a pin and a second ball-jointed body, full inertias,
    a joint torque as input: 14 states (the looped tangent), three-stage joints."""
    def body(parent, kind, child_point, load=False):
        return {"parent": parent, "kind": kind, "rotation": ("BODY", 123), "axis": (1, 0, 1),
                "parent_point": (0, 0, 1), "child_point": child_point, "rigid": True,
                "products": True, "load": load}
    spec = [body(-1, "ball", (1, 1, 0), load=True), body(0, "pin", (0, -1, 0), load=True),
            body(0, "ball", (0, 1, -1))]
    system, inputs = random_trees.build(spec)
    assert inputs
    mk, mr = _pair(system, "balls", inputs, fresh=random_trees.build(spec)[0])
    assert mr.nx == 14
    vs_kane, vs_fd = check_jacobians(mk, mr, seed=11)
    assert vs_kane < 1e-12
    assert vs_fd < 1e-7


@settings(max_examples=4, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spec=random_trees.tree(), seed=st.integers(0, 2**32 - 1))
def test_random_trees(spec, seed):
    """Branching trees (random parents, pins, sliders and balls about random axes, full
    inertias, joint loads as inputs): jac_x and jac_r against Kane and finite differences."""
    def compile_(formulation):
        system, inputs = random_trees.build(spec)
        return eomc.compile(system, f"jt_{formulation[0]}", inputs=inputs, functions=FUNCTIONS,
                            progress=False, formulation=formulation)
    try:
        mk = compile_("kane")
        mr = compile_("recursive")
    except ModelError as exc:       # a speed nothing resists: refused by both (test_agreement)
        assert "no inertia" in str(exc)
        return
    try:
        vs_kane, vs_fd = check_jacobians(mk, mr, seed)
    except AssertionError:
        # every state drawn had a stiff M (checked fewer than asked): nothing to compare
        x = np.random.default_rng(seed).uniform(-1, 1, mk.nx)
        assert np.linalg.cond(mk.mass_matrix(0.0, x, r=np.zeros(mk.ninput))) > 1e4
        return
    assert vs_kane < 1e-12
    assert vs_fd < 1e-6


def test_jac_x_ops_grow_quadratically_and_solve_without_a_factorization():
    """O(n) per column (the tangent of the RNEA trace and the articulated-body solve), so
    jac_x costs a bounded multiple of nx·rhs ops (differentiating M = CRBA column by
    column grew like n^2.5 in all); and its C factors no matrix (the tree's rhs, jac_x
    and jac_r never factor M)."""
    from eomc.compiler.driver import generate
    ratios = []
    for n in (6, 12):
        system, _ = cart_joints(n)
        gen = generate(system, "c", functions=["rhs", "jac_x"], formulation="recursive",
                       use_cache=False, progress=False)[1]
        ops = {f: sum(c.values()) for f, c in gen.metadata["op_counts"].items()}
        ratios.append(ops["jac_x"] / (gen.metadata["nx"] * ops["rhs"]))
        assert "ldlt" not in gen.c_source and "_lu_" not in gen.c_source
    # a constant per column: the ratio does not grow with n (it grew ~n^0.5 before)
    assert ratios[1] < 1.1 * ratios[0] < 1.5


def test_singular_articulated_inertia_is_a_status_not_nan():
    """Masses set to zero at run time: jac_x and jac_r report the singular mass matrix
    (as rhs does) instead of returning inf or NaN."""
    kane, inputs = cart_relative(2, em, torques=True)
    rec = eomc.compile(kane, "sing", inputs=inputs, functions=FUNCTIONS, progress=False,
                       formulation="recursive")
    names = rec.metadata["param_names"]
    p = np.array([0.0 if k.startswith("m") else 1.0 for k in names])
    x = np.full(rec.nx, 0.3)
    r = np.zeros(rec.ninput)
    for call in (rec.rhs, rec.jacobian, rec.input_jacobian):
        with pytest.raises(EomcError, match="(?i)singular|mass matrix"):
            call(0.0, x, p=p, r=r)


def test_msolve_reports_a_singular_mass_matrix():
    """jac_r by NAME_msolve (14 states: the analytic plan, compiler/tree/input_jacobian.py) on
    the cart whose inputs are loads (its columns from the residual's derivative): masses zero
    at run time give the singular-mass-matrix status, as rhs does, not inf or NaN."""
    kane, inputs = cart_relative(6, em, torques=True)
    rec = eomc.compile(kane, "sing6", inputs=inputs, functions=FUNCTIONS, progress=False,
                       formulation="recursive")
    assert "sing6_msolve(an, out, 7, 7, 7)" in rec.source_path.read_text()
    names = rec.metadata["param_names"]
    p = np.array([0.0 if k.startswith("m") else 1.0 for k in names])
    x, r = np.full(rec.nx, 0.3), np.zeros(rec.ninput)
    for call in (rec.rhs, rec.input_jacobian):
        with pytest.raises(EomcError, match="(?i)singular|mass matrix"):
            call(0.0, x, p=p, r=r)


def test_outputs_reading_accelerations_without_jacobians():
    """An output that reads u', built with rhs and outputs only: the recursive form solves
    A·u' = b with the real A and b (it once had only a stand-in of A's structure then)."""
    kane, inputs = cart_relative(2, em)
    ud = [s.diff() for s in kane.u]
    outputs = {"a0": ud[0], "a2": ud[2]}
    rec = eomc.compile(kane, "acc_r", inputs=inputs, outputs=outputs, functions=["rhs", "outputs"],
                       progress=False, formulation="recursive")
    x = np.array([0.1, 0.4, -0.3, 0.2, -0.5, 0.7])
    r = np.array([0.8])
    xd = rec.rhs(0.0, x, r=r)
    out = rec.outputs(0.0, x, r=r)
    assert abs(xd[3]) > 0.1
    assert np.allclose([out["a0"], out["a2"]], [xd[3], xd[5]], rtol=1e-12, atol=1e-13)


def test_looped_jacobians_c_is_clean_and_deterministic(tmp_path):
    """The looped path (14 states) with jac_r and linearize: byte-identical C from two
    generations, and gcc -std=c99 -Wall -Wextra -Werror accepts it."""
    import shutil
    import subprocess
    from pathlib import Path
    from eomc.compiler.driver import generate
    kane, inputs = cart_relative(6, em, torques=True)
    a, b = (generate(kane, "loop", functions=["rhs", "jac_x", "jac_r", "linearize"], inputs=inputs,
                     formulation="recursive", use_cache=False, progress=False)[1] for _ in range(2))
    assert a.c_source == b.c_source and a.header == b.header
    assert "for (k = 0; k < 7; k++)" in a.c_source       # the coordinates' tangent loop
    (tmp_path / "loop.c").write_text(a.c_source)
    (tmp_path / "loop.h").write_text(a.header)
    runtime_c = Path(__file__).resolve().parents[3] / "runtime" / "c"
    gcc = shutil.which("gcc") or shutil.which("cc")
    subprocess.run([gcc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O1", f"-I{runtime_c}",
                    f"-I{tmp_path}", "-c", str(tmp_path / "loop.c"), "-o", str(tmp_path / "loop.o")],
                   check=True)
