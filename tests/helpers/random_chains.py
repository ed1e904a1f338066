"""Random open chains for property tests (hypothesis strategies and a builder).

Each link turns about a random axis of the previous link's frame (the first
one may sit on a slider), carries a particle or a rigid body at a random
offset, and may get a joint torque input, gravity and a viscous drag load.
``build`` takes the mechanics module, so the same chain is formed by
eomc.mechanics and by sympy.physics.mechanics.
"""
import sympy as sm
from hypothesis import strategies as st

link = st.fixed_dictionaries({
    "axis": st.sampled_from("xyz"),
    "offset": st.tuples(*[st.integers(-2, 2)] * 3).filter(any),
    "rigid": st.booleans(),
    "inertia": st.tuples(*[st.integers(1, 4)] * 3),
    "torque": st.booleans(),
    "drag": st.booleans(),
})
chain = st.fixed_dictionaries({
    "slider": st.booleans(),
    "links": st.lists(link, min_size=1, max_size=3),
    "speed_scale": st.integers(1, 3),
})


def build(me, spec):
    links = spec["links"]
    n = len(links) + spec["slider"]
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    g = sm.Symbol("g")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    base, frame, k = O, N, 0
    bodies, loads = [], []
    kd = [qi.diff() - spec["speed_scale"] * ui for qi, ui in zip(q, u)]
    if spec["slider"]:
        base = O.locatenew("S", q[0] * N.x)
        base.set_vel(N, spec["speed_scale"] * u[0] * N.x)
        bodies.append(me.Particle("Slider", base, sm.Symbol("ms")))
        k = 1
    for i, ln in enumerate(links):
        j = k + i
        axis = getattr(frame, ln["axis"])
        B = frame.orientnew(f"B{i}", "Axis", [q[j], axis])
        B.set_ang_vel(frame, spec["speed_scale"] * u[j] * axis)
        a, b, c = ln["offset"]
        m = sm.Symbol(f"m{i}")
        G = base.locatenew(f"G{i}", sm.Rational(1, 2) * (a * B.x + b * B.y + c * B.z))
        G.v2pt_theory(base, N, B)
        end = base.locatenew(f"E{i}", a * B.x + b * B.y + c * B.z)
        end.v2pt_theory(base, N, B)
        if ln["rigid"]:
            I = me.inertia(B, *[sm.Symbol(f"I{i}{d}") * w for d, w in zip("xyz", ln["inertia"])])
            bodies.append(me.RigidBody(f"Body{i}", G, B, m, (I, G)))
        else:
            bodies.append(me.Particle(f"Bob{i}", G, m))
        loads.append((G, -m * g * N.z))
        if ln["torque"]:
            T = me.dynamicsymbols(f"T{i}")
            loads += [(B, T * axis), (frame, -T * axis)]
        if ln["drag"]:
            loads.append((end, -sm.Symbol(f"c{i}") * end.vel(N)))
        base, frame = end, B
    km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations(bodies, loads)
    return km
