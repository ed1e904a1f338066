"""The rhs with one routine pair per limb shape (compiler/tree/limbs.py) against the straight-line rhs.

Random URDF trees with twin limbs (a base, fixed or floating, with two mirror-image chains:
offsets and fixed rotations mirrored, so the twins differ in their parameters' values and in
their fixed rotations' numbers, which the routines read from a table per limb) and
example-robot-data's G1 (Euler angles and quaternion, limits on and off, with motor torques),
each built with the routines and with them switched off (LIMB_MIN_BODIES = None), at random
states to 1e-12; a tree without twins keeps the straight-line rhs byte for byte.  With rhs_batch
the routines stay and run in lanes too (G1 bit for bit with libm's sin and cos in the lanes, random
twin trees to 1e-12).
"""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import eomc
from eomc.compiler.tree import limbs
from eomc.compiler.urdf.model import UrdfModel
from helpers.robots import relative_error, robot_path


def _routines(model):
    return f"{model.name}_limb0_in(" in model.source_path.read_text()


def _build(path, name, tmp_path, on, floating, limits=False, functions=("rhs",), shape=None):
    mp = pytest.MonkeyPatch()
    if not on:
        mp.setattr(limbs, "LIMB_MIN_BODIES", None)
    elif shape is not None:      # small random trees: their limbs are short
        mp.setattr(limbs, "LIMB_MIN_BODIES", 2 * shape)
        mp.setattr(limbs, "LIMB_MIN_SHAPE", shape)
    try:
        return eomc.compile(UrdfModel(path, floating_base=floating, limits=limits), name, functions=list(functions),
                            progress=False, formulation="recursive", output_dir=tmp_path / name,
                            cache_dir=tmp_path / ("cache_on" if on else "cache_off"))
    finally:
        mp.undo()


def _states(model, rng, count=6):
    for _ in range(count):
        q = rng.uniform(-np.pi, np.pi, model.nq)
        if model.nq > model.nu:         # a quaternion base: position, then (w, x, y, z)
            q[3:7] /= np.linalg.norm(q[3:7])
        yield np.concatenate([q, rng.normal(size=model.nu)])


def _agree(on, off, seed):
    rng = np.random.default_rng(seed)
    for x in _states(on, rng):
        r = rng.normal(size=on.ninput) if on.ninput else None
        a, b = on.rhs(0.0, x, r=r), off.rhs(0.0, x, r=r)
        assert relative_error(a, b) < 1e-12, relative_error(a, b)


_AXES = ("1 0 0", "0 1 0", "0 0 1")


