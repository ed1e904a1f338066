"""Small model files (as text) shared by the build, driver, CLI and packaging tests.

``write(tmp_path, text, name)`` puts one in a directory and returns its path.
The oracles are closed forms (a planar pendulum, a pendulum on a cart).
"""
import textwrap
from pathlib import Path

import numpy as np

__all__ = ["PENDULUM", "CART", "TWO_LEGS", "write", "pendulum_rhs", "cart_rhs"]

PENDULUM = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import *

    q, u = dynamicsymbols("q u")
    m, l, g = sm.symbols("m l g")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", [q, N.z])
    A.set_ang_vel(N, u * N.z)
    O = Point("O")
    O.set_vel(N, 0)
    P = O.locatenew("P", l * A.x)
    P.v2pt_theory(O, N, A)
    bob = Particle("bob", P, m)
    kane = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
    kane.kanes_equations([bob], [(P, -m * g * N.y)])

    system = kane
    name = "pend"
    parameters = {m: 2.0, l: 0.5, g: 9.81}
    initial_state = {q: 0.3}
    outputs = {"energy": bob.kinetic_energy(N) + m * g * P.pos_from(O).dot(N.y)}
    ''')

CART = textwrap.dedent('''\
    import sympy as sm
    from eomc.mechanics import *

    x, th, v, w = dynamicsymbols("x th v w")
    F = dynamicsymbols("F")
    M, m, l, g = sm.symbols("M m l g")
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Axis", [th, N.z])
    B.set_ang_vel(N, w * N.z)
    O = Point("O")
    O.set_vel(N, 0)
    C = O.locatenew("C", x * N.x)
    C.set_vel(N, v * N.x)
    P = C.locatenew("P", -l * B.y)
    P.v2pt_theory(C, N, B)
    kane = KanesMethod(N, q_ind=[x, th], u_ind=[v, w], kd_eqs=[x.diff() - v, th.diff() - w])
    kane.kanes_equations([Particle("cart", C, M), Particle("bob", P, m)],
                         [(C, F * N.x - M * g * N.y), (P, -m * g * N.y)])

    system = kane
    parameters = {M: 1.5, m: 0.5, l: 0.8, g: 9.81}
    inputs = [F]
    initial_state = {th: 0.4}
    ''')


def write(directory, text, name):
    path = Path(directory) / f"{name}.py"
    path.write_text(text)
    return path


def pendulum_rhs(x, m=2.0, l=0.5, g=9.81):
    """q'' = -g cos(q) / l for the bob at l (cos q, sin q) under gravity -y."""
    q, u = x
    return np.array([u, -g * np.cos(q) / l])


def cart_rhs(x, F=0.0, M=1.5, m=0.5, l=0.8, g=9.81):
    """Closed-form cart-pendulum: solve the 2x2 mass matrix by hand."""
    _, th, v, w = x
    s, c = np.sin(th), np.cos(th)
    mass = np.array([[M + m, m * l * c], [m * l * c, m * l * l]])
    force = np.array([F + m * l * s * w * w, -m * g * l * s])
    return np.concatenate([[v, w], np.linalg.solve(mass, force)])


# Two legs hanging from a torso on a planar root, a sphere foot each: the feet are one self-pair
# (siblings) and each touches the floor (the implicit-batch and energy-function tests).
TWO_LEGS = """<mujoco model="twolegs">
  <worldbody>
    <geom name="floor" type="plane" size="0 0 1"/>
    <body name="torso" pos="0 0 0.5">
      <joint name="rootx" type="slide" axis="1 0 0"/>
      <joint name="rootz" type="slide" axis="0 0 1"/>
      <joint name="rooty" type="hinge" axis="0 1 0"/>
      <geom name="torso" type="box" size="0.1 0.1 0.05" mass="5" contype="0" conaffinity="0"/>
      <body name="left" pos="0 0.06 0">
        <joint name="hip_l" type="hinge" axis="1 0 0" damping="0.5"/>
        <geom name="thigh_l" type="box" size="0.02 0.02 0.2" pos="0 0 -0.2" mass="1" contype="0" conaffinity="0"/>
        <geom name="foot_l" type="sphere" size="0.04" pos="0 0 -0.4" mass="0.2"/>
      </body>
      <body name="right" pos="0 -0.06 0">
        <joint name="hip_r" type="hinge" axis="1 0 0" damping="0.5"/>
        <geom name="thigh_r" type="box" size="0.02 0.02 0.2" pos="0 0 -0.2" mass="1" contype="0" conaffinity="0"/>
        <geom name="foot_r" type="sphere" size="0.04" pos="0 0 -0.4" mass="0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
