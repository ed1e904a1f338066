"""NAME_implicit_batch (compiler/emit/batch.py, fn="implicit"): the fixed-step implicit step's
terms (NAME_implicit) over many states in SIMD lanes, on a model with ground contacts -- the
gym hopper: eight contact points on four geoms, each pair behind a broad-phase branch and each
point's law behind its depth branch, which the lanes take as masks.  At states where some lanes
of a group touch the ground and others do not, the batch equals the scalar NAME_implicit bit for
bit when sin/cos go through libm (-DEOMC_BATCH_LIBM_TRIG) and within the vector sin/cos's bound
otherwise; the same holds for the hopper's rhs_batch, whose contact branches were refused (the
scalar loop) before masks.  Also the rewrite itself on small bodies: a state-dependent branch
becomes masks and masked stores, a branch on parameters stays a C branch.

Oracle: the scalar NAME_implicit and NAME_rhs of the same library (the same expressions)."""
import re
import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

from eomc.compiler.build.builder import machine_lanes
from eomc.compiler.emit.batch import Unsupported, batch_rhs
from helpers import model_files

STRICT = "-O2 -std=c99 -fPIC -Wall -Wextra -Werror"
FUNCTIONS = ("rhs", "implicit", "implicit_batch", "rhs_batch")


def _hopper(cache, cflags):
    gymnasium = pytest.importorskip("gymnasium")
    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    with warnings.catch_warnings():      # the file's self-collision pairs left out (said by a warning)
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path), name="ibh", functions=FUNCTIONS, cache_dir=cache, cflags=cflags,
                            progress=False)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("implicit_batch_cache")


def _scalar(model, X):
    """NAME_implicit at each row of X (the scalar call through cffi)."""
    ffi = model.ffi
    fp = getattr(model.model_lib, f"{model.name}_implicit")
    out = np.zeros((len(X), model.metadata["implicit"]["layout"]["size"]))
    work = np.zeros(model.work_size + 1)
    r = np.zeros(max(model.ninput, 1))
    for k, x in enumerate(X):
        assert fp(0.0, ffi.from_buffer("double[]", np.ascontiguousarray(x)), model._default_p,
                  ffi.from_buffer("double[]", r), ffi.from_buffer("double[]", out[k]),
                  ffi.from_buffer("double[]", work)) == 0
    return out


