"""Every row of the table of joint kinds is one consistent mobilizer: moving its coordinates by
q' = N(q) u moves the child body exactly with the spatial velocity S u.

The oracle is the definition of the three: with R_PC = Eᵀ and r the child's origin in parent
components, the child's angular velocity is R_PCᵀ dR_PC/dt and its origin's velocity R_PCᵀ dr/dt
(both in child components); central differences of R_PC(q), r(q) along q' give them to ~1e-10.
A wrong sign in S, a transposed E, or a kinematics row that belongs to another angle set fails.
"""
import numpy as np
import pytest
import sympy as sm

from eomc.compiler.multibody.joint_kinds import KINDS, JointSite


def _rotation(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q * np.sign(np.linalg.det(Q))


CASES = [("revolute", {}), ("revolute", {"anchor": True, "ref": 0.3}), ("prismatic", {"ref": -0.2}),
         ("ball", {"anchor": True}), ("ball", {"quaternion": True}), ("free", {}),
         ("free", {"quaternion": True}), ("free", {"placed": False}), ("planar", {}), ("fixed", {})]


@pytest.mark.parametrize("kind, options", CASES, ids=[f"{k}-{'-'.join(o) or 'plain'}" for k, o in CASES])
def test_velocity_of_the_mobilizer_is_S_u(kind, options):
    rng = np.random.default_rng(7)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    site = JointSite(_rotation(rng), axis, [sm.Float(x) for x in rng.normal(size=3)],
                     [sm.Float(x) for x in rng.normal(size=3)],
                     anchor=[sm.Float(x) for x in rng.normal(size=3)] if options.get("anchor") else None,
                     ref=options.get("ref", 0.0), quaternion=options.get("quaternion", False),
                     placed=options.get("placed", True))
    names_q, names_u = KINDS[kind].suffixes(site.quaternion)
    qs = sm.symbols(f"q0:{len(names_q)}") if names_q else ()
    us = sm.symbols(f"u0:{len(names_u)}") if names_u else ()
    joint = KINDS[kind].mobilize(site, qs, us)
    assert len(joint.kinematics) == len(qs) and len(joint.motions) == len(us)
    q = rng.normal(size=len(qs))
    if site.quaternion:                       # w and the vector part, unit length
        at = 3 if kind == "free" else 0
        q[at:at + 4] /= np.linalg.norm(q[at:at + 4])
    u = rng.normal(size=len(us))
    R_of = sm.lambdify([qs], joint.rotation.T, "numpy")
    r_of = sm.lambdify([qs], joint.position, "numpy")
    qdot = np.array(sm.lambdify([qs, us], joint.kinematics, "numpy")(q, u), dtype=float) if qs else q
    h = 1e-5
    R = np.asarray(R_of(q), dtype=float)
    dR = (np.asarray(R_of(q + h * qdot), dtype=float) - np.asarray(R_of(q - h * qdot), dtype=float)) / (2 * h)
    dr = (np.asarray(r_of(q + h * qdot), dtype=float) - np.asarray(r_of(q - h * qdot), dtype=float)).ravel() / (2 * h)
    W = R.T @ dR
    assert np.allclose(W, -W.T, atol=1e-8)    # a rotation's rate is skew
    got = np.concatenate([[W[2, 1], W[0, 2], W[1, 0]], R.T @ dr])
    S = np.array([[float(x) for x in m] for m in joint.motions]).reshape(-1, 6)
    want = S.T @ u if len(us) else np.zeros(6)
    assert np.allclose(got, want, atol=1e-8), (got, want)
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-12)


def test_the_readers_name_every_kind_from_the_table():
    """URDF and MJCF joint types map onto the table's rows only (no formula of their own)."""
    from eomc.compiler.mjcf.treeir import MJCF_KINDS
    from eomc.compiler.urdf.tree import URDF_KINDS
    assert set(URDF_KINDS.values()) | set(MJCF_KINDS.values()) | {"fixed"} == set(KINDS)
