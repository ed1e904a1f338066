"""The rhs of a repeated chain as loops over per-link arrays (compiler/tree/chain_loop.py).

The looped rhs against the straight-line one (the same model built with the loop off) at
random states to 1e-13, against an independent algorithm (eomc's CRBA mass matrix and RNEA
forcing, M u' = f) and against SymPy's Kane (KanesMethod of the hand-built cart, compiled
by the Kane formulation); trees without a repeated run keep the straight-line rhs; the
looped C is clean under -Wall -Wextra -Wshadow -Wconversion and under ASan/UBSan.
"""
from pathlib import Path

import numpy as np
import pytest

import eomc
import eomc.mechanics as em
from eomc.compiler.driver import generate
from eomc.compiler.tree import chain_loop
from helpers import emit_support as es
from helpers.robots import relative_error
from helpers.trees import cart_joints, cart_relative

PARAMETERS = {"m0": 2.0, "m": 0.5, "l": 0.75, "g": 9.81}


def _looped(model):
    """Does NAME_rhs run loops over the chain?"""
    text = model.source_path.read_text()
    start = text.index(f"int {model.name}_rhs(")
    return "for (k = 0; k < " in text[start:text.index("\n}\n", start)]


def _build(system, name, min_links, tmp_path, functions=("rhs",), **kw):
    """``system`` compiled by the recursive formulation with CHAIN_LOOP_MIN_LINKS = min_links."""
    mp = pytest.MonkeyPatch()
    mp.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", min_links)
    try:
        return eomc.compile(system, name, functions=list(functions), formulation="recursive", progress=False,
                            cache_dir=tmp_path / "cache", **kw)
    finally:
        mp.undo()


def _states(model, rng, count=5):
    for _ in range(count):
        x = np.concatenate([rng.uniform(-np.pi, np.pi, model.nq), rng.normal(size=model.nu)])
        yield x


def _cart(n):
    import sympy as sm
    system, inputs = cart_joints(n)
    names = {s.name: s for s in sm.symbols("m0 m l g", positive=True)}
    return system, inputs, {names[k]: v for k, v in PARAMETERS.items()}


@pytest.mark.parametrize("n", [3, 10, 40])
def test_loop_equals_straight_line_and_crba(n, tmp_path):
    """The looped rhs equals the straight-line one to 1e-13 and solves M u' = f (CRBA, RNEA).
    (At n = 3 the repeated run is links 2 and 3: link 1 hangs from the cart's centre.)"""
    system, inputs, params = _cart(n)
    loop = _build(system, f"cl_loop{n}", 2, tmp_path, ("rhs", "mass_matrix", "forcing"), inputs=inputs,
                  parameters=params)
    line = _build(cart_joints(n)[0], f"cl_line{n}", None, tmp_path, inputs=inputs, parameters=params)
    assert _looped(loop) and not _looped(line)
    ops = [sum(m.metadata["op_counts"]["rhs"].values()) for m in (loop, line)]
    if n >= 10:     # a looped link does what a straight-line one does: dead carried values are
        assert ops[0] <= 1.01 * ops[1], ops     # pruned (without: 1.18 times as many on n = 40)
    rng = np.random.default_rng(n)
    for x in _states(loop, rng):
        r = rng.normal(size=1)
        a, b = loop.rhs(0.0, x, r=r), line.rhs(0.0, x, r=r)
        assert relative_error(a, b) < 1e-13
        ud = a[loop.nq:]
        assert relative_error(loop.mass_matrix(0.0, x, r=r) @ ud, loop.forcing(0.0, x, r=r)) < 1e-10


