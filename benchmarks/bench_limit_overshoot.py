"""Issue 29 item 5: how far joints go past their limits in the no-flag runs, eomc vs MuJoCo.

    python benchmarks/bench_limit_overshoot.py [--t-final 1] [--no-write] [--cache-dir DIR]

Planar-rooted MJCF (gymnasium's walker2d, hopper, half_cheetah; dm_control's walker, hopper,
cheetah; ``--planar-t-final``, 5 s): as the ant, MuJoCo both as filed and with eomc's contact
set (self-collisions off).

MJCF (gymnasium's ant and humanoid): both start at the file's qpos0, no control, T seconds.
eomc: ``eomc.compile(path)`` with no flags and ``model.simulate(None, (0, T))`` (the default
method); MuJoCo: ``mj_step`` at the file's time step and integrator, in the same run.  The
humanoid twice on MuJoCo's side: as filed (its self-collisions on) and with the contact set eomc
builds by default (body--floor only: every body geom contype 2 / conaffinity 0, the floor 1 / 2),
and once more on eomc's side with ``MjcfModel(path, pairs=True)`` (its self-collision pairs).
Per joint and side on which a run goes past the limit (a side the start was already outside of
is left out: that excursion is the start's), the largest excursion past it, in rad, and the
limit stiffness eomc used.

URDF (Go2 and G1 as ``benchmarks/contact_defaults.py`` runs them: ``eomc simulate ...
--t-final T -o traj.csv``, no method flags): eomc only (MuJoCo has no model of these robots
with eomc's contacts); per robot the three joints that went furthest past a limit, with their
default stiffness and the rule's inputs (``compiler/urdf/treeir.joint_inertias``: the joint's
own inertia, its static load and the inertia it carries).  The stated overshoot the verdict
allows is 100 limit widths, 0.03 rad (``runtime/switching.LIMIT_OVERSHOOT_WIDTHS``).
"""
import argparse
import csv
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import environment_header, write_results  # noqa: E402
from contact_defaults import robots as cli_robots  # noqa: E402

ALLOWED = 100 * 3e-4


def _new_excursions(names, q, lo, hi):
    """{(joint, side): (largest excursion past the limit, index)} of the sides the start was not
    already outside of."""
    out = {}
    for j, name in enumerate(names):
        if not (np.isfinite(lo[j]) or np.isfinite(hi[j])):
            continue
        for side, o in (("lower", lo[j] - q[:, j]), ("upper", q[:, j] - hi[j])):
            if not np.isfinite(o).any() or o[0] > 0:
                continue
            k = int(np.nanargmax(o))
            if o[k] > 1e-5:
                out[(name, side)] = (float(o[k]), k)
    return out


def mujoco_run(path, T, self_collisions=True):
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(path))
    if not self_collisions:
        for g in range(m.ngeom):
            floor = int(m.geom_bodyid[g]) == 0
            m.geom_contype[g], m.geom_conaffinity[g] = (1, 2) if floor else (2, 0)
    d = mujoco.MjData(m)
    joints = [j for j in range(m.njnt) if m.jnt_limited[j] and int(m.jnt_type[j]) in (2, 3)]
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in joints]
    adr = [int(m.jnt_qposadr[j]) for j in joints]
    lo, hi = (np.array([m.jnt_range[j][s] for j in joints]) for s in (0, 1))
    qs = [d.qpos[adr].copy()]
    while d.time < T - 1e-9:
        mujoco.mj_step(m, d)
        qs.append(d.qpos[adr].copy())
    return _new_excursions(names, np.array(qs), lo, hi)


