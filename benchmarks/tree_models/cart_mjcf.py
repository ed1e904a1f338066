"""MJCF of the relative-coordinate n-link cart (the performance report's gen_mjcf.py): a slide
joint along x for the cart, hinges about +z at each link's pin, point masses l below their pins,
gravity 9.81 along -y, no contacts, limits, damping or armature.  MuJoCo rejects zero inertia,
so every body gets the smallest it accepts (1e-15 kg m²)."""


def mjcf(n, m0=2.0, m=0.5, l=0.75, g=9.81, inertia="1e-15"):
    I = f"{inertia} {inertia} {inertia}"
    body = ""
    for k in range(n, 0, -1):
        pos = "0 0 0" if k == 1 else f"0 {-l} 0"
        body = (f'<body name="link{k}" pos="{pos}"><joint name="pin{k}" type="hinge" axis="0 0 1" '
                f'pos="0 0 0"/><inertial pos="0 {-l} 0" mass="{m}" diaginertia="{I}"/>{body}</body>')
    return f"""<mujoco model="cart{n}">
  <compiler angle="radian" inertiafromgeom="false" autolimits="false"/>
  <option gravity="0 -{g} 0" timestep="0.001">
    <flag contact="disable" constraint="disable" limit="disable" equality="disable" frictionloss="disable"/>
  </option>
  <worldbody>
    <body name="cart" pos="0 0 0"><joint name="slide" type="slide" axis="1 0 0" pos="0 0 0"/>
      <inertial pos="0 0 0" mass="{m0}" diaginertia="{I}"/>{body}</body>
  </worldbody>
</mujoco>
"""
