"""Derivative calls of an MJCF model built with quaternions (the default since session 30) and with
body-XYZ angles: jac_x, jvp, vjp per call, and the quaternion build's jac_x checked.

    taskset -c 1 python benchmarks/bench_orientation_derivatives.py [--models ant,humanoid,dm_humanoid]
        [--rounds 7] [--no-write]

Why: session 30 made MJCF free and ball joints quaternions by default; the W-method, Radau's Newton
matrix, linearize and the sensitivities call these functions, so the default build's derivatives
must not cost more than the Euler build's did (a quaternion joint's 4 x 3 block of K goes through
K⁺ in the analytic kernel, compiler/tree/analytic.py; its body-body pairs through the taped table
call, compiler/contact/table.py).

Models: gymnasium's ant and humanoid and dm_control's humanoid as shipped, each built twice
(``MjcfModel(path, orientation=...)``, functions rhs, jac_x, jvp, vjp; one cache entry each).
States: the quaternion build's passive run from its initial state (default method) at TIMES, each
mapped to the Euler build through MuJoCo's qpos (compiler/mjcf/compare: to_mujoco, from_mujoco):
the same physical state (in flight, touching down, lying on the ground).  Per state the
contestants are called in one process, interleaved per round (thread CPU, ``CALLS`` calls a
sample), medians of the rounds; jvp along one direction, vjp of one λ (random, fixed seed).

Checks, per state:
- chart: the speed rows (u' = f_u) of both builds are the same function of the physical state, so
  J_u,quat(φ(x_e)) · Dφ(x_e) = J_u,euler(x_e), with φ the Euler -> quaternion map of the orientation
  coordinates (identity elsewhere) and Dφ its exact derivative (complex step): the largest
  difference relative to max(1, |J_u,euler|);
- FD: the quaternion build's jac_x against central differences of its rhs (h = 1e-6 · max(1, |x_i|));
  contacts' laws are smooth only piecewise, so this bounds the agreement at ~1e-6, not the 1e-12
  of the chart check.
"""
import os
import statistics
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

TIMES = (0.0, 0.4, 3.0)
CALLS = 200
MODELS = ("ant", "humanoid", "dm_humanoid")


def model_path(name):
    from bench_passive import gym_file
    if name.startswith("dm_"):
        import dm_control
        return Path(dm_control.__file__).parent / "suite" / f"{name[3:]}.xml"
    return gym_file(name)


def quat_of_xyz(a):
    """MuJoCo's (w, x, y, z) of body-XYZ angles a (R = Rx Ry Rz): q_x ⊗ q_y ⊗ q_z; complex-safe."""
    def mul(p, q):
        return np.array([p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
                         p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
                         p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
                         p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]])
    c, s = np.cos(np.asarray(a) / 2), np.sin(np.asarray(a) / 2)
    zero = 0 * c[0]
    qx = np.array([c[0], s[0], zero, zero])
    qy = np.array([c[1], zero, s[1], zero])
    qz = np.array([c[2], zero, zero, s[2]])
    return mul(mul(qx, qy), qz)


def chart_map(euler, quat):
    """(phi, D): phi(x_e) the quaternion build's state of the Euler build's x_e, D its Jacobian
    (nx_q x nx_e), the orientation blocks by complex step (exact to rounding)."""
    ne, nq = list(euler.state_names), list(quat.state_names)
    angles = {}       # joint prefix -> (Euler column of rx, quaternion column of qw)
    for i, s in enumerate(ne):
        if s.endswith("_rx") and s.startswith("q_"):
            angles[s[:-3]] = (i, nq.index(s[:-3] + "_qw"))
    plain = [(nq.index(s), i) for i, s in enumerate(ne)
             if not any(s.startswith(p) and s[len(p):] in ("_rx", "_ry", "_rz") for p in angles)]
    assert len(plain) + 3 * len(angles) == euler.nx and len(plain) + 4 * len(angles) == quat.nx

    def phi(xe):
        xq = np.zeros(quat.nx, dtype=np.asarray(xe).dtype)
        for jq, je in plain:
            xq[jq] = xe[je]
        for ie, iq in angles.values():
            w = quat_of_xyz(xe[ie:ie + 3])
            xq[iq:iq + 4] = w
        return xq

    def jac(xe):
        D = np.zeros((quat.nx, euler.nx))
        for jq, je in plain:
            D[jq, je] = 1.0
        for ie, iq in angles.values():
            for k in range(3):
                a = np.array(xe[ie:ie + 3], dtype=complex)
                a[k] += 1e-30j
                D[iq:iq + 4, ie + k] = quat_of_xyz(a).imag / 1e-30
        return D
    return phi, jac


def euler_state(euler, quat, xq):
    """The Euler build's state of the quaternion build's xq (the same orientations, the same speeds:
    both builds' free-joint speeds are body-frame), sign-matched so that phi(x_e) = xq."""
    from eomc.compiler.mjcf.model import _xyz_angles
    from eomc.compiler.mjcf.treeir import quat_matrix
    ne, nq = list(euler.state_names), list(quat.state_names)
    xe = np.zeros(euler.nx)
    for i, s in enumerate(ne):
        if s.endswith("_rx") and s.startswith("q_"):
            w = nq.index(s[:-3] + "_qw")
            xe[i:i + 3] = _xyz_angles(quat_matrix(xq[w:w + 4]))
        elif s[:-3] + "_rx" in ne and s[-3:] in ("_ry", "_rz"):
            continue
        else:
            xe[i] = xq[nq.index(s)]
    return xe


