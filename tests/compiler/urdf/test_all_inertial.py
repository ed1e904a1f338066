"""UrdfModel(all_inertial_parameters=True): every link's mass, centre of mass and inertia entries
are parameters, the file's zeros included (what identification fits), and the dynamics are
the file's at the defaults and Pinocchio's at any other value.

The small arm's third link has the zeros a CAD export writes (tests/helpers/small_arm.py).
Oracles: the default build (same rhs at the defaults) and Pinocchio's ABA with the link's
inertia changed in entries that are zero in the file."""
import warnings

import numpy as np
import pinocchio as pin
import pytest

import eomc
from eomc.compiler.urdf.model import UrdfModel
from helpers.small_arm import small_arm

ENTRIES = ("m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    directory = tmp_path_factory.mktemp("arm")
    path = small_arm(directory)
    cache = directory / "cache"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        build = lambda formulation, **kw: eomc.compile(  # noqa: E731
            UrdfModel(path, limits=False, **kw), f"arm_{formulation}_{len(kw)}", functions=["rhs"],
            formulation=formulation, cache_dir=cache, progress=False)
        return path, build("recursive"), build("recursive", all_inertial_parameters=True), \
            build("kane", all_inertial_parameters=True)


def test_zeros_become_parameters_at_zero(arm):
    _, plain, full, _ = arm
    assert "cy_l3" not in plain.param_names and "Ixy_l3" not in plain.param_names
    defaults = dict(zip(full.param_names, full.param_defaults))
    for link in ("l2", "l3"):                   # joints about y: every entry does work
        for k in ENTRIES:
            assert f"{k}_{link}" in defaults, (k, link, full.param_names)
    for k in ("cy", "cz", "Ixy", "Ixz", "Iyz"):
        assert defaults[f"{k}_l3"] == 0.0
    # the first link turns about z only: its inertia about x and y does no work, not a parameter
    assert "Izz_l1" in defaults and "Ixx_l1" not in defaults
    for name, value in zip(plain.param_names, plain.param_defaults):
        assert defaults[name] == value


def test_same_dynamics_at_the_defaults_and_both_routes(arm):
    _, plain, full, kane = arm
    # Kane's equations drop what cancels (the first link's cz against its child's joint offset)
    assert set(kane.param_names) <= set(full.param_names)
    assert {n for n in full.param_names if n.endswith(("_l2", "_l3"))} <= set(kane.param_names)
    pick = [full.param_names.index(n) for n in kane.param_names]
    rng = np.random.default_rng(0)
    for _ in range(5):
        x, r = rng.uniform(-2, 2, 6), rng.uniform(-3, 3, 3)
        ref = plain.rhs(0.0, x, r=r)
        assert np.max(np.abs(full.rhs(0.0, x, r=r) - ref)) < 1e-12 * np.max(np.abs(ref))
        p = np.array(full.param_defaults) * rng.uniform(0.8, 1.2, full.nparam)
        p[[full.param_names.index(f"{k}_l3") for k in ("cy", "Ixy", "Iyz")]] = [0.01, 3e-4, -2e-4]
        a, b = full.rhs(0.0, x, p=p, r=r), kane.rhs(0.0, x, p=p[pick], r=r)
        assert np.max(np.abs(a - b)) < 1e-11 * np.max(np.abs(a))


def test_entries_zero_in_the_file_act_as_in_pinocchio(arm):
    """cy, cz, Ixy, Ixz, Iyz of link 3 set away from zero: ABA against Pinocchio's with that inertia."""
    path, _, full, _ = arm
    pm = pin.buildModelFromUrdf(str(path))
    data = pm.createData()
    c = np.array([0.12, 0.013, -0.008])
    Ic = np.array([[0.002, 3e-4, -2e-4], [3e-4, 0.012, 1e-4], [-2e-4, 1e-4, 0.0125]])
    pm.inertias[pm.getJointId("j3")] = pin.Inertia(0.8, c, Ic)
    values = {"cx_l3": c[0], "cy_l3": c[1], "cz_l3": c[2], "Ixx_l3": Ic[0, 0], "Iyy_l3": Ic[1, 1],
              "Izz_l3": Ic[2, 2], "Ixy_l3": Ic[0, 1], "Ixz_l3": Ic[0, 2], "Iyz_l3": Ic[1, 2]}
    p = np.array(full.param_defaults)
    for name, v in values.items():
        p[full.param_names.index(name)] = v
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, v, tau = rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3), rng.uniform(-3, 3, 3)
        ref = pin.aba(pm, data, q, v, tau)
        got = full.rhs(0.0, np.concatenate([q, v]), p=p, r=tau)[3:]
        assert np.max(np.abs(got - ref)) < 1e-11 * np.max(np.abs(ref)), (got, ref)
