"""Solo12 (example-robot-data) standing on compliant ground under joint PD feedback.

    python examples/quadruped_stand.py [--t-final 10] [--method radau]

A floating base, four foot contacts (spheres of 1.6 cm at the FOOT links' origins,
Hunt–Crossley + regularised friction, eomc.compiler.contact), joint PD feedback
r = K (x_ref - x) evaluated in C (runtime/feedback.py).  The robot starts with its
feet just touching the ground, sinks into its stance and stays: the script prints
the base height's range over the last half and the feet's normal forces against m·g.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

import eomc
from eomc.compiler.urdf.model import UrdfModel

LEGS = ("FL", "FR", "HL", "HR")
STANCE = {"FL": (0.0, 0.8, -1.6), "FR": (0.0, 0.8, -1.6), "HL": (0.0, -0.8, 1.6), "HR": (0.0, -0.8, 1.6)}
FOOT_RADIUS = 0.016
KP, KD = 20.0, 0.5         # N m / rad, N m s / rad per joint
VS = 1e-4                  # friction regularisation speed: slow creep of the splayed feet


def solo12_path():
    from importlib.metadata import distribution
    root = Path(distribution("example-robot-data").locate_file(
        "cmeel.prefix/share/example-robot-data/robots"))
    return root / "solo_description" / "robots" / "solo12.urdf"


def build(**options):
    """The Solo12 with floating base and foot contacts (rhs, jac_x and jac_r for Radau with feedback, outputs, events)."""
    feet = [dict(link=f"{leg}_FOOT", radius=FOOT_RADIUS, vs=VS) for leg in LEGS]
    options.setdefault("functions", ("rhs", "jac_x", "jac_r", "outputs", "events"))
    return eomc.compile(UrdfModel(solo12_path(), floating_base=True), contacts=feet,
                        formulation="recursive", name="solo12_stand", **options)


def stance(model):
    """(x0, K, x_ref): the stance with feet touching (depth 0), and the PD gain."""
    x = np.zeros(len(model.state_names))
    for leg, angles in STANCE.items():
        for joint, a in zip(("HAA", "HFE", "KFE"), angles):
            x[model.state_names.index(f"q_{leg}_{joint}")] = a
    depth = model.outputs(0.0, x)
    iz = model.state_names.index("q_base_link_floating_z")
    x[iz] = np.mean([depth[f"depth_{leg}_FOOT"] for leg in LEGS])   # lift until the feet touch
    K = np.zeros((len(model.input_names), len(model.state_names)))
    for row, name in enumerate(model.input_names):
        joint = name[len("tau_"):]
        K[row, model.state_names.index(f"q_{joint}")] = KP
        K[row, model.state_names.index(f"u_{joint}")] = KD
    return x, K, x.copy()


def stand(model, t_final=10.0, method="radau", rtol=1e-6, atol=1e-8, **kw):
    x0, K, x_ref = stance(model)
    return model.simulate(x0, (0.0, t_final), r=np.zeros(len(model.input_names)), K=K, x_ref=x_ref,
                          method=method, rtol=rtol, atol=atol, **kw)


def total_mass(model):
    p = dict(zip(model.param_names, model.param_defaults))
    return sum(v for k, v in p.items() if k.startswith("m_"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-final", type=float, default=10.0)
    ap.add_argument("--method", default="radau")
    a = ap.parse_args(argv)
    model = build()
    res = stand(model, a.t_final, a.method)
    z = res["q_base_link_floating_z"]
    late = res.t >= a.t_final / 2
    fn = sum(res.outputs[f"Fn_{leg}_FOOT"] for leg in LEGS)
    mg = total_mass(model) * 9.81
    print(f"base height: start {z[0]:.5f} m, last half {z[late].min():.6f} .. {z[late].max():.6f} m "
          f"(range {1e3 * np.ptp(z[late]):.4f} mm)")
    print("feet normal forces at the end: " + ", ".join(f"{leg} {res.outputs[f'Fn_{leg}_FOOT'][-1]:.3f} N"
                                                          for leg in LEGS)
          + f"; sum {fn[-1]:.4f} N, m g = {mg:.4f} N")
    print("touch-down/lift-off events: " + ", ".join(f"{leg} {len(res.t_events[f'contact_{leg}_FOOT'])}"
                                                     for leg in LEGS) + f"; stats {res.stats}")
    return res


if __name__ == "__main__":
    main(sys.argv[1:])
