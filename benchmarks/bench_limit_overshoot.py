"""Issue 29 item 5: how far joints go past their limits in the no-flag runs, eomc vs MuJoCo.

    python benchmarks/bench_limit_overshoot.py [--t-final 1] [--suite-t-final 5] [--only suite,planar,urdf]
                                              [--no-write] [--cache-dir DIR]

Every gymnasium and dm_control model with limited hinges or slides (``--only suite``,
``--suite-t-final``, 5 s): the passive drop from the file's qpos0, no control.  eomc:
``eomc.compile(path)`` with no flags (the file's contacts, self-collision pairs included, as
MuJoCo's filters let them through) and ``model.simulate(None, (0, T))`` (the default method);
MuJoCo: ``mj_step`` at the file's time step and integrator as filed, in the same run, and again
at a tenth of the step with every ``solref`` time constant held at what the file's step makes it
(MuJoCo raises it to 2 steps, refsafe): where MuJoCo's own excursion converges.  Gymnasium's
humanoid once more as the collapse onto its knees (``pairs="trees"``: no self-collisions, against
MuJoCo with its self-collisions off: body geoms contype 2 / conaffinity 0, the floor 1 / 2).  Per
model its worst joint: the one furthest past the stated overshoot's bound (:data:`BOUND_FACTOR`
times MuJoCo's excursion at the file's step plus :data:`BOUND_SLACK`, docs/joint-laws.md),
with the hold factor G of eomc's limit spring there (``model.metadata["limit_laws"]``).

Planar-rooted MJCF (gymnasium's walker2d, hopper, half_cheetah; dm_control's walker, hopper,
cheetah; ``--planar-t-final``, 5 s): every joint past a limit, MuJoCo both as filed and with eomc's
contact set of session 9 (self-collisions off).

Per joint and side on which a run goes past the limit (a side the start was already outside of
is left out: that excursion is the start's), the largest excursion past it, in rad.

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
# The stated overshoot of an MJCF limit (docs/joint-laws.md): eomc's largest excursion past a
# limit in a no-flag run is at most BOUND_FACTOR times MuJoCo's in the same drop plus BOUND_SLACK
# (rad or m), except where MuJoCo's limit holds a load its spring cannot (the dm walker's ankles)
BOUND_FACTOR, BOUND_SLACK = 1.35, 0.005


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


def mujoco_run(path, T, self_collisions=True, finer=1):
    """MuJoCo's excursions (:func:`_new_excursions`) over T seconds of mj_step; ``finer``: at
    1/finer of the file's step, every solref time constant held at its value at the file's step
    (refsafe raises it to 2 steps), so that only the step changes."""
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(path))
    if not self_collisions:
        for g in range(m.ngeom):
            floor = int(m.geom_bodyid[g]) == 0
            m.geom_contype[g], m.geom_conaffinity[g] = (1, 2) if floor else (2, 0)
    if finer > 1:
        if not m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE):
            for refs in (m.jnt_solref, m.geom_solref, m.pair_solref, m.tendon_solref_lim, m.eq_solref,
                         m.dof_solref, m.tendon_solref_fri):
                for r in refs:
                    if r[0] > 0:
                        r[0] = max(r[0], 2 * m.opt.timestep)
        m.opt.timestep /= finer
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


def eomc_run(path, T, cache, pairs=None, model_out=None):
    """eomc's excursions, limit stiffnesses and run status; ``pairs``: MjcfModel's (None: the
    default, ``eomc.compile(path)``); ``model_out``: a list the built model is appended to."""
    import eomc
    from eomc.compiler.mjcf import MjcfModel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(Path(path), pairs=pairs) if pairs is not None else str(path),
                             cache_dir=cache, progress=False)
        if model_out is not None:
            model_out.append(model)
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


SUITE = (("gymnasium", ("ant", "half_cheetah", "hopper", "humanoid", "humanoidstandup", "inverted_double_pendulum",
                         "inverted_pendulum", "pusher", "pusher_v5", "reacher", "swimmer", "walker2d",
                         "walker2d_v5")),
         ("dm_control", ("acrobot", "ball_in_cup", "cartpole", "cheetah", "finger", "fish", "hopper", "humanoid",
                          "humanoid_CMU", "manipulator", "pendulum", "point_mass", "quadruped", "reacher",
                          "stacker", "swimmer", "walker")))


def _folders():
    import dm_control
    import gymnasium
    return {"gymnasium": Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets",
            "dm_control": Path(dm_control.__file__).parent / "suite"}


def _limited(path):
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(path))
    return any(m.jnt_limited[j] and int(m.jnt_type[j]) in (2, 3) for j in range(m.njnt))


def bound(theirs):
    """the stated overshoot's bound on eomc's excursion given MuJoCo's (docs/joint-laws.md)"""
    return BOUND_FACTOR * theirs + BOUND_SLACK


