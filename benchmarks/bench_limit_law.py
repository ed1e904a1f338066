"""The URDF limit law's cost and overshoot on the 19 no-flag example-robot-data runs whose
limits were struck fast (docs/joint-laws.md, the entry spring): one library per robot (this
checkout's build, no flags), three sets of gains in one process, interleaved:

- main: another checkout's law (``--main-law FILE``: its compiler/tree/joint_laws.py, e.g. from
  ``git show main:compiler/tree/joint_laws.py``), its scale_gains in limit_k/limit_c and the
  entry spring off (limit_kd = limit_cd = 0) -- session 25's single stiff spring;
- branch: this checkout's defaults (the limit's own spring + the entry spring);
- old: the limit's own spring alone (before session 25).

10 s from the default start (zeros where the model has none), default method; thread CPU of
simulate (pin the process: taskset -c 1); the joints the verdict says went past 100 widths.
Prints one JSON line per run; summarise with --table FILE.  Usage:
  taskset -c 1 python bench_limit_law.py --main-law main_joint_laws.py [--rounds 2] [--only panda,ur3] > runs.jsonl
  python bench_limit_law.py --table runs.jsonl"""
import argparse, collections, importlib.util, json, sys, time, warnings
import numpy as np
import eomc
from eomc.compiler.urdf import read_urdf
from eomc.compiler.urdf.tree import build_tree
from eomc.compiler.urdf.treeir import joint_inertias
from eomc.compiler.tree.joint_laws import scale_gains
from eomc.runtime.switching import PhysicsWarning
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import robots_dir  # noqa: E402
R = str(robots_dir()) + "/"  # example-robot-data
ROBOTS = ["panda_description/urdf/panda.urdf", "panda_description/urdf/panda_collision.urdf",
          "ur_description/urdf/ur3_gripper.urdf", "ur_description/urdf/ur3_joint_limited_robot.urdf",
          "ur_description/urdf/ur3_robot.urdf", "ur_description/urdf/ur5_gripper.urdf",
          "ur_description/urdf/ur10_robot.urdf", "ur_description/urdf/ur10_joint_limited_robot.urdf",
          "so_arm_description/urdf/so100.urdf", "so_arm_description/urdf/so101.urdf",
          "alex_description/urdf/alex_nub_hands.urdf", "alex_description/urdf/alex_sake_hands.urdf",
          "alex_description/urdf/alex_psyonic_hands.urdf", "g1_description/urdf/g1_29dof_rev_1_0.urdf",
          "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "talos_data/robots/talos_full_v2.urdf",
          "talos_data/robots/talos_full_v2_box.urdf", "romeo_description/urdf/romeo.urdf",
          "romeo_description/urdf/romeo_small.urdf"]
mainlaw = None


def load_main(path):
    """The other checkout's joint_laws module, imported inside eomc's package (its relative imports)."""
    spec = importlib.util.spec_from_file_location("eomc.compiler.tree._main_joint_laws", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module

def variants(model, path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scales = joint_inertias(build_tree(read_urdf(path)))
    names = list(model.param_names)
    base = np.array(model.param_defaults, dtype=float)
    main, old = base.copy(), base.copy()
    for j, s in scales.items():
        from eomc.compiler.urdf.tree import identifier
        jn = identifier(j)
        if f"limit_k_{jn}" not in names:
            continue
        k1, c1 = mainlaw.scale_gains(mainlaw.JointScale(*s))
        k0, c0 = scale_gains(s)
        for p, (k, c) in ((main, (k1, c1)), (old, (k0, c0))):
            p[names.index(f"limit_k_{jn}")], p[names.index(f"limit_c_{jn}")] = k, c
            for extra in ("limit_kd_", "limit_cd_"):
                if extra + jn in names:
                    p[names.index(extra + jn)] = 0.0
    return {"main": main, "branch": base, "old": old}

X0 = None
def run(model, p):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.thread_time()
        res = model.simulate(X0, (0.0, 10.0), p=p, raise_on_failure=False)
        cpu = time.thread_time() - t0
    past = [str(w.message) for w in caught if issubclass(w.category, PhysicsWarning) and "past its" in str(w.message)]
    nj = sum(m.count(" went ") for m in past)
    return cpu, res.status, nj, (past[0][:200] if past else "")

def table(path):
    """The markdown table of a runs file: the smaller CPU of the rounds, the most joints past."""
    rows = [json.loads(line) for line in open(path)]
    by, order = collections.defaultdict(lambda: collections.defaultdict(list)), []
    for d in rows:
        if d["robot"] not in order:
            order.append(d["robot"])
        by[d["robot"]][d["v"]].append(d)
    tot = collections.Counter()
    out = ["| run (10 s, no flags) | main CPU s | branch CPU s | branch/main | pre-s25 CPU s | "
           "joints past 100 widths: main / branch / pre-s25 |", "|---|---:|---:|---:|---:|---|"]
    for r in order:
        v = by[r]
        if not all(k in v for k in ("main", "branch", "old")):
            continue
        m = {k: min(d["cpu"] for d in v[k]) for k in v}
        past = {k: max(d["joints_past"] for d in v[k]) for k in v}
        st = {k: max(d["status"] for d in v[k]) for k in v}
        for k in m:
            tot[k] += m[k]
        note = f" (status {st})" if any(st.values()) else ""
        out.append(f"| {r.replace('.urdf', '')} | {m['main']:.4f} | {m['branch']:.4f} | {m['branch'] / m['main']:.2f} | "
                   f"{m['old']:.4f} | {past['main']} / {past['branch']} / {past['old']}{note} |")
    n = sum(1 for r in order if len(by[r]) == 3)
    out.append(f"| **sum ({n} runs)** | {tot['main']:.2f} | {tot['branch']:.2f} | {tot['branch'] / tot['main']:.2f} | "
               f"{tot['old']:.2f} | |")
    loads = [float(d["load"]) for d in rows]
    out.append(f"\n1-min load during the runs: {min(loads)}-{max(loads)}")
    return "\n".join(out)


def main():
    global mainlaw
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--main-law")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--only")
    ap.add_argument("--table")
    a = ap.parse_args()
    if a.table:
        print(table(a.table))
        return
    mainlaw = load_main(a.main_law)
    only = a.only.split(",") if a.only else None
    which = ["main", "branch", "old"]
    global X0
    for r in ROBOTS:
        if only and not any(o in r for o in only):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = eomc.compile(R + r, progress=False)
        ps = variants(model, R + r)
        X0 = None if getattr(model, "initial_state", None) is not None else np.zeros(model.nx)
        for k in range(a.rounds):
            for v in (which if k % 2 == 0 else which[::-1]):
                cpu, st, nj, msg = run(model, ps[v])
                print(json.dumps({"robot": r.split("/")[-1], "v": v, "round": k, "cpu": cpu, "status": st,
                                  "joints_past": nj, "msg": msg, "load": open("/proc/loadavg").read().split()[0]}),
                      flush=True)


if __name__ == "__main__":
    main()