@pytest.mark.parametrize("n", [3, 10])
def test_loop_against_kane(n, tmp_path):
    """SymPy's KanesMethod of the hand-built relative cart (compiled by the Kane formulation)
    against the looped rhs of the same KanesMethod read as a tree (its links repeat too)."""
    kane, inputs = cart_relative(n, em)
    mk = eomc.compile(kane, f"clk{n}", inputs=inputs, functions=["rhs"], progress=False, formulation="kane",
                      cache_dir=tmp_path / "cache")
    mr = _build(kane, f"clr{n}", 2, tmp_path, inputs=inputs)
    assert _looped(mr)
    rng = np.random.default_rng(100 + n)
    p = np.array(mk.param_defaults) * rng.uniform(0.5, 1.5, len(mk.param_defaults))
    for x in _states(mr, rng):
        r = rng.normal(size=1)
        assert relative_error(mr.rhs(0.0, x, p, r), mk.rhs(0.0, x, p, r)) < 1e-11


def test_non_repeating_trees_keep_straight_line(tmp_path):
    """Links with their own inertia symbols do not repeat: no loop even at CHAIN_LOOP_MIN_LINKS
    = 2, and the C of that build is the same as with the switch off; a cart shorter than the
    switch's count keeps the straight-line rhs."""
    system, _ = cart_joints(4, rigid=True)
    rigid = _build(system, "cl_rigid", 2, tmp_path)
    assert not _looped(rigid)
    short = _build(cart_joints(3)[0], "cl_short", 4, tmp_path)
    assert not _looped(short)
    off = _build(cart_joints(4, rigid=True)[0], "cl_rigid", None, tmp_path / "off")
    assert off.source_path.read_text() == rigid.source_path.read_text()


def test_run_in_the_middle(tmp_path):
    """A different tip after the repeated links: cart, link 1, the loop, the tip (a block)."""
    n = 6
    system, inputs = cart_joints(n, tip=True)
    loop = _build(system, "cl_tip", 3, tmp_path, inputs=inputs)
    line = _build(cart_joints(n, tip=True)[0], "cl_tip", None, tmp_path / "off", inputs=inputs)
    assert f"for (k = 0; k < {n - 1}; k++)" in loop.source_path.read_text() and not _looped(line)
    rng = np.random.default_rng(5)
    p = rng.uniform(0.5, 1.5, loop.nparam)
    for x in _states(loop, rng):
        r = rng.normal(size=1)
        assert relative_error(loop.rhs(0.0, x, p, r), line.rhs(0.0, x, p, r)) < 1e-13


def test_on_by_default_from_four_links(tmp_path):
    """The switch is 4 links by default (measured faster than the straight-line rhs from there:
    benchmarks/results/cart_scaling.md, session 21): a long cart's rhs is looped, with its
    links' sin and cos from NAME_chain_sincos; a run of 3 (the cart of 4) keeps the straight line."""
    assert chain_loop.CHAIN_LOOP_MIN_LINKS == chain_loop.CHAIN_LOOP_MIN_LINKS_DEFAULT == 4
    kw = dict(functions=["rhs"], formulation="recursive", progress=False, cache_dir=tmp_path / "cache",
              fold_parameters=True)
    model = eomc.compile(cart_joints(30)[0], "cl_default", parameters=_cart(30)[2], **kw)
    assert _looped(model) and "cl_default_chain_sincos(x + 2, 29, SC2);" in model.source_path.read_text()
    assert not _looped(eomc.compile(cart_joints(4)[0], "cl_default4", parameters=_cart(4)[2], **kw))
    assert _looped(eomc.compile(cart_joints(5)[0], "cl_default5", parameters=_cart(5)[2], **kw))



CHAIN = Path(__file__).resolve().parents[3] / "benchmarks" / "tree_models" / "cart_rel_joints.py"


def _batch_case(case):
    """(system, extra compile options) of a chain whose rhs is looped: the bench's cart (link 1
    hangs from the cart's centre like the rest: n = 4 is a run of 4, every angle a looped
    link's), the tests' cart (link 1 a block of its own: its sin and cos libm's in the scalar
    rhs) and the twisting 3D chain from the root (6 links)."""
    import runpy
    if case.startswith("bench"):
        mp = pytest.MonkeyPatch()
        mp.setenv("EOMC_N_LINKS", case[len("bench"):])
        try:
            mod = runpy.run_path(str(CHAIN))
        finally:
            mp.undo()
        return mod["system"], dict(inputs=mod["inputs"], parameters=mod["parameters"])
    if case.startswith("cart"):
        system, inputs, params = _cart(int(case[len("cart"):]))
        return system, dict(inputs=inputs, parameters=params)
    system, params = _twisted_chain(int(case[len("twist"):]))
    return system, dict(parameters=params, fold_parameters=True)


