"""NAME_implicit's scratch-array passes (compiler/emit/packed.py: the pairs' input literal read in
place; compiler/emit/forward.py: outputs stored where they are made): the same bits as the C
without them, and each one's refusals.

Oracle: the same model built with both passes replaced by the identity (the C before session 32),
its NAME_implicit and NAME_implicit_var on states in and out of touch, bit for bit."""
import re
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.emit import generate
from eomc.compiler.emit.forward import forwarded_outputs
from eomc.compiler.emit.packed import packed_inputs

from helpers.implicit_call import call_into

from ..contact.test_narrow import LIMBS


def _build(tmp, tag, monkeypatch=None):
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp / f"{tag}.xml"
    path.write_text(LIMBS)
    if monkeypatch is not None:
        monkeypatch.setattr(generate, "packed_inputs", lambda lines, parts, base: (lines, parts))
        monkeypatch.setattr(generate, "forwarded_outputs", lambda lines, parts, base: (lines, parts))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = eomc.compile(MjcfModel(path, pairs=True), "lfw", functions=("rhs", "outputs", "implicit"),
                             cache_dir=tmp / f"cache_{tag}", progress=False)
    (source,) = tmp.glob(f"cache_{tag}/**/lfw.c")
    return model, source.read_text()


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("forward")
    mine = _build(tmp, "passes")
    with pytest.MonkeyPatch.context() as mp:
        plain = _build(tmp, "plain", mp)
    return mine, plain


def _var_body(source):
    at = source.index("int lfw_implicit_var(")
    return source[at:source.index("\n}\n", at)]


_call = call_into


def test_the_passes_took_the_literal_and_copies(both):
    (_, mine), (_, plain) = both
    assert "(const double[" in _var_body(plain) and "(const double[" not in _var_body(mine)
    assert re.search(r"eomc_pairs_slopes\(&S_\[\d+\], ", _var_body(mine))
    copy = re.compile(r"^    out\[\d+\] = S_\[\d+\];$", re.M)
    assert len(copy.findall(mine)) < len(copy.findall(plain))


def test_the_same_bits_as_without_them(both):
    (m, _), (b, _) = both
    size = m.metadata["implicit"]["layout"]["size"]
    at = m.metadata["implicit"]["layout"]["contact"]
    ncontact = len(m.metadata["implicit"]["contacts"])
    names, rng = list(m.state_names), np.random.default_rng(5)
    kept = {}
    for model in (m, b):
        kept[model] = np.full(size, np.nan)
        model.ffi.addressof(model.model_lib, f"{model.name}_implicit_const")(
            model.ffi.from_buffer("double[]", kept[model]))
    touching = 0
    for i in range(150):
        x = np.zeros(m.nx)
        x[names.index("q_joint0_z")] = 0.3
        x[names.index("q_joint3_z")] = 0.3
        x[names.index("q_joint3_y")] = rng.uniform(-0.12, 0.3) if i % 3 else rng.uniform(-0.12, -0.06)
        x += rng.normal(0, 0.01 if i % 2 else 0.3, m.nx)
        whole = {}
        for model in (m, b):
            whole[model] = rng.normal(size=size)
            s1 = _call(model, "implicit", x, whole[model])
            s2 = _call(model, "implicit_var", x, kept[model])
            assert s1 == s2
        assert whole[m].tobytes() == whole[b].tobytes()
        assert kept[m].tobytes() == kept[b].tobytes()
        touching += int((whole[m][at + 25 * np.arange(ncontact)] > 0).sum())
    assert touching > 0


# the passes on text: what each refuses

_PART = """static EOMC_NOINLINE void f_implicit_part0_{k}({params})
{{
{body}
}}
"""


def _part(k, params, *body):
    return _PART.format(k=k, params=params, body="\n".join(body))


def test_packed_renames_the_slots_and_stores_the_rest():
    lines = ["    double S_[3];", "    f_implicit_part0_0(x, S_);",
             "    const double t9 = eomc_pairs_slopes((const double[4]){S_[2], x[1], S_[2], -p[3]}, p, 0, &PT_[0], "
             "&out[8], 50, 1);",
             "    return 0;"]
    parts = [_part(0, "const double *x, double *S_", "    const double t1 = x[0];", "    S_[2] = t1;")]
    new, new_parts = packed_inputs(lines, parts, "f_implicit_part")
    assert new[0] == "    double S_[7];"
    assert "    S_[3] = t1;" in new_parts[0]
    assert new[2:5] == ["    S_[4] = x[1];", "    S_[5] = S_[3];", "    S_[6] = -p[3];"]
    assert new[5].startswith("    const double t9 = eomc_pairs_slopes(&S_[3], p, 0, ")


def test_packed_leaves_a_scratch_array_passed_elsewhere():
    lines = ["    double S_[3];", "    g(S_);",
             "    const double t9 = eomc_pairs_slopes((const double[1]){S_[2]}, p, 0, &PT_[0], &out[8], 50, 1);"]
    assert packed_inputs(lines, [], "f_implicit_part") == (lines, [])


def _program(*between):
    lines = ["    double S_[2];", "    f_implicit_part0_0(x, S_);", "    f_implicit_part0_1(out, S_);", *between,
             "    return 0;"]
    parts = [_part(0, "const double *x, double *S_", "    const double t1 = x[0]*x[1];", "    S_[1] = t1;",
                   "    const double t2 = x[2];", "    S_[0] = t2;"),
             _part(1, "double *out, double *S_", "    out[0] = S_[1];", "    out[1] = S_[0]*2.0;")]
    return lines, parts


def test_forward_stores_the_output_where_it_is_made():
    lines, parts = _program()
    new, new_parts = forwarded_outputs(lines, parts, "f_implicit_part")
    assert "    out[0] = t1;" in new_parts[0] and "S_[1]" not in new_parts[0]
    assert new_parts[0].startswith(
        "static EOMC_NOINLINE void f_implicit_part0_0(double *out, const double *x, double *S_)")
    assert "out[0] = S_[1]" not in new_parts[1]
    assert new[1] == "    f_implicit_part0_0(out, x, S_);"


def test_forward_leaves_an_output_stored_twice_or_read_or_an_early_return():
    for between in (["    out[0] = 1.0;"], ["    const double t5 = out[0];"], ["    if (t1 > 0.0) return 1;"]):
        lines, parts = _program(*between)
        assert forwarded_outputs(lines, parts, "f_implicit_part") == (lines, parts), between


def test_forward_leaves_a_slot_stored_under_a_branch():
    lines, parts = _program()
    parts[0] = parts[0].replace("    S_[1] = t1;", "    if (t1 > 0.0) {\n        S_[1] = t1;\n    }")
    new, new_parts = forwarded_outputs(lines, parts, "f_implicit_part")
    assert "out[0] = S_[1];" in new_parts[1]
