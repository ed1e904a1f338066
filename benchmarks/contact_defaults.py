"""`eomc simulate`, `eomc animate` and `eomc check` with no method or tolerance flags on the robots a new user
tries first (issue 29's "done when"): Go2 and G1 with a floating base and their feet as
contacts, Solo12, and gymnasium's hopper, ant and humanoid (contacts from the MJCF file).

    python benchmarks/contact_defaults.py [--only go2,solo12] [--t-final 1] [--check-t-final 10] [--no-write]

`simulate` runs --t-final (default 1 s); `animate` and `check` run with no flags at all (their
own default span, 10 s) unless --check-t-final is given, as issue 29's "done when" asks (animate
writes its page as the model's name + .html in the work folder).  Exit
status of check: 0 passed, 1 a check failed, 3 inconclusive (docs/cli.md).  animate's HTML
page is written in the robot's work folder (its size is recorded).

Each command runs as a user types it (a fresh process, the model cache warm from a first
build that is not timed); recorded: exit status, wall and CPU time (children included), the
physics warnings printed, and where the robot ends: the floating base's height at the start
and the end (it stands, sits or falls as the contact law says) and the lowest base height.

Whether a timed command found its build in the cache is checked, not assumed: a command that
writes a new entry into the cache's generated or models folders derived the model again (the
build cache's keys hold eomc's compiler sources, so a checkout changed while this runs -- a
merge in the worktree -- misses: session 13's G1 simulate, 59.6 s CPU of derivation for a
1 s run of 0.9 s).  Such a row says "miss" and the command is timed once more, warm, in a row
of its own.
"""
import argparse
import csv
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import environment_header, robots_dir, write_results  # noqa: E402

ROBOTS = robots_dir()


def robots():
    import gymnasium
    gym = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
    try:
        import example_robot_data as erd       # noqa: F401
    except ImportError:
        pass
    go2 = ROBOTS / "go2_description" / "urdf" / "go2.urdf"
    g1 = ROBOTS / "g1_description" / "urdf" / "g1_29dof_rev_1_0.urdf"
    solo = ROBOTS / "solo_description" / "robots" / "solo12.urdf"
    feet = lambda names, r: [a for n in names for a in ("--contact", f"{n}:0,0,0:{r}")]  # noqa: E731
    return {
        "go2": [str(go2), "--floating-base", *feet(["FL_foot", "FR_foot", "RL_foot", "RR_foot"], 0.022)],
        "g1": [str(g1), "--floating-base", "--contact", "@collision"],
        "solo12": [str(solo), "--floating-base", *feet(["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"], 0.016)],
        "hopper": [str(gym / "hopper.xml")],
        "ant": [str(gym / "ant.xml")],
        "humanoid": [str(gym / "humanoid.xml")],
    }


def run(cmd, cwd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return p, wall, cpu


CACHE_KINDS = ("generated", "models")


def cache_entries(root):
    """The entries of the cache at ``root`` that a derivation or a compilation writes."""
    found = set()
    for kind in CACHE_KINDS:
        for entry in (Path(root) / "v1" / kind).glob("*/*"):
            found.add(str(entry))
    return found


def base_height(csv_path):
    """(start, end, lowest) of the floating base's height column, or None."""
    with open(csv_path) as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    head, data = rows[0], rows[1:]
    cols = [i for i, h in enumerate(head) if h.startswith("q_") and (h.endswith("_z") or h == "q_rootz")]
    if not cols or not data:
        return None
    z = [float(r[cols[0]]) for r in data]
    return z[0], z[-1], min(z), head[cols[0]]


def warnings_of(text):
    return [ln.strip() for ln in text.splitlines() if "Warning" in ln or "warning:" in ln.lower()]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="")
    ap.add_argument("--t-final", default="1")
    ap.add_argument("--check-t-final", default=None, help="check's span (default: none given, check's own)")
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--commands", default="simulate,animate,check", help="which commands to run")
    ap.add_argument("--cache-dir", default="/tmp/eomc-contact-defaults-cache")
    args = ap.parse_args()
    eomc = str(Path(sys.executable).parent / "eomc")
    env_cache = {**os.environ, "EOMC_CACHE_DIR": args.cache_dir}
    os.environ.update(env_cache)
    rows = []
    every = robots()
    for name in (args.only.split(",") if args.only else every):     # in the order given
        spec = every[name]
        work = Path(f"/tmp/contact-defaults/{name}")
        work.mkdir(parents=True, exist_ok=True)
        sim = [eomc, "simulate", *spec, "--t-final", args.t_final, "-o", "traj.csv"]
        chk = [eomc, "check", *spec] + (["--t-final", args.check_t_final] if args.check_t_final else [])
        # no flags: the page is the model's name + .html in the work folder
        ani = [eomc, "animate", *spec] + (["--t-final", args.check_t_final] if args.check_t_final else [])
        run(sim, work)                                    # build once (not timed)
        for label, cmd in (("simulate", sim), ("animate", ani), ("check", chk)):
            if label not in args.commands.split(","):
                continue
            for tag in ("", " (warm re-run)"):
                rows.append(timed(name, label + tag, cmd, work, args.cache_dir))
                if rows[-1][-1] == "hit":
                    break
    table = ["| robot | command | exit | wall s | CPU s | build cache | base height start → end (lowest) | physics warnings | last line |",
             "|---|---|--:|--:|--:|---|---|---|---|"]
    for name, label, rc, wall, cpu, h, warn, tail, cache in rows:
        hh = f"{h[0]:.3f} → {h[1]:.3f} ({h[2]:.3f}) [{h[3]}]" if h else ""
        ww = "<br>".join(w.replace("|", "/")[:200] for w in warn) or "none"
        table.append(f"| {name} | {label} | {rc} | {wall:.1f} | {cpu:.1f} | {cache} | {hh} | {ww} | {tail.replace('|', '/')[:160]} |")
    text = environment_header("eomc simulate / animate / check with no method flags on contact robots", args) \
        + "\n" + __doc__.split("\n\n", 2)[2] + "\n\n" + "\n".join(table) + "\n"
    print("\n".join(table))
    if not args.no_write:
        write_results("contact_defaults", text, keep_notes=True)


def timed(name, label, cmd, work, cache_dir):
    """One timed command: its table row, the last field "hit" or "miss" (it derived or
    compiled the model again: cache_entries grew)."""
    for old in work.glob("*.html"):
        old.unlink()
    before = cache_entries(cache_dir)
    p, wall, cpu = run(cmd, work)
    new = cache_entries(cache_dir) - before
    cache = "hit" if not new else "miss: " + ", ".join(sorted(Path(e).parent.parent.name for e in new))
    if label.startswith("animate"):
        pages = list(work.glob("*.html"))
        p.stdout += "".join(f"\nwrote {q.name} ({q.stat().st_size / 1e6:.2f} MB)" for q in pages) \
            if pages else "\nno HTML page written"
    h = base_height(work / "traj.csv") if label.startswith("simulate") and p.returncode == 0 else None
    warn = warnings_of(p.stderr + p.stdout)
    tail = (p.stdout + p.stderr).strip().splitlines()[-1:] or [""]
    print(f"{name:9s} {label:8s} rc {p.returncode} wall {wall:6.1f} s cpu {cpu:6.1f} s cache {cache} "
          f"base {h} warnings {len(warn)} | {tail[0][:150]}", flush=True)
    for w in warn:
        print("    " + w[:300], flush=True)
    return name, label, p.returncode, wall, cpu, h, warn, tail[0], cache


if __name__ == "__main__":
    main()
