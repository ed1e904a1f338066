"""Issue 19: every example-robot-data URDF built straight from its tree, checked against Pinocchio.

Per URDF file of the installed example-robot-data wheel that Pinocchio loads:

- dof (eomc's; merged massless subtrees drop joints, see the notes column),
- URDF -> tree: read + checks + the tree IR (compiler/urdf/treeir.py), in-process, CPU s, median of 3
  (after a first call that pays the imports),
- cold build: ``eomc build FILE --formulation recursive --outputs rhs`` (plus
  ``--floating-base`` for the robots that walk or fly) in a fresh child process and a
  fresh cache; CPU is the child's user+sys including gcc, peak RSS the child Python's,
- Pinocchio's ``buildModelFromUrdf`` time, in-process, CPU s, median of 3, in the same run,
- max relative error of eomc's rhs (u'), inverse_dynamics and mass_matrix against
  Pinocchio's ABA, RNEA and CRBA at 5 random states (a second, in-process build with
  those functions; joints eomc merged are locked at 0 in Pinocchio's model with
  ``buildReducedModel``).

Then a chain-length table: n-link URDF chains with alternating x/y axes (the
reliability report's 3-D chain), cold builds at n = 25, 50, 100, 200, and the
exponent of a least-squares fit of log CPU against log n.
"""
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from common import environment_header, format_table, peer_versions, write_results  # noqa: E402

FLOATING = ("a1", "alex", "alexander", "anymal", "b1", "bolt", "borinot", "go1", "go2", "hector",
            "hextilt", "hyq", "icub", "iris", "laikago", "quadruped", "romeo", "simple_humanoid",
            "solo", "talos_full", "talos_reduced", "g1", "human", "centauro", "tiago")

CHILD = r"""
import runpy, sys, warnings
warnings.simplefilter("ignore")
sys.argv = ["eomc"] + sys.argv[1:]
try:
    runpy.run_module("eomc", run_name="__main__")
except SystemExit as exc:
    code = exc.code or 0
else:
    code = 0
# VmHWM, not ru_maxrss: Linux keeps ru_maxrss across exec, so it would report the parent's
hwm = [l.split()[1] for l in open("/proc/self/status") if l.startswith("VmHWM:")]
print("RSS_KB", hwm[0] if hwm else 0, file=sys.stderr)
sys.exit(code)
"""


def robots_root():
    from importlib.metadata import distribution
    return Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))


def floating(path):
    return any(str(path.relative_to(robots_root())).startswith(f"{k}") or path.stem.startswith(k)
               for k in FLOATING)


def cold_build(path, args, outdir):
    """(CPU s of the child incl. gcc, wall s, peak RSS MB of the child Python, stderr tail)."""
    env = dict(os.environ, EOMC_CACHE_DIR=tempfile.mkdtemp(prefix="eomc_ub_"))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", CHILD, "build", str(path), "-o", str(outdir),
                           "--formulation", "recursive", "--outputs", "rhs", "-q", *args],
                          env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    rss = [int(line.split()[1]) for line in proc.stderr.splitlines() if line.startswith("RSS_KB")]
    if proc.returncode:
        return None, wall, None, proc.stderr.strip().splitlines()[0][-160:]
    return cpu, wall, rss[0] / 1024 if rss else None, ""


def median_time(fn, repeat=3):
    """Median CPU seconds of this process (the machine is shared: wall time measures the load)."""
    samples = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        samples.append(time.process_time() - t0)
    return float(np.median(samples))


def to_tree(path, fb):
    from eomc.compiler.multibody.formed import model_of_tree
    from eomc.compiler.urdf import build_tree, read_urdf
    from eomc.compiler.urdf.treeir import tree_ir
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tree = build_tree(read_urdf(path), floating_base=fb)
        model_of_tree(tree_ir(tree).tree)
    return tree


def pinocchio_errors(path, fb, tree, cache):
    """Max relative errors (ABA, RNEA, CRBA) at 5 random states."""
    import pinocchio as pin
    import eomc
    from helpers.robots import PinRef, relative_error
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from eomc.compiler.model.validate import sanitize_name
        from eomc.compiler.urdf.model import UrdfModel
        model = eomc.compile(UrdfModel(path, floating_base=fb, limits=False), sanitize_name(path.stem),
                             functions=["rhs", "inverse_dynamics", "mass_matrix"],
                             formulation="recursive", cache_dir=cache, progress=False)
    ref = PinRef(path, [(j.name, j.type) for j in tree.joints], floating=fb, locked=tree.locked)
    rng = np.random.default_rng(19)
    worst = [0.0, 0.0, 0.0]
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, model.nq)
        if fb:
            q[:3] = rng.normal(size=3)
            q[3:6] = rng.uniform(-1.2, 1.2, 3)
        v = rng.normal(size=model.nu)
        x = np.concatenate([q, v])
        tau = rng.normal(size=model.ninput)
        a = rng.normal(size=model.nu)
        errs = (relative_error(model.rhs(0.0, x, r=tau)[model.nq:], ref.aba(q, v, tau)),
                relative_error(model.inverse_dynamics(0.0, x, a, r=np.zeros(model.ninput)), ref.rnea(q, v, a)),
                relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)))
        worst = [max(w, e) for w, e in zip(worst, errs)]
    return worst


