"""NAME_implicit with the pairs' loop writing its slopes straight into out[] and NAME_finite_wide in
16 sums (contact/table.SLOPES_INTO_OUT, emit/generate.WIDE_FINITE_CHAINS: session 14's experiment,
both off by default) equals the default build bit for bit, status included.

Why: on gymnasium's humanoid the default copies the loop's 2725-entry slope block from PT_ into
out[] after zeroing it, and the finiteness sum waits on one add per four entries; both are pure
overhead, so the switches must change no bit of the result."""
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.contact import table
from eomc.compiler.emit import generate

from .test_narrow import LIMBS


def _build(tmp, name, into):
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp / "limbs.xml"
    path.write_text(LIMBS)
    old = table.SLOPES_INTO_OUT, generate.WIDE_FINITE_CHAINS
    table.SLOPES_INTO_OUT, generate.WIDE_FINITE_CHAINS = into, 16 if into else 4
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return eomc.compile(MjcfModel(path, pairs=True), name, functions=("rhs", "implicit"),
                                cache_dir=tmp / f"cache{int(into)}", progress=False)
    finally:
        table.SLOPES_INTO_OUT, generate.WIDE_FINITE_CHAINS = old


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("into")
    plain, into = _build(tmp, "lplain", False), _build(tmp, "linto", True)
    (a,), (b,) = tmp.glob("cache0/**/lplain.c"), tmp.glob("cache1/**/linto.c")
    a, b = a.read_text(), b.read_text()     # the switches took: the loop writes out[], 16 sums
    assert "double *slo" in b and "s15 +=" in b and "double *slo" not in a and "s15 +=" not in a
    return plain, into


def _implicit(m, x):
    size = m.metadata["implicit"]["layout"]["size"]
    f = getattr(m.model_lib, f"{m.name}_implicit")
    p = np.array(m.param_defaults, dtype=float)
    out, work, r = np.zeros(size), np.zeros(4096), np.zeros(max(m.ninput, 1))
    x = np.ascontiguousarray(x, dtype=float)
    ptr = [m.ffi.cast("double *", m.ffi.from_buffer(a)) for a in (x, p, r, out, work)]
    return f(0.0, *ptr), out


def test_the_slopes_written_into_out_equal_the_copied_ones(pair):
    plain, into = pair
    assert plain.metadata["implicit"] == into.metadata["implicit"]
    assert any(c.get("pair") for c in into.metadata["implicit"]["contacts"])
    rng = np.random.default_rng(3)
    names = list(plain.state_names)
    pressed = 0
    for i in range(60):
        x = np.zeros(plain.nx)
        x[names.index("q_joint0_z")] = 0.3
        x[names.index("q_joint3_z")] = 0.3
        x[names.index("q_joint3_y")] = rng.uniform(-0.12, -0.06)
        x += rng.normal(0, 0.01, plain.nx)
        a, b = _implicit(plain, x), _implicit(into, x)
        assert a[0] == b[0] == 0
        assert np.array_equal(a[1], b[1])
        lay = plain.metadata["implicit"]["layout"]
        pts = a[1][lay["contact"]:].reshape(-1, 25)
        pressed += int(np.any(pts[:, 7:16] != 0))
    assert pressed > 0                       # some states press a pair (its K in the block)
    x[0] = np.nan
    assert _implicit(plain, x)[0] == _implicit(into, x)[0] != 0
