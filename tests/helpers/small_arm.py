"""A three-link spatial arm (joint axes z, y, y, as UR5's first three) for the identification
tests: links 1 and 2 carry full inertias (centres of mass off every axis, rotated inertial
frames), link 3 keeps the zeros a CAD export writes (centre of mass on its x axis, principal
inertia axes along the link), so ``all_inertial_parameters`` has zeros to turn into parameters."""
from pathlib import Path

SMALL_ARM = """<?xml version="1.0"?>
<robot name="arm3">
  <link name="base"/>
  <link name="l1">
    <inertial><origin xyz="0.01 -0.02 0.08" rpy="0.1 0.2 -0.3"/><mass value="2.0"/>
      <inertia ixx="0.020" ixy="0.001" ixz="-0.002" iyy="0.018" iyz="0.0015" izz="0.012"/></inertial>
  </link>
  <link name="l2">
    <inertial><origin xyz="0.15 0.01 -0.02" rpy="-0.2 0.1 0.4"/><mass value="1.5"/>
      <inertia ixx="0.004" ixy="-0.0005" ixz="0.0003" iyy="0.030" iyz="0.0" izz="0.031"/></inertial>
  </link>
  <link name="l3">
    <inertial><origin xyz="0.12 0 0"/><mass value="0.8"/>
      <inertia ixx="0.002" ixy="0.0" ixz="0.0" iyy="0.012" iyz="0.0" izz="0.0125"/></inertial>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0.05 0.15"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
</robot>
"""


def small_arm(directory):
    """Write the arm's URDF into ``directory``; returns its path."""
    path = Path(directory) / "arm3.urdf"
    path.write_text(SMALL_ARM)
    return path
