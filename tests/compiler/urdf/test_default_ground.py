"""A URDF robot with named ground contacts: its other bodies' <collision> geometry meets the same
ground by default (compiler/urdf/model._ground), a body that goes under the ground anyway is
named by the run's verdict (runtime/ground_check.py), and small feet get a stiffness from the
load they carry (compiler/contact/law.load_stiffness).

Why (issue 29): Go2 and Solo12 with their feet as contacts ended with their trunks 0.07 m and
0.24 m under the floor, status 0, no warning; G1's 5 mm feet went 7.5 mm deep."""
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.contact.law import DEFAULTS, LOAD_SINK
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.switching import PhysicsWarning

# a trunk on one leg: it cannot stand, it topples onto its trunk
ONE_LEG = """<robot name="oneleg">
  <link name="trunk">
    <inertial><mass value="5"/><inertia ixx="0.02" iyy="0.07" izz="0.08" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.4 0.2 0.1"/></geometry></collision>
  </link>
  <link name="leg">
    <inertial><origin xyz="0 0 -0.15"/><mass value="0.5"/>
      <inertia ixx="0.004" iyy="0.004" izz="0.0001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.15"/><geometry><cylinder radius="0.02" length="0.3"/></geometry></collision>
  </link>
  <joint name="hip" type="revolute"><parent link="trunk"/><child link="leg"/><origin xyz="0 0 -0.05"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="5"/><dynamics damping="0.5"/></joint>
  <link name="foot"/>
  <joint name="ankle" type="fixed"><parent link="leg"/><child link="foot"/><origin xyz="0 0 -0.3"/></joint>
</robot>
"""

FOOT = "foot:0,0,0:0.02"


def _build(tmp_path, contacts, functions=None):
    path = tmp_path / "oneleg.urdf"
    path.write_text(ONE_LEG)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(UrdfModel(path, floating_base=True, contacts=tuple(contacts)), cache_dir=tmp_path / "c",
                            progress=False, **({"functions": functions} if functions else {}))


def _drop(model):
    x0 = np.zeros(model.nx)
    x0[model.state_names.index("q_trunk_floating_z")] = 0.05 + 0.3 + 0.02 + 0.001    # foot 1 mm above
    x0[model.state_names.index("q_trunk_floating_ry")] = 0.2                          # leaning: it falls
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = model.simulate(x0, (0.0, 1.5))
    return res, [str(w.message) for w in caught if issubclass(w.category, PhysicsWarning)]


def test_the_trunk_meets_the_ground_by_default(tmp_path):
    model = _build(tmp_path, [FOOT])
    depths = sorted(n for n in model.output_names if n.startswith("depth_"))
    # the trunk's box corners join the named foot, and the leg's far end (the rim by the foot is left
    # to the foot sphere: its 4 top rim points' box)
    assert depths == ["depth_foot"] + [f"depth_leg_col_{i}" for i in range(4)] + [f"depth_trunk_col_{i}" for i in range(8)]
    res, warned = _drop(model)
    assert res.status == 0
    assert not [w for w in warned if "under the ground" in w or "penetrated" in w], warned
    corners = np.array([res.outputs[n] for n in depths if n.startswith("depth_trunk")])
    assert corners.max() > 0.0                 # it did land on its trunk
    assert corners.max() < 0.01                # and the trunk holds (a point contact's allowance)
    z = res.x[:, model.state_names.index("q_trunk_floating_z")]
    assert z[-1] > 0.0


def test_without_the_ground_the_trunk_falls_through_and_the_run_says_so(tmp_path):
    model = _build(tmp_path, [FOOT, "@no-ground"])
    assert [n for n in model.output_names if n.startswith("depth_")] == ["depth_foot"]
    res, warned = _drop(model)
    z = res.x[:, model.state_names.index("q_trunk_floating_z")]
    assert z[-1] < -0.05                       # nothing holds the trunk
    # one body: "body trunk went ..."; several (trunk and leg here) share one note, "bodies trunk ..."
    named = [w for w in warned if ("body trunk went" in w or "bodies trunk " in w) and "under the ground" in w]
    assert named, warned


def _stand(tmp_path, mass, radius, k=None):
    """A box on four named spheres (the default ground adds nothing: its only body has contacts)."""
    path = tmp_path / f"box{mass}.urdf"
    path.write_text(f"""<robot name="box">
  <link name="box"><inertial><mass value="{mass}"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>
  </inertial><collision><geometry><box size="0.4 0.2 0.1"/></geometry></collision></link>
</robot>""")
    feet = [dict(link="box", point=(sx * 0.2, sy * 0.1, -0.05), radius=radius, name=f"f{i}", **({"k": k} if k else {}))
            for i, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1)))]
    return eomc.compile(UrdfModel(path, floating_base=True, contacts=tuple(feet)), functions=("rhs", "outputs"),
                        cache_dir=tmp_path / "c", progress=False)


def test_small_feet_under_a_heavy_robot_are_as_stiff_as_the_load_needs(tmp_path):
    heavy = _stand(tmp_path, 40.0, 0.005)
    assert [n for n in heavy.output_names if n.startswith("depth_")] == [f"depth_f{i}" for i in range(4)]
    p = dict(zip(heavy.param_names, heavy.param_defaults))
    W, r = 40.0 * 9.81, 0.005
    assert p["k_f0"] == pytest.approx((W / 4) / (LOAD_SINK * r) ** 1.5, rel=1e-12)
    # at rest each foot sinks LOAD_SINK of its radius: there the four carry the weight
    x = np.zeros(heavy.nx)
    x[heavy.state_names.index("q_box_floating_z")] = 0.05 + r - LOAD_SINK * r
    out = heavy.outputs(0.0, x)
    assert sum(out[f"Fn_f{i}"] for i in range(4)) == pytest.approx(W, rel=1e-9)
    # a light robot on large feet keeps the plain default; a given k is kept
    light = _stand(tmp_path, 1.0, 0.02)
    assert dict(zip(light.param_names, light.param_defaults))["k_f0"] == DEFAULTS["k"]
    given = _stand(tmp_path, 40.0, 0.005, k=3e5)
    assert dict(zip(given.param_names, given.param_defaults))["k_f0"] == 3e5
