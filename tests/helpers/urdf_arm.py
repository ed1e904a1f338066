"""A two-link arm in URDF, written for the tests (no third-party file)."""

__all__ = ["ARM", "LAW_ARM", "FLOATING_FEET", "LIMITED_HINGE", "check_limited_hinge_energy_verdict"]

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="upper">
    <inertial>
      <origin xyz="0 0 0.2" rpy="0 0 0"/>
      <mass value="1.5"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.001"/>
    </inertial>
  </link>
  <link name="lower">
    <inertial>
      <origin xyz="0 0 0.15"/>
      <mass value="1.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.0005"/>
    </inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/>
    <child link="upper"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
  </joint>
  <joint name="elbow" type="continuous">
    <parent link="upper"/>
    <child link="lower"/>
    <origin xyz="0 0 0.4" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
  </joint>
</robot>
"""


# three joints that each carry a law (soft limits, damping, Coulomb friction), one prismatic
LAW_ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0 0 -0.25"/><mass value="1.2"/>
    <inertia ixx="0.02" iyy="0.025" izz="0.008" ixy="0.001" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.05 0 -0.2"/><mass value="0.8"/>
    <inertia ixx="0.01" iyy="0.012" izz="0.003" ixy="0" ixz="0.0005" iyz="0"/></inertial></link>
  <link name="l3"><inertial><origin xyz="0 0.02 0"/><mass value="0.3"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/><axis xyz="0 1 0"/>
    <limit lower="-0.5" upper="0.8" effort="10" velocity="2"/>
    <dynamics damping="0.3" friction="0.2"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/><origin xyz="0 0 -0.5" rpy="0.1 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1.2" effort="10" velocity="2"/>
    <dynamics damping="0.1" friction="0.05"/>
  </joint>
  <joint name="j3" type="prismatic">
    <parent link="l2"/><child link="l3"/><origin xyz="0 0 -0.4"/><axis xyz="0 0 1"/>
    <limit lower="-0.1" upper="0.05" effort="10" velocity="1"/>
    <dynamics damping="0.4" friction="0.5"/>
  </joint>
</robot>
"""


# a two-body robot for a floating base whose two collision spheres touch the ground
# (contacts="@collision"): a trunk and a leg on a hinge with limits
FLOATING_FEET = """<?xml version="1.0"?>
<robot name="hop">
  <link name="trunk">
    <inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.1 0 0"/><geometry><sphere radius="0.03"/></geometry></collision>
  </link>
  <link name="leg">
    <inertial><origin xyz="0 0 -0.1"/><mass value="0.5"/>
      <inertia ixx="0.001" iyy="0.001" izz="0.0001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.2"/><geometry><sphere radius="0.02"/></geometry></collision>
  </link>
  <joint name="hip" type="revolute"><parent link="trunk"/><child link="leg"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="5" velocity="5"/></joint>
</robot>
"""


# one hinge with a limit and no contact: its model's energy output holds the limit's spring
# (tests/compiler/contact/test_limit_energy.py, tests/compiler/formulations/test_select.py)
LIMITED_HINGE = """<robot name="arm">
  <link name="base"/>
  <link name="arm">
    <inertial><origin xyz="0 0 -0.25"/><mass value="2"/>
      <inertia ixx="0.05" iyy="0.05" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-0.4" upper="0.3" effort="10" velocity="5"/></joint>
</robot>
"""


def check_limited_hinge_energy_verdict(arm):
    """LIMITED_HINGE built as ``arm``: with a stiff undamped limit (k = 1e4, c = 0), a swing into the
    limit at 3 rad/s gains energy under RK4 at 10 ms (the run's energy verdict fails it, status
    STATUS_ENERGY) and keeps it under Radau at 1e-10 (status 0, the energy output flat to 1e-9)."""
    import warnings
    import numpy as np
    from eomc.runtime.switching import STATUS_ENERGY, PhysicsWarning
    p = np.array(arm.param_defaults)
    p[arm.param_names.index("limit_k_hinge")], p[arm.param_names.index("limit_c_hinge")] = 1e4, 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PhysicsWarning)
        bad = arm.simulate(np.array([0.0, 3.0]), (0.0, 2.0), p=p, method="rk4", dt=1e-2, raise_on_failure=False)
        good = arm.simulate(np.array([0.0, 3.0]), (0.0, 2.0), p=p, method="radau", rtol=1e-10, atol=1e-12)
    assert bad.status == STATUS_ENERGY and "energy rose" in bad.message
    E = good.outputs["energy"]
    assert good.status == 0 and good.x[:, 0].max() > 0.3 and E.max() - E[0] < 1e-9 * abs(E).max()