def chain_text(n):
    links = ['<link name="base"/>'] + [
        f'<link name="l{k}"><inertial><origin xyz="0 0 0.05"/><mass value="0.1"/>'
        f'<inertia ixx="1e-4" iyy="1e-4" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        for k in range(n)]
    joints = [f'<joint name="j{k}" type="revolute"><parent link="{"base" if k == 0 else f"l{k - 1}"}"/>'
              f'<child link="l{k}"/><origin xyz="0 0 0.1"/><axis xyz="{("1 0 0", "0 1 0")[k % 2]}"/></joint>'
              for k in range(n)]
    return '<?xml version="1.0"?>\n<robot name="chain">\n' + "\n".join(links + joints) + "\n</robot>\n"


def robot_row(path, root, work):
    """(table row, csv row or None) of one URDF file."""
    import pinocchio as pin
    rel = str(path.relative_to(root))
    try:
        pin.buildModelFromUrdf(str(path))
    except Exception:
        return [rel, "-", "-", "-", "-", "-", "Pinocchio refuses it", "-"], None
    pin_load = median_time(lambda: pin.buildModelFromUrdf(str(path)))
    fb = floating(path)
    name = rel + (" (fb)" if fb else "")
    try:
        tree = to_tree(path, fb)
    except Exception as exc:
        return [name, "-", "-", "-", "-", f"{pin_load * 1e3:.1f}",
                f"refused: {str(exc).replace(str(root) + '/', '')[-150:]}", "-"], None
    dof = sum({"floating": 6, "planar": 3}.get(j.type, 1) for j in tree.joints)
    t_tree = median_time(lambda: to_tree(path, fb))
    cpu, wall, rss, err = cold_build(path, ["--floating-base"] if fb else [], work / path.stem)
    note = f"{len(tree.locked)} massless joints locked" if tree.locked else ""
    if cpu is None:
        return [name, dof, f"{t_tree:.3f}", "failed", "-", f"{pin_load * 1e3:.1f}", err, note], None
    try:
        e = pinocchio_errors(path, fb, tree, work / "cache")
        errs = " / ".join(f"{x:.1e}" for x in e)
    except Exception as exc:
        e, errs = None, f"check failed: {type(exc).__name__}: {str(exc).replace(str(root) + '/', '')[-160:]}"
    return ([name, dof, f"{t_tree:.3f}", f"{cpu:.2f}", f"{rss:.0f}", f"{pin_load * 1e3:.1f}", errs, note],
            [rel, fb, dof, t_tree, cpu, wall, rss, pin_load] + (list(e) if e else [None] * 3))


def chain_row(n, work):
    path = work / f"chain{n}.urdf"
    path.write_text(chain_text(n))
    t_tree = median_time(lambda: to_tree(path, False))
    cpu, wall, rss, err = cold_build(path, [], work / f"chain{n}")
    return [n, f"{t_tree:.3f}", f"{cpu:.2f}" if cpu else err, f"{wall:.2f}", f"{rss:.0f}" if rss else "-"], \
        (n, cpu) if cpu else None


def main():
    """Serial by default; ``--part robots:I/M`` or ``--part chains`` append JSON lines to
    ``--rows-out`` (parts run side by side), and ``--merge F1,F2,..`` writes the table."""
    import argparse
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="substring of the URDF paths to run")
    parser.add_argument("--chains", default="25,50,100,200")
    parser.add_argument("--part", help="robots:I/M (every M-th robot from the I-th) or chains")
    parser.add_argument("--rows-out", help="append rows here as JSON lines (with --part)")
    parser.add_argument("--merge", help="comma-separated --rows-out files: write the results table")
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--note", action="append", default=[],
                        help="a line for the results header (e.g. which merged rows are older)")
    args = parser.parse_args()
    root = robots_root()
    work = Path(tempfile.mkdtemp(prefix="bench_urdf_build_"))
    load_start = os.getloadavg()
    rows, csv, chain_rows, fit = [], [], [], []

    def emit(kind, row, extra):
        print(row, flush=True)
        if args.rows_out:
            with open(args.rows_out, "a") as fh:
                fh.write(json.dumps({"kind": kind, "row": row, "extra": extra,
                                     "load": os.getloadavg()[0]}) + "\n")
        (rows if kind == "robot" else chain_rows).append(row)
        if extra is not None:
            (csv if kind == "robot" else fit).append(extra)
    if args.merge:
        loads = []
        for name in args.merge.split(","):
            for line in Path(name).read_text().splitlines():
                item = json.loads(line)
                loads.append(item["load"])
                (rows if item["kind"] == "robot" else chain_rows).append(item["row"])
                if item["extra"] is not None:
                    (csv if item["kind"] == "robot" else fit).append(item["extra"])
        # a robot or chain run again (after a fix) replaces its earlier row
        rows = list({r[0]: r for r in rows}.values())
        csv = list({c[0] + (" (fb)" if c[1] else ""): c for c in csv}.values())
        chain_rows = list({r[0]: r for r in chain_rows}.values())
        fit = list({f[0]: f for f in fit}.values())
        rows.sort(key=lambda r: r[0])
        chain_rows.sort(key=lambda r: r[0])
        load_start = (min(loads), float(np.median(loads)), max(loads)) if loads else load_start
    else:
        paths = sorted(root.rglob("*.urdf"))
        if args.only:
            paths = [p for p in paths if args.only in str(p)]
        do_robots, do_chains = True, True
        if args.part:
            do_robots, do_chains = args.part.startswith("robots"), args.part == "chains"
            if do_robots and ":" in args.part:
                i, m = (int(v) for v in args.part.split(":")[1].split("/"))
                paths = paths[i::m]
        for path in paths if do_robots else ():
            emit("robot", *robot_row(path, root, work))
        for n in [int(v) for v in args.chains.split(",") if v] if do_chains else ():
            emit("chain", *chain_row(n, work))
        if args.part:
            return
    fit = [tuple(f) for f in fit]
    exponent = float(np.polyfit(np.log([n for n, _ in fit]), np.log([c for _, c in fit]), 1)[0]) \
        if len(fit) > 1 else float("nan")
    head = environment_header("URDF cold builds straight from the tree (issue 19)", args, notes=[
        "peers: " + ", ".join(peer_versions(["pinocchio"])),
        f"1-min load average while the rows ran: min {load_start[0]:.1f}, median {load_start[1]:.1f}, "
        f"max {load_start[2]:.1f} on 2 cores shared with other jobs (CPU times, not wall, are the "
        f"figures; they still suffer from the contention)" if args.merge else
        f"load average at start: {load_start[0]:.2f} / {load_start[1]:.2f} / {load_start[2]:.2f}",
        "cold build: `eomc build FILE --formulation recursive --outputs rhs -q [--floating-base]` in a "
        "child process with an empty cache; CPU = user+sys of the child and gcc; RSS = the child "
        "Python's peak (VmHWM)",
        "errors: max relative error over 5 random states of rhs u' vs pinocchio.aba, "
        "inverse_dynamics vs pinocchio.rnea, mass_matrix vs pinocchio.crba (a second build with "
        "those functions); (fb) = floating base; joints eomc locked are locked in Pinocchio's model "
        "too (buildReducedModel)",
        "URDF->tree and Pinocchio load (pinocchio.buildModelFromUrdf): in-process CPU time, median of 3",
    ] + args.note)
    table = format_table(["URDF", "dof", "URDF->tree s", "cold build CPU s", "peak RSS MB",
                          "Pinocchio load ms", "rel. err ABA / RNEA / CRBA", "notes"], rows)
    chains = format_table(["links", "URDF->tree s", "cold build CPU s", "wall s", "peak RSS MB"], chain_rows)
    built = [c for c in csv if c[4] is not None]
    checked = [c for c in built if c[8] is not None]
    summary = ""
    if checked:
        worst = max(checked, key=lambda c: max(c[8:11]))
        over = [f"{c[0]} ({max(c[8:11]):.1e})" for c in checked if max(c[8:11]) > 1e-12]
        summary = (f"{len(built)} of {len(rows)} files built; {len(rows) - len(built)} not "
                   f"(Pinocchio's own refusals included); largest relative error "
                   f"{max(worst[8:11]):.1e} ({worst[0]}); above 1e-12: {', '.join(over) or 'none'}; "
                   f"largest cold build {max(c[4] for c in built):.2f} s CPU, largest peak RSS "
                   f"{max(c[6] for c in built):.0f} MB, largest URDF->tree {max(c[3] for c in built):.3f} s.\n\n")
    text = (head + "\n## Robots\n\n" + summary + table + "\n\n## Chains (alternating x/y axes, rhs only)\n\n" + chains
            + f"\n\nfitted exponent of CPU s against n: **{exponent:.2f}**\n")
    print(text)
    if not args.no_write:
        write_results("urdf_build", text, csv, ["urdf", "floating_base", "dof", "urdf_to_tree_s", "cpu_s",
                                                "wall_s", "rss_mb", "pinocchio_load_s", "err_aba",
                                                "err_rnea", "err_crba"])


if __name__ == "__main__":
    main()