def _scalar_rhs_c(source, name):
    """NAME_rhs's definition and the NAME_chain_sincos helper's in a C file."""
    start = source.index(f"\nint {name}_rhs(")
    helper = source.index(f"static void {name}_chain_sincos(")
    return source[helper:source.index("\n}\n", helper)] + source[start:source.index("\n}\n", start)]


@pytest.mark.parametrize("lanes", [4, 8])
@pytest.mark.parametrize("case", ["bench4", "cart5", "cart20", "twist6"])
def test_looped_rhs_batch_equals_the_looped_rhs_per_lane(case, lanes, tmp_path):
    """rhs_batch beside a looped rhs (issue 31: the batch against the scalar rhs users get, which
    is looped from a run of 4 links): the build's scalar rhs is the looped one, the same C as a
    build without rhs_batch; its lanes run the same passes (vectorized, two groups of lanes per
    NAME_rhs_lanes2 call) and each lane is the looped rhs bit for bit -- with
    -DEOMC_BATCH_LIBM_TRIG (libm's sin and cos in the straight-line blocks' lanes, as the scalar
    rhs), and with the default trig where every angle is a looped link's (the bench's cart: the
    links' sin and cos are NAME_chain_sincos's kernels on both sides); where a block's angle is
    not (link 1 of the tests' cart, the twisting chain's root) the lanes' sin and cos are within
    1 ulp of libm's (tests/compiler/emit/test_batch.py) and the rhs within 1e-12.  States: whole
    tiles, an odd count of groups (one group alone) and a scalar tail; parameters shared and one
    row per state (NAME_rhs_batch_p)."""
    import cffi
    from eomc.compiler.build.builder import machine_lanes
    from eomc.compiler.build.toolchain import find_compiler, machine_flags
    from eomc.compiler.driver import compile as compile_model
    if lanes > machine_lanes():
        pytest.skip(f"this machine has {machine_lanes()} double lanes")
    system, kw = _batch_case(case)
    kw.update(formulation="recursive", progress=False, cache_dir=tmp_path / "cache")
    alone = generate(_batch_case(case)[0], "clb", functions=("rhs",), **kw)[1]
    flags = f"-O2 -std=c99 -fPIC -Wall -Wextra -Werror {' '.join(machine_flags(find_compiler()))} -DEOMC_BATCH_LANES={lanes}"
    exact = compile_model(system, "clb", functions=["rhs", "rhs_batch"], cflags=f"{flags} -DEOMC_BATCH_LIBM_TRIG", **kw)
    fast = compile_model(_batch_case(case)[0], "clb", functions=["rhs", "rhs_batch"], cflags=flags,
                         **{**kw, "cache_dir": tmp_path / "cache2"})
    source = exact.source_path.read_text()
    assert _looped(exact) and _scalar_rhs_c(source, "clb") == _scalar_rhs_c(alone.c_source, "clb")
    assert exact.metadata["rhs_batch"]["vectorized"] is True and "clb_rhs_lanes2(t, x[g], x[g + 1]" in source
    rng = np.random.default_rng(lanes)
    n = 11 * lanes + 3
    X = np.concatenate([rng.uniform(-np.pi, np.pi, (n, exact.nq)), rng.normal(size=(n, exact.nu))], axis=1)
    X[5, exact.nq - 1] = 1e7          # a link's angle past the lanes' reduction: libm's in that lane
    R = rng.normal(size=(n, exact.ninput)) if exact.ninput else None
    for model in (exact, fast):
        got = model.rhs_batch(0.3, X, r=R)
        want = np.array([model.rhs(0.3, x, r=None if R is None else R[k]) for k, x in enumerate(X)])
        if model is exact or case.startswith("bench"):
            assert np.array_equal(got, want), (case, relative_error(got, want))
        else:
            assert not np.array_equal(got, want) and relative_error(got, want) < 1e-12
    if exact.nparam:      # one parameter row per state
        ffi = cffi.FFI()
        ffi.cdef("int clb_rhs_batch_p(int n, double t, const double *X, const double *P, const double *R, "
                 "double *XDOT, int *status, double *work);")
        lib = ffi.dlopen(str(exact.library_path))
        P = np.array(exact.param_defaults) * rng.uniform(0.8, 1.2, (n, exact.nparam))
        XT, PT = np.ascontiguousarray(X.T), np.ascontiguousarray(P.T)
        RT = np.ascontiguousarray(R.T) if R is not None else None
        out, status = np.zeros_like(XT), np.zeros(n, dtype=np.intc)
        work = np.zeros(max(exact.metadata.get("work_size", 0), 1) + 1)
        ret = lib.clb_rhs_batch_p(n, 0.3, ffi.from_buffer("double[]", XT), ffi.from_buffer("double[]", PT),
                                  ffi.NULL if RT is None else ffi.from_buffer("double[]", RT),
                                  ffi.from_buffer("double[]", out), ffi.from_buffer("int[]", status),
                                  ffi.from_buffer("double[]", work))
        assert ret == 0 and not status.any()
        want = np.array([exact.rhs(0.3, x, P[k], r=None if R is None else R[k]) for k, x in enumerate(X)])
        assert np.array_equal(out.T, want)


DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "NAME.h"

int main(void)
{
    const eomc_model *m = NAME_model();
    size_t nx = (size_t)m->nx, i;
    double *x = malloc(nx * sizeof(double)), *xd = malloc(nx * sizeof(double));
    double *work = malloc((m->work_size + 1) * sizeof(double)), r[1] = {0.3}, sum = 0.0;
    int k, bad = 0;
    for (k = 0; k < 20; k++) {
        for (i = 0; i < nx; i++) x[i] = 0.37 * (double)((i * 7 + (size_t)k * 3) % 11) - 1.8;
        if (m->rhs(0.1, x, m->param_defaults, r, xd, work) != EOMC_OK) bad++;
        for (i = 0; i < nx; i++) sum += xd[i];
    }
    printf("%s %d %g\n", m->name, bad, sum);
    free(x); free(xd); free(work);
    return bad;
}
"""


def test_looped_c_strict_and_sanitizer_clean(tmp_path, monkeypatch):
    """-Wall -Wextra -Wshadow -Wconversion -pedantic -Werror, then ASan and UBSan on 20 calls."""
    monkeypatch.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", 2)
    system, inputs, params = _cart(6)
    gm = generate(system, "clsan", functions=("rhs",), formulation="recursive", inputs=inputs,
                  parameters=params, cache_dir=tmp_path / "cache", progress=False)[1]
    assert "for (k = 0; k < 5; k++)" in gm.c_source
    proc, run = es.sanitized_run(gm, tmp_path, DRIVER, flags=("-Wshadow", "-Wconversion"))
    assert proc.returncode == 0, proc.stderr
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.startswith("clsan 0 ") and "runtime error" not in run.stderr


SINCOS_DRIVER = r"""
#include <stdio.h>
#include <math.h>
#include "NAME.c"

static int ulps(double a, double b)   /* 0 equal (NaN both), 1 neighbours, 2 farther */
{
    if (a != a || b != b) return (a != a && b != b) ? 0 : 2;
    if (a == b) return 0;
    return nextafter(a, b) == b ? 1 : 2;
}

