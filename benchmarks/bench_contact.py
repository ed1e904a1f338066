"""Stiff-contact work-precision: Solo12 standing on four compliant feet (examples/quadruped_stand.py).

    python benchmarks/bench_contact.py [--t-final 1.0] [--repeat 3]

Contestants, interleaved per tolerance, thread CPU time, median of --repeat runs:
eomc's Radau IIA(5) and DOP853 (loops in C, feedback K in C) and scipy's solve_ivp
Radau and LSODA on the same compiled rhs (feedback and the Jacobian jac_x + jac_r·K
through Python).  Error: max abs over the final state's base position and joint
angles against a Radau run at rtol = atol = 1e-12.  Prints a Markdown table.
"""
import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import quadruped_stand as qs  # noqa: E402


def _cpu(fn):
    t0 = time.thread_time()
    out = fn()
    return time.thread_time() - t0, out


def mujoco_stance(x0, t_final, timestep=5e-4):
    """The same Solo12 in MuJoCo (its URDF through MjSpec, meshes dropped, a free joint on the
    base, a sphere geom of the same radius and mu = 1 on each FOOT link, a floor plane, MuJoCo's
    default soft contact solref=(0.02, 1), solimp=(0.9, 0.95, 0.001)), the same joint PD as
    qfrc_applied each step, started from the same state.  Returns (t, base z, per-foot normal
    forces (n_t, 4), penetration per foot at the end)."""
    import re
    import mujoco
    text = qs.solo12_path().read_text()
    text = re.sub(r"<visual>.*?</visual>", "", text, flags=re.S)
    text = re.sub(r"<collision>.*?</collision>", "", text, flags=re.S)
    text = text.replace("</robot>", '<mujoco><compiler fusestatic="false" discardvisual="true" '
                        'balanceinertia="false"/></mujoco></robot>', 1)
    spec = mujoco.MjSpec.from_string(text)
    spec.body("base_link").add_freejoint()
    for leg in qs.LEGS:
        g = spec.body(f"{leg}_FOOT").add_geom()
        g.type = mujoco.mjtGeom.mjGEOM_SPHERE
        g.size = [qs.FOOT_RADIUS, 0, 0]
        g.friction = [1.0, 0.005, 0.0001]
    floor = spec.worldbody.add_geom()
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = [5, 5, 0.1]
    spec.option.timestep = timestep
    m = spec.compile()
    d = mujoco.MjData(m)
    d.qpos[:3] = x0[:3]
    d.qpos[3:7] = [1, 0, 0, 0]
    joints = [m.jnt(i).name for i in range(1, m.njnt)]
    names = [n for n in qs.LEGS for _ in range(3)]
    del names
    ref = np.array([qs.STANCE[j[:2]][("HAA", "HFE", "KFE").index(j[3:])] for j in joints])
    d.qpos[7:] = ref
    feet = [m.geom(g).bodyid for g in range(m.ngeom) if m.geom(g).type == mujoco.mjtGeom.mjGEOM_SPHERE]
    feet = {int(b): k for k, b in enumerate(np.ravel(feet))}
    n = int(round(t_final / timestep))
    ts, zs, fs = [], [], []
    force = np.zeros(6)
    depth = np.zeros(4)
    for step in range(n + 1):
        d.qfrc_applied[6:] = qs.KP * (ref - d.qpos[7:]) - qs.KD * d.qvel[6:]
        if step % 20 == 0 or step == n:
            mujoco.mj_forward(m, d)
            fn = np.zeros(4)
            for c in range(d.ncon):
                con = d.contact[c]
                body = m.geom_bodyid[con.geom1] if m.geom_bodyid[con.geom1] in feet else m.geom_bodyid[con.geom2]
                mujoco.mj_contactForce(m, d, c, force)
                fn[feet[int(body)]] += force[0]
                depth[feet[int(body)]] = -con.dist
            ts.append(d.time)
            zs.append(d.qpos[2])
            fs.append(fn)
        if step < n:
            mujoco.mj_step(m, d)
    knees = {j: float(d.qpos[7 + k]) for k, j in enumerate(joints)}
    spread = {leg: d.xpos[b].copy() for b, k in feet.items() for leg in [qs.LEGS[k]]}
    return np.array(ts), np.array(zs), np.array(fs), depth, mujoco.__version__, knees, spread


