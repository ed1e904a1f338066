"""Issue 23 item 4: frame outputs -- the cost of eomc's NAME_outputs (frames + centre of mass) and of
rhs + outputs, against Pinocchio's kinematics + frame Jacobians (+ ABA), in C.

Per robot (UR5 with tool0; Panda with panda_hand; Solo12 with a floating base and its four
feet), each built with ``frames=[..., "com"]`` (functions rhs, outputs):

    eomc outputs        NAME_outputs: per frame p, R, (v; w) and the 6 x nu Jacobian, then
                        the centre of mass and its velocity (LOCAL_WORLD_ALIGNED)
    eomc rhs+outputs    NAME_rhs then NAME_outputs on the same state
    Pinocchio frames    forwardKinematics(q, v), computeJointJacobians, updateFramePlacements,
                        per frame getFrameJacobian(LOCAL_WORLD_ALIGNED) and getFrameVelocity,
                        centerOfMass(VELOCITY): the same numbers
    Pinocchio aba+frames  aba(q, v, 0) then the above

Each in its own C/C++ harness timed with CLOCK_THREAD_CPUTIME_ID over the same NSTATES
random states (converted: Pinocchio's quaternion for the floating base), contestants
interleaved repeat by repeat, the process pinned to one core; medians.  Before timing, the
first state's first-frame position and Jacobian from the two harnesses are compared.
"""
import hashlib
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from common import environment_header, format_table, median_iqr, write_results  # noqa: E402