def _batch_at(model, X, shift):
    """NAME_implicit_batch over the rows of X through cffi, its OUT ``shift`` doubles past a
    64-byte boundary: (n, size).  n == lanes with shift 0 is the lanes rollout's call (the
    lanes write into OUT itself when a state's outputs are many); any other shift takes the
    tile's copy."""
    ffi = model.ffi
    fp = getattr(model.model_lib, f"{model.name}_implicit_batch")
    n, size = len(X), model.metadata["implicit"]["layout"]["size"]
    raw = np.zeros(n * size + 16)
    first = (-(raw.ctypes.data // 8)) % 8 + shift
    out = raw[first:first + n * size]
    assert (out.ctypes.data - 8 * shift) % 64 == 0
    cols, status = np.ascontiguousarray(X.T), np.zeros(n, dtype=np.intc)
    work, r = np.zeros(model.work_size + 1), np.zeros(max(model.ninput, 1) * n)
    assert fp(n, 0.0, ffi.from_buffer("double[]", cols), model._default_p, ffi.from_buffer("double[]", r),
              ffi.from_buffer("double[]", out), ffi.from_buffer("int[]", status), ffi.from_buffer("double[]", work)) == 0
    return out.reshape(size, n).T.copy()


def _states(model, n, seed):
    """Near the file's start, the torso lowered by up to 0.3 m or raised by 0.1 m (the foot
    starts 0.1 m up): some states with feet, legs or thighs on the ground, some in the air."""
    rng = np.random.default_rng(seed)
    X = np.tile(np.array(model.initial_state, dtype=float), (n, 1))
    X[:, :model.nq] += 0.02 * rng.normal(size=(n, model.nq))
    X[:, model.nq:] = 0.5 * rng.normal(size=(n, model.nu))
    X[:, list(model.state_names).index("q_rootz")] += rng.uniform(-0.3, 0.1, n)
    return X


def _touching(model, out):
    """(n, ncontact) bool: the contact's stiffness block K is nonzero (in touch)."""
    at = model.metadata["implicit"]["layout"]
    nc = len(model.metadata["implicit"]["contacts"])
    return (out[:, at["contact"]:at["contact"] + 25 * nc].reshape(len(out), nc, 25)[:, :, 7:16] != 0).any(axis=2)


@pytest.mark.parametrize("trig", ["libm", "vector"])
def test_hopper_implicit_and_rhs_in_lanes_with_contacts_on_and_off(cache, trig):
    flags = f"{STRICT} -DEOMC_BATCH_LIBM_TRIG" if trig == "libm" else STRICT
    model = _hopper(cache, flags)
    for fn in ("implicit_batch", "rhs_batch"):
        assert model.metadata[fn]["vectorized"], model.metadata[fn]
    lanes = machine_lanes()
    X = _states(model, 4 * lanes + 3, 0)         # whole groups of lanes and a scalar tail
    want, got = _scalar(model, X), model.implicit_batch(0.0, X)
    touch = _touching(model, want)
    groups = touch[:4 * lanes].reshape(4, lanes, -1).any(axis=2)    # a state with any contact on
    assert touch.any(axis=1).any() and not touch.any(axis=1).all()
    assert (groups.any(axis=1) & ~groups.all(axis=1)).any(), groups   # a group mixes both
    assert got.shape == want.shape
    rhs_want = np.array([model.rhs(0.0, x) for x in X])
    rhs_got = model.rhs_batch(0.0, X)
    if trig == "libm":
        assert np.array_equal(got, want)
        assert np.array_equal(rhs_got, rhs_want)
    else:   # sin/cos within 1 ulp of libm's; a contact law's slopes near touch-down magnify it
        assert np.array_equal(_touching(model, got), touch)
        assert (np.abs(got - want) / np.maximum(np.abs(want), 1.0)).max() < 1e-9
        assert (np.abs(rhs_got - rhs_want) / np.maximum(np.abs(rhs_want), 1.0)).max() < 1e-9
        assert np.mean(got == want) > 0.9


@pytest.mark.skipif(shutil.which("clang") is None, reason="clang is not installed (CI installs it: .ci/run)")
def test_the_lanes_c_is_clean_under_clang_too(cache):
    """The lanes build's C (its sin/cos kernels among the helpers) is warning-free under clang's
    -Wall -Wextra as under gcc's: a helper no lane code calls (the lone vsin/vcos where every
    angle is paired into vsincos) is not emitted.  clang flagged both in every lanes build."""
    model = _hopper(cache, STRICT)
    source = Path(model.directory) / f"{model.name}.c"
    assert f"{model.name}_vsincos(" in source.read_text()
    done = subprocess.run(["clang", "-std=c99", "-O1", "-fPIC", "-Wall", "-Wextra", "-Werror", "-fsyntax-only",
                           source.name], cwd=source.parent, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]


# Two legs hanging from a torso on a planar root, a sphere foot each: the feet are one self-pair
# (siblings), and each touches the floor.  With pairs.TABLE_FROM = 1 the pair goes through the
# table's C loop (eomc_pairs), as G1's 16 foot-sphere pairs do by default.
TWO_LEGS = model_files.TWO_LEGS


def test_a_pair_table_call_runs_lane_by_lane_in_the_batch(tmp_path, monkeypatch):
    """The pairs' table loop (eomc_pairs) in NAME_implicit_batch: each lane's inputs gathered and
    the scalar loop called, so the batch stays vectorized around it and equals the scalar
    NAME_implicit bit for bit (libm sin/cos) in groups whose lanes have the feet pressed together,
    apart (the pair skipped by its broad phase) and on the floor or not.  Built with tiles of one
    group (batch.TILE_BYTES 0, as a model whose outputs are many: the humanoid's, G1's), so that
    a call with n == lanes into an aligned OUT takes the lanes' direct writes."""
    import eomc
    from eomc.compiler.contact import pairs
    from eomc.compiler.emit import batch
    from eomc.compiler.mjcf.model import MjcfModel
    monkeypatch.setattr(pairs, "TABLE_FROM", 1)
    monkeypatch.setattr(batch, "TILE_BYTES", 0)
    path = tmp_path / "twolegs.xml"
    path.write_text(TWO_LEGS)
    model = eomc.compile(MjcfModel(path), name="ibpt", functions=("rhs", "implicit", "implicit_batch", "outputs"),
                         cache_dir=tmp_path / "cache", cflags=f"{STRICT} -DEOMC_BATCH_LIBM_TRIG", progress=False)
    source = next((tmp_path / "cache").rglob("ibpt.c")).read_text()
    assert "eomc_pairs(" in source and "the pairs' loop, lane by lane" in source
    # NAME_implicit's call writes its slopes into out[] (contact/table.slopes_into), and the lanes take
    # that call too: no fall back to the scalar loop
    assert "double *slo, int nslo" in source and "slo_[" in source
    assert "const int direct = n == L" in source
    assert model.metadata["implicit_batch"]["vectorized"], model.metadata["implicit_batch"]
    # the table's outputs past its wrenches are not read with full = 0 (contact/table.py): each lane
    # puts only the wrenches, which the loop zeroes itself, so no memset of the rest
    lanes_fn = source[source.index("static EOMC_VTARGET void ibpt_implicit_lanes("):]
    lanes_fn = lanes_fn[:lanes_fn.index("\n}\n")]
    wrenches = int(re.search(r"eomc_pairs_slopes\(.*?\n\{\n(?:.*\n)*?.*k < \(full \? \d+ : (\d+)\)", source).group(1))
    nout = int(re.search(r"double out_\[(\d+)\];", lanes_fn).group(1))
    assert wrenches < nout
    assert re.search(rf"_put_lane\(\w+ \+ 0, out_, {wrenches}, l_\);", lanes_fn), lanes_fn[-800:]
    assert "memset(out_" not in lanes_fn
    lanes = machine_lanes()
    rng = np.random.default_rng(5)
    n = 4 * lanes + 3
    X = np.zeros((n, model.nx))
    names = list(model.state_names)
    X[:, names.index("q_rootz")] = rng.uniform(-0.08, 0.05, n)     # the feet 1-4 cm into the floor or above
    X[:, names.index("q_hip_l")] = rng.uniform(-0.25, 0.05, n)     # swung towards each other, or apart
    X[:, names.index("q_hip_r")] = rng.uniform(-0.05, 0.25, n)
    X[:, model.nq:] = rng.normal(size=(n, model.nu))
    want, got = _scalar(model, X), model.implicit_batch(0.0, X)
    pressed = np.array([model.outputs(0.0, x)["depth_foot_l__foot_r"] > 0 for x in X])
    groups = pressed[:4 * lanes].reshape(4, lanes)
    assert (groups.any(axis=1) & ~groups.all(axis=1)).any(), groups     # a group mixes both
    assert _touching(model, want).any() and not _touching(model, want).all()
    assert np.array_equal(got, want)
    for shift in (0, 1):           # one group in OUT itself (aligned), and through the tile
        assert np.array_equal(_batch_at(model, X[:lanes], shift), want[:lanes])


def _batch_rows(model, X, out, rows):
    """NAME_implicit_batch_rows over the rows of X into OUT ``out`` (size x n, written in place)
    and the states' own buffers ``rows`` (n x size): the statuses."""
    import cffi
    own = cffi.FFI()
    own.cdef(f"int {model.name}_implicit_batch_rows(int n, double t, const double *X, const double *p, "
             f"const double *R, double *OUT, double *const *rows, int *status, double *work);")
    lib = own.dlopen(str(model.library_path))
    n = len(X)
    cols, status = np.ascontiguousarray(X.T), np.zeros(n, dtype=np.intc)
    work, r = np.zeros(model.work_size + 1), np.zeros(max(model.ninput, 1) * n)
    p = np.asarray(model.param_defaults, dtype=float)
    ptrs = own.new("double *[]", [own.cast("double *", own.from_buffer("double[]", rows[k])) for k in range(n)])
    getattr(lib, f"{model.name}_implicit_batch_rows")(
        n, 0.0, own.from_buffer("double[]", cols), own.from_buffer("double[]", p), own.from_buffer("double[]", r),
        own.from_buffer("double[]", out), ptrs, own.from_buffer("int[]", status), own.from_buffer("double[]", work))
    return status


def test_the_pairs_slope_block_goes_into_each_states_own_row(tmp_path, monkeypatch):
    """NAME_implicit_batch_rows (the lanes rollout's, batch.py's rows): the pairs' slope block of each
    state written by its lane's pairs' loop straight into that state's own buffer at the block's
    place (nothing else of the buffer touched), every other output in OUT as NAME_implicit_batch
    writes it, the block's rows of OUT left alone by the lanes -- bit for bit the scalar
    NAME_implicit (libm sin/cos) with the feet pressed together, apart and on the floor, one group
    in OUT itself and a scalar tail; into rows that hold NaN or the block of an earlier call (the
    loop keeps it: table.KEPT_BLOCK); and the statuses of states with a non-finite entry are the
    scalar call's."""
    import eomc
    from eomc.compiler.contact import pairs
    from eomc.compiler.emit import batch
    from eomc.compiler.mjcf.model import MjcfModel
    monkeypatch.setattr(pairs, "TABLE_FROM", 1)
    path = tmp_path / "twolegs.xml"
    path.write_text(TWO_LEGS)
    model = eomc.compile(MjcfModel(path), name="ibrw", functions=("rhs", "implicit", "implicit_batch", "outputs"),
                         cache_dir=tmp_path / "cache", cflags=f"{STRICT} -DEOMC_BATCH_LIBM_TRIG", progress=False)
    info = model.metadata["implicit"]
    first, length = model.metadata["implicit_batch"]["rows_block"]
    pair_points = [k for k, c in enumerate(info["contacts"]) if c.get("pair")]
    assert pair_points and length == 25 * len(pair_points)
    assert first == info["layout"]["contact"] + 25 * pair_points[0]
    lanes = machine_lanes()
    rng = np.random.default_rng(6)
    n = 2 * lanes + 3
    X = np.zeros((n, model.nx))
    names = list(model.state_names)
    X[:, names.index("q_rootz")] = rng.uniform(-0.08, 0.05, n)
    X[:, names.index("q_hip_l")] = rng.uniform(-0.25, 0.05, n)
    X[:, names.index("q_hip_r")] = rng.uniform(-0.05, 0.25, n)
    X[:, model.nq:] = rng.normal(size=(n, model.nu))
    want = _scalar(model, X)
    block = slice(first, first + length)
    pressed = (want[:, block].reshape(n, -1, 25)[:, :, 0] > 0).any(axis=1)
    assert pressed[:2 * lanes].any() and not pressed[:2 * lanes].all()
    size = info["layout"]["size"]
    for m in (lanes, n):            # the rollout's call (OUT aligned, one group), and groups with a tail
        raw = np.full(m * size + 8, 7.0)
        at = (-(raw.ctypes.data // 8)) % 8
        out = raw[at:at + m * size]
        rows = np.full((m, size), np.nan)
        status = _batch_rows(model, X[:m], out, rows)
        got = out.reshape(size, m).T
        assert (status == 0).all()
        assert np.array_equal(rows[:, block], want[:m, block])
        assert np.isnan(rows[:, :first]).all() and np.isnan(rows[:, first + length:]).all()
        assert np.array_equal(got[:, :first], want[:m, :first])
        assert np.array_equal(got[:, first + length:], want[:m, first + length:])
        g = m // lanes * lanes          # the lanes' states: their block columns untouched
        assert (got[:g, block] == 7.0).all()
        # again into the same rows with each row's state moved on (pressed rows now apart and
        # the other way): the loop keeps the block (table.KEPT_BLOCK) and zeroes only the records
        # it wrote, so what stays is the scalar call's block of the new states all the same
        perm = np.roll(np.arange(m), 1)
        status = _batch_rows(model, X[perm], out, rows)
        assert (status == 0).all()
        assert np.array_equal(rows[:, block], want[perm][:, block])
        assert (want[perm][:, block].reshape(m, -1, 25)[:, :, 0] > 0).any(axis=1).tolist() != pressed[:m].tolist()
    bad = X[:lanes].copy()
    bad[1, names.index("q_hip_l")] = np.nan
    bad[2, model.nq] = np.inf
    raw = np.zeros(lanes * size + 8)
    at = (-(raw.ctypes.data // 8)) % 8
    status = _batch_rows(model, bad, raw[at:at + lanes * size], np.zeros((lanes, size)))
    want_status = [model.model_lib.__getattribute__(f"{model.name}_implicit")(
        0.0, model.ffi.from_buffer("double[]", np.ascontiguousarray(x)), model._default_p,
        model.ffi.from_buffer("double[]", np.zeros(max(model.ninput, 1))),
        model.ffi.from_buffer("double[]", np.zeros(size)), model.ffi.from_buffer("double[]", np.zeros(model.work_size + 1)))
        for x in bad]
    assert list(status) == want_status and want_status[1] != 0 and want_status[0] == 0


def test_the_lanes_finiteness_check_by_sums_gives_the_entry_by_entry_verdict(tmp_path):
    """NAME_implicit_batch's check of a group's outputs (batch._finite_by_sum: the sums first, entry
    by entry only in a group where a lane's sum is not finite) marks exactly the lanes with an inf
    or NaN entry in its ranges -- also where finite entries' sum overflows (not marked), a +inf
    and a -inf cancel to NaN (marked), and a condition leaves a range out (its NaN not marked)."""
    import ctypes
    import subprocess
    from eomc.compiler.emit.batch import _finite_by_sum
    L, n = 4, 43
    code = ("typedef double eomc_vd __attribute__((vector_size(8 * 4)));\n"
            "typedef unsigned long long eomc_vu __attribute__((vector_size(8 * 4)));\n"
            "void check(const double *v, int skip, int *marked)\n{\n"
            "    enum { L = 4 };\n    const eomc_vd *xo = (const eomc_vd *)v;\n    eomc_vu bad = {0};\n    int i, l;\n"
            + _finite_by_sum("xo", [(0, 20, None), (37, n, None), (20, 37, "!skip")])
            + "    for (l = 0; l < L; l++) marked[l] = bad[l] != 0;\n}\n")
    (tmp_path / "f.c").write_text(code)
    subprocess.run(["cc", *STRICT.split(), "-shared", "-o", str(tmp_path / "f.so"), str(tmp_path / "f.c")],
                   check=True)
    check = ctypes.CDLL(str(tmp_path / "f.so")).check
    v = np.random.default_rng(3).normal(size=(n, L))
    v[5, 0] = np.nan                    # lane 0: a NaN
    v[:, 1] = 1e308                     # lane 1: finite, its sums overflow
    v[2, 2], v[40, 2] = np.inf, -np.inf   # lane 2: the sum NaN
    v[30, 3] = np.nan                   # lane 3: a NaN in the range left out when skip
    for skip, want in ((0, [1, 0, 1, 1]), (1, [1, 0, 1, 0])):
        marked = (ctypes.c_int * L)()
        buf = np.ascontiguousarray(v)
        check(buf.ctypes.data_as(ctypes.c_void_p), skip, marked)
        assert list(marked) == want
    fine = np.ones((n, L))
    marked = (ctypes.c_int * L)()
    check(fine.ctypes.data_as(ctypes.c_void_p), 0, marked)
    assert list(marked) == [0, 0, 0, 0]


def _lanes(lines, fn="implicit"):
    code, used = batch_rhs("m", lines, [], fn=fn, out="out")
    return code, used


def test_a_state_branch_becomes_masks_and_masked_stores():
    lines = ["    const double t0 = x[0] - p[0];",
             "    if (!(-t0 > 0.0)) {",
             "        const double t1 = sqrt(t0);",
             "        out[0] = t1*p[1];",
             "        if (!(x[1] > 0.0)) {",
             "            out[1] = t1;",
             "        } else {",
             "            out[1] = 0.0;",
             "        }",
             "    } else {",
             "        out[0] = 0.0;",
             "        out[1] = 0.0;",
             "    }",
             "    return m_finite_wide(out, 2);"]
    code, used = _lanes(lines)
    assert "mask" in used and "sqrt" in used
    assert "const eomc_vu c0_ = (eomc_vu)((-t0) > (0.0));" in code
    assert "const eomc_vu m0_ = ~c0_;" in code and "if (m_vany(m0_)) {" in code
    assert "const eomc_vu m1_ = m0_ & ~c1_;" in code            # nested: within the outer mask
    assert "const eomc_vu e1_ = m0_ & c1_;" in code and "const eomc_vu e0_ = c0_;" in code
    assert "out[0] = (eomc_vd)(((eomc_vu)(m_v_sqrt(t0)" not in code    # t1 is a temporary
    assert "out[1] = (eomc_vd)(((eomc_vu)(t1) & m1_) | ((eomc_vu)out[1] & ~m1_));" in code
    assert "out[1] = (eomc_vd)((eomc_vu)out[1] & ~e1_);" in code      # a zero: the lanes' bits cleared
    # shared parameters (implicit): one double for all lanes
    assert "const double *p," in code
    with pytest.raises(Unsupported, match="not closed"):
        _lanes(lines[:-2])


def test_a_parameter_branch_stays_a_c_branch_and_other_tests_are_refused():
    code, used = _lanes(["    if (p[0] > 0.0) {", "        out[0] = x[0];", "    }"])
    assert "if (p[0] > 0.0) {" in code and "mask" not in used
    with pytest.raises(Unsupported, match="a branch on"):
        _lanes(["    if (isfinite(x[0])) {", "        out[0] = x[0];", "    }"])


def test_reads_t_is_what_the_body_reads():
    """implicit_batch.reads_t (the lanes rollout batches rows at different times only when it is
    False): a body that names t, itself or in a call of a split part, reads it; temporaries t0,
    t1 and (void)-free bodies do not."""
    from eomc.compiler.emit.batch import batch_code, reads_t
    autonomous = ["    const double t0 = x[0] - p[0];", "    out[0] = t0*x[1];", "    return m_finite_wide(out, 1);"]
    assert not reads_t(autonomous)
    assert reads_t(["    const double t0 = sin(20.0*t);"] + autonomous[1:])
    assert reads_t(["    m_implicit_part0(t, x, out);"] + autonomous[2:])
    for lines, want in ((autonomous, False), (["    out[0] = t*x[0];", "    return m_finite_wide(out, 1);"], True)):
        meta = batch_code("m", 2, 0, (lines, []), npar=1, fn="implicit", nout=1)[2]
        assert meta["reads_t"] is want
    assert "reads_t" not in batch_code("m", 1, 0, (["    xdot[0] = t;"], []), fn="rhs")[2]