def _foot_xy(model, res, leg):
    """The FOOT link origin's x, y at the end (from the base pose and joint angles, via Pinocchio)."""
    import pinocchio as pin
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.helpers.robots import rotation_xyz
    pm = pin.buildModelFromUrdf(str(qs.solo12_path()), pin.JointModelFreeFlyer())
    pd = pm.createData()
    x = np.array([res[n][-1] for n in model.state_names])
    q = np.concatenate([x[:3], pin.Quaternion(rotation_xyz(*x[3:6])).coeffs(), np.zeros(pm.nq - 7)])
    for j in range(2, pm.njoints):
        q[pm.joints[j].idx_q] = x[model.state_names.index(f"q_{pm.names[j]}")]
    pin.framesForwardKinematics(pm, pd, q)
    p = pd.oMf[pm.getFrameId(f"{leg}_FOOT")].translation
    return f"{p[0]:.5f} {p[1]:.5f}"


def stance_table(model, t_final):
    """Base height and foot forces at the end of t_final s: eomc (Radau) vs MuJoCo."""
    x0, _, _ = qs.stance(model)
    t0 = time.perf_counter()
    res = qs.stand(model, t_final)
    wall_e = time.perf_counter() - t0
    z = res["q_base_link_floating_z"]
    late = res.t >= t_final / 2
    fe = np.array([res.outputs[f"Fn_{leg}_FOOT"][-1] for leg in qs.LEGS])
    de = np.array([res.outputs[f"depth_{leg}_FOOT"][-1] for leg in qs.LEGS])
    t0 = time.perf_counter()
    tm, zm, fm, dm, version, joints_m, feet_m = mujoco_stance(x0, t_final)
    wall_m = time.perf_counter() - t0
    latem = tm >= t_final / 2
    legs = [f"FL_{j}" for j in ("HAA", "HFE", "KFE")]
    angles_e = " ".join(f"{res['q_' + j][-1]:.5f}" for j in legs)
    angles_m = " ".join(f"{joints_m[j]:.5f}" for j in legs)
    mg = qs.total_mass(model) * 9.81
    lines = [f"## Stance after {t_final:g} s: eomc vs MuJoCo {version}\n",
             f"Same URDF, same start (feet touching), same joint PD (Kp = {qs.KP}, Kd = {qs.KD}), "
             f"m g = {mg:.4f} N.  eomc: Hunt–Crossley k = 1e6 N/m^1.5, c = 2 s/m, mu = 1, "
             f"v_s = {qs.VS} m/s, Radau rtol 1e-6.  MuJoCo: default soft contact (solref 0.02 1, "
             f"solimp 0.9 0.95 0.001), pyramidal friction mu = 1, Euler, timestep 0.5 ms.\n",
             "| | eomc | MuJoCo |", "|---|---|---|",
             f"| base height at the end (m) | {z[-1]:.6f} | {zm[-1]:.6f} |",
             f"| base height range, second half (mm) | {1e3 * np.ptp(z[late]):.4f} | {1e3 * np.ptp(zm[latem]):.4f} |",
             f"| sum of foot normal forces (N) | {fe.sum():.4f} | {fm[-1].sum():.4f} |",
             f"| foot normal forces FL FR HL HR (N) | {' '.join(f'{f:.3f}' for f in fe)} | "
             f"{' '.join(f'{f:.3f}' for f in fm[-1])} |",
             f"| foot penetration (mm) | {' '.join(f'{1e3 * x:.3f}' for x in de)} | "
             f"{' '.join(f'{1e3 * x:.3f}' for x in dm)} |",
             f"| joint angles FL HAA HFE KFE at the end (rad) | {angles_e} | {angles_m} |",
             f"| FL foot body x, y at the end (m) | {_foot_xy(model, res, 'FL')} | "
             f"{feet_m['FL'][0]:.5f} {feet_m['FL'][1]:.5f} |",
             f"| wall time of the run (s, incl. Python loop for MuJoCo) | {wall_e:.2f} | {wall_m:.2f} |"]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-final", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tols", default="1e-4,1e-6,1e-8")
    ap.add_argument("--stance", type=float, default=10.0, help="seconds of the stance vs MuJoCo (0: skip)")
    ap.add_argument("--no-work-precision", action="store_true")
    a = ap.parse_args(argv)
    import scipy
    from scipy.integrate import solve_ivp
    import eomc
    model = qs.build()
    x0, K, x_ref = qs.stance(model)
    nq = sum(1 for n in model.state_names if n.startswith("q_"))
    T = a.t_final
    r0 = np.zeros(len(model.input_names))
    ref = model.simulate(x0, (0, T), r=r0, K=K, x_ref=x_ref, method="radau", rtol=1e-12, atol=1e-12,
                         max_steps=10**7).x_final

    def err(x):
        return float(np.max(np.abs(x[:nq] - ref[:nq])))

    def fun(t, x):
        return model.rhs(t, x, r=K @ (x_ref - x))

    def jac(t, x):
        r = K @ (x_ref - x)
        return model.jacobian(t, x, r=r) - model.input_jacobian(t, x, r=r) @ K

    def eomc_run(method, tol):
        return lambda: model.simulate(x0, (0, T), r=r0, K=K, x_ref=x_ref, method=method, rtol=tol,
                                      atol=tol, max_steps=10**7, t_eval=[T]).x_final

    def scipy_run(method, tol):
        def go():
            kw = {"jac": jac} if method == "Radau" else {}
            sol = solve_ivp(fun, (0, T), x0, method=method, rtol=tol, atol=tol, **kw)
            return sol.y[:, -1]
        return go
    load = os.getloadavg()
    print(f"# Stiff contact work-precision (Solo12 standing, {T} s)\n")
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load {load[0]:.1f} {load[1]:.1f} "
          f"{load[2]:.1f} on {os.cpu_count()} cores; Python {platform.python_version()}, numpy "
          f"{np.__version__}, scipy {scipy.__version__}, eomc {eomc.__version__}; thread CPU time, "
          f"median of {a.repeat}, contestants interleaved.\n")
    if a.stance > 0:
        print(stance_table(model, a.stance))
        print()
    rows = []
    for tol in [] if a.no_work_precision else [float(t) for t in a.tols.split(",")]:
        runs = {"eomc radau": eomc_run("radau", tol), "eomc dop853": eomc_run("dop853", tol),
                "scipy Radau": scipy_run("Radau", tol), "scipy LSODA": scipy_run("LSODA", tol)}
        times = {k: [] for k in runs}
        errors = {}
        for _ in range(a.repeat):        # interleaved
            for name, run in runs.items():
                try:
                    dt, x = _cpu(run)
                except Exception as exc:     # DOP853 gives up on stiffness: that is the result
                    times[name].append(float("nan"))
                    errors[name] = f"stopped: {str(exc).split(';')[0].split(': ', 1)[-1][:70]}"
                    continue
                times[name].append(dt)
                errors[name] = err(x)
        for name in runs:
            rows.append((tol, name, errors[name], float(np.median(times[name]))))
    if a.no_work_precision:
        return
    print(f"## Work-precision, {T} s of standing\n")
    print("| rtol = atol | method | error (max abs, q) | CPU time (s) |")
    print("|---|---|---|---|")
    for tol, name, e, t in rows:
        print(f"| {tol:g} | {name} | {e if isinstance(e, str) else f'{e:.2e}'} | {t:.4f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
