"""The recursive rhs's joint angles' sin and cos four at a time (compiler/tree/trig.py).

The text rewrite (runs of angles per function and array, the short ones and the nested lines
left alone), the helper NAME_tree_sincos against libm (within 1 ulp; libm's bits past the
lanes' reduction, for inf and NaN, and everywhere with -DEOMC_BATCH_LIBM_TRIG), and built robots:
the rhs calls the helper and gives the libm rhs's numbers to 1e-12 (its bits with
-DEOMC_BATCH_LIBM_TRIG), and G1's lanes (NAME_rhs_batch, default flags) give the scalar rhs's bits.
"""
import ctypes
import re
import subprocess

import numpy as np
import pytest

import eomc
from eomc.compiler.build.toolchain import DEFAULT_CFLAGS, find_compiler, machine_flags
from eomc.compiler.formulations.recursive import Recursive
from eomc.compiler.tree import trig
from eomc.compiler.urdf.model import UrdfModel
from helpers.robots import relative_error, robot_path


def test_rewrite_takes_runs_of_angles_per_function_and_array():
    lines = ["    double S_[4];",
             "    const double t0 = sin(x[3]);",
             "    const double t1 = cos(x[3]);",
             "    const double t2 = p[0] * t0;",
             "    const double t3 = sin(x[5]);",          # a gap of one: the same run
             "    const double t4 = cos(xq[0]);",         # another array, alone: libm's
             "    const double t5 = cos(x[9]);",          # x[9..10]: a second run
             "    const double t6 = sin(x[10]);",
             "    const double t7 = sin(x[20]);",         # alone: libm's
             "        const double t8 = sin(x[4]);",      # inside a block: left as it is
             "    xdot[0] = t0 + t1 + t3 + t4 + t5 + t6 + t7;"]
    out, parts, helper = trig.tree_trig("m", lines, [])
    assert parts == [] and "static void m_tree_sincos(" in helper and "#if EOMC_TREE_VTRIG" in helper
    assert out == ["    double S_[4];",
                   "    double SC0[6];",
                   "    m_tree_sincos(&x[3], 3, SC0);",
                   "    const double t0 = SC0[0];",
                   "    const double t1 = SC0[3];",
                   "    const double t2 = p[0] * t0;",
                   "    const double t3 = SC0[2];",
                   "    const double t4 = cos(xq[0]);",
                   "    double SC1[4];",
                   "    m_tree_sincos(&x[9], 2, SC1);",
                   "    const double t5 = SC1[2];",
                   "    const double t6 = SC1[1];",
                   "    const double t7 = sin(x[20]);",
                   "        const double t8 = sin(x[4]);",
                   "    xdot[0] = t0 + t1 + t3 + t4 + t5 + t6 + t7;"]
    part = ("static EOMC_NEAR void m_rhs_part0_0(const double *x, double *restrict S_)\n{\n"
            "    const double t0_1 = sin(x[-2]);\n    const double t1_1 = sin(x[-1]);\n    S_[0] = t0_1 + t1_1;\n}\n")
    table = "static const double m_limb_k0[2] = {1.0, -1.0};\n"
    out, parts, helper = trig.tree_trig("m", ["    return 0;"], [table, part])
    assert out == ["    return 0;"] and parts[0] == table and helper
    assert parts[1] == ("static EOMC_NEAR void m_rhs_part0_0(const double *x, double *restrict S_)\n{\n"
                        "    double SC0[4];\n    m_tree_sincos(&x[-2], 2, SC0);\n"
                        "    const double t0_1 = SC0[0];\n    const double t1_1 = SC0[1];\n    S_[0] = t0_1 + t1_1;\n}\n")
    # nothing to take: the text as it was, no helper
    assert trig.tree_trig("m", ["    const double t0 = sin(x[1]);"], [table]) == (
        ["    const double t0 = sin(x[1]);"], [table], "")


def _helper_lib(tmp_path, extra):
    tc = find_compiler()
    src = tmp_path / "h.c"
    src.write_text("#include <math.h>\n" + trig.helper_c("h") +
                   "\nvoid run(const double *q, int n, double *sc) { h_tree_sincos(q, n, sc); }\n")
    lib = tmp_path / f"libh{len(extra)}.so"
    subprocess.run([*tc.argv, *DEFAULT_CFLAGS, *machine_flags(tc), *extra, "-Wall", "-Wextra", "-Werror", "-shared",
                    "-o", str(lib), str(src), "-lm"], check=True, capture_output=True)
    f = ctypes.CDLL(str(lib)).run
    f.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.c_int, ctypes.POINTER(ctypes.c_double)]

    def call(q):
        q = np.ascontiguousarray(q, dtype=float)
        sc = np.full(2 * len(q), np.nan)
        f(q.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), len(q), sc.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
        return sc[:len(q)], sc[len(q):]
    return call


