"""rhs calls per BDF step on the contact models a new user runs with no flags (README's contact
section, docs/contact.md: "about two rhs calls per step").

Runs ``eomc simulate MODEL [flags]`` as a user types it (the default method, t_final 10, rtol 1e-6)
on gymnasium's hopper, ant and humanoid (no flags) and on Solo12 and Go2 with their feet as
contacts (README's and issue 29's flags), and reads the summary line the command prints
("N steps (R rejected), F rhs, J jacobian, L LU"). Per model: rhs calls per accepted step and
per attempted step (rejected ones included); Jacobians come from the analytic ``jac_x`` and are
not rhs calls. Not a timing: the counts do not depend on the machine's load.
"""

import argparse
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import environment_header, robots_dir, write_results  # noqa: E402

ROBOTS = robots_dir()


def cases():
    import gymnasium
    gym = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
    solo = ["--floating-base"] + [a for f in ("FL", "FR", "HL", "HR")
                                  for a in ("--contact", f"{f}_FOOT:0,0,0:0.016")]
    go2 = ["--floating-base"] + [a for f in ("FL", "FR", "RL", "RR")
                                 for a in ("--contact", f"{f}_foot:0,0,0:0.022")]
    return [("hopper", gym / "hopper.xml", []), ("ant", gym / "ant.xml", []),
            ("humanoid", gym / "humanoid.xml", []),
            ("solo12", ROBOTS / "solo_description/robots/solo12.urdf", solo),
            ("go2", ROBOTS / "go2_description/urdf/go2.urdf", go2)]


LINE = re.compile(r": (\S+) t=\[.*\]: (\d+) steps \((\d+) rejected\), (\d+) rhs, (\d+) jacobian, (\d+) LU")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", default=None, help="comma-separated subset of hopper,ant,humanoid,solo12,go2")
    ap.add_argument("--cache-dir", default=None, help="EOMC_CACHE_DIR for the builds")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args(argv)
    import os
    env = dict(os.environ, **({"EOMC_CACHE_DIR": args.cache_dir} if args.cache_dir else {}))
    want = None if args.models is None else set(args.models.split(","))
    rows = []
    for name, path, flags in cases():
        if want is not None and name not in want:
            continue
        cmd = [sys.executable, "-m", "eomc", "simulate", str(path), *flags]
        out = subprocess.run(cmd, env=env, capture_output=True, text=True)
        m = LINE.search(out.stdout)
        if out.returncode != 0 or not m:
            print(f"{name}: exit {out.returncode}\n{out.stdout[-2000:]}\n{out.stderr[-2000:]}", file=sys.stderr)
            continue
        method, steps, rej, nfev, njev, nlu = m.group(1), *map(int, m.groups()[1:])
        rows.append((name, " ".join(flags) or "(none)", method, steps, rej, nfev, njev, nlu,
                     nfev / steps, nfev / (steps + rej)))
        print(f"{name}: {method} {steps} steps ({rej} rejected) {nfev} rhs {njev} jac {nlu} LU: "
              f"{nfev / steps:.2f} rhs per accepted step, {nfev / (steps + rej):.2f} per attempted", flush=True)
    head = ["model", "flags", "method", "steps", "rejected", "rhs calls", "jacobians", "LU",
            "rhs / accepted step", "rhs / attempted step"]
    table = ["| " + " | ".join(head) + " |", "|" + "---|" * 3 + "--:|" * (len(head) - 3)]
    table += [f"| {r[0]} | `{r[1]}` | {r[2]} | {r[3]} | {r[4]} | {r[5]} | {r[6]} | {r[7]} | {r[8]:.2f} | {r[9]:.2f} |"
              for r in rows]
    text = environment_header("rhs calls per step of the default method on contact models", args,
                              ) + "\n" + __doc__ + "\n" + "\n".join(table) + "\n"
    if not args.no_write:
        print(write_results("bdf_calls", text))
    else:
        print("\n".join(table))


if __name__ == "__main__":
    main()
