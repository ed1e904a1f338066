"""mass_matrix, forcing and inverse_dynamics from the loop kernel NAME_dyn
(compiler/tree/dynamics_kernel.py), which the compiler uses per function where the analytic plan
exists above TANGENT_MIN_STATES states and M's straight-line code would be large
(lower.dynamics_kernel_functions: benchmarks/results/dynamics_kernel.md).

Checked, compiled, against Pinocchio's crba and rnea (an algorithm and code of its own) on
Panda (fixed base, fixed links and two fingers on one body) and Solo12 (floating base: eomc's
speeds are Pinocchio's v), and against eomc's own straight-line ABA (the rhs): M u' = forcing;
with the kernel forced for all three functions, for mass_matrix alone (forcing and
inverse_dynamics straight-line beside it, forcing a call of inverse_dynamics at u' = 0) and with
the compiler's own choice (Panda is small: all three straight-line).  Small models keep the straight-line recursions
(their C unchanged).
"""
import warnings

import numpy as np
import pinocchio as pin
import pytest

import eomc
from eomc.compiler.emit.symbolic import TANGENT_MIN_STATES
from eomc.compiler.tree import lower
from eomc.compiler.urdf import from_urdf
from helpers.robots import PinRef, joints_of, relative_error, robot_path
from helpers.trees import cart_joints

FNS = ["rhs", "mass_matrix", "forcing", "inverse_dynamics"]
KERNEL = ("mass_matrix", "forcing", "inverse_dynamics")


ALL, NONE = (0, 0, 0), (10 ** 9,) * 3
CHOICES = {"all": ALL, "mass_matrix": (0, 10 ** 9, 10 ** 9), "compiler": None}


def kernel(model, fn=None):
    """Does the C call NAME_dyn (in function ``fn``, or anywhere)?"""
    text = model.source_path.read_text()
    if fn is not None:
        start = text.index(f"int {model.name}_{fn}(")
        text = text[start:text.index("\n}\n", start)]
    return f"{model.name}_dyn(an, " in text


@pytest.mark.parametrize("name,floating,choice", [("panda", False, "all"), ("solo12", True, "all"),
                                                  ("panda", False, "mass_matrix"), ("panda", False, "compiler")])
def test_against_pinocchio(name, floating, choice, tmp_path, monkeypatch):
    if CHOICES[choice] is not None:
        monkeypatch.setattr(lower, "DYN_KERNEL_MIN_PAIRS", dict(zip(KERNEL, CHOICES[choice])))
    path = robot_path(name)
    system = from_urdf(path, floating_base=floating, limits=False)
    model = eomc.compile(system, f"{name}_dyn", functions=FNS, formulation="recursive", progress=False,
                         cache_dir=tmp_path)
    expect = {"all": KERNEL, "mass_matrix": ("mass_matrix",), "compiler": ()}[choice]
    assert [fn for fn in KERNEL if kernel(model, fn)] == list(expect)
    text = model.source_path.read_text()
    forcing = text[text.index(f"int {model.name}_forcing("):]
    # both straight-line: forcing is a call of inverse_dynamics at u' = 0 (RNEA's code once)
    assert (f"{model.name}_inverse_dynamics(t, x, " in forcing[:forcing.index("\n}\n")]) == (choice != "all")
    ref = PinRef(path, joints_of(system), floating=floating)
    nq, nu, iv = model.nq, model.nu, ref.iv
    rng = np.random.default_rng(17)
    for _ in range(3):
        q = rng.uniform(-np.pi, np.pi, nq)
        if floating:
            q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
        v, a = rng.normal(size=nu), rng.normal(size=nu)
        x = np.concatenate([q, v])
        Mp = pin.crba(ref.model, ref.data, ref.q(q))
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        M = model.mass_matrix(0.0, x)
        assert np.array_equal(M, M.T)
        assert relative_error(M, Mp[np.ix_(iv, iv)]) < 1e-12
        pv, pa = np.zeros(ref.model.nv), np.zeros(ref.model.nv)
        pv[iv], pa[iv] = v, a
        tau = pin.rnea(ref.model, ref.data, ref.q(q), pv, pa)[iv]
        assert relative_error(model.inverse_dynamics(0.0, x, a), tau) < 1e-12
        bias = pin.rnea(ref.model, ref.data, ref.q(q), pv, np.zeros(ref.model.nv))[iv]
        assert relative_error(model.forcing(0.0, x), -bias) < 1e-12
        ud = model.rhs(0.0, x)[nq:]
        assert relative_error(M @ ud, model.forcing(0.0, x)) < 1e-10


def test_small_models_keep_the_straight_line_recursions(tmp_path):
    system, _ = cart_joints(4, rigid=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(system, "dcart4", functions=FNS, formulation="recursive", progress=False,
                             cache_dir=tmp_path)
    assert model.nx <= TANGENT_MIN_STATES and not kernel(model)
