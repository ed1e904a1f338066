"""Issue 31 item 2 / issue 29 item 3: eomc.rollout with contacts vs mujoco.rollout.

gymnasium's hopper, ant and humanoid as shipped (contacts, joint limits, damping and armature on
both sides), zero controls, NROLL starts at the file's qpos0 with the hinge and slide speeds
uniform in +-0.5 (free joints at rest), one simulated second at the XML's own timestep.  Each
side with the contacts it reads from the file (MuJoCo: its geoms against the floor plane,
soft constraints; eomc: the same geoms' ground contacts, compliant law: docs/contact.md) and
its fixed-step implicit method: MuJoCo mjINT_IMPLICITFAST (and its default, Euler), eomc
method="implicitfast" -- checked (the residual test splits steps whose linearisation fails,
eomc_implicit.split = 0.5: what simulate and rollout run by default) and unchecked (split = 0:
one model call per step, as MuJoCo's implicitfast) and checked with lanes=True (each thread's
rows 8 -- the machine's double lanes -- at a time as fibers, their model calls one
NAME_implicit_batch call: the models are built with implicit_batch besides the default functions,
whose C it leaves as it was).  Same thread count on both sides (1 and 2):
mujoco.rollout gets one MjData per thread, eomc.rollout threads=k.

Steps/s = NROLL * steps / median time; wall and process CPU (all threads), contestants
interleaved repeat by repeat, medians of REPEAT, process pinned to cores 0,1.  The contact laws
differ, so the two sides' end states differ by what the laws do, not by round-off:
"vs MuJoCo" is the median and max over rows of max |q_eomc - q_mujoco| over the compared
coordinates (hinges, slides, free joints' positions; bench_fixedstep.compared_q).  Row 0 of
eomc.rollout is checked bit for bit against simulate (same method, same code).  Errors beside
the times: over the first ERROR_ROWS starts, each side against its own reference (as
bench_fixedstep): eomc against its Radau at rtol = atol = 1e-9, MuJoCo against its RK4 at
timestep / 16; median / max over those rows of max |q - q_ref| at the end.

Go2 and G1: MuJoCo Menagerie is not installed here (its pip package downloads the files from
GitHub, which this machine cannot reach), so both sides read one MJCF that MuJoCo's own compiler
makes from example-robot-data's URDF (``urdf_mjcf``): the URDF's links, inertias, joint axes and
ranges (limits on both sides), a free joint at the root, a ground plane and the foot spheres
eomc's URDF runs name (Go2: a 22 mm sphere at each *_foot link, as contact_defaults.py; G1: the
URDF's own eight 5 mm collision spheres under the ankles); the other collision meshes are left
out on both sides (no default-ground corners: the same contacts on both sides), MuJoCo's default
timestep 2 ms.  Neither file has motors, so every hinge gets a spring about the start pose and a
damper (Go2 40 N m/rad, 1 N m s/rad; G1 150, 4), which both sides read from the file: the robots
stand and sway instead of collapsing limp.  Start: Go2 crouched (thighs 0.9, calves -1.8 rad), G1 at its zero pose, the
lowest sphere 1 mm above the plane, hinge speeds uniform in +-0.5 as for the gym models.

    taskset -c 0,1 nice python benchmarks/bench_rollout_contacts.py [--models hopper,ant,humanoid,go2,g1]
        [--orientation quaternion|euler]

--orientation euler: eomc's free joints as body-XYZ angles (MjcfModel(orientation="euler"))
instead of MuJoCo's own quaternion (the default since session 30), the same starts (zero
angles for the unit quaternion); the table is printed, not written
(benchmarks/results/quaternion_fixedstep.md quotes both orientations' runs).
"""
import argparse
import collections
import os
import statistics
import sys
import time
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402
import bench_fixedstep as B  # noqa: E402

MODELS = ("hopper", "ant", "humanoid", "go2", "g1")


def _functions():
    """The default functions and NAME_implicit_batch (the lanes contestant's; the scalar
    functions' C is the same with or without it)."""
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    return tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST) + ("implicit_batch",)
NROLL, REPEAT = 64, 5
ERROR_ROWS = 4            # starts whose error against each side's own reference is measured
LEGS = ("FL", "FR", "RL", "RR")
# URDF robots: (file under example-robot-data's robots/, foot spheres (link, offset, radius) or
# None for the URDF's own collision spheres, start pose {joint: angle})
# None for the URDF's own collision spheres, start pose {joint: angle}, every hinge's spring stiffness
# (N m/rad) and damping (N m s/rad) about the start pose: a passive stand instead of motors)
URDF = {"go2": ("go2_description/urdf/go2.urdf", [(f"{leg}_foot", (0.0, 0.0, 0.0), 0.022) for leg in LEGS],
                {f"{leg}_{j}_joint": v for leg in LEGS for j, v in (("thigh", 0.9), ("calf", -1.8))}, 40.0, 1.0),
        "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", None, {}, 150.0, 4.0)}