def fd_jac(model, x, h=1e-6):
    J = np.zeros((model.nx, model.nx))
    for i in range(model.nx):
        e = np.zeros(model.nx)
        e[i] = h * max(1.0, abs(x[i]))
        J[:, i] = (model.rhs(0.0, x + e) - model.rhs(0.0, x - e)) / (2 * e[i])
    return J


def per_call(call, n=CALLS):
    from common import thread_cpu_per_call
    return thread_cpu_per_call(call, n)


def build(name, orientation, cache):
    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(model_path(name), orientation=orientation), name=f"od_{name}",
                            functions=("rhs", "jac_x", "jvp", "vjp"), cache_dir=cache / f"{name}_{orientation}",
                            progress=False)


def measure(name, rounds, cache):
    quat, euler = build(name, "quaternion", cache), build(name, "euler", cache)
    run = quat.simulate(quat.initial_state, (0.0, TIMES[-1]), t_eval=np.array(TIMES))
    phi, dphi = chart_map(euler, quat)
    rng = np.random.default_rng(5)
    rows = []
    for t, xq0 in zip(TIMES, run.x):
        xq0 = np.array(xq0, dtype=float)
        for w in quat.quaternions:         # an output point's quaternion is interpolated: made unit
            xq0[w:w + 4] /= np.linalg.norm(xq0[w:w + 4])
        xe = euler_state(euler, quat, xq0)
        xq = phi(xe)         # the same state, its quaternion unit and of phi's sign
        assert np.abs(np.abs(xq) - np.abs(xq0)).max() < 1e-12, "the two builds' states differ"
        dq = rng.normal(size=(1, quat.nx))
        de = rng.normal(size=(1, euler.nx))
        lq, le = rng.normal(size=quat.nx), rng.normal(size=euler.nx)
        contestants = {
            "jac_x euler": lambda: euler.jac_x(0.0, xe), "jac_x quat": lambda: quat.jac_x(0.0, xq),
            "jvp euler": lambda: euler.jvp(0.0, xe, de), "jvp quat": lambda: quat.jvp(0.0, xq, dq),
            "vjp euler": lambda: euler.vjp(0.0, xe, le), "vjp quat": lambda: quat.vjp(0.0, xq, lq),
            "rhs euler": lambda: euler.rhs(0.0, xe), "rhs quat": lambda: quat.rhs(0.0, xq)}
        samples = {k: [] for k in contestants}
        for _ in range(rounds):
            for k, call in contestants.items():
                samples[k].append(per_call(call))
        med = {k: statistics.median(v) * 1e6 for k, v in samples.items()}
        Jq, Je = quat.jac_x(0.0, xq), euler.jac_x(0.0, xe)
        speeds_q, speeds_e = slice(quat.nq, quat.nx), slice(euler.nq, euler.nx)
        chart = np.abs(Jq[speeds_q] @ dphi(xe) - Je[speeds_e]).max() / max(1.0, np.abs(Je[speeds_e]).max())
        fd = np.abs(Jq - fd_jac(quat, xq)).max() / max(1.0, np.abs(Jq).max())
        rows.append([name, f"{t:g}"] + [med[k] for k in contestants]
                    + [med[f"{f} quat"] / med[f"{f} euler"] for f in ("jac_x", "jvp", "vjp", "rhs")] + [chart, fd])
        print(rows[-1], flush=True)
    return rows


def main(argv):
    from common import format_table, publish
    rounds = int(argv[argv.index("--rounds") + 1]) if "--rounds" in argv else 7
    names = argv[argv.index("--models") + 1].split(",") if "--models" in argv else MODELS
    cache = Path(os.environ.get("EOMC_CACHE_DIR") or tempfile.mkdtemp(prefix="eomc_od_"))
    rows = [r for n in names for r in measure(n, rounds, cache)]
    heads = (["model", "t (s)"] + [f"{f} {o} µs" for f in ("jac_x", "jvp", "vjp", "rhs") for o in ("euler", "quat")]
             + [f"{f} quat / euler" for f in ("jac_x", "jvp", "vjp", "rhs")]
             + ["chart: J_u,q Dφ vs J_u,e", "jac_x quat vs central FD"])
    publish("orientation_derivatives", "Derivative calls: quaternion build (the MJCF default) vs Euler build", [
        f"- load average before the run: {os.getloadavg()}",
        format_table(heads, rows),
        f"Thread CPU per call, medians of {rounds} interleaved rounds ({CALLS} calls a sample), one process; "
        "states of the quaternion build's passive run from its initial state, the Euler build at the same "
        "physical state (see the script's docstring for the two checks)."], argv)


if __name__ == "__main__":
    main(sys.argv[1:])