def eomc_run(path, T, cache, pairs=False):
    import eomc
    from eomc.compiler.mjcf import MjcfModel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(Path(path), pairs=True) if pairs else str(path), cache_dir=cache,
                             progress=False)
        res = model.simulate(None, (0.0, T), n_points=int(T * 2000) + 1)
    P = dict(zip(model.param_names, model.param_defaults))
    # a limit at exactly 0 has no limit_lo_/limit_hi_ parameter (the C holds the 0): the limited
    # joints are those with a stiffness
    names = [n[len("limit_k_"):] for n in model.param_names if n.startswith("limit_k_")]
    names = [n for n in names if f"q_{n}" in model.state_names]
    cols = [list(model.state_names).index(f"q_{n}") for n in names]
    lo = np.array([P.get(f"limit_lo_{n}", 0.0) for n in names])
    hi = np.array([P.get(f"limit_hi_{n}", 0.0) for n in names])
    got = _new_excursions(names, res.x[:, cols], lo, hi)
    return got, {n: P[f"limit_k_{n}"] for n in names}, res.status


def mjcf_table(T, cache):
    import gymnasium
    folder = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
    rows = []
    for stem, pairs in (("ant", False), ("humanoid", False), ("humanoid", True)):
        path = folder / f"{stem}.xml"
        got, ks, status = eomc_run(path, T, cache, pairs)
        filed = mujoco_run(path, T, True)
        same = filed if stem == "ant" or pairs else mujoco_run(path, T, False)
        label = stem + (", pairs=True" if pairs else "")
        keys = sorted(set(got) | set(same) | set(filed))
        n = len(rows)
        for key in keys:
            e = got.get(key, (0.0,))[0]
            s = same.get(key, (0.0,))[0]
            f = filed.get(key, (0.0,))[0]
            if max(e, s, f) < 1e-3:
                continue
            ratio = f"{e / s:.2f}" if s > 1e-4 else "-"
            rows.append([label, key[0], key[1], f"{e:.4f}", f"{s:.4f}", ratio, f"{f:.4f}", f"{ks[key[0]]:.4g}",
                         "yes" if e > ALLOWED else "no"])
        if len(rows) == n:
            rows.append([label, "(none past a limit by 1 mrad)", "", "", "", "", "", "", ""])
        if status:
            rows.append([label, "(eomc status)", "", str(status), "", "", "", "", ""])
    return rows


PLANAR = (("gymnasium", "walker2d"), ("gymnasium", "hopper"), ("gymnasium", "half_cheetah"),
          ("dm_control", "walker"), ("dm_control", "hopper"), ("dm_control", "cheetah"))


def planar_table(T, cache):
    """The planar-rooted robots (root slide, slide, hinge; compiler/mjcf/carried.py's held
    inertia): eomc no flags vs MuJoCo as filed and with eomc's contact set (no self-collisions)."""
    import dm_control
    import gymnasium
    folders = {"gymnasium": Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets",
               "dm_control": Path(dm_control.__file__).parent / "suite"}
    rows = []
    for suite, stem in PLANAR:
        path = folders[suite] / f"{stem}.xml"
        got, ks, status = eomc_run(path, T, cache)
        filed, same = mujoco_run(path, T, True), mujoco_run(path, T, False)
        label = f"{suite} {stem}"
        n = len(rows)
        for key in sorted(set(got) | set(same) | set(filed)):
            e, s, f = (r.get(key, (0.0,))[0] for r in (got, same, filed))
            if max(e, s, f) < 1e-3:
                continue
            rows.append([label, key[0], key[1], f"{e:.4f}", f"{s:.4f}", f"{e / s:.2f}" if s > 1e-4 else "-",
                         f"{f:.4f}", f"{e / f:.2f}" if f > 1e-4 else "-", f"{ks[key[0]]:.4g}"])
        if len(rows) == n:
            rows.append([label, "(none past a limit by 1 mrad)"] + [""] * 7)
        if status:
            rows.append([label, "(eomc status)", "", str(status)] + [""] * 5)
    return rows


