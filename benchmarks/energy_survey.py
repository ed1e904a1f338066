"""Issue 29 item 1: which of the models people bring get the runtime's energy verdict with no flags.

A model gets the generated ``energy`` output -- and so its passive runs (inputs at zero) a verdict
on created energy, runtime/switching.energy_verdict -- when
``eomc.compiler.contact.tree.energy_blockers`` finds nothing against it.  This survey reads (no
build) every gymnasium MuJoCo asset, every dm_control suite model and 12 example-robot-data
robots (Go2, G1, Solo12 floating with their feet as contacts; nine arms and robots fixed, with
their limits) and writes per model "verdict" or its blockers, grouped by kind, with the count.
Session 17 (energy5): 16 -> 32 of 45; session 18 (energy6): body-body cylinder and ellipsoid
pairs counted (pairs.counted_kinds), servos with activation dynamics judged from act = 0.

    python benchmarks/energy_survey.py [--out benchmarks/results/energy_survey.md]
"""
import argparse
import collections
import glob
import re
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def models():
    import dm_control
    import gymnasium
    from importlib.metadata import distribution
    from eomc.compiler.mjcf.model import read_model as mread
    from eomc.compiler.urdf.model import UrdfModel, read_model as uread
    gym = sorted(glob.glob(str(Path(gymnasium.__file__).parent / "envs/mujoco/assets/*.xml")))
    dm = sorted(glob.glob(str(Path(dm_control.__file__).parent / "suite/*.xml")))
    robots = Path(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots"))
    for p in gym:
        yield "gymnasium", Path(p).stem, lambda p=p: mread(p)
    for p in dm:
        yield "dm_control", Path(p).stem, lambda p=p: mread(p)

    def feet(names, r):
        return [f"{n}:0,0,0:{r}" for n in names]
    floating = {"go2": ("go2_description/urdf/go2.urdf", feet(["FL_foot", "FR_foot", "RL_foot", "RR_foot"], 0.022)),
                "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", ["@collision"]),
                "solo12": ("solo_description/robots/solo12.urdf", feet(["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"], 0.016))}
    for n, (p, c) in floating.items():
        yield "example-robot-data", f"{n} floating + feet", \
            lambda p=p, c=c: uread(UrdfModel(robots / p, floating_base=True, contacts=tuple(c)))
    fixed = {"ur5": "ur_description/urdf/ur5_robot.urdf", "ur10": "ur_description/urdf/ur10_robot.urdf",
             "panda": "panda_description/urdf/panda.urdf", "xarm7": "xarm_description/urdf/xarm7.urdf",
             "kinova": "kinova_description/robots/kinova.urdf",
             "finger_edu": "finger_edu_description/robots/finger_edu.urdf", "go2": "go2_description/urdf/go2.urdf",
             "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf", "solo12": "solo_description/robots/solo12.urdf"}
    for n, p in fixed.items():
        yield "example-robot-data", f"{n} fixed", lambda p=p: uread(UrdfModel(robots / p))


def summary(blockers):
    """The blockers grouped: a pair kind's count, others as they read (first 120 characters)."""
    kinds = collections.Counter()
    rest = []
    for b in blockers:
        m = re.search(r"\((\w+-\w+): its force", b)
        if m:
            kinds["-".join(sorted(m.group(1).split("-")))] += 1
        else:
            rest.append(b[:120])
    return "; ".join([f"{n} {k} pair point(s)" for k, n in sorted(kinds.items())] + rest)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "energy_survey.md"))
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    from eomc.compiler.contact.tree import energy_blockers
    rows, judged, total = [], 0, 0
    for source, name, read in models():
        try:
            blockers = energy_blockers(read())
            said = "verdict" if not blockers else summary(blockers)
        except Exception as e:              # a model that does not read: said, counted without a verdict
            blockers, said = ["error"], f"error {type(e).__name__}: {str(e)[:100]}"
        total += 1
        judged += not blockers
        rows.append(f"| {source} | {name} | {said} |")
        print(rows[-1], flush=True)
    import subprocess
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    text = "\n".join([
        "# Energy verdict survey (issue 29 item 1)", "",
        f"`python benchmarks/energy_survey.py` on {head} ({time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC): "
        f"**{judged} of {total}** models get the `energy` output, so their passive runs the energy verdict "
        "(`energy_blockers` empty; no flags). Session 17: 32 of 45.", "",
        "| source | model | energy verdict, or what keeps it out |", "|---|---|---|", *rows, ""])
    Path(args.out).write_text(text)
    print(f"{judged} of {total}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