def urdf_mjcf(name, out_dir):
    """(path, start height, pose): the MJCF MuJoCo's compiler makes of a URDF robot (see the module
    docstring), written to out_dir; both contestants read this one file."""
    import re
    import xml.etree.ElementTree as ET

    from importlib.metadata import distribution

    import mujoco
    rel, feet, pose, stiffness, damping = URDF[name]
    robots = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    root = ET.parse(robots / rel).getroot()
    spheres = []
    for link in root.iter("link"):
        for c in link.findall("collision"):
            s = c.find("geometry/sphere")
            if s is not None:
                o = c.find("origin")
                xyz = tuple(float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split())
                spheres.append((link.get("name"), xyz, float(s.get("radius"))))
        for tag in ("visual", "collision"):
            for e in link.findall(tag):
                link.remove(e)
    text = re.sub(r"(<robot[^>]*>)", r'\1<mujoco><compiler discardvisual="true" fusestatic="false" '
                  r'balanceinertia="false"/></mujoco>', ET.tostring(root, encoding="unicode"), count=1)
    spec = mujoco.MjSpec.from_string(text)
    for joint in spec.joints:
        joint.stiffness[0], joint.damping[0], joint.springref = stiffness, damping, pose.get(joint.name, 0.0)
    spec.worldbody.first_body().add_freejoint(name="base")
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1])
    for k, (body, xyz, r) in enumerate(feet or spheres):
        spec.body(body).add_geom(name=f"foot{k}", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0], pos=xyz)
    m = spec.compile()
    d = mujoco.MjData(m)
    for j, v in pose.items():
        d.qpos[m.jnt_qposadr[m.joint(j).id]] = v
    mujoco.mj_kinematics(m, d)
    low = min(d.geom_xpos[g][2] - m.geom_size[g][0] for g in range(m.ngeom)
              if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE)
    path = Path(out_dir) / f"{name}_from_urdf.xml"
    path.write_text(spec.to_xml())
    return path, 0.001 - low, pose


def _models(name, cache_dir, orientation="quaternion"):
    """(eomc model, MuJoCo implicitfast, MuJoCo Euler, start height, pose) of one case
    (orientation: eomc's free joints, MjcfModel's)."""
    import mujoco

    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    if name not in URDF:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")          # the files' self-collision pairs (said by a warning)
            em = B.eomc_model(name, cache_dir, functions=_functions(), orientation=orientation)
        mm = B.mujoco_model(name, "IMPLICITFAST")
        fine = B.mujoco_model(name, "RK4", float(mm.opt.timestep) / 16)
        return em, mm, B.mujoco_model(name, "EULER"), fine, None, {}
    import tempfile
    out = Path(cache_dir or tempfile.gettempdir()) / "bench_rollout_contacts"
    out.mkdir(parents=True, exist_ok=True)
    path, height, pose = urdf_mjcf(name, out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        em = eomc.compile(MjcfModel(path, orientation=orientation), cache_dir=cache_dir, functions=_functions(),
                          name=f"ro_{name}" + ("" if orientation == "quaternion" else "_euler"))
    mjm = []
    for integrator in ("IMPLICITFAST", "EULER", "RK4"):
        spec = mujoco.MjSpec.from_file(str(path))
        spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator}")
        if integrator == "RK4":                  # the reference: RK4 at timestep / 16
            spec.option.timestep = spec.option.timestep / 16
        mjm.append(spec.compile())
    return em, mjm[0], mjm[1], mjm[2], height, pose


