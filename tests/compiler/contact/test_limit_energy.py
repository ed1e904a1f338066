"""The generated ``energy`` output of a URDF robot counts its joint limits' springs
(compiler/tree/joint_laws.limit_energy), so a start past a limit is not an energy gain.

Why: Go2's zero pose has its knees 0.84 rad past their limits; their springs held 14.8 kJ
the energy output left out, and the default ``eomc simulate`` warned of a 367 J energy gain
(benchmarks/results/contact_defaults.md) that the integrator never made (issue 29)."""
import warnings

import numpy as np
import pytest
from scipy.integrate import quad

import eomc
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.switching import PhysicsWarning
from helpers.urdf_arm import LIMITED_HINGE as URDF, check_limited_hinge_energy_verdict


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("limit_energy")
    path = tmp / "arm.urdf"
    path.write_text(URDF)
    # a contact far below (height -10 m) gives the robot its generated energy output
    contact = dict(link="arm", point=(0.0, 0.0, -0.5), radius=0.02, name="tip", height=-10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(UrdfModel(path, contacts=(contact,)), functions=("rhs", "jac_x", "outputs"),
                            cache_dir=tmp / "c", progress=False)


def _stored(K, e, r):
    """K ∫₀^r d³/(d + e)² dd, the limit spring's energy, by quadrature."""
    return K * quad(lambda d: d ** 3 / (d + e) ** 2, 0.0, r, epsabs=0, epsrel=1e-13)[0] if r > 0 else 0.0


def test_energy_counts_the_limit_springs(arm):
    p = dict(zip(arm.param_names, arm.param_defaults))
    K, e = p["limit_k_hinge"], p["limit_e_hinge"]
    # the entry spring (joint_laws.entry_gains): the same law limit_d deeper, of stiffness limit_kd
    Kd, D = p["limit_kd_hinge"], p["limit_d_hinge"]
    assert Kd > 0 and D > 0
    g, m = 9.81, 2.0
    for q, u in ((0.0, 0.3), (0.3 + 2e-4, 0.0), (0.3 + 2 * D, 0.0), (0.7, -1.0), (-0.9, 2.0), (-0.4 - 5e-5, 0.1)):
        out = arm.outputs(0.0, np.array([q, u]))
        # kinetic about the hinge (I_y + m l²) u²/2, gravity -m g l cos q (l = 0.25 below)
        plain = (0.05 + m * 0.25 ** 2) * u ** 2 / 2 - m * g * 0.25 * np.cos(q)
        spring = sum(_stored(K, e, r) + _stored(Kd, e, r - D) for r in (q - 0.3, -0.4 - q))
        assert out["energy"] == pytest.approx(plain + spring, rel=1e-12, abs=1e-12)
    assert "joint limits" in arm.metadata["energy"]


@pytest.mark.parametrize("side, inside", [("upper", 0.3), ("lower", -0.4)])
def test_the_energy_output_is_the_integral_of_the_law_s_force(arm, side, inside):
    """The energy verdict reads the limits' potential from the energy output: it must be the
    integral of the force the rhs applies, whatever the law (the limit's own spring, the entry
    spring limit_d deeper, at their defaults and at other run-time values).  At rest
    (u = 0) the hinge's generalised force is I·u' = -dE/dq, so E(q) - E(inside) = -∫ I·u' dq
    along the rhs itself (scipy's quad; I from the energy's kinetic part)."""
    names = list(arm.param_names)
    base = np.array(arm.param_defaults, dtype=float)
    other = base.copy()
    other[names.index("limit_kd_hinge")] *= 3.0
    other[names.index("limit_d_hinge")] *= 0.5
    other[names.index("limit_k_hinge")] *= 0.7
    sign = 1.0 if side == "upper" else -1.0
    for p in (base, other):
        D = p[names.index("limit_d_hinge")]
        energy = lambda q, u=0.0: arm.outputs(0.0, np.array([q, u]), p=p)["energy"]  # noqa: E731
        inertia = 2.0 * (energy(inside, 1.0) - energy(inside))
        force = lambda q: inertia * arm.rhs(0.0, np.array([q, 0.0]), p=p)[1]    # noqa: E731
        for depth in (5e-4, D, 1.5 * D, 4 * D, 0.05):
            q = inside + sign * depth
            kinks = sorted([inside, inside + sign * D])
            work = quad(force, inside, q, points=[k for k in kinks if min(inside, q) < k < max(inside, q)],
                        epsabs=0, epsrel=1e-12, limit=200)[0]
            assert energy(q) - energy(inside) == pytest.approx(-work, rel=1e-9, abs=1e-12), (side, depth)


def test_a_start_past_a_limit_is_no_energy_gain(arm):
    # 0.5 rad past the upper limit at rest: the spring throws the arm back, the damping of the
    # limit takes energy out; before the limits' energy was counted this warned of a gain
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = arm.simulate(np.array([0.8, 0.0]), (0.0, 2.0), method="radau", rtol=1e-8, atol=1e-10)
    assert res.status == 0
    E = np.asarray(res.outputs["energy"])
    assert E[0] > 100.0          # the spring's energy is in it (K r²/2 ~ 1e3 J)
    assert E.max() <= E[0] * (1 + 1e-6)
    gains = [str(w.message) for w in caught if issubclass(w.category, PhysicsWarning) and "energy rose" in str(w.message)]
    assert gains == []


def test_a_robot_with_limits_and_no_contact_gets_the_same_energy_and_its_verdict(arm, tmp_path):
    """No ground contact: the limits alone give the robot its energy output (the same values as
    with the far contact), so RK4 at 10 ms on an undamped stiff limit that creates energy at the
    impact fails the run (status 20, the energy 4 J -> 330 J; before, with no energy output,
    status 0)."""
    path = tmp_path / "arm.urdf"
    path.write_text(URDF)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bare = eomc.compile(UrdfModel(path), functions=("rhs", "jac_x", "outputs"), cache_dir=tmp_path / "c",
                            progress=False)
    assert bare.output_names == ("energy",) and "joint limits" in bare.metadata["energy"]
    for q, u in ((0.0, 0.3), (0.3 + 2e-4, 0.0), (-0.9, 2.0)):
        x = np.array([q, u])
        assert bare.outputs(0.0, x)["energy"] == pytest.approx(arm.outputs(0.0, x)["energy"], rel=1e-13)
    check_limited_hinge_energy_verdict(bare)
