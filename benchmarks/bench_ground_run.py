"""Where the time of a first ground run goes: ``eomc simulate X.urdf --floating-base --ground``
(issue 29's "Done when"; results in benchmarks/results/ground_run.md, written by hand from
this script's lines).

    # build + run, a fresh cache (the build's CPU: this process and its children, gcc included)
    python benchmarks/bench_ground_run.py build ROBOT [CLI FLAGS ...]
    # the run alone: thread CPU of runtime.simulate inside `eomc simulate` (warm cache), 3 repeats
    python benchmarks/bench_ground_run.py run ROBOT [CLI FLAGS ...]
    # MuJoCo on the same URDF: its <collision> meshes (convex hulls) on a floor plane, free root
    python benchmarks/bench_ground_run.py mujoco ROBOT ...
    # rhs and jac_x per call: the default build (with NAME_implicit) in cache A against the build
    # eomc simulate makes for the default method (without it, session 26) in cache B
    python benchmarks/bench_ground_run.py calls ROBOT CACHE_A CACHE_B

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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import robots_dir  # noqa: E402

ROBOTS = robots_dir()
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
    load0 = os.getloadavg()[0]
    line = _main(_cli(robot, flags))
    s1, c1 = cpu()
    peak = [resource.getrusage(who).ru_maxrss / 1024 for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    import eomc
    print(f"{robot} {' '.join(flags)}: cold command CPU {s1 - s0 + c1 - c0:.1f} s (python {s1 - s0:.1f}, "
          f"children/gcc {c1 - c0:.1f}) | peak MB python {peak[0]:.0f}, largest child {peak[1]:.0f} | {line} | "
          f"load {load0:.1f} -> {os.getloadavg()[0]:.1f} | eomc {Path(eomc.__file__).parent}", flush=True)


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


def _states(model, n, rng, lift):
    """n random states near the zero pose (joints and tilt N(0, 0.2), speeds N(0, 0.5)), the
    base at a height uniform in [lift, lift + 0.4] m: lift 0 puts most bodies within reach of
    the ground (touching or near it), lift 3 every body far above it."""
    import numpy as np
    X = np.zeros((n, model.nx))
    z = model.state_names.index(next(s for s in model.state_names if s.endswith("_floating_z")))
    X[:, :model.nq] = rng.normal(scale=0.2, size=(n, model.nq))
    X[:, z] = lift + rng.uniform(0.0, 0.4, size=n)
    X[:, model.nq:] = rng.normal(scale=0.5, size=(n, model.nu))
    return X


def _loaded(robot, flags, cache, methods):
    """The model the CLI's load_model serves from ``cache`` (built there by `build`)."""
    from eomc.cli import common
    os.environ["EOMC_CACHE_DIR"] = str(cache)
    options = {"floating_base": True, "contacts": ["@ground"]} if not flags else None
    assert options is not None, "calls: the default flags only"
    with contextlib.redirect_stderr(io.StringIO()):
        return common.load_model(ROBOTS / FILES[robot], quiet=True, methods=methods, **options)


def calls(robot, caches, copies=3, repeat=5, n=300):
    """rhs and jac_x per call of the default build (NAME_implicit in it: main's, from caches[0])
    against the build without NAME_implicit (caches[1]) at the same states: each library loaded
    from ``copies`` copies of its build directory (one copy's pages can run slow: session 24),
    thread CPU of a loop of cffi calls (the same loop for every copy), copies interleaved,
    ``repeat`` rounds; a contestant's time is the median over its copies of each copy's median.
    Also the largest relative difference of their results (|a - b| / max(|a|, |b|)) and how many
    entries are bit-equal."""
    import shutil
    import tempfile
    import numpy as np
    from eomc.runtime.loader import load
    full = _loaded(robot, [], caches[0], None)
    lean = _loaded(robot, [], caches[1], ("auto",))
    assert "implicit" in full.functions and "implicit" not in lean.functions, (full.functions, lean.functions)
    tmp = Path(tempfile.mkdtemp(prefix="ground_calls_"))
    models = {}
    for key, cache in (("full", caches[0]), ("lean", caches[1])):
        found = [j.parent for j in Path(cache).glob("v1/models/*/*/*.json") if j.stem == full.name]
        assert len(found) == 1, found
        for k in range(copies):
            shutil.copytree(found[0], tmp / f"{key}{k}")
            with contextlib.redirect_stderr(io.StringIO()):
                models[(key, k)] = load(tmp / f"{key}{k}")
    rng = np.random.default_rng(26)
    x0 = _start_state(full)
    with contextlib.redirect_stderr(io.StringIO()):
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = full.simulate(x0, (0.0, 2.0))
    rows = np.asarray(res.x)
    sets = {"no-flag run 2 s": rows[np.linspace(0, len(rows) - 1, n).round().astype(int)],
            "random, near the ground": _states(full, n, rng, 0.0),
            "random, 3 m above": _states(full, n, rng, 3.0)}
    for label, X in sets.items():
        X = np.ascontiguousarray(X)
        line = [f"{robot} {label}:"]
        for fn, size in (("rhs", full.nx), ("jac_x", full.nx * full.nx)):
            outs = {mk: np.zeros((n, size)) for mk in models}
            times = {mk: [] for mk in models}
            for r in range(repeat):
                for mk in (sorted(models) if r % 2 == 0 else sorted(models, reverse=True)):
                    m = models[mk]
                    ffi, f = m.ffi, getattr(m.c_model, fn)
                    work = ffi.from_buffer("double[]", m._work()[0])
                    xs = [ffi.from_buffer("double[]", X[i]) for i in range(n)]
                    os_ = [ffi.from_buffer("double[]", outs[mk][i]) for i in range(n)]
                    p, rr = m._default_p, (m._default_r if m.ninput else ffi.NULL)
                    t0 = time.thread_time()
                    for i in range(n):
                        f(0.0, xs[i], p, rr, os_[i], work)
                    times[mk].append((time.thread_time() - t0) / n)
            a, b = outs[("full", 0)], outs[("lean", 0)]
            rel = np.max(np.abs(a - b) / np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-300))
            same = int(np.sum(a.view(np.int64) == b.view(np.int64)))
            per = {key: sorted(float(np.median(times[(key, k)])) for k in range(copies)) for key in ("full", "lean")}
            tf, tl = (float(np.median(per[key])) for key in ("full", "lean"))
            line.append(f"{fn} {tf * 1e6:.2f} -> {tl * 1e6:.2f} us ({tl / tf:.3f}x; copies "
                        f"{'/'.join(f'{t * 1e6:.2f}' for t in per['full'])} | "
                        f"{'/'.join(f'{t * 1e6:.2f}' for t in per['lean'])}), max rel diff {rel:.1e}, "
                        f"{same}/{a.size} bit-equal;")
        print(" ".join(line) + f" load {os.getloadavg()[0]:.1f}", flush=True)
    shutil.rmtree(tmp, ignore_errors=True)


def _start_state(model):
    from eomc.cli.common import initial_state
    with contextlib.redirect_stdout(io.StringIO()):
        x0 = initial_state(model, {})
    return [x0[s] for s in model.state_names]


if __name__ == "__main__":
    what, robots = sys.argv[1], sys.argv[2:]
    if what == "mujoco":
        for r in robots:
            mujoco(r)
    elif what == "calls":
        calls(robots[0], robots[1:3])
    else:
        {"build": build, "run": run}[what](robots[0], robots[1:])