def urdf_table(T, cache):
    from eomc.compiler.urdf import read_urdf
    from eomc.compiler.urdf.tree import build_tree
    from eomc.compiler.urdf.treeir import joint_inertias
    from eomc.compiler.tree.joint_laws import scale_gains
    env = {**os.environ, "EOMC_CACHE_DIR": str(cache)}
    eomc_cli = str(Path(sys.executable).parent / "eomc")
    rows = []
    for name in ("go2", "g1"):
        args = cli_robots()[name]
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "traj.csv"
            p = subprocess.run([eomc_cli, "simulate", *args, "--t-final", str(T), "-o", str(out), "-q"],
                               capture_output=True, text=True, env=env)
            warned = [ln for ln in p.stderr.splitlines() if "past its" in ln]
            with out.open() as fh:
                reader = csv.reader(fh)
                head = next(reader)
                X = np.array([[float(v) for v in row] for row in reader])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tree = build_tree(read_urdf(args[0]), floating_base=True)
        scales = joint_inertias(tree)
        limited = [j for j in tree.joints if j.limit is not None and j.name in scales]
        names = [j.name for j in limited]
        cols = [head.index(f"q_{n}") for n in names]
        lo = np.array([j.limit[0] if j.limit[0] is not None else -np.inf for j in limited], dtype=float)
        hi = np.array([j.limit[1] if j.limit[1] is not None else np.inf for j in limited], dtype=float)
        got = _new_excursions(names, X[:, cols], lo, hi)
        top = sorted(got.items(), key=lambda kv: -kv[1][0])[:3]
        for (joint, side), (over, _) in top:
            s = scales[joint]
            k, c = scale_gains(s)
            rows.append([name, joint, side, f"{over:.4f}", f"{k:.4g}", f"{c:.4g}", f"{s[0]:.3g}", f"{s[1]:.3g}",
                         f"{s[2]:.3g}", "yes" if over > ALLOWED else "no"])
        if warned:
            rows.append([name, "(warning)", "", warned[0][:160], "", "", "", "", "", ""])
        if p.returncode:
            rows.append([name, "(exit status)", "", str(p.returncode), "", "", "", "", "", ""])
    return rows


def table(headers, rows):
    out = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    out += ["| " + " | ".join(str(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


NOTES_MARK = "## Notes"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-final", type=float, default=1.0)
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--cache-dir", default=None)
    ap.add_argument("--planar-t-final", type=float, default=5.0)
    ap.add_argument("--only", default="mjcf,planar,urdf")
    args = ap.parse_args()
    cache = Path(args.cache_dir or tempfile.mkdtemp(prefix="bench_limits_"))
    parts = [environment_header("Joint limits: excursion past the range in no-flag runs, eomc vs MuJoCo",
                                f"python3 benchmarks/bench_limit_overshoot.py --t-final {args.t_final:g} "
                                f"--planar-t-final {args.planar_t_final:g} --only {args.only}"), ""]
    if "mjcf" in args.only:
        rows = mjcf_table(args.t_final, cache)
        parts += [f"## MJCF, {args.t_final:g} s from qpos0: largest excursion past the limit (rad)", "",
                  table(["model", "joint", "side", "eomc", "MuJoCo, same contacts", "eomc ÷ MuJoCo",
                         "MuJoCo as filed", "eomc limit_k", "past 0.03 rad"], rows), ""]
    if "planar" in args.only:
        rows = planar_table(args.planar_t_final, cache)
        parts += [f"## Planar-rooted MJCF robots, {args.planar_t_final:g} s from qpos0: largest excursion past "
                  f"the limit (rad)", "",
                  table(["model", "joint", "side", "eomc", "MuJoCo, same contacts", "eomc ÷ same",
                         "MuJoCo as filed", "eomc ÷ filed", "eomc limit_k"], rows), ""]
    if "urdf" in args.only:
        rows = urdf_table(args.t_final, cache)
        parts += [f"## URDF robots, `eomc simulate` with no method flags, {args.t_final:g} s: the three joints "
                  f"furthest past a limit (rad)", "",
                  table(["robot", "joint", "side", "excursion", "default k", "default c", "own inertia",
                         "load", "carried inertia", "past 0.03 rad"], rows), ""]
    text = "\n".join(parts)
    print(text)
    if not args.no_write:
        from common import RESULTS_DIR
        old = RESULTS_DIR / "limit_overshoot.md"
        if old.exists() and NOTES_MARK in old.read_text():      # hand-written notes are kept
            text += "\n" + old.read_text()[old.read_text().index(NOTES_MARK):]
        write_results("limit_overshoot", text)


if __name__ == "__main__":
    main()