int main(void)
{
    const double q[11] = {0.0, 1.5707963267948966, 1.5707963267948966 + 1e-12, -3.141592653589793,
                          1e-300, -2.5, 823549.0, 1e7, -3e300, NAN, INFINITY};
    double sc[22];
    int n, k, far = 0, off = 0;
    for (n = 1; n <= 11; n++) {
        for (k = 0; k < 2 * n; k++) sc[k] = -7.0;
        NAME_chain_sincos(q, n, sc);
        for (k = 0; k < n; k++) {
            int a = ulps(sc[2 * k], sin(q[k])), b = ulps(sc[2 * k + 1], cos(q[k]));
            far += (a > 1) + (b > 1);
            off += (a > 0) + (b > 0);
        }
    }
    printf("%d %d %d\n", EOMC_CHAIN_VTRIG, far, off);
    return 0;
}
"""


@pytest.mark.parametrize("lanes", [True, False])
def test_chain_sincos_within_one_ulp_of_libm(lanes, tmp_path, monkeypatch):
    """NAME_chain_sincos (the links' sin and cos, four lanes at a time where the C is built for
    AVX2, the last group overlapping) against libm for 1..11 angles: multiples of pi/2 and
    next to them, tiny, huge (libm's lanes), NaN and inf; within 1 ulp, exact without lanes."""
    import subprocess
    monkeypatch.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", 2)
    system, inputs, params = _cart(6)
    gm = generate(system, "clsc", functions=("rhs",), formulation="recursive", inputs=inputs,
                  parameters=params, cache_dir=tmp_path / "cache", progress=False)[1]
    assert "clsc_chain_sincos(x + 2, 5, SC2);" in gm.c_source     # links 2-6 (link 1 hangs from the cart's centre)
    es.write_sources(gm, str(tmp_path))
    (tmp_path / "main.c").write_text(SINCOS_DRIVER.replace("NAME", gm.name))
    flags = ["-mavx2"] if lanes else ["-mno-avx"]
    built = subprocess.run(["gcc", *es.STRICT, "-Wshadow", "-Wconversion", "-O2", *flags, "-I", str(tmp_path),
                            str(tmp_path / "main.c"), "-o", str(tmp_path / "sc"), "-lm"], capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    vtrig, far, off = map(int, subprocess.run([str(tmp_path / "sc")], capture_output=True, text=True).stdout.split())
    assert vtrig == int(lanes) and far == 0
    if not lanes:
        assert off == 0


@pytest.mark.parametrize("n", [3, 5, 9])
def test_lanes_trig_agrees_at_awkward_angles(n, tmp_path):
    """The looped rhs (its links' sin and cos in lanes; n = 3: two links, the scalar path) equals
    the straight-line rhs to 1e-12 at angles next to multiples of pi/2 and past 2^19 pi/2."""
    system, inputs, params = _cart(n)
    loop = _build(system, f"claw{n}", 2, tmp_path, inputs=inputs, parameters=params)
    line = _build(cart_joints(n)[0], f"clawl{n}", None, tmp_path, inputs=inputs, parameters=params)
    assert _looped(loop) and f"_chain_sincos(x + 2, {n - 1}, SC" in loop.source_path.read_text()
    rng = np.random.default_rng(7 + n)
    for scale in (1.0, 1e-9, 1e6, 1e7):
        q = rng.integers(-4, 5, n + 1) * np.pi / 2 + scale * rng.uniform(-1, 1, n + 1)
        x = np.concatenate([q, rng.normal(size=n + 1)])
        r = rng.normal(size=1)
        assert relative_error(loop.rhs(0.0, x, r=r), line.rhs(0.0, x, r=r)) < 1e-12, scale


def test_float_target_of_a_looped_rhs(tmp_path, monkeypatch):
    """The c99-f32 target cuts the lanes' block (double vectors) out: libm's sinf and cosf per
    link, the C clean under the float target's strict flags with no double left."""
    import re
    import subprocess
    monkeypatch.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", 2)
    system, inputs, params = _cart(6)
    gm = generate(system, "clf", functions=("rhs",), formulation="recursive", inputs=inputs, parameters=params,
                  cache_dir=tmp_path / "cache", progress=False, target="c99-f32")[1]
    code = re.sub(r"/\*.*?\*/", "", gm.c_source, flags=re.S)
    assert "clf_chain_sincos(x + 2, 5, SC2);" in code and "sinf(q[k])" in code
    assert "eomc_cvd" not in code and not re.search(r"\bdouble\b", code.replace("clf_", ""))
    es.write_sources(gm, str(tmp_path))
    run = subprocess.run(["gcc", "-std=c99", "-O2", "-mavx2", "-Wall", "-Wextra", "-Wdouble-promotion",
                          "-Wfloat-conversion", "-Wpedantic", "-Werror", "-c", str(tmp_path / "clf.c"), "-I", str(tmp_path),
                          "-o", str(tmp_path / "clf.o")], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[:3000]


def _twisted_chain(n):
    """n identical links hanging from the ground, each a pin about a tilted axis (the chain
    twists in 3D: every carried entry nonzero), full inertia, the joint off the mass centre."""
    import sympy as sm
    from sympy.physics import mechanics as me
    q, u = me.dynamicsymbols(f"q:{n}"), me.dynamicsymbols(f"u:{n}")
    g = sm.Symbol("g")
    ground = me.RigidBody("ground")
    parent, joints = ground, []
    for i in range(n):
        link = me.RigidBody(f"link{i}", mass=sm.Float(0.5))
        link.inertia = (me.inertia(link.frame, 0.01, 0.02, 0.03, 0.001, 0.002, 0.003), link.masscenter)
        joints.append(me.PinJoint(f"pin{i}", parent, link, q[i], u[i], child_point=-0.1 * link.frame.y,
                                  parent_point=0.2 * parent.frame.z + 0.1 * parent.frame.x,
                                  joint_axis=parent.frame.x + 0.5 * parent.frame.y + 0.3 * parent.frame.z))
        parent = link
    system = me.System.from_newtonian(ground)
    system.add_joints(*joints)
    system.apply_uniform_gravity(-g * ground.frame.z)
    return system, {g: 9.81}


@pytest.mark.parametrize("n", [4, 9])
def test_twisted_chain_from_the_root(n, tmp_path):
    """A run of identical links from the root on: the root is a block of its own (its passes
    start from rest and gravity), the rest a loop; equal to the straight-line rhs to 1e-12.
    (Looping the root with the others gave u' wrong by 100 %.)"""
    system, params = _twisted_chain(n)
    loop = _build(system, f"cltw{n}", 2, tmp_path, parameters=params, fold_parameters=True)
    line = _build(_twisted_chain(n)[0], f"cltwl{n}", None, tmp_path, parameters=params, fold_parameters=True)
    assert _looped(loop) and f"_chain_sincos(x + 1, {n - 1}, SC1);" in loop.source_path.read_text()
    rng = np.random.default_rng(n)
    for x in _states(loop, rng):
        assert relative_error(loop.rhs(0.0, x), line.rhs(0.0, x)) < 1e-12


def test_default_functions_beside_a_looped_rhs(tmp_path):
    """The default function set of a cart whose rhs is looped (by default): jac_x and jac_r (their
    own tangent programs) agree with the straight-line build's and with central differences of
    the looped rhs; linearize builds."""
    n = 8
    system, inputs, params = _cart(n)
    loop = eomc.compile(system, "cl_all", cache_dir=tmp_path / "cache", inputs=inputs, parameters=params,
                        formulation="recursive", progress=False)
    line = _build(cart_joints(n)[0], "cl_all", None, tmp_path / "off", functions=("rhs", "jac_x", "jac_r"),
                  inputs=inputs, parameters=params)
    assert _looped(loop) and not _looped(line) and {"jac_x", "jac_r", "linearize"} <= set(loop.metadata["functions"])
    rng = np.random.default_rng(11)
    for x in _states(loop, rng, 3):
        r = rng.normal(size=1)
        J = loop.jacobian(0.0, x, r=r)
        assert relative_error(J, line.jacobian(0.0, x, r=r)) < 1e-12
        assert relative_error(loop.input_jacobian(0.0, x, r=r), line.input_jacobian(0.0, x, r=r)) < 1e-12
        h = 1e-6
        fd = np.column_stack([(loop.rhs(0.0, x + h * e, r=r) - loop.rhs(0.0, x - h * e, r=r)) / (2 * h)
                              for e in np.eye(loop.nx)])
        assert relative_error(J, fd) < 1e-6
