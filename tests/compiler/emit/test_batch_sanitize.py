"""NAME_rhs_batch (compiler/emit/batch.py) under AddressSanitizer and UBSan: its lane loads
and stores (whole vectors memcpy'd out of the column-major X, R and into XDOT), the scalar
tail, the per-lane Kane solve and the failing-state paths read and write only inside the
caller's arrays, with no undefined behaviour, at 4 and 8 lanes -- on a recursive-form robot
(UR5, split into parts), a Kane-form cart with inputs and a 5-link cart whose rhs is looped
(compiler/tree/chain_loop.py: its lanes loop too, two groups of lanes a call) and a tree
with twin limbs whose rhs runs limb routines (compiler/tree/limbs.py: in lanes too, two limbs a
routine, their work arrays' stores at negative offsets).  The driver allocates every array
at its exact size, so one element past a column's end is caught; it also checks each
state's result and status against the scalar rhs, so a clean run is a correct run.  The same
driver runs NAME_jac_x_batch (its tangent loop over vectors, nx*nx outputs per state) against
the scalar jac_x on UR5 with its joint limits (the lanes' Heaviside helper) and on a 6-link cart
(the analytic kernel retyped into lanes), and NAME_outputs_batch against the scalar outputs on
the Kane-form double pendulum (energy and tip position: sin/cos in lanes), and
NAME_implicit_batch against the scalar NAME_implicit on the gym hopper (its contacts' branches
as masks: at the driver's states some lanes of a group touch the ground and some do not)."""
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from eomc.compiler.build.builder import machine_lanes
from eomc.compiler.driver import generate

from helpers import emit_support as es
from helpers.robots import robot_path

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

CART = Path(__file__).resolve().parents[3] / "examples" / "cart_pole_system.py"
CHAIN = Path(__file__).resolve().parents[3] / "benchmarks" / "tree_models" / "cart_rel_joints.py"
PENDULUM = Path(__file__).resolve().parents[3] / "examples" / "double_pendulum.py"

DRIVER = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "NAME.h"

static unsigned long long seed = 12345;
static double uniform(void)      /* in [-2, 2), the same on every machine */
{
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return 4.0 * (double)(seed >> 11) / 9007199254740992.0 - 2.0;
}

