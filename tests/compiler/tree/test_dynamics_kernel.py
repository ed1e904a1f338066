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


KICK = """<mujoco model="kick">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="torso" pos="0 0 0.3">
      <freejoint name="root"/>
      <geom name="torso" type="sphere" size="0.1" mass="1"/>
      <body name="leg" pos="0 0 -0.05">
        <joint name="hip" type="hinge" axis="0 1 0"/>
        <geom name="leg" type="capsule" fromto="0 0 0 0.2 0 -0.12" size="0.03" mass="0.3"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="hip" gear="2"/></actuator>
</mujoco>
"""


def test_with_ground_contacts(tmp_path, monkeypatch):
    """A tree with ground contacts, default function set (issue 33's build time): mass_matrix from
    NAME_dyn and jac_r from NAME_msolve on M's inputs alone (lower.contact_mass_inputs),
    inverse_dynamics as M u' - f from NAME_implicit, forcing a call of it.  Checked against the
    rhs's own ABA (M u' = forcing, τ(u') = 0 at the rhs's u'), mass_matrix (the kernel) against
    τ(a) - τ(0) (NAME_implicit's straight-line CRBA), jac_r against M⁻¹ ∂forcing/∂r, at states
    with the contacts pressed and clear."""
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp_path / "kick.xml"
    path.write_text(KICK)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path), "kick", progress=False, cache_dir=tmp_path)
    assert model.nx > TANGENT_MIN_STATES and {"implicit", "jac_r"} <= set(model.functions)
    text = model.source_path.read_text()

    def body(fn):
        start = text.index(f"int {model.name}_{fn}(")
        return text[start:text.index("\n}\n", start)]
    assert kernel(model, "mass_matrix") and "_msolve(an, out, " in body("jac_r")
    assert "_implicit(t, x, p, r, im, work)" in body("inverse_dynamics")
    assert "_inverse_dynamics(t, x, " in body("forcing")
    rng = np.random.default_rng(3)
    iz, nq, nu = model.state_names.index("q_root_z"), model.nq, model.nu
    pressed = clear = 0
    for k in range(8):
        x = np.asarray(model.initial_state, dtype=float) + np.concatenate(
            [0.3 * rng.normal(size=nq), 0.3 * rng.normal(size=nu)])
        x[3:7] /= np.linalg.norm(x[3:7])
        x[iz] = 0.5 if k % 3 == 0 else 0.06 + 0.04 * rng.random()
        r = rng.normal(size=model.ninput)
        M, f = model.mass_matrix(0.0, x, r=r), model.forcing(0.0, x, r=r)
        ud = model.rhs(0.0, x, r=r)[nq:]
        assert np.array_equal(M, M.T)
        assert relative_error(M @ ud, f) < 1e-10
        assert np.max(np.abs(model.inverse_dynamics(0.0, x, ud, r=r))) < 1e-10 * max(1.0, np.max(np.abs(f)))
        a, tau0 = rng.normal(size=nu), model.inverse_dynamics(0.0, x, np.zeros(nu), r=r)
        assert np.array_equal(tau0, -f)
        err = model.inverse_dynamics(0.0, x, a, r=r) - tau0 - M @ a    # (τ is ~1e6 where a contact is deep)
        assert np.max(np.abs(err)) < 1e-12 * max(1.0, np.max(np.abs(tau0)), np.max(np.abs(M @ a)))
        # jac_r = [0; M⁻¹ B], B = ∂f/∂r: the motor's f is linear in r (a unit step is exact but for rounding)
        B = np.array([model.forcing(0.0, x, r=r + e) - f for e in np.eye(model.ninput)]).T
        Jr = model.jac_r(0.0, x, r=r)
        assert np.array_equal(Jr[:nq], np.zeros((nq, model.ninput)))
        assert relative_error(Jr[nq:], np.linalg.solve(M, B)) < 1e-9
        gap = min(v for n, v in model.outputs(0.0, x, r=r).items() if n.startswith("Fn_"))
        force = max(v for n, v in model.outputs(0.0, x, r=r).items() if n.startswith("Fn_"))
        pressed, clear = pressed + (force > 0), clear + (force == 0 and gap == 0)
    assert pressed >= 2 and clear >= 2
