"""NAME_implicit's pairs' loop writes its slope block straight into out[] (contact/table.slopes_into:
PairTableSlopesInto; since session 15 the default): every entry of the block is written at every
call, whatever out[] held, and holds what the rhs's outputs say.

Why: the block used to live in the loop's scratch PT_ (zeroed by the loop, copied into out[] entry by
entry: 2725 doubles a call on gymnasium's humanoid); written in place, a far pair's entries are 0
only because the loop zeroes out[]'s block, and a caller's out[] holds the previous state's values
(the fixed step reuses it).  Oracles: the outputs function (depth, point, F_n per pair; no force, no
slope) and out[] prefilled with NaN (an entry left unwritten fails NAME_finite_wide) or with another
state's block.  The slopes' values against central differences: test_pair_slopes.py."""
import numpy as np
import pytest

from helpers.implicit_call import call_into
from helpers.mjcf_builds import text_model

from .test_narrow import LIMBS


@pytest.fixture(scope="module")
def limbs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("into")
    model = text_model(LIMBS, "linto", tmp, ("rhs", "outputs", "implicit"), mjcf=dict(pairs=True))
    (source,) = tmp.glob("cache/**/linto.c")
    return model, source.read_text()


@pytest.fixture(scope="module")
def limbs_lanes(tmp_path_factory):
    """The limbs on a floor built for the lanes rollout too: NAME_implicit's out[] then ends with the
    energy, an output after the pairs' block (compiler/tree/lower.implicit_layout)."""
    tmp = tmp_path_factory.mktemp("into_lanes")
    floored = LIMBS.replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="2 2 0.1"/>', 1)
    # on a floor: a model with contacts has the energy output
    model = text_model(floored, "lintol", tmp, ("rhs", "outputs", "implicit", "implicit_batch"),
                       mjcf=dict(pairs=True))
    (source,) = tmp.glob("cache/**/lintol.c")
    return model, source.read_text()


def _implicit(m, x, fill):
    """(status, out) of NAME_implicit at x with out[] holding ``fill`` before the call."""
    out = np.array(fill, dtype=float)
    return call_into(m, "implicit", x, out), out


def test_the_loop_writes_the_block_into_out(limbs):
    _, source = limbs
    call = [line for line in source.splitlines() if "= eomc_pairs_slopes(" in line]
    assert len(call) == 1 and "&PT_[0], &out[" in call[0], call
    assert "double *slo, int nslo" in source


def test_the_block_is_written_whole_and_is_the_outputs(limbs):
    m, _ = limbs
    info = m.metadata["implicit"]
    at, size = info["layout"]["contact"], info["layout"]["size"]
    rng = np.random.default_rng(3)
    names = list(m.state_names)
    previous = np.zeros(size)
    pressed = skipped = 0
    for _ in range(60):
        x = np.zeros(m.nx)
        x[names.index("q_joint0_z")] = 0.3
        x[names.index("q_joint3_z")] = 0.3
        x[names.index("q_joint3_y")] = rng.uniform(-0.12, -0.06)
        x += rng.normal(0, 0.01, m.nx)
        status, out = _implicit(m, x, np.full(size, np.nan))
        assert status == 0                           # no entry left as the NaN it held
        assert np.array_equal(_implicit(m, x, previous)[1], out)    # nor as another state's value
        previous = out
        o = dict(m.outputs(0.0, x))
        for c, item in enumerate(info["contacts"]):
            e = out[at + 25 * c:at + 25 * (c + 1)]
            name = item["name"]
            if o[f"Fn_{name}"] > 0:
                pressed += 1
                assert e[0] == o[f"depth_{name}"] > 0
                assert np.array_equal(e[1:4], [o[f"px_{name}"], o[f"py_{name}"], o[f"pz_{name}"]])
                assert e[7:].any()
            else:
                assert not e[7:].any()               # no force, no slope
                skipped += e[0] == 0                 # the broad phase skipped it: all 0
                assert e[0] == 0 or e[0] == o[f"depth_{name}"]
    assert pressed > 0 and skipped > 0


def test_a_nan_state_is_still_refused(limbs):
    m, _ = limbs
    x = np.zeros(m.nx)
    x[0] = np.nan
    assert _implicit(m, x, np.zeros(m.metadata["implicit"]["layout"]["size"]))[0] != 0


# NAME_implicit checks out[] before the pairs' block and the block through the sum of what the loop
# wrote there (compiler/tree/emit.finite_return, contact/table.py's chk): the same verdict as the whole
# out[]'s check, at states in and out of touch and with a parameter that poisons a pressed pair.

def test_the_return_checks_the_block_through_the_loops_sum(limbs):
    m, source = limbs
    at, size = (m.metadata["implicit"]["layout"][k] for k in ("contact", "size"))
    (ret,) = [line.strip() for line in source.splitlines() if line.strip().startswith("return t")
              and "linto_finite_wide(out, " in line]
    token = ret.split()[1]
    assert ret == (f"return {token} - {token} == 0.0 ? linto_finite_wide(out, {at}) "
                   f": linto_finite_wide(out, {size});")
    assert f"const double {token} = eomc_pairs_slopes(" in source
    assert "return chk;" in source and "chk += (sl[0] + sl[1]) + (sl[2] + sl[3]);" in source


