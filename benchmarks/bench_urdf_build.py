"""Issue 19: every example-robot-data URDF built straight from its tree, checked against Pinocchio.

Per URDF file of the installed example-robot-data wheel that Pinocchio loads:

- dof (eomc's; merged massless subtrees drop joints, see the notes column),
- URDF -> tree: read + checks + the tree IR (compiler/urdf/treeir.py), in-process, median of 3,
- cold build: ``eomc build FILE --formulation recursive --outputs rhs`` (plus
  ``--floating-base`` for the robots that walk or fly) in a fresh child process and a
  fresh cache; CPU is the child's user+sys including gcc, peak RSS the child Python's,
- Pinocchio's ``buildModelFromUrdf`` time, in-process, median of 3, in the same run,
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
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - t0)
    return float(np.median(samples))


def to_tree(path, fb):
    from eomc.compiler.tree.formed import formed_of_tree
    from eomc.compiler.urdf import build_tree, read_urdf
    from eomc.compiler.urdf.treeir import tree_ir
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tree = build_tree(read_urdf(path), floating_base=fb)
        formed_of_tree(tree_ir(tree).tree)
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
        model = eomc.compile(UrdfModel(path, floating_base=fb), sanitize_name(path.stem),
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


def main():
    import argparse
    import pinocchio as pin
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="substring of the URDF paths to run")
    parser.add_argument("--chains", default="25,50,100,200")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args()
    root = robots_root()
    work = Path(tempfile.mkdtemp(prefix="bench_urdf_build_"))
    rows, csv = [], []
    load_start = os.getloadavg()
    for path in sorted(root.rglob("*.urdf")):
        rel = str(path.relative_to(root))
        if args.only and args.only not in rel:
            continue
        try:
            pin.buildModelFromUrdf(str(path))
        except Exception:
            rows.append([rel, "-", "-", "-", "-", "-", "Pinocchio refuses it", "-"])
            continue
        pin_load = median_time(lambda: pin.buildModelFromUrdf(str(path)))
        fb = floating(path)
        try:
            tree = to_tree(path, fb)
        except Exception as exc:
            rows.append([rel, "-", "-", "-", "-", f"{pin_load * 1e3:.1f}", f"refused: {str(exc)[-120:]}", "-"])
            print(rows[-1], flush=True)
            continue
        dof = sum({"floating": 6, "planar": 3}.get(j.type, 1) for j in tree.joints)
        t_tree = median_time(lambda: to_tree(path, fb))
        cpu, wall, rss, err = cold_build(path, ["--floating-base"] if fb else [], work / path.stem)
        note = (f"{len(tree.locked)} massless joints locked" if tree.locked else "")
        if cpu is None:
            rows.append([rel + (" (fb)" if fb else ""), dof, f"{t_tree:.3f}", "failed", "-",
                         f"{pin_load * 1e3:.1f}", err, note])
            print(rows[-1], flush=True)
            continue
        try:
            e = pinocchio_errors(path, fb, tree, work / "cache")
            errs = " / ".join(f"{x:.1e}" for x in e)
        except Exception as exc:
            e, errs = None, f"check failed: {type(exc).__name__}: {str(exc).replace(str(root) + '/', '')[-160:]}"
        rows.append([rel + (" (fb)" if fb else ""), dof, f"{t_tree:.3f}", f"{cpu:.2f}", f"{rss:.0f}",
                     f"{pin_load * 1e3:.1f}", errs, note])
        csv.append([rel, fb, dof, t_tree, cpu, wall, rss, pin_load] + (list(e) if e else [None] * 3))
        print(rows[-1], flush=True)
    chain_rows, fit = [], []
    for n in [int(v) for v in args.chains.split(",") if v]:
        path = work / f"chain{n}.urdf"
        path.write_text(chain_text(n))
        t_tree = median_time(lambda: to_tree(path, False))
        cpu, wall, rss, err = cold_build(path, [], work / f"chain{n}")
        chain_rows.append([n, f"{t_tree:.3f}", f"{cpu:.2f}" if cpu else err, f"{wall:.2f}",
                           f"{rss:.0f}" if rss else "-"])
        if cpu:
            fit.append((n, cpu))
        print(chain_rows[-1], flush=True)
    exponent = float(np.polyfit(np.log([n for n, _ in fit]), np.log([c for _, c in fit]), 1)[0]) \
        if len(fit) > 1 else float("nan")
    head = environment_header("URDF cold builds straight from the tree (issue 19)", args, notes=[
        "peers: " + ", ".join(peer_versions(["pinocchio"])),
        f"load average at start: {load_start[0]:.2f} / {load_start[1]:.2f} / {load_start[2]:.2f}; "
        f"2 cores shared with other jobs",
        "cold build: `eomc build FILE --formulation recursive --outputs rhs -q [--floating-base]` in a "
        "child process with an empty cache; CPU = user+sys of the child and gcc; RSS = the child "
        "Python's peak",
        "errors: max relative error over 5 random states of rhs u' vs pinocchio.aba, "
        "inverse_dynamics vs pinocchio.rnea, mass_matrix vs pinocchio.crba; (fb) = floating base",
    ])
    table = format_table(["URDF", "dof", "URDF->tree s", "cold build CPU s", "peak RSS MB",
                          "Pinocchio load ms", "rel. err ABA / RNEA / CRBA", "notes"], rows)
    chains = format_table(["links", "URDF->tree s", "cold build CPU s", "wall s", "peak RSS MB"], chain_rows)
    text = (head + "\n## Robots\n\n" + table + "\n\n## Chains (alternating x/y axes, rhs only)\n\n" + chains
            + f"\n\nfitted exponent of CPU s against n: **{exponent:.2f}**\n")
    print(text)
    if not args.no_write:
        write_results("urdf_build", text, csv, ["urdf", "floating_base", "dof", "urdf_to_tree_s", "cpu_s",
                                                "wall_s", "rss_mb", "pinocchio_load_s", "err_aba",
                                                "err_rnea", "err_crba"])


if __name__ == "__main__":
    main()
