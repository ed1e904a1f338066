"""What a normal-force spike at a touch-down is: eomc's law at an impact against MuJoCo's.

    python benchmarks/bench_impact.py [--no-write] [--cache-dir DIR]

The first-hour round of session 20 saw ``Fn_right_foot`` reach 35 kN (90x the body's weight)
in one output row of gymnasium's humanoid falling passively (``eomc simulate humanoid.xml``,
rows 3 ms apart).  Is it the law at a touch-down, an output sampled at a bad point, or a real
impact?  Here, from the file's qpos0 with no control:

- eomc: ``eomc.compile(path)`` with no flags, ``model.simulate`` with the default method, its
  outputs at 2 us over the touch-down (interpolated states, the law evaluated there) and at the
  CLI's rows; the feet's normal impulse over windows after the touch-down, against the body's
  momentum change M*dv (root vz by central differences: the root stops with the legs, the arms
  a little later), net of gravity's M*g*w;
- MuJoCo: ``mj_step`` at the file's time step, ``mj_contactForce`` (normal component, summed over
  each foot's contacts) at every step, ``subtree_linvel`` of the world body (the centre of mass).

Both must take out the same momentum (M*v at touch-down, about 60 N s); the question is over how
long.  The table is the answer: eomc's Hunt-Crossley law (k from MuJoCo's resting depth under the
whole weight, c from solref's damping ratio at rest: docs/contact.md) stops the body in about
1.5 ms, MuJoCo's soft constraint (solref time constant 0.02 s) in about 30 ms, so eomc's peak is
about 7x MuJoCo's and 10-20x shorter; MuJoCo's feet sink 20 mm doing it (bench_mjcf_drops.py),
eomc's 1 mm.  The spike is physics of eomc's law, sampled near its peak, not a sampling artefact.
"""
import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

FEET = ("right_foot", "left_foot")


def _eomc(path, cache_dir):
    import eomc
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(path, progress=False, cache_dir=cache_dir)
        rows = model.simulate(model.initial_state, (0, 0.3))               # the CLI's rows (3 ms)
        te = np.concatenate([np.arange(0, 0.14, 1e-3), np.arange(0.14, 0.20, 2e-6), np.arange(0.2, 0.3, 1e-3)])
        fine = model.simulate(model.initial_state, (0, 0.3), t_eval=te)
    t = fine.t
    force = sum(np.asarray(fine.outputs[f"Fn_{f}"]) for f in FEET)
    on = t[np.flatnonzero(force > 0)[0]]
    vz = np.gradient(fine.x[:, model.state_names.index("q_root_z")], t)
    row_force = sum(np.asarray(rows.outputs[f"Fn_{f}"]) for f in FEET)
    half = np.flatnonzero(force > force.max() / 2)
    return dict(t=t, force=force, on=on, vz=vz, peak=force.max(), fwhm=t[half[-1]] - t[half[0]],
                row_peak=row_force.max(), row_t=rows.t[np.argmax(row_force)],
                depth=max(float(np.max(fine.outputs[f"depth_{f}"])) for f in FEET))


def _mujoco(path):
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    feet = {mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f) for f in FEET}
    f6, rows = np.zeros(6), []
    while d.time < 0.3:
        mujoco.mj_step(m, d)
        fz = 0.0            # the forces the step applied (computed at its start)
        for c in range(d.ncon):
            if {d.contact[c].geom1, d.contact[c].geom2} & feet:
                mujoco.mj_contactForce(m, d, c, f6)
                fz += f6[0]
        mujoco.mj_forward(m, d)     # the step's end state's velocities (cvel is the start's after mj_step)
        mujoco.mj_subtreeVel(m, d)
        rows.append((d.time, fz, d.subtree_linvel[0][2]))
    return m.opt.timestep, float(m.body_subtreemass[0]), np.array(rows)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--cache-dir", default=None)
    parser.add_argument("--model", default=None, help="humanoid.xml (default: gymnasium's)")
    args = parser.parse_args(argv)
    if args.model:
        path = Path(args.model)
    else:
        import gymnasium
        path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "humanoid.xml"
    dt, mass, mj = _mujoco(path)
    e = _eomc(path, args.cache_dir)
    g = 9.81
    t, force, on, vz = e["t"], e["force"], e["on"], e["vz"]
    v0 = vz[np.searchsorted(t, on - 1e-4)]
    k = np.flatnonzero(mj[:, 1] > 0)[0]
    vmj0 = mj[k - 1, 2]
    table = []
    for w in (1e-3, 2e-3, 3e-3, 6e-3, 9e-3, 30e-3, 60e-3):
        s = (t >= on) & (t <= on + w)
        impulse = float(np.trapezoid(force[s], t[s]))
        v = vz[np.searchsorted(t, on + w)]
        n = int(round(w / dt)) if abs(w / dt - round(w / dt)) < 1e-9 else 0    # whole MuJoCo steps only
        mj_impulse = float(mj[k:k + n, 1].sum() * dt) if n else float("nan")
        mj_v = mj[k + n - 1, 2] if n else float("nan")
        table.append([f"{w * 1e3:g}", f"{impulse:.1f}", f"{impulse - mass * g * w:.1f}", f"{mass * (v - v0):.1f}",
                      f"{v:+.3f}", "-" if not n else f"{mj_impulse:.1f}",
                      "-" if not n else f"{mj_impulse - mass * g * w:.1f}", "-" if not n else f"{mj_v:+.3f}"])
    text = environment_header("A touch-down's normal-force spike: eomc's law vs MuJoCo (gymnasium humanoid, passive)",
                              args, notes=[f"model {path.name}: mass {mass:.2f} kg, weight {mass * g:.0f} N; "
                                           f"MuJoCo time step {dt} s"])
    text += (f"\n- eomc: touch-down at t = {on:.6f} s with the root falling at {v0:.3f} m/s (M*v = "
             f"{mass * abs(v0):.1f} N s); both feet's normal force peaks at {e['peak']:.0f} N "
             f"({e['peak'] / (mass * g):.0f}x the weight), width at half height {e['fwhm'] * 1e3:.2f} ms; "
             f"the CLI's 3 ms rows show {e['row_peak']:.0f} N at t = {e['row_t']:.3f} (a row near the peak); "
             f"deepest foot {e['depth'] * 1e3:.2f} mm\n"
             f"- MuJoCo: the feet's first contact step ends at t = {mj[k, 0]:.3f} s (centre of mass at "
             f"{vmj0:.3f} m/s); peak {mj[:, 1].max():.0f} N ({mj[:, 1].max() / (mass * g):.0f}x the weight)\n\n")
    text += format_table(["window after touch-down (ms)", "eomc feet impulse (N s)", "eomc net of M*g*w",
                          "eomc M*dv (root)", "eomc root vz", "MuJoCo feet impulse", "MuJoCo net of M*g*w",
                          "MuJoCo com vz"], table)
    text += ("\n\nBoth take out the body's momentum (M*v at touch-down; the net impulse is less than the "
             "root's M*dv by what the arms, still moving, carry); eomc within about 1.5 ms, MuJoCo over about 30 ms. The spike is eomc's contact law at an impact (Hunt-Crossley with the "
             "parameters mapped from MuJoCo's solref/solimp at rest), not an output sampled at a bad point.\n")
    print(text)
    if not args.no_write:
        for p in write_results("impact", text):
            print(f"wrote {p}")


if __name__ == "__main__":
    main()