ROBOTS = [("ur5", False, ["tool0"]), ("panda", False, ["panda_hand"]),
          ("solo12", True, ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"])]
NSTATES, NCALLS, REPEAT = 200, 20000, 7
CORE = 1

EOMC_HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "@NAME@.h"
static double cpu(void) { struct timespec t; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
int main(int argc, char **argv) {
    (void)argc;
    const int nx = @NX@, no = @NOUT@, ns = atoi(argv[2]), mode = atoi(argv[4]); const long nc = atol(argv[3]);
    double *X = malloc(sizeof(double) * nx * ns), xdot[@NX@], out[@NOUT@], P[@NPARAM@ + 1], r[@NINPUT@ + 1] = {0.0};
    double work[@WORK@ + 1];
    FILE *f = fopen(argv[1], "rb");
    if (!f || fread(P, sizeof(double), @NPARAM@, f) != @NPARAM@ || fread(X, sizeof(double), (size_t)nx * ns, f) != (size_t)nx * ns) return 2;
    fclose(f);
    if (@NAME@_outputs(0.0, X, P, r, out, work)) return 3;
    printf("first"); for (int j = 0; j < no; ++j) printf(" %.17g", out[j]); printf("\n");
    double sum = 0.0, t0 = cpu();
    for (long i = 0; i < nc; ++i) {
        const double *x = X + (i % ns) * nx;
        if (mode) { @NAME@_rhs(0.0, x, P, r, xdot, work); sum += xdot[nx - 1]; }
        @NAME@_outputs(0.0, x, P, r, out, work); sum += out[no - 1];
    }
    printf("ns %.3f\nchecksum %g\n", 1e9 * (cpu() - t0) / nc, sum);
    return 0;
}
"""

PIN_HARNESS = r"""
#include <pinocchio/multibody.hpp>
#include <pinocchio/serialization.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/center-of-mass.hpp>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>
using namespace pinocchio;
static double cpu() { timespec t; clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
int main(int argc, char **argv) {
    Model model;
    model.loadFromText(argv[1]);
    Data data(model);
    const int nq = model.nq, nv = model.nv, ns = atoi(argv[3]), mode = atoi(argv[5]); const long nc = atol(argv[4]);
    std::vector<FrameIndex> frames;
    for (int k = 6; k < argc; ++k) frames.push_back(model.getFrameId(argv[k]));
    std::vector<Eigen::VectorXd> Q(ns, Eigen::VectorXd(nq)), V(ns, Eigen::VectorXd(nv));
    FILE *f = fopen(argv[2], "rb");
    for (int k = 0; k < ns; ++k)
        if (fread(Q[k].data(), sizeof(double), nq, f) != (size_t)nq || fread(V[k].data(), sizeof(double), nv, f) != (size_t)nv) return 2;
    fclose(f);
    Eigen::VectorXd tau = Eigen::VectorXd::Zero(nv);
    std::vector<Data::Matrix6x> J(frames.size(), Data::Matrix6x::Zero(6, nv));
    std::vector<Motion> vel(frames.size());
    double sum = 0.0;
    auto step = [&](int k) {
        if (mode) { aba(model, data, Q[k], V[k], tau); sum += data.ddq[nv - 1]; }
        forwardKinematics(model, data, Q[k], V[k]);
        computeJointJacobians(model, data);
        updateFramePlacements(model, data);
        for (size_t i = 0; i < frames.size(); ++i) {
            J[i].setZero();
            getFrameJacobian(model, data, frames[i], LOCAL_WORLD_ALIGNED, J[i]);
            vel[i] = getFrameVelocity(model, data, frames[i], LOCAL_WORLD_ALIGNED);
        }
        centerOfMass(model, data, VELOCITY, false);
        sum += J.back()(5, nv - 1) + vel.back().angular()[2] + data.vcom[0][2];
    };
    step(0);
    printf("first");
    for (int j = 0; j < 3; ++j) printf(" %.17g", data.oMf[frames[0]].translation()[j]);
    for (int i = 0; i < 6; ++i) for (int j = 0; j < nv; ++j) printf(" %.17g", J[0](i, j));
    printf("\n");
    double t0 = cpu();
    for (long i = 0; i < nc; ++i) step(i % ns);
    printf("ns %.3f\nchecksum %g\n", 1e9 * (cpu() - t0) / nc, sum);
    return 0;
}
"""


def _run(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw)


def _cmeel():
    from importlib.metadata import distribution
    return Path(distribution("pin").locate_file("cmeel.prefix"))


def pin_harness(tmp):
    """The Pinocchio harness binary (cached in the temp folder: g++ takes minutes on its templates)."""
    import pinocchio as pin
    cm = _cmeel()
    key = hashlib.sha256(f"{PIN_HARNESS}{pin.__version__}".encode()).hexdigest()[:16]
    cached = Path(tempfile.gettempdir()) / f"eomc_bench_pin_frames_{key}"
    t0 = time.perf_counter()
    if not cached.is_file():
        src = tmp / "pin_frames.cpp"
        src.write_text(PIN_HARNESS)
        _run(["g++", "-O3", "-DNDEBUG", "-std=c++17", "-DBOOST_MPL_LIMIT_LIST_SIZE=30",
              "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30", "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
              "-DBOOST_FUSION_INVOKE_MAX_ARITY=12", f"-I{cm / 'include'}", f"-I{cm / 'include/eigen3'}",
              str(src), f"-L{cm / 'lib'}", "-lboost_serialization", f"-Wl,-rpath,{cm / 'lib'}",
              "-o", str(tmp / "pin_frames")])
        shutil.copy(tmp / "pin_frames", cached)
    shutil.copy(cached, tmp / "pin_frames")
    return tmp / "pin_frames", time.perf_counter() - t0


def eomc_harness(model, directory, tmp):
    src = (EOMC_HARNESS.replace("@NAME@", model.name).replace("@NX@", str(model.nx))
           .replace("@NOUT@", str(model.noutput)).replace("@NPARAM@", str(model.nparam))
           .replace("@NINPUT@", str(model.ninput)).replace("@WORK@", str(model.work_size)))
    c, exe = tmp / f"eomc_{model.name}.c", tmp / f"eomc_{model.name}"
    c.write_text(src)
    _run(["gcc", "-O2", "-std=c99", str(c), f"-I{directory}", f"-L{directory}", f"-l{model.name}",
          f"-Wl,-rpath,{directory}", "-lm", "-o", str(exe)])
    return exe


def _write(path, rows, head=()):
    with open(path, "wb") as fh:
        fh.write(struct.pack(f"{len(head)}d", *head))
        for row in rows:
            fh.write(struct.pack(f"{len(row)}d", *row))


def _timed(cmd):
    out = _run(cmd).stdout.splitlines()
    return float(out[1].split()[1]), np.array([float(v) for v in out[0].split()[1:]])


def main():
    import eomc
    import pinocchio as pin
    from eomc.compiler.urdf import build_tree, read_urdf
    from eomc.compiler.urdf.model import UrdfModel
    from helpers.robots import PinRef, robot_path
    os.sched_setaffinity(0, {CORE})
    rng = np.random.default_rng(23)
    robots, checks = [], []
    with tempfile.TemporaryDirectory(prefix="bench_frames_") as tmpname:
        tmp = Path(tmpname)
        pin_exe, pin_build = pin_harness(tmp)
        for name, floating, frames in ROBOTS:
            path = robot_path(name)
            out = tmp / f"out_{name}"
            t0 = time.perf_counter()
            model = eomc.compile(UrdfModel(path, floating_base=floating), f"{name}_frames",
                                 functions=["rhs", "outputs"], formulation="recursive", progress=False,
                                 cache_dir=tmp / "cache", output_dir=out, frames=frames + ["com"])
            build = time.perf_counter() - t0
            tree = build_tree(read_urdf(path), floating_base=floating)
            ref = PinRef(path, [(j.name, j.type) for j in tree.joints], floating=floating)
            pin_model = tmp / f"{name}_pin.txt"
            ref.model.saveToText(str(pin_model))
            ex, pv = [], []
            for _ in range(NSTATES):
                q = rng.uniform(-np.pi, np.pi, model.nq)
                if floating:
                    q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
                u = rng.normal(size=model.nu)
                ex.append(np.concatenate([q, u]))
                pv.append(np.concatenate([ref.q(q), ref.v(u)]))
            files = {k: tmp / f"{name}_{k}.bin" for k in ("eomc", "pin")}
            _write(files["eomc"], ex, head=[float(v) for v in model.param_defaults])
            _write(files["pin"], pv)
            exe = eomc_harness(model, out, tmp)
            cmds = {"eomc": [str(exe), str(files["eomc"]), str(NSTATES), str(NCALLS), "0"],
                    "eomc_rhs": [str(exe), str(files["eomc"]), str(NSTATES), str(NCALLS), "1"],
                    "pin": [str(pin_exe), str(pin_model), str(files["pin"]), str(NSTATES), str(NCALLS), "0", *frames],
                    "pin_aba": [str(pin_exe), str(pin_model), str(files["pin"]), str(NSTATES), str(NCALLS), "1",
                                *frames]}
            robots.append((name, floating, frames, model, ref, build, cmds))
            print(f"{name}: built in {build:.1f} s wall ({model.noutput} outputs)", flush=True)
        keys = ("eomc", "eomc_rhs", "pin", "pin_aba")
        samples = {(r[0], k): [] for r in robots for k in keys}
        firsts = {}
        for _ in range(REPEAT):
            for name, floating, frames, model, ref, build, cmds in robots:
                for key in keys:
                    ns, first = _timed(cmds[key])
                    samples[name, key].append(ns)
                    firsts[name, key] = first
        rows = []
        for name, floating, frames, model, ref, build, cmds in robots:
            outs = dict(zip(model.output_names, firsts[name, "eomc"]))
            f0, nv = frames[0], model.nu
            p = np.array([outs[f"{f0}.p.{a}"] for a in "xyz"])
            J = np.array([[outs[f"{f0}.J[{i}][{j}]"] for j in range(nv)] for i in range(6)])
            pin_first = firsts[name, "pin"]
            p_pin, J_pin = pin_first[:3], pin_first[3:].reshape(6, ref.model.nv)[:, ref.iv]
            err = max(np.max(np.abs(p - p_pin)), np.max(np.abs(J - J_pin)))
            checks.append(f"{name}: first state, {f0} position and Jacobian, eomc vs Pinocchio: max |diff| {err:.1e}")
            med = {k: median_iqr(samples[name, k])[0] for k in keys}
            ops = model.metadata["op_counts"]
            rows.append([name + (" (floating)" if floating else ""), model.nu, ", ".join(frames) + ", com",
                         model.noutput, round(med["eomc"]), round(med["pin"]), f"{med['pin'] / med['eomc']:.2f}",
                         round(med["eomc_rhs"]), round(med["pin_aba"]), f"{med['pin_aba'] / med['eomc_rhs']:.2f}",
                         sum(int(v) for v in ops["outputs"].values()), round(build, 1)])
    headers = ["robot", "nu", "frames", "outputs", "eomc outputs [ns]", "Pinocchio frames [ns]",
               "Pinocchio / eomc", "eomc rhs+outputs [ns]", "Pinocchio aba+frames [ns]", "ratio",
               "outputs ops", "build wall [s]"]
    table = format_table(headers, rows)
    print(table)
    print("\n".join(checks))
    uptime = _run(["uptime"]).stdout.strip()
    header = environment_header(
        "Frame outputs: eomc's NAME_outputs vs Pinocchio's kinematics + frame Jacobians (issue 23, item 4)", None,
        notes=[f"`python3 benchmarks/bench_frames.py`; uptime at the end: {uptime}",
               "the machine is shared (2 cores, other jobs running): thread CPU time keeps the per-call "
               "figures fair; build wall times are inflated",
               f"pinned to core {CORE}; medians of {REPEAT} interleaved repeats of {NCALLS} calls over "
               f"{NSTATES} random states (the same states, converted, for both)",
               f"pin {pin.__version__}; Pinocchio harness g++ -O3 -DNDEBUG from the wheel's headers "
               f"({pin_build:.0f} s wall to compile, or a cached build); eomc library and harness gcc -O2",
               "what each call computes: see the docstring of benchmarks/bench_frames.py; build: "
               "functions rhs, outputs (recursive formulation), warm SymPy, empty cache",
               *checks])
    write_results("frames", header + "\n" + table + "\n", csv_rows=rows, csv_headers=headers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