def _errors(em, mm, me, fine, X0, S0, nstep, dt, nrows=ERROR_ROWS):
    """{contestant: "median / max"} of each side's error against its own reference over the first
    nrows starts (max |q - q_ref| over the compared coordinates at the end, as bench_fixedstep):
    eomc against its Radau at rtol = atol = 1e-9, MuJoCo against its RK4 at timestep / 16.  The
    contact laws differ, so a side's error says how well its fixed step follows its own law; the
    "vs MuJoCo" column says how far the two laws are apart."""
    import mujoco
    from mujoco import rollout as mj_rollout

    import eomc
    T = nstep * dt
    err = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        refs = [em.simulate(X0[i], (0.0, T), method="radau", rtol=1e-9, atol=1e-9, t_eval=[T],
                            max_steps=10 ** 7, raise_on_failure=False) for i in range(nrows)]
        for c, split in (("eomc implicitfast (checked)", None), ("eomc implicitfast (unchecked)", 0.0)):
            kw = {} if split is None else {"split": split}
            res = eomc.rollout(em, X0[:nrows], steps=nstep, dt=dt, threads=1, method="implicitfast",
                               raise_on_failure=False, **kw)
            e = [np.abs(B.compared_q(em, mm, x=res.x[i]) - B.compared_q(em, mm, x=refs[i].x[-1])).max()
                 if refs[i].status == 0 else np.nan for i in range(nrows)]
            err[c] = f"{np.median(e):.2g} / {np.max(e):.2g}"
    zero = np.zeros((nrows, nstep * 16, mm.nu))
    ref = mj_rollout.rollout([fine] * nrows, [mujoco.MjData(fine)], S0[:nrows], zero, nstep=nstep * 16)[0]
    q_ref = [B.compared_q(em, fine, qpos=ref[i, -1, 1:1 + fine.nq]) for i in range(nrows)]
    for c, m in (("mujoco implicitfast", mm), ("mujoco euler", me)):
        out = mj_rollout.rollout([m] * nrows, [mujoco.MjData(m)], S0[:nrows], zero[:, :nstep], nstep=nstep)[0]
        e = [np.abs(B.compared_q(em, m, qpos=out[i, -1, 1:1 + m.nq]) - q_ref[i]).max() for i in range(nrows)]
        err[c] = f"{np.median(e):.2g} / {np.max(e):.2g}"
    return err


def starts(em, mm, height, pose):
    """(X0, S0): the NROLL starts of one case as eomc states and MuJoCo full-physics states (the
    pose, the start height of a URDF robot, hinge and slide speeds uniform in +-0.5, seed 0)."""
    import mujoco
    rng = np.random.default_rng(0)
    x0 = B.eomc_start(em, mm)
    names = list(em.state_names)
    for j, v in pose.items():
        x0[names.index(f"q_{j}")] = v
    if height is not None:
        x0[names.index("q_base_z")] = height
    X0 = np.tile(x0, (NROLL, 1))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    S0 = np.empty((NROLL, mujoco.mj_stateSize(mm, spec)))
    d = mujoco.MjData(mm)
    for i in range(NROLL):
        mujoco.mj_resetData(mm, d)
        for j, v in pose.items():
            d.qpos[int(mm.jnt_qposadr[mm.joint(j).id])] = v
        if height is not None:
            d.qpos[int(mm.jnt_qposadr[mm.joint("base").id]) + 2] = height
        for j in range(mm.njnt):
            if int(mm.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                v = rng.uniform(-0.5, 0.5)
                d.qvel[int(mm.jnt_dofadr[j])] = v
                X0[i, names.index(f"u_{mm.joint(j).name}")] = v
        mujoco.mj_getState(mm, d, S0[i], spec)
    return X0, S0


@contextmanager
def _watch(mode):
    """The energy watch of rollout's fast path (eomc_options.watch_output) as ``mode`` for the
    --watch-ablation contestants: "off" (none: rows judged on their start and end only, session
    15's verdict -- an ablation, not a setting rollout offers) or "outputs" (through the whole
    NAME_outputs call, as for a model built before NAME_energy); anything else: rollout's own
    (NAME_energy where the model has it)."""
    import eomc.runtime.rollout as R
    saved = R._energy_watch, R._energy_fn
    if mode == "off":
        R._energy_watch = lambda model: 0
    elif mode == "outputs":
        R._energy_fn = lambda model, ffi: ffi.NULL
    try:
        yield
    finally:
        R._energy_watch, R._energy_fn = saved


def _ablated(f, mode):
    def run():
        with _watch(mode):
            return f()
    return run


def _case(name, threads_list, cache_dir, watch_ablation=False, orientation="quaternion"):
    import mujoco
    from mujoco import rollout as mj_rollout

    import eomc
    em, mm, me, fine, height, pose = _models(name, cache_dir, orientation)
    dt = float(mm.opt.timestep)
    nstep = int(round(1.0 / dt))
    X0, S0 = starts(em, mm, height, pose)
    ctrl = np.zeros((NROLL, nstep, mm.nu))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = em.simulate(X0[0], (0.0, nstep * dt), method="implicitfast", dt=dt, t_eval=[nstep * dt])
    errors = _errors(em, mm, me, fine, X0, S0, nstep, dt)
    errors["eomc implicitfast (checked, lanes)"] = "as checked"    # its rows, the lanes' sin/cos aside
    errors = collections.defaultdict(lambda: "as checked", errors)    # --watch-ablation: the same steps
    rows = []
    for k in threads_list:
        datas = [mujoco.MjData(mm) for _ in range(k)]
        with mj_rollout.Rollout(nthread=k) as ro:
            contestants = {
                "eomc implicitfast (checked)": lambda: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=k,
                                                                    method="implicitfast", raise_on_failure=False),
                "eomc implicitfast (unchecked)": lambda: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=k,
                                                                      method="implicitfast", split=0.0,
                                                                      raise_on_failure=False),
                "eomc implicitfast (checked, lanes)": lambda: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=k,
                                                                           method="implicitfast", lanes=True,
                                                                           raise_on_failure=False),
            }
            if watch_ablation:      # the energy watch's cost: none, through the outputs, NAME_energy (above)
                for lanes in (False, True):
                    for mode in ("off", "outputs"):
                        run = (lambda lanes=lanes: eomc.rollout(em, X0, steps=nstep, dt=dt, threads=k, lanes=lanes,
                                                                method="implicitfast", raise_on_failure=False))
                        contestants[f"eomc implicitfast (checked{', lanes' if lanes else ''}), "
                                    f"{'no energy watch' if mode == 'off' else 'watch via outputs'}"] = \
                            _ablated(run, mode)
            contestants |= {
                "mujoco implicitfast": lambda: ro.rollout([mm] * NROLL, datas, S0, ctrl, nstep=nstep)[0],
                "mujoco euler": lambda: ro.rollout([me] * NROLL, datas, S0, ctrl, nstep=nstep)[0],
            }
            times = {c: [] for c in contestants}
            cpu = {c: [] for c in contestants}
            out = {}
            for _ in range(REPEAT):
                for c, f in contestants.items():
                    t0, c0 = time.perf_counter(), time.process_time()
                    out[c] = f()
                    times[c].append(time.perf_counter() - t0)
                    cpu[c].append(time.process_time() - c0)
        assert np.array_equal(out["eomc implicitfast (checked)"].x[0], one.x[-1]), name
        mj_q = np.array([B.compared_q(em, mm, qpos=s[-1, 1:1 + mm.nq]) for s in out["mujoco implicitfast"]])
        total = NROLL * nstep
        sps = {c: total / statistics.median(v) for c, v in times.items()}
        cps = {c: total / statistics.median(v) for c, v in cpu.items()}
        for c in contestants:
            if c.startswith("eomc"):
                res = out[c]
                q = np.array([B.compared_q(em, mm, x=x) for x in res.x])
                dq = np.abs(q - mj_q).max(axis=1)
                agree = f"{np.median(dq):.2g} / {dq.max():.2g}"
                note = (f"{int(np.sum(res.status == 0))}/{NROLL} ok ({int(np.sum(res.clean))} clean), "
                        f"{int(np.median(res.steps))} steps")
            else:
                agree, note = "", ""
            rows.append([name, f"{dt:g}", k, c, f"{sps[c]:.3g}", f"{sps[c] / sps['mujoco implicitfast']:.2f}",
                         f"{cps[c]:.3g}", f"{cps[c] / cps['mujoco implicitfast']:.2f}", errors[c], agree, note])
        print(rows[-len(contestants):], flush=True)
    return rows


