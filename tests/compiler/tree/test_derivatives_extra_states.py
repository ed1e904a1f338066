"""jac_p and jvp with extra first-order states z (x = [q; u; z]), both formulations.

torque_chain (tests/helpers/state_models.py): motor states z drive the joints and
z' depends on q, u, z, an input and the parameters, so every row block of
d xdot/d[x; p] is exercised.  References: central differences of rhs for
jac_p, jac_x and jac_p for jvp.
"""
import numpy as np
import pytest

import eomc
import eomc.mechanics as em
from helpers.state_models import torque_chain


@pytest.fixture(scope="module", params=["kane", "recursive"])
def model(request, tmp_path_factory):
    d = torque_chain(2, em)
    return eomc.compile(d["system"], parameters=d["parameters"], inputs=d["inputs"], states=d["states"],
                        formulation=request.param, functions=["rhs", "jac_x", "jac_p", "jvp"],
                        cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def test_jac_p_and_jvp_with_extra_states(model):
    assert model.nx > model.nq + model.nu
    rng = np.random.default_rng(8)
    x, r = rng.uniform(-1, 1, model.nx), rng.uniform(-1, 1, model.ninput)
    p = model.param_defaults * rng.uniform(0.8, 1.2, model.nparam)
    J = model.jac_p(0.0, x, r=r, p=p)
    fd = np.empty_like(J)
    for j in range(model.nparam):
        h = 1e-6 * max(1.0, abs(p[j]))
        up, dn = p.copy(), p.copy()
        up[j] += h
        dn[j] -= h
        fd[:, j] = (model.rhs(0.0, x, p=up, r=r) - model.rhs(0.0, x, p=dn, r=r)) / (2 * h)
    assert np.max(np.abs(J - fd)) < 1e-7 * max(1.0, np.max(np.abs(fd)))
    assert np.max(np.abs(J[model.nq + model.nu:])) > 0      # z' depends on the parameters
    D = rng.normal(size=(3, model.nx + model.nparam))
    xdot, out = model.jvp(0.0, x, D, p=p, r=r)
    ref = D[:, :model.nx] @ model.jacobian(0.0, x, p=p, r=r).T + D[:, model.nx:] @ J.T
    assert np.max(np.abs(xdot - model.rhs(0.0, x, p=p, r=r))) < 1e-14 * max(1.0, np.max(np.abs(xdot)))
    assert np.max(np.abs(out - ref)) < 1e-12 * max(1.0, np.max(np.abs(ref)))


CLOSED_WITH_ACTIVATIONS = """<mujoco>
  <worldbody>
    <body pos="0 0 1"><joint name="j1" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.05" contype="0" conaffinity="0"/>
      <body pos="0.3 0 0"><joint name="j2" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.05" contype="0" conaffinity="0"/></body></body>
  </worldbody>
  <equality><joint joint1="j1" joint2="j2" polycoef="0 0.5 0 0 0"/></equality>
  <actuator><general joint="j1" dyntype="filter" dynprm="0.1" gainprm="1"/>
    <general joint="j2" dyntype="integrator" gainprm="1"/></actuator>
</mujoco>"""


def test_closed_tree_extra_state_rows_of_jac_x_and_jac_r(tmp_path):
    """A closed tree (a joint coupling: one multiplier λ after u') with activation states: the
    extra states' rows of jac_x and jac_r start right after the speeds.  They used to start
    after u' and λ, one row late per multiplier: the first activation's row was never written
    (uninitialised memory in radau's Newton matrix) -- dm_control's quadruped (4 couplings,
    12 filters) stalled at t = 1e-53 in radau."""
    path = tmp_path / "closed_act.xml"
    path.write_text(CLOSED_WITH_ACTIVATIONS)
    model = eomc.compile(str(path), functions=["rhs", "jac_x", "jac_r"], cache_dir=tmp_path / "cache",
                         progress=False)
    assert model.nx == model.nq + model.nu + 2
    rng = np.random.default_rng(5)
    for _ in range(3):
        x, r = rng.uniform(-0.5, 0.5, model.nx), rng.uniform(-1, 1, model.ninput)
        for jac, size, shift in ((model.jac_x, model.nx, "x"), (model.jac_r, model.ninput, "r")):
            J = jac(0.0, x, r=r)
            fd = np.empty((model.nx, size))
            for j in range(size):
                e = np.zeros(size)
                e[j] = 1e-6
                up = model.rhs(0.0, x + e, r=r) if shift == "x" else model.rhs(0.0, x, r=r + e)
                dn = model.rhs(0.0, x - e, r=r) if shift == "x" else model.rhs(0.0, x, r=r - e)
                fd[:, j] = (up - dn) / 2e-6
            assert np.max(np.abs(J - fd)) < 1e-6 * max(1.0, np.max(np.abs(fd))), shift
            z = model.nq + model.nu
            assert np.max(np.abs(J[z:])) > 0                     # the rows are there, and right