int main(void)
{
    const eomc_model *m = NAME_model();
    const int n = NSTATES, nx = m->nx, nr = m->ninput, no = NOUT;
    const int bad_block = 1, bad_tail = NSTATES - 2;   /* in a group of lanes; in the tail */
    double *X = (double *)malloc((size_t)nx * n * sizeof(double));
    double *XDOT = (double *)malloc((size_t)no * n * sizeof(double));
    double *R = nr ? (double *)malloc((size_t)nr * n * sizeof(double)) : NULL;
    double *work = (double *)malloc((m->work_size ? m->work_size : 1) * sizeof(double));
    double *xs = (double *)malloc((size_t)nx * sizeof(double));
    double *xd = (double *)malloc((size_t)no * sizeof(double));
    double *rs = (double *)malloc((size_t)(nr ? nr : 1) * sizeof(double));
    int *status = (int *)malloc((size_t)n * sizeof(int));
    int i, k, pass, wrong = 0, failed = 0;
    for (i = 0; i < nx * n; i++) X[i] = uniform();
    for (i = 0; i < nr * n; i++) R[i] = 0.5 * uniform();
    X[(size_t)1 * n + bad_block] = NAN;
    X[(size_t)1 * n + bad_tail] = INFINITY;    /* q1: both models depend on it */
    for (pass = 0; pass < 2; pass++) {           /* inputs per state, then R = NULL */
        const double *Rp = pass == 0 ? R : NULL;
        int worst = NAME_FN_batch(n, 0.3, X, m->param_defaults, Rp, XDOT, status, work);
        if (worst == EOMC_OK) wrong++;           /* two states are bad: the call says so */
        for (k = 0; k < n; k++) {
            int s;
            for (i = 0; i < nx; i++) xs[i] = X[(size_t)i * n + k];
            for (i = 0; i < nr; i++) rs[i] = Rp ? Rp[(size_t)i * n + k] : 0.0;
            s = NAME_FN(0.3, xs, m->param_defaults, rs, xd, work);
            if (s != EOMC_OK) failed++;
            if ((s == EOMC_OK) != (status[k] == EOMC_OK)) wrong++;
            if (s != EOMC_OK) continue;
            for (i = 0; i < no; i++) {
                double got = XDOT[(size_t)i * n + k], d = fabs(got - xd[i]);
                if (!(d <= 1e-11 * (1.0 + fabs(xd[i])))) wrong++;
            }
        }
    }
    printf("%s wrong=%d failed=%d\n", m->name, wrong, failed);
    free(X); free(XDOT); free(R); free(work); free(xs); free(xd); free(rs); free(status);
    return wrong != 0;
}
"""


# a torso on a fixed base and two mirror-image 3-body chains (fixed rotations mirrored: a table of
# numbers per limb); LIMB_MIN_SHAPE 3, LIMB_MIN_BODIES 6 give them limb routines
_TWIN_JOINT = ('<joint name="{n}_joint" type="revolute"><parent link="{p}"/><child link="{n}"/>'
               '<origin xyz="0.05 {y} -0.2" rpy="{r} 0.1 0"/><axis xyz="{a}"/>'
               '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')


def _twins_urdf():
    def link(n, m):
        return (f'<link name="{n}"><inertial><origin xyz="0.01 0.02 -0.1"/><mass value="{m}"/>'
                '<inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    out = ['<robot name="twins">', link("base", 4.0), link("torso", 2.0),
           '<joint name="torso_joint" type="revolute"><parent link="base"/><child link="torso"/>'
           '<origin xyz="0 0 0.2"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>']
    for side, s in (("l", 1), ("r", -1)):
        parent = "torso"
        for j, axis in enumerate(("1 0 0", "0 1 0", "0 0 1")):
            name = f"{side}{j}"
            out += [link(name, 1.0 + 0.5 * j), _TWIN_JOINT.format(n=name, p=parent, y=s * 0.1, r=s * 0.3, a=axis)]
            parent = name
    return "\n".join(out + ["</robot>"])


def _gm(kind, cache):
    if kind == "twins_rhs":        # limb routines (compiler/tree/limbs.py), in lanes too
        from eomc.compiler.tree import limbs
        from eomc.compiler.urdf.model import UrdfModel
        path = Path(cache) / "twins.urdf"
        path.write_text(_twins_urdf())
        mp = pytest.MonkeyPatch()
        mp.setattr(limbs, "LIMB_MIN_BODIES", 6)
        mp.setattr(limbs, "LIMB_MIN_SHAPE", 3)
        try:
            return generate(UrdfModel(path, limits=False), "santwin",
                            functions=("rhs", "rhs_batch"), formulation="recursive", cache_dir=cache,
                            progress=False)[1]
        finally:
            mp.undo()
    if kind == "chain_rhs":        # 5 links: the looped rhs (compiler/tree/chain_loop.py) and its looped lanes
        os.environ["EOMC_N_LINKS"] = "5"
        try:
            return generate(str(CHAIN), "sanloop", functions=("rhs", "rhs_batch"), formulation="recursive",
                            cache_dir=cache, progress=False)[1]
        finally:
            del os.environ["EOMC_N_LINKS"]
    if kind == "chain_jac_x":      # 6 links: jac_x through the analytic kernel, retyped into lanes
        os.environ["EOMC_N_LINKS"] = "6"
        try:
            return generate(str(CHAIN), "sanchain", functions=("rhs", "jac_x", "jac_x_batch"), formulation="recursive",
                            cache_dir=cache, progress=False)[1]
        finally:
            del os.environ["EOMC_N_LINKS"]
    if kind == "hopper_implicit":
        import warnings
        gymnasium = pytest.importorskip("gymnasium")
        from eomc.compiler.mjcf.model import MjcfModel
        with warnings.catch_warnings():      # the file's self-collision pairs left out (said by a warning)
            warnings.simplefilter("ignore")
            return generate(MjcfModel(Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"),
                            "sanhop", functions=("rhs", "implicit", "implicit_batch"), cache_dir=cache,
                            progress=False)[1]
    if kind == "pendulum_outputs":
        return generate(str(PENDULUM), "sanpend", functions=("rhs", "outputs", "outputs_batch"),
                        cache_dir=cache, progress=False)[1]
    if kind == "ur5_jac_x":
        from eomc.compiler.urdf.model import UrdfModel
        return generate(UrdfModel(robot_path("ur5")), "sanjur5", functions=("rhs", "jac_x", "jac_x_batch"),
                        cache_dir=cache, progress=False)[1]
    if kind == "ur5":
        from eomc.compiler.urdf.model import UrdfModel
        return generate(UrdfModel(robot_path("ur5"), limits=False), "sanur5", functions=("rhs", "rhs_batch"),
                        cache_dir=cache, progress=False)[1]
    return generate(str(CART), "sancart", functions=("rhs", "rhs_batch"), formulation="kane",
                    cache_dir=cache, progress=False)[1]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("batch_san_cache")


@pytest.mark.parametrize("lanes", [4, 8])
@pytest.mark.parametrize("kind", ["ur5", "kane_cart", "chain_rhs", "twins_rhs", "ur5_jac_x", "chain_jac_x", "pendulum_outputs",
                                  "hopper_implicit"])
def test_rhs_batch_sanitizer_clean(cache, tmp_path, kind, lanes):
    if lanes > machine_lanes():
        pytest.skip(f"this machine has {machine_lanes()} double lanes: the lanes would not run")
    if kind.endswith(("_jac_x", "_outputs", "_implicit")) and lanes != machine_lanes():
        pytest.skip(f"{kind}: the machine's own lane width only (CI time)")
    gm = _gm(kind, cache)
    fn = next((f for f in ("jac_x", "outputs", "implicit") if kind.endswith(f"_{f}")), "rhs")
    assert gm.metadata[f"{fn}_batch"]["vectorized"], gm.metadata[f"{fn}_batch"]
    if kind == "kane_cart":
        assert gm.metadata["formulation"] == "kane" and gm.metadata["ninput"] > 0
    if kind == "chain_rhs":      # the looped lanes, two groups a call (a pair, then one group alone)
        assert "sanloop_chain_sincos(x + 1, 5, SC1);" in gm.c_source and "sanloop_rhs_lanes2(t, x[g]" in gm.c_source
    if kind == "twins_rhs":      # the routines, run in lanes (a table of numbers per limb: the mirror images)
        assert "santwin_vlimb0_in(p, &x[" in gm.c_source and "santwin_limb_k" in gm.c_source
    src = es.write_sources(gm, str(tmp_path))
    nstates = 3 * lanes + 3                       # three groups of lanes and a 3-state tail
    main = tmp_path / "main.c"
    nout = {"jac_x": gm.metadata["nx"] ** 2, "outputs": gm.metadata["noutput"],
            "implicit": gm.metadata.get("implicit", {}).get("layout", {}).get("size")}.get(fn, gm.metadata["nx"])
    main.write_text(DRIVER.replace("NAME", gm.name).replace("NSTATES", str(nstates)).replace("FN", fn)
                    .replace("NOUT", str(nout)))
    exe = tmp_path / "driver"
    # -g1 (line tables): a report still names file:line in every frame; the instrumentation does
    # not depend on the debug level, and full -g's variable info for the lane vectors doubled gcc's
    # time (UR5 jac_x 12.3 -> 5.9 s CPU, the 6-link chain 11.3 -> 5.6 s)
    cmd = ["gcc", *es.STRICT, "-O1", "-g1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
           "-fno-omit-frame-pointer", f"-DEOMC_BATCH_LANES={lanes}", src, str(main), "-I", str(tmp_path),
           "-o", str(exe), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True,
                         env=dict(os.environ, ASAN_OPTIONS="detect_leaks=1"))
    assert run.returncode == 0, run.stdout + run.stderr
    assert "runtime error" not in run.stderr and "AddressSanitizer" not in run.stderr, run.stderr
    # the two bad states (one in a group of lanes, one in the tail) fail in both passes
    assert run.stdout.strip() == f"{gm.name} wrong=0 failed=4", run.stdout
