"""One placement of the bodies for the three loop kernels (NAME_rd_place,
compiler/tree/analytic.place_c): the derivative kernel NAME_rnea_derivs (jac_x), NAME_dyn
(mass_matrix, forcing, inverse_dynamics) and NAME_msolve (jac_r) each call it once, and its code
is in the file once (each placed the bodies in its own loop before: the same C compiled three
times, issue 30's build bar).

Checked on G1's default function set (floating base with eomc's Euler-angle free joint; limits
off, as Pinocchio has no limit laws): jac_x against Pinocchio's computeABADerivatives, mass_matrix
against crba, forcing and inverse_dynamics against rnea, jac_r against differences of the rhs
(linear in the inputs: exact to rounding), M jac_r's columns those of the identity.  The bits are those of the three loops it
replaced (benchmarks/results/derivative_build.md, session 25: 16 states, old and new libraries).
"""
import numpy as np
import pinocchio as pin

import eomc
from eomc.compiler.tree.analytic import PLACE_FROM_PARENT_LINES
from eomc.compiler.urdf import from_urdf
from helpers.robots import PinRef, joints_of, relative_error, robot_path

G1 = "g1_description/urdf/g1_29dof_rev_1_0.urdf"


def _body(text, head):
    start = text.index(head)
    return text[start:text.index("\n}\n", start)]


def test_g1_places_once_and_agrees_with_pinocchio(tmp_path):
    path = robot_path(G1)
    system = from_urdf(path, floating_base=True, limits=False)
    model = eomc.compile(system, "g1_place", formulation="recursive", progress=False, cache_dir=tmp_path)
    text, n = model.source_path.read_text(), model.name
    assert text.count(PLACE_FROM_PARENT_LINES[0]) == 1      # the placement's code, once
    for head in (f"static void {n}_rnea_derivs(const", f"static void {n}_dyn(const double *an, const double *u, "
                 "const double *ud, double *tau, double *M)\n{", f"static int {n}_msolve("):
        assert _body(text, head).count(f"{n}_rd_place(an, R, P, Sw, Y);") == 1, head
    for fn in ("jac_x", "mass_matrix", "forcing", "jac_r"):
        assert fn in model.functions

    ref = PinRef(path, joints_of(system), floating=True)
    nq, nu, iv = model.nq, model.nu, ref.iv
    rng = np.random.default_rng(25)
    for _ in range(3):
        q = rng.uniform(-1.0, 1.0, nq)
        q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
        v, a = rng.normal(size=nu), rng.normal(size=nu)
        x = np.concatenate([q, v])
        pv, pa, zero = np.zeros(ref.model.nv), np.zeros(ref.model.nv), np.zeros(ref.model.nv)
        pv[iv], pa[iv] = v, a

        J = model.jac_x(0.0, x)             # zero inputs, as Pinocchio's zero torques
        pin.computeABADerivatives(ref.model, ref.data, ref.q(q), ref.v(v), zero)
        K = J[:nq, nq:nq + nu]              # q' = K u: the Euler angles' tangent
        assert relative_error(J[nq:, nq:], ref.data.ddq_dv[np.ix_(iv, iv)]) < 1e-10
        assert relative_error(J[nq:, :nq] @ K, ref.data.ddq_dq[np.ix_(iv, iv)]) < 1e-10

        M = model.mass_matrix(0.0, x)
        Mp = pin.crba(ref.model, ref.data, ref.q(q))
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        assert relative_error(M, Mp[np.ix_(iv, iv)]) < 1e-12
        tau = pin.rnea(ref.model, ref.data, ref.q(q), pv, pa)[iv]
        assert relative_error(model.inverse_dynamics(0.0, x, a), tau) < 1e-12
        bias = pin.rnea(ref.model, ref.data, ref.q(q), pv, zero)[iv]
        assert relative_error(model.forcing(0.0, x), -bias) < 1e-12

        Jr = model.jac_r(0.0, x)
        base = model.rhs(0.0, x)[nq:]
        cols = np.stack([model.rhs(0.0, x, r=e)[nq:] - base for e in np.eye(model.ninput)], axis=1)
        assert relative_error(Jr[nq:], cols) < 1e-9
        B = M @ Jr[nq:]                     # each input a torque on its joint's speed: a column of the identity
        assert np.max(np.abs(B - np.round(B))) < 1e-9 and sorted(np.round(B).sum(axis=0)) == [1.0] * model.ninput
