"""Where the time of a first ground run goes: ``eomc simulate X.urdf --floating-base --ground``
(issue 29's "Done when"; results in benchmarks/results/ground_run.md, written by hand from
this script's lines).

    # build + run, a fresh cache (the build's CPU: this process and its children, gcc included)
    python benchmarks/bench_ground_run.py build ROBOT [CLI FLAGS ...]
    # the run alone: thread CPU of runtime.simulate inside `eomc simulate` (warm cache), 3 repeats
    python benchmarks/bench_ground_run.py run ROBOT [CLI FLAGS ...]
    # MuJoCo on the same URDF: its <collision> meshes (convex hulls) on a floor plane, free root
    python benchmarks/bench_ground_run.py mujoco ROBOT ...

ROBOT: solo12, go2 or g1 (example-robot-data).  CLI FLAGS default to ``--floating-base
--ground``.  MuJoCo: the URDF's visuals dropped, a free joint on the root, a floor plane,
MuJoCo's defaults (2 ms, implicitfast and Euler), the robot lifted so its lowest collision
vertex is 1 mm above the floor (as eomc simulate's start), 10 s through mujoco.rollout (its C
loop), thread CPU, median of 5.  Run with EOMC_CACHE_DIR set, pinned (taskset -c 1), from
outside the checkout.
"""
import contextlib
import io
import os
import re
import resource
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROBOTS = Path("/root/.pyenv/versions/3.11.7/lib/python3.11/site-packages/cmeel.prefix/share/"
              "example-robot-data/robots")
FILES = {"solo12": "solo_description/robots/solo12.urdf", "go2": "go2_description/urdf/go2.urdf",
         "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf"}


def _cli(robot, flags):
    return ["simulate", str(ROBOTS / FILES[robot])] + (flags or ["--floating-base", "--ground"]) + ["-q"]


def _main(argv):
    from eomc.cli import main
    with contextlib.redirect_stdout(io.StringIO()) as out, contextlib.redirect_stderr(io.StringIO()):
        try:
            main(argv)
        except SystemExit:
            pass
    lines = [line for line in out.getvalue().splitlines() if " steps (" in line]
    return lines[0] if lines else out.getvalue()[-300:]


def build(robot, flags):
    """A cold `eomc simulate` in this process: CPU of the whole command (build + run) and its children."""
    def cpu():
        a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return a.ru_utime + a.ru_stime, b.ru_utime + b.ru_stime
    s0, c0 = cpu()
    line = _main(_cli(robot, flags))
    s1, c1 = cpu()
    print(f"{robot} {' '.join(flags)}: cold command CPU {s1 - s0 + c1 - c0:.1f} s (python {s1 - s0:.1f}, "
          f"children/gcc {c1 - c0:.1f}) | {line} | load {os.getloadavg()[0]:.1f}", flush=True)


def run(robot, flags):
    import eomc.runtime.simulate as S
    times, orig = [], S.simulate

    def timed(*a, **k):
        t0 = time.thread_time()
        res = orig(*a, **k)
        times.append(time.thread_time() - t0)
        return res
    S.simulate = timed
    for _ in range(3):
        line = _main(_cli(robot, flags))
    print(f"{robot} {' '.join(flags)}: run CPU s {' '.join(f'{t:.3f}' for t in times)} | {line} | "
          f"load {os.getloadavg()[0]:.1f}", flush=True)


def mujoco_model(robot):
    import mujoco
    path = ROBOTS / FILES[robot]
    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for e in link.findall("visual"):
            link.remove(e)
    for m in root.iter("mesh"):
        fn = re.sub(r"^package://", str(ROBOTS.parent.parent) + "/", m.get("filename"))
        m.set("filename", fn if fn.startswith("/") else str(path.parent / fn))
    text = re.sub(r"(<robot[^>]*>)", r'\1<mujoco><compiler discardvisual="true" fusestatic="false" '
                  r'balanceinertia="false" strippath="false"/></mujoco>', ET.tostring(root, encoding="unicode"),
                  count=1)
    spec = mujoco.MjSpec.from_string(text)
    spec.worldbody.first_body().add_freejoint(name="base")
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1])
    return spec.compile()


def mujoco(robot):
    import mujoco
    import numpy as np
    from mujoco import rollout
    m = mujoco_model(robot)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    low = np.inf
    for g in range(m.ngeom):
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            i = m.geom_dataid[g]
            v = m.mesh_vert[m.mesh_vertadr[i]:m.mesh_vertadr[i] + m.mesh_vertnum[i]]
            low = min(low, (v @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g])[:, 2].min())
    d.qpos[2] += 0.001 - low
    state0 = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, d, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    for integrator in ("implicitfast", "euler"):
        m.opt.integrator = getattr(mujoco.mjtIntegrator, "mjINT_" + integrator.upper())
        n = int(round(10.0 / m.opt.timestep))
        times = []
        for _ in range(5):
            t0 = time.thread_time()
            st, _ = rollout.rollout(m, d, state0[None], nstep=n)
            times.append(time.thread_time() - t0)
        z = st[0, :, 3]          # [time, qpos...]: the base's z
        print(f"{robot}: mujoco {integrator} dt={m.opt.timestep} {n} steps, {m.ngeom} geoms: CPU median "
              f"{np.median(times):.3f} s | base z {z[0]:.3f} -> {z[-1]:.3f} (min {z.min():.3f}) | "
              f"load {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    what, robots = sys.argv[1], sys.argv[2:]
    if what == "mujoco":
        for r in robots:
            mujoco(r)
    else:
        {"build": build, "run": run}[what](robots[0], robots[1:])