def main():
    global REPEAT
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default=",".join(MODELS))
    parser.add_argument("--cache-dir", default=os.environ.get("EOMC_CACHE_DIR"))
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--watch-ablation", action="store_true",
                        help="also the checked contestants without the energy watch and with it through "
                             "NAME_outputs (what NAME_energy saves)")
    parser.add_argument("--repeat", type=int, default=REPEAT, help="interleaved repeats (medians)")
    parser.add_argument("--orientation", choices=("euler", "quaternion"), default="quaternion",
                        help="eomc's free joints: MuJoCo's quaternion (default) or body-XYZ angles")
    args = parser.parse_args()
    REPEAT = args.repeat
    threads = [1, 2] if len(os.sched_getaffinity(0)) >= 2 else [1]
    rows = []
    for name in args.models.split(","):
        rows += _case(name, threads, args.cache_dir, args.watch_ablation, args.orientation)
    import mujoco
    table = format_table(["model", "timestep", "threads", "contestant", "steps/s (wall)", "vs mujoco implicitfast",
                          "steps/CPU-s", "vs mujoco implicitfast (CPU)",
                          f"error vs own reference, first {ERROR_ROWS} starts: median / max",
                          "vs MuJoCo: max |dq| median / max",
                          "rows"], rows)
    text = environment_header(
        "Rollouts with contacts: eomc.rollout vs mujoco.rollout (issues 29, 31)",
        notes=[f"MuJoCo {mujoco.__version__}; {NROLL} starts x 1 simulated second per call at each file's "
               f"timestep; contacts and limits on both sides; zero controls; wall and process-CPU medians of "
               f"{REPEAT} interleaved repeats, process pinned to cores {sorted(os.sched_getaffinity(0))}; shared "
               f"noisy machine; row 0 of eomc.rollout equals simulate bit for bit (asserted); eomc orientation "
               f"{args.orientation}."]
    ) + "\n" + table + "\n"
    print(table)
    if not args.no_write and args.orientation == "quaternion":
        write_results("rollout_contacts", text, keep_notes=True)


if __name__ == "__main__":
    main()
