"""A cart-pole balanced upright by LQR, designed from the compiled model's own linearization.

The model (this file, as any eomc model file): a cart of mass M on a rail,
pushed by the input force F, carrying a pendulum (bob m at length l) whose
angle th is measured from hanging down, so upright is th = pi.  Run it as a
script to design and close the loop:

    python examples/cartpole_lqr.py

``model.linearize`` at the upright equilibrium gives A, B; scipy's Riccati
solver gives the LQR gain K; ``simulate(..., K=K, x_ref=upright)`` applies
F = K (x_ref - x) inside the C integrator (no Python per step).  A terminal
event stops the run if the pole ever falls past horizontal.
"""
import sympy as sm

from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols

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
system = KanesMethod(N, q_ind=[x, th], u_ind=[v, w], kd_eqs=[x.diff() - v, th.diff() - w])
system.kanes_equations([Particle("cart", C, M), Particle("bob", P, m)],
                       [(C, F * N.x - M * g * N.y), (P, -m * g * N.y)])

name = "cartpole"
parameters = {M: 1.0, m: 0.3, l: 0.6, g: 9.81}
inputs = [F]
initial_state = {th: sm.pi - 0.3}
outputs = {"bob_height": -l * sm.cos(th)}
# fallen: the bob below the rail's level (|th - pi| > pi/2), either way
events = {"fallen": {"expr": sm.cos(th), "terminal": True, "direction": 1}}


if __name__ == "__main__":
    from pathlib import Path

    import numpy as np
    from scipy.linalg import solve_continuous_are

    import eomc

    model = eomc.compile(str(Path(__file__).resolve()))
    upright = np.array([0.0, np.pi, 0.0, 0.0])
    A, Bm = model.linearize(0.0, upright)
    K = Bm.T @ solve_continuous_are(A, Bm, np.diag([10.0, 100.0, 1.0, 1.0]), np.eye(1))
    print("LQR gain K =", np.array2string(K, precision=3))
    print("closed-loop eigenvalues:", np.round(np.linalg.eigvals(A - Bm @ K), 3))
    res = model.simulate(model.initial_state, (0, 10), K=K, x_ref=upright, rtol=1e-9, atol=1e-9)
    print(f"0.3 rad off upright -> after 10 s: th - pi = {res.x_final[1] - np.pi:.2e}, "
          f"x = {res.x_final[0]:.2e} ({res.stats['nfev']} rhs calls, all in C)")
    free = model.simulate(model.initial_state, (0, 10), rtol=1e-9, atol=1e-9)
    print(f"without control: {free.event_stop} at t = {free.t_final:.4f} s")