def suite_table(T, cache):
    """Per model with limits, its worst joint (furthest past the bound), eomc no flags vs MuJoCo
    as filed and at a tenth of its step; the humanoid's collapse again without self-collisions."""
    rows = []
    runs = [(suite, stem, None, True) for suite, stems in SUITE for stem in stems]
    runs.append(("gymnasium", "humanoid", "trees", False))
    for suite, stem, pairs, self_collisions in runs:
        path = _folders()[suite] / f"{stem}.xml"
        if not _limited(path):
            continue
        label = f"{suite} {stem}" + (", pairs=trees vs MuJoCo without self-collisions" if pairs else "")
        built = []
        got, _, status = eomc_run(path, T, cache, pairs, built)
        filed = mujoco_run(path, T, self_collisions)
        fine = mujoco_run(path, T, self_collisions, finer=10)
        keys = [k for k in set(got) | set(filed) if max(got.get(k, (0.0,))[0], filed.get(k, (0.0,))[0]) > 1e-3]
        if not keys:
            rows.append([label, "0", "(none past a limit by 1 mrad)"] + [""] * 9)
        else:
            e, s, f = ({k: r.get(k, (0.0,))[0] for k in keys} for r in (got, filed, fine))
            worst = max(keys, key=lambda k: (e[k] / bound(s[k]), k))
            hold = ((built[0].metadata.get("limit_laws") or {}).get(worst[0]) or {}).get("hold")
            rows.append([label, str(len(keys)), f"{worst[0]} ({worst[1]})", f"{e[worst]:.4f}", f"{s[worst]:.4f}",
                         f"{e[worst] / s[worst]:.2f}" if s[worst] > 1e-4 else "-", f"{f[worst]:.4f}",
                         f"{e[worst] / f[worst]:.2f}" if f[worst] > 1e-4 else "-", f"{bound(s[worst]):.4f}",
                         "yes" if e[worst] <= bound(s[worst]) else "**no**", f"{hold[0]:.3g}" if hold else "-",
                         f"{max(e.values()):.4f}"])
        if status:
            rows.append([label, "(eomc status)", str(status)] + [""] * 9)
    return rows


PLANAR = (("gymnasium", "walker2d"), ("gymnasium", "hopper"), ("gymnasium", "half_cheetah"),
          ("dm_control", "walker"), ("dm_control", "hopper"), ("dm_control", "cheetah"))


def planar_table(T, cache):
    """The planar-rooted robots (root slide, slide, hinge; compiler/mjcf/carried.py's held
    inertia): eomc no flags vs MuJoCo as filed and with eomc's contact set (no self-collisions)."""
    folders = _folders()
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
    ap.add_argument("--suite-t-final", type=float, default=5.0)
    ap.add_argument("--only", default="suite,planar,urdf")
    args = ap.parse_args()
    cache = Path(args.cache_dir or tempfile.mkdtemp(prefix="bench_limits_"))
    parts = [environment_header("Joint limits: excursion past the range in no-flag runs, eomc vs MuJoCo",
                                f"python3 benchmarks/bench_limit_overshoot.py --t-final {args.t_final:g} "
                                f"--planar-t-final {args.planar_t_final:g} --suite-t-final {args.suite_t_final:g} "
                                f"--only {args.only}"), ""]
    if "suite" in args.only:
        rows = suite_table(args.suite_t_final, cache)
        parts += [f"## Every gymnasium and dm_control model with limits, {args.suite_t_final:g} s from qpos0: the "
                  f"worst joint (rad)", "",
                  f"Bound: eomc <= {BOUND_FACTOR:g} x MuJoCo (file's step) + {BOUND_SLACK:g} rad. Worst joint: the "
                  f"furthest past it. h/10: MuJoCo at a tenth of the file's step, solref time constants held.", "",
                  table(["model", "joints past", "worst joint", "eomc", "MuJoCo", "eomc ÷ MuJoCo", "MuJoCo h/10",
                         "eomc ÷ h/10", "bound", "within", "hold G", "eomc's largest"], rows), ""]
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
