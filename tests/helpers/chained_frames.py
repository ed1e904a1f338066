"""The same open chain written two ways: chained frames, or angles summed by hand.

A chain of links hangs from a cart; link k turns about a basis axis of link
k-1 (``axes[k-1]``, one of "x", "y", "z") by its relative angle q_k, and its
point mass (or rigid body) sits at -l along its own y axis.

* ``style="sum"``: a run of links turning about the same axis is oriented from
  the frame before the run by the summed angle q_i + ... + q_k (the form the
  performance report recommends: one sin/cos per link);
* ``style="chain"``: every link frame is oriented from the previous link's,
  as SymPy users usually write it, with the angular velocity of each frame
  given in N (set_ang_vel(N, ...): for a planar chain (u1 + ... + uk) N.z, as the
  performance report's n_link_cart_rel_chain.py) ...;
* ``style="chainrel"``: ... or relative to the previous frame (set_ang_vel(A, u_k A.axis));
* ``style="chainq"``: ... or not at all (SymPy's q' form, mapped to u by kd_eqs).

Both describe the same system with the same coordinates and speeds.
"""
import sympy as sm

__all__ = ["STYLES", "chain_cart"]

STYLES = ("sum", "chain", "chainrel", "chainq")


def chain_cart(mech, axes, style, rigid=False):
    """A formed KanesMethod of the cart with len(axes) links (see the module docstring)."""
    n = len(axes)
    q = mech.dynamicsymbols(f"q:{n + 1}")
    u = mech.dynamicsymbols(f"u:{n + 1}")
    m0, m, l, g, Ixx, Iyy, Izz = sm.symbols("m0 m l g Ixx Iyy Izz", positive=True)
    F = mech.dynamicsymbols("F")
    N = mech.ReferenceFrame("N")
    O = mech.Point("O")
    O.set_vel(N, 0)
    cart = O.locatenew("P0", q[0] * N.x)
    cart.set_vel(N, u[0] * N.x)
    points, frames = [cart], [N]
    omega = [0 * N.x]      # angular velocity in N of frames[i], written run by run
    run_start = 0          # index (into frames) of the frame a run of equal axes starts from
    for k in range(1, n + 1):
        axis = axes[k - 1]
        A = frames[-1]
        if k == 1 or axes[k - 2] != axis:
            run_start = k - 1
        base = frames[run_start]
        omega.append(omega[run_start] + sum(u[run_start + 1:k + 1]) * getattr(base, axis))
        if style == "sum":
            B = base.orientnew(f"B{k}", "Axis", [sum(q[run_start + 1:k + 1]), getattr(base, axis)])
            B.set_ang_vel(base, sum(u[run_start + 1:k + 1]) * getattr(base, axis))
        else:
            B = A.orientnew(f"B{k}", "Axis", [q[k], getattr(A, axis)])
            if style == "chain":
                B.set_ang_vel(N, omega[k])
            elif style == "chainrel":
                B.set_ang_vel(A, u[k] * getattr(A, axis))
        P = points[-1].locatenew(f"P{k}", -l * B.y)
        P.v2pt_theory(points[-1], N, B)
        points.append(P)
        frames.append(B)
    bodies = [mech.Particle("Pa0", cart, m0)]
    for k in range(1, n + 1):
        if rigid:
            C = points[k - 1].locatenew(f"C{k}", -l / 2 * frames[k].y)
            C.v2pt_theory(points[k - 1], N, frames[k])
            bodies.append(mech.RigidBody(f"L{k}", C, frames[k], m,
                                         (mech.inertia(frames[k], Ixx, Iyy, Izz), C)))
        else:
            bodies.append(mech.Particle(f"Pa{k}", points[k], m))
    masses = [m0] + [m] * n
    loads = [(P, -mi * g * N.y) for P, mi in zip(points, masses)] + [(cart, F * N.x)]
    km = mech.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    km.kanes_equations(bodies, loads)
    return km

