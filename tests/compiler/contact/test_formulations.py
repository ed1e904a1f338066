"""The contact loads of eomc.contact.ground give the same model under Kane's and the
recursive formulation (a System of joints: the recursion reads them as world loads),
and bad contact parameters are refused naming the contact."""
import numpy as np
import pytest
import sympy as sm

import eomc
import eomc.contact
from eomc.mechanics import PinJoint, PrismaticJoint, RigidBody, System, dynamicsymbols


def _planar_ball():
    """A ball on two sliders (x, z) and a pin (y): the recursion takes one speed per joint."""
    qx, qz, qa = dynamicsymbols("qx qz qa")
    ux, uz, ua = dynamicsymbols("ux uz ua")
    m, g, I = sm.symbols("m g I", positive=True)
    ground = RigidBody("ground")
    cx = RigidBody("cx", mass=0.3)
    cz = RigidBody("cz", mass=0.2)
    ball = RigidBody("ball", mass=m)
    from eomc.mechanics import inertia
    cx.inertia = (inertia(cx.frame, 0.01, 0.01, 0.01), cx.masscenter)
    cz.inertia = (inertia(cz.frame, 0.01, 0.01, 0.01), cz.masscenter)
    ball.inertia = (inertia(ball.frame, I, I, I), ball.masscenter)
    system = System.from_newtonian(ground)
    system.add_joints(PrismaticJoint("sx", ground, cx, qx, ux, joint_axis=ground.x),
                      PrismaticJoint("sz", cx, cz, qz, uz, joint_axis=cx.z),
                      PinJoint("pin", cz, ball, qa, ua, joint_axis=cz.y))
    system.apply_uniform_gravity(-g * ground.z)
    foot = eomc.contact.ground(ball.masscenter, ball, world=system, name="ball", radius=0.1, mu=0.7,
                               vs=0.05, k=2e4, c=1.5)
    system.add_loads(*foot.loads)
    return system, {m: 1.0, g: 9.81, I: 0.004, **foot.parameters}, foot


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    out = {}
    for form in ("kane", "recursive"):
        system, parameters, foot = _planar_ball()
        out[form] = eomc.compile(system, name=f"ball_{form}", parameters=parameters,
                                 outputs=foot.outputs, events=foot.events, formulation=form,
                                 cache_dir=cache)
    return out


def test_kane_and_recursive_agree_in_and_out_of_contact(models):
    kane, rec = models["kane"], models["recursive"]
    assert kane.metadata["formulation"] == "kane" and rec.metadata["formulation"] == "recursive"
    assert kane.state_names == rec.state_names and kane.param_names == rec.param_names
    rng = np.random.default_rng(3)
    iz = kane.state_names.index("qz")
    in_contact = 0
    for i in range(20):
        x = rng.uniform(-1, 1, len(kane.state_names))
        x[iz] = 0.1 - 0.01 * rng.uniform() if i % 2 else 0.5
        a, b = kane.rhs(0.0, x), rec.rhs(0.0, x)
        assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(a).max())
        oa, ob = kane.outputs(0.0, x), rec.outputs(0.0, x)
        assert oa.keys() == ob.keys()
        for key in oa:
            assert np.allclose(oa[key], ob[key], rtol=1e-12, atol=1e-12), key
        in_contact += oa["Fn_ball"] > 0
        assert np.allclose(kane.jacobian(0.0, x), rec.jacobian(0.0, x), rtol=1e-9, atol=1e-9)
    assert in_contact >= 5          # the comparison saw the contact forces, not only free flight


def test_bad_contact_parameters_are_refused():
    from eomc.mechanics import Point, ReferenceFrame
    N, O = ReferenceFrame("N"), Point("O")
    P = O.locatenew("P", dynamicsymbols("z") * N.z)
    for kw, words in ((dict(k=-1.0), "stiffness k = -1 must be >= 0"),
                      (dict(mu=-0.2), "friction coefficient mu = -0.2"),
                      (dict(radius=-0.01), "radius r = -0.01"),
                      (dict(vs=0.0), "vs = 0 must be > 0"),
                      (dict(k=float("nan")), "must be finite"),
                      (dict(restitution=1.5, impact_speed=1.0), "restitution e = 1.5")):
        with pytest.raises(ValueError, match="contact 'foot'") as info:
            eomc.contact.ground(P, N, world=(N, O), name="foot", **kw)
        assert words in str(info.value)
    with pytest.raises(ValueError, match="not an identifier"):
        eomc.contact.ground(P, N, world=(N, O), name="left foot")