def test_helper_is_libm_within_one_ulp_and_libm_past_the_reduction(tmp_path):
    lanes = _helper_lib(tmp_path, [])
    exact = _helper_lib(tmp_path, ["-DEOMC_BATCH_LIBM_TRIG"])
    rng = np.random.default_rng(31)
    close = 0
    for n in range(1, 10):
        q = rng.uniform(-7, 7, n)
        q[n // 2] = np.pi / 2 * rng.integers(-40, 40) + 1e-12      # near a multiple of pi/2 (2nd round)
        s, c = lanes(q)
        assert np.all(np.abs(s - np.sin(q)) <= np.spacing(np.abs(np.sin(q)))), n
        assert np.all(np.abs(c - np.cos(q)) <= np.spacing(np.abs(np.cos(q)))), n
        close += int(np.array_equal(s, np.sin(q)) and np.array_equal(c, np.cos(q)))
        s, c = exact(q)                     # -DEOMC_BATCH_LIBM_TRIG: libm's bits
        assert np.array_equal(s, np.sin(q)) and np.array_equal(c, np.cos(q))
    assert close >= 1
    big = np.array([1e7, 2e6, 1e300, -np.inf, np.nan, 0.5])     # 2e6 past 2^19 pi/2: libm's lanes
    s, c = lanes(big)
    with np.errstate(invalid="ignore"):
        want_s, want_c = np.sin(big), np.cos(big)
    assert np.array_equal(s[1:5], want_s[1:5], equal_nan=True) and np.array_equal(c[1:5], want_c[1:5], equal_nan=True)
    assert abs(s[0] - want_s[0]) <= np.spacing(abs(want_s[0])) and abs(s[5] - want_s[5]) <= np.spacing(want_s[5])


def _robot(path, floating, name, tmp_path, on=True, functions=("rhs",), cflags=None):
    mp = pytest.MonkeyPatch()
    if not on:
        mp.setattr(Recursive, "scalar_text", lambda self, fn, nm, sym, lines, parts: (lines, parts))
    try:
        return eomc.compile(UrdfModel(robot_path(path), floating_base=floating, limits=False), name,
                            functions=list(functions), progress=False, formulation="recursive", cflags=cflags,
                            output_dir=tmp_path / f"{name}_{on}_{cflags is None}",
                            cache_dir=tmp_path / f"cache_{on}")
    finally:
        mp.undo()


@pytest.mark.parametrize("path,floating", [("panda", False), ("go2_description/urdf/go2.urdf", "quaternion")])
def test_robot_rhs_takes_the_helper_and_libm_bits_with_the_switch(path, floating, tmp_path):
    tc = find_compiler()
    flags = [*DEFAULT_CFLAGS, *machine_flags(tc)]
    new = _robot(path, floating, "tr", tmp_path)
    old = _robot(path, floating, "tr", tmp_path, on=False)
    libm = _robot(path, floating, "tr", tmp_path, cflags=[*flags, "-DEOMC_BATCH_LIBM_TRIG"])
    src, before = new.source_path.read_text(), old.source_path.read_text()
    libm_calls = re.compile(r"= (?:sin|cos)\(x\[-?\d+\]\);")
    assert src.count("tr_tree_sincos(&x[") == 1 and not libm_calls.search(src)     # every angle in one call
    assert "tr_tree_sincos" not in before and len(libm_calls.findall(before)) >= 10
    rng = np.random.default_rng(7)
    for _ in range(8):
        q = rng.uniform(-np.pi, np.pi, new.nq)
        if new.nq > new.nu:
            q[3:7] /= np.linalg.norm(q[3:7])
        x = np.concatenate([q, rng.normal(size=new.nu)])
        r = rng.normal(size=new.ninput) if new.ninput else None
        a, b, c = new.rhs(0.0, x, r=r), old.rhs(0.0, x, r=r), libm.rhs(0.0, x, r=r)
        assert relative_error(a, b) < 1e-12, relative_error(a, b)
        assert np.array_equal(c, b)          # the switch: libm's sin and cos, the old rhs's bits


def test_g1_lanes_give_the_scalar_rhs_bits(tmp_path):
    """G1's lanes take VECTOR_TRIG's kernels, the scalar rhs now too: bit for bit with the default
    flags (before: within 1e-12, tests/compiler/tree/test_limbs.py)."""
    from eomc.compiler.build.builder import machine_lanes
    if machine_lanes() < 4:
        pytest.skip(f"this machine has {machine_lanes()} double lanes")
    m = _robot("g1_description/urdf/g1_29dof_rev_1_0.urdf", True, "g1t", tmp_path, functions=("rhs", "rhs_batch"))
    assert m.metadata["rhs_batch"]["vectorized"] is True and "g1t_tree_sincos(&xq[" in m.source_path.read_text()
    rng = np.random.default_rng(3)
    n = 4 * 5 + 3
    X = np.array([np.concatenate([rng.uniform(-np.pi, np.pi, m.nq), rng.normal(size=m.nu)]) for _ in range(n)])
    X[2, 9] = 5e5            # below 2^19 pi/2: the kernels in both
    X[5, 10] = 3e6           # past it: libm's in both
    R = rng.normal(size=(n, m.ninput))
    got = m.rhs_batch(0.1, X, r=R)
    want = np.array([m.rhs(0.1, x, r=R[k]) for k, x in enumerate(X)])
    assert np.array_equal(got, want), relative_error(got, want)