def test_outputs_after_the_block_are_checked_apart(limbs_lanes):
    """The energy after the block (the lanes rollout's build): out[] before the block and after it
    are checked, the block through the sum (session 46: the whole out[] was read again)."""
    m, source = limbs_lanes
    layout = m.metadata["implicit"]["layout"]
    size, energy = layout["size"], layout["energy"]
    at, length = m.metadata["implicit_batch"]["rows_block"]      # the pairs' records, after the floor's
    assert at > layout["contact"] and at + length == energy == size - 1
    (ret,) = [line.strip() for line in source.splitlines() if line.strip().startswith("return t")
              and "lintol_finite_wide(out, " in line]
    token = ret.split()[1]
    assert ret == (f"return {token} - {token} == 0.0 ? (lintol_finite_wide(out, {at}) == EOMC_OK "
                   f"? lintol_finite_wide(out + {energy}, 1) : EOMC_NONFINITE) : lintol_finite_wide(out, {size});")


@pytest.mark.parametrize("which", ["limbs", "limbs_lanes"])
def test_the_verdict_is_every_entrys_at_states_in_and_out_of_touch(which, request):
    m, _ = request.getfixturevalue(which)
    size = m.metadata["implicit"]["layout"]["size"]
    names, rng = list(m.state_names), np.random.default_rng(5)
    p = np.array(m.ffi.unpack(m._default_p, len(m.param_names)), dtype=float)
    pressed = poisoned = 0
    for i in range(40):
        x = np.zeros(m.nx)
        x[names.index("q_joint0_z")] = 0.3
        x[names.index("q_joint3_z")] = 0.3
        x[names.index("q_joint3_y")] = rng.uniform(-0.12, 0.3)
        x += rng.normal(0, 0.01, m.nx)
        status, out = _implicit(m, x, np.zeros(size))
        assert (status == 0) == bool(np.isfinite(out).all())
        o = dict(m.outputs(0.0, x))
        pressed += any(v > 0 for k, v in o.items() if k.startswith("Fn_"))
        if i % 10 == 0:         # a pressed pair's law with a NaN parameter: refused
            hit = [k[3:] for k, v in o.items() if k.startswith("Fn_") and v > 0 and f"vs_{k[3:]}" in m.param_names]
            for name in hit[:1]:
                q = p.copy()
                q[list(m.param_names).index(f"vs_{name}")] = np.nan
                out = np.zeros(size)
                ffi = m.ffi
                fp = ffi.addressof(m.model_lib, f"{m.name}_implicit")
                s = fp(0.0, ffi.from_buffer("double[]", x), ffi.from_buffer("double[]", q), ffi.NULL,
                       ffi.from_buffer("double[]", out), ffi.NULL)
                assert s != 0
                poisoned += 1
    assert pressed > 0 and poisoned > 0


# NAME_implicit_var keeps the block between calls into one out[] (contact/table.KEPT_BLOCK): it zeroes
# only the records its last call wrote there, not the whole block.  Oracle: NAME_implicit (its
# constants, the block zeroed, then NAME_implicit_var) into a fresh buffer at the same state, bit for
# bit, along a walk of states in and out of touch, through a call refused for a NaN parameter.

def _var(m, x, out, p=None):
    return call_into(m, "implicit_var", x, out, p)


def test_var_keeps_the_block_and_equals_the_whole_call(limbs):
    m, source = limbs
    assert "&out[" in source and ", 1);" in [line for line in source.splitlines() if "= eomc_pairs_slopes(" in line][0]
    info = m.metadata["implicit"]
    at, size = info["layout"]["contact"], info["layout"]["size"]
    names, rng = list(m.state_names), np.random.default_rng(11)
    p = np.array(m.ffi.unpack(m._default_p, len(m.param_names)), dtype=float)
    kept = np.full(size, np.nan)                  # the fixed step's buffer: NaN, then the constants
    m.ffi.addressof(m.model_lib, f"{m.name}_implicit_const")(m.ffi.from_buffer("double[]", kept))
    pressed = lifted = refused = 0
    was = None
    for i in range(120):
        x = np.zeros(m.nx)
        x[names.index("q_joint0_z")] = 0.3
        x[names.index("q_joint3_z")] = 0.3
        x[names.index("q_joint3_y")] = rng.uniform(-0.12, 0.3) if i % 3 else rng.uniform(-0.12, -0.06)
        x += rng.normal(0, 0.01, m.nx)
        o = dict(m.outputs(0.0, x))
        hit = [k[3:] for k, v in o.items() if k.startswith("Fn_") and v > 0 and f"vs_{k[3:]}" in m.param_names]
        if i % 17 == 5 and hit:                   # a refused call leaves NaN slopes in its record
            q = p.copy()
            q[list(m.param_names).index(f"vs_{hit[0]}")] = np.nan
            assert _var(m, x, kept, q) != 0
            refused += 1
            continue
        status, whole = _implicit(m, x, rng.normal(size=size))     # whatever the buffer held
        assert _var(m, x, kept) == status == 0
        assert kept.tobytes() == whole.tobytes()
        touch = whole[at + 25 * np.arange(len(info["contacts"]))] > 0
        pressed += touch.sum()
        lifted += was is not None and (was & ~touch).any()
        was = touch
    assert pressed > 0 and lifted > 0 and refused > 0
