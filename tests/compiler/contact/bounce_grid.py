"""The bouncing-sphere property grid (issue 29): every method, stiffness, damping, friction.

A 1 kg sphere of radius 0.1 m (sphere_model.py) dropped from 0.5 m with a sideways speed
of 1 m/s (so friction acts during each impact), integrated for 1.2 s (two or three bounces).
One case is judged right or loud:

- loud: the run failed (non-zero status) or warned (PhysicsWarning naming the contact);
- right: the energy never rises above its start by more than the stated tolerance
  (runtime/switching.energy_tolerance), and the first apex after the first bounce equals
  the law's own prediction -- a 1-D reference (the same normal law, gravity included,
  scipy DOP853 at rtol 1e-12 split at touch-down and lift-off) -- to
  APEX_TOL(rtol) of the drop height.  Friction acts along the ground only, so the
  vertical motion and the apex do not depend on mu.

Anything else is silent wrong physics: the grid's point is that there is none.
"""
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from sphere_model import sphere_model  # noqa: E402

R, M, G, Z0, VX = 0.1, 1.0, 9.81, 0.5, 1.0
T_FINAL = 1.2
STIFFNESS = (1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12)
DAMPING = {"none": 0.0, "small": 0.05, "large": 2.0}
FRICTION = (0.0, 0.5)
METHODS = ("dopri5", "dop853", "radau", "bdf")
RTOLS = (1e-3, 1e-6)


def apex_tolerance(rtol):
    """How far the first apex may sit from the reference (fraction of the drop height)."""
    return max(300.0 * rtol, 1e-5)


def build(cache_dir):
    import eomc
    spec, _ = sphere_model(radius=R, k=1e6, c=0.0, mu=0.5, vs=1e-3)
    system = spec.pop("system")
    return eomc.compile(system, name="bounce_grid", formulation="kane", cache_dir=cache_dir, **spec)


def reference_apex(k, c):
    """First apex height after the first bounce of the 1-D normal law (None: no lift-off)."""
    from scipy.integrate import solve_ivp

    def contact(t, y):
        d, dd = R - y[0], -y[1]
        f = k * max(d, 0.0) ** 1.5 * (1 + 1.5 * c * dd)
        return [y[1], -G + max(f, 0.0) / M]

    v_in = -np.sqrt(2 * G * (Z0 - R))
    lift = lambda t, y: y[0] - R - 1e-300   # noqa: E731
    lift.terminal, lift.direction = True, 1
    out = solve_ivp(contact, (0, 10.0), [R, v_in], method="DOP853", rtol=1e-12, atol=1e-15,
                    events=lift, max_step=1e-3 * min(1.0, (M / k) ** 0.5 * 50))
    if out.status != 1:
        return None
    v_out = out.y_events[0][0][1]
    return R + v_out ** 2 / (2 * G)


def run_case(model, k, c, mu, method, rtol, switching=True):
    """(verdict, detail): verdict "right", "loud" or "SILENT" (wrong physics with status 0)."""
    from eomc.runtime.switching import PhysicsWarning, energy_tolerance
    names = model.param_names
    p = np.array(model.param_defaults)
    p[names.index("k_ball")], p[names.index("c_ball")], p[names.index("mu_ball")] = k, c, mu
    x0 = np.zeros(12)
    x0[2], x0[model.state_names.index("vx")] = Z0, VX
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = model.simulate(x0, (0, T_FINAL), p=p, method=method, rtol=rtol, atol=rtol * 1e-3,
                             raise_on_failure=False, n_points=2401, max_steps=200000,
                             switching=switching)
    loud = [w for w in caught if issubclass(w.category, PhysicsWarning)]
    if res.status != 0:
        return "loud", f"status {res.status}: {res.message[:90]}"
    if loud:
        return "loud", f"warning: {str(loud[0].message)[:90]}"
    E = res.outputs["energy"]
    gain = float(E.max() - E[0])
    if gain > energy_tolerance(rtol, rtol * 1e-3) * abs(E[0]):
        return "SILENT", f"energy gain {gain:.3g}"
    ev = res.t_events["contact_ball"]
    ref = reference_apex(k, c)
    if len(ev) < 2:     # stayed on the ground: right only if the law says it does not lift off
        if ref is None:
            return "right", f"no lift-off, as the law says; energy gain {gain:.1e}"
        return "SILENT", "no lift-off recorded, but the law bounces"
    if ref is None:
        return "SILENT", "lifted off, but the law says it stays on the ground"
    t_free = (res.t > ev[1]) & ((res.t < ev[2]) if len(ev) > 2 else True)
    z, vz = res["z"][t_free], res["vz"][t_free]
    if ref is None or not len(z):
        return "SILENT", "no free flight after the first bounce"
    apex = float(np.median(z + vz ** 2 / (2 * G)))
    err = abs(apex - ref) / Z0
    if err > apex_tolerance(rtol):
        return "SILENT", f"apex {apex:.6g} vs law {ref:.6g} (error {err:.2g} of the drop)"
    return "right", f"apex error {err:.1e}, energy gain {gain:.1e}"