@st.composite
def twin_tree(draw):
    """(URDF text, limb length): a base, a torso on it with a stub and two mirror-image chains of
    revolute joints (the torso: a fixed base's limbs hang from a body, not from the ground)."""
    k = draw(st.integers(2, 4))
    num = st.floats(-0.3, 0.3, allow_nan=False).map(lambda v: round(v, 3))
    links = [{"axis": draw(st.sampled_from(_AXES)), "xyz": [draw(num) for _ in range(3)],
              "rpy": [draw(num) if draw(st.booleans()) else 0.0 for _ in range(3)],
              "mass": draw(st.floats(0.2, 3.0).map(lambda v: round(v, 3))),
              "com": [draw(num) for _ in range(3)],
              "inertia": draw(st.floats(0.01, 0.1).map(lambda v: [round(v, 4), round(1.2 * v, 4), round(1.4 * v, 4)]))}
             for _ in range(k)]
    out = ['<robot name="twins">', _link("base", 4.0, [0, 0, 0.05], [0.2, 0.3, 0.25]),
           _link("torso", 2.0, [0, 0, 0.1], [0.1, 0.1, 0.05]), _link("stub", 0.5, [0, 0, 0.1], [0.02, 0.02, 0.01]),
           '<joint name="torso_joint" type="revolute"><parent link="base"/><child link="torso"/>'
           '<origin xyz="0 0 0.2"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>',
           '<joint name="stub_joint" type="revolute"><parent link="torso"/><child link="stub"/>'
           '<origin xyz="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>']
    for side, s in (("left", 1), ("right", -1)):
        parent = "torso"
        for j, ln in enumerate(links):
            name = f"{side}_{j}"
            x, y, z = ln["xyz"]
            roll, pitch, yaw = ln["rpy"]
            cx, cy, cz = ln["com"]
            out.append(_link(name, ln["mass"], [cx, s * cy, cz], ln["inertia"]))
            out.append(f'<joint name="{name}_joint" type="revolute"><parent link="{parent}"/><child link="{name}"/>'
                       f'<origin xyz="{x} {s * y + s * 0.1 * (j == 0)} {z}" rpy="{s * roll} {pitch} {s * yaw}"/>'
                       f'<axis xyz="{ln["axis"]}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
            parent = name
    out.append("</robot>")
    return "\n".join(out), k


def _link(name, mass, com, inertia):
    return (f'<link name="{name}"><inertial><origin xyz="{com[0]} {com[1]} {com[2]}"/><mass value="{mass}"/>'
            f'<inertia ixx="{inertia[0]}" iyy="{inertia[1]}" izz="{inertia[2]}" ixy="0" ixz="0" iyz="0"/>'
            '</inertial></link>')


@settings(max_examples=5, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(spec=twin_tree(), floating=st.sampled_from([False, True, "quaternion"]), seed=st.integers(0, 2**32 - 1))
def test_random_twin_limbs_equal_the_straight_line_rhs(spec, floating, seed, tmp_path):
    text, k = spec
    path = tmp_path / "twins.urdf"
    path.write_text(text)
    on = _build(path, "twins_on", tmp_path, True, floating, shape=k)
    off = _build(path, "twins_off", tmp_path, False, floating)
    assert _routines(on) and not _routines(off)
    _agree(on, off, seed)


@pytest.mark.parametrize("floating,limits", [("quaternion", False), (True, False), ("quaternion", True)])
def test_g1_limb_routines_equal_the_straight_line_rhs(floating, limits, tmp_path):
    """G1's legs and arms (two shapes, mirror images: the arms' fixed rotations from a table);
    limits on: the joints' laws are loads of the limbs' bodies too."""
    path = robot_path("g1_description/urdf/g1_29dof_rev_1_0.urdf")
    on = _build(path, "g1_on", tmp_path, True, floating, limits)
    off = _build(path, "g1_off", tmp_path, False, floating, limits)
    assert _routines(on) and not _routines(off)
    assert f"{on.name}_limb1_in(" in on.source_path.read_text()
    _agree(on, off, 19)


def test_trees_without_long_twins_keep_the_straight_line_rhs(tmp_path):
    """Go2's legs (3 bodies, below LIMB_MIN_SHAPE): the C is the one with the routines off."""
    path = robot_path("go2_description/urdf/go2.urdf")
    on = _build(path, "go2", tmp_path, True, "quaternion")
    text = on.source_path.read_text()
    off = _build(path, "go2", tmp_path, False, "quaternion")
    assert not _routines(off) and text == off.source_path.read_text()


def _scalar_rhs_c(source, name):
    """NAME_rhs's C with the limb routines and sub-functions it calls (everything before NAME_rhs's
    end from the first limb table or routine on), for comparing two builds."""
    start = min(i for i in (source.find(f"static const double {name}_limb_k"), source.find("static EOMC_NEAR void"))
                if i >= 0)
    end = source.index("\n}\n", source.index(f"\nint {name}_rhs("))
    return source[start:end]


@pytest.mark.parametrize("floating,limits,lanes", [(True, False, 4), (True, False, 8), ("quaternion", True, 4)])
def test_rhs_batch_runs_the_limb_routines_in_lanes(floating, limits, lanes, tmp_path):
    """With rhs_batch asked for, G1 keeps its limb routines (the scalar rhs is the C of a build
    without rhs_batch), and the lanes run them too (NAME_vlimb*: each routine and its parts
    rewritten into lanes, compiler/emit/batch.py): vectorized, and each lane is the scalar rhs bit
    for bit with -DEOMC_BATCH_LIBM_TRIG (libm's sin and cos in the lanes, as the scalar rhs), within
    1e-12 with the lanes' own kernels (within 1 ulp of libm's: tests/compiler/emit/test_batch.py).
    States: whole tiles, a lone group and a scalar tail, inputs per state; parameters shared and one
    row per state (NAME_rhs_batch_p).  Until session 23 a build with rhs_batch wrote no limb
    routines: its lanes were the straight-line rhs (G1 2.67-3.26x the scalar rhs, bench_rhs_batch)."""
    import cffi
    from eomc.compiler.build.builder import machine_lanes
    from eomc.compiler.build.toolchain import find_compiler, machine_flags
    from eomc.compiler.driver import generate
    if lanes > machine_lanes():
        pytest.skip(f"this machine has {machine_lanes()} double lanes")
    path = robot_path("g1_description/urdf/g1_29dof_rev_1_0.urdf")

    def model():
        return UrdfModel(path, floating_base=floating, limits=limits)
    kw = dict(formulation="recursive", progress=False)
    alone = generate(model(), "g1l", functions=("rhs",), cache_dir=tmp_path / "c0", **kw)[1]
    flags = f"-O2 -std=c99 -fPIC -Wall -Wextra -Werror {' '.join(machine_flags(find_compiler()))} -DEOMC_BATCH_LANES={lanes}"
    exact = eomc.compile(model(), "g1l", functions=["rhs", "rhs_batch"], cflags=f"{flags} -DEOMC_BATCH_LIBM_TRIG",
                         output_dir=tmp_path / "exact", cache_dir=tmp_path / "c1", **kw)
    fast = eomc.compile(model(), "g1l", functions=["rhs", "rhs_batch"], cflags=flags, output_dir=tmp_path / "fast",
                        cache_dir=tmp_path / "c2", **kw)
    source = exact.source_path.read_text()
    assert _routines(exact) and _scalar_rhs_c(source, "g1l") == _scalar_rhs_c(alone.c_source, "g1l")
    assert exact.metadata["rhs_batch"]["vectorized"] is True
    assert "g1l_vlimb0_in(p, &x[" in source and "g1l_vlimb1_out(p, &x[" in source
    rng = np.random.default_rng(lanes)
    n = 7 * lanes + 3
    X = np.array(list(_states(exact, rng, n)))
    X[4, 8] = 1e7          # a limb's angle past the lanes' reduction: libm's in that lane
    R = rng.normal(size=(n, exact.ninput))
    for m in (exact, fast):
        got = m.rhs_batch(0.3, X, r=R)
        want = np.array([m.rhs(0.3, x, r=R[k]) for k, x in enumerate(X)])
        if m is exact:
            assert np.array_equal(got, want), relative_error(got, want)
        else:
            assert relative_error(got, want) < 1e-12, relative_error(got, want)
    ffi = cffi.FFI()
    ffi.cdef("int g1l_rhs_batch_p(int n, double t, const double *X, const double *P, const double *R, "
             "double *XDOT, int *status, double *work);")
    lib = ffi.dlopen(str(exact.library_path))
    P = np.array(exact.param_defaults) * rng.uniform(0.8, 1.2, (n, exact.nparam))
    XT, PT, RT = (np.ascontiguousarray(a.T) for a in (X, P, R))
    out, status = np.zeros_like(XT), np.zeros(n, dtype=np.intc)
    work = np.zeros(max(exact.metadata.get("work_size", 0), 1) + 1)
    ret = lib.g1l_rhs_batch_p(n, 0.3, ffi.from_buffer("double[]", XT), ffi.from_buffer("double[]", PT),
                              ffi.from_buffer("double[]", RT), ffi.from_buffer("double[]", out),
                              ffi.from_buffer("int[]", status), ffi.from_buffer("double[]", work))
    assert ret == 0 and not status.any()
    want = np.array([exact.rhs(0.3, x, P[k], r=R[k]) for k, x in enumerate(X)])
    assert np.array_equal(out.T, want)


@settings(max_examples=4, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(spec=twin_tree(), floating=st.sampled_from([False, True, "quaternion"]), seed=st.integers(0, 2**32 - 1))
def test_random_twin_limbs_in_lanes_equal_the_scalar_rhs(spec, floating, seed, tmp_path):
    """Random twin limbs (mirror images: a table of numbers per limb, parameters shared with the
    parent read where they are) with rhs_batch: the routines in lanes, within 1e-12 of the scalar
    rhs (which runs the routines too) over groups of lanes and a tail."""
    text, k = spec
    path = tmp_path / "twins.urdf"
    path.write_text(text)
    on = _build(path, "twins_lanes", tmp_path, True, floating, shape=k, functions=("rhs", "rhs_batch"))
    assert _routines(on) and f"{on.name}_vlimb0_in(" in on.source_path.read_text()
    assert on.metadata["rhs_batch"]["vectorized"] is True
    rng = np.random.default_rng(seed)
    X = np.array(list(_states(on, rng, 19)))
    R = rng.normal(size=(len(X), on.ninput)) if on.ninput else None
    want = np.array([on.rhs(0.0, x, r=None if R is None else R[j]) for j, x in enumerate(X)])
    assert relative_error(on.rhs_batch(0.0, X, r=R), want) < 1e-12
