"""The tree's ``energy`` output (compiler/tree/contacts._energy) is a sum of named shares: one
temporary per body (its kinetic and gravity terms) and one per limited joint (its limit springs'
stored energy), so the printed C has no one giant statement.  Why: printed as one sum it was a
33 kB C statement on Talos, and gcc compiled the file 0.15-0.17 s slower on G1 and Talos
(benchmarks/results/derivative_build.md, session 20).  The energy's value is checked elsewhere
(test_energy_function.py against NAME_outputs, tests/runtime/test_limit_energy.py)."""
import re
from pathlib import Path

from eomc.compiler.driver import generate
from helpers.urdf_arm import LAW_ARM


def _law_arm_energy(tmp_path, name):
    """LAW_ARM's default build: (nq, its C, NAME_energy's body, the joints with an entry spring)."""
    path = tmp_path / "law_arm.urdf"
    path.write_text(LAW_ARM)
    g = generate(str(path), name, formulation="recursive", use_cache=False, progress=False)[1]
    c = g.c_source
    start = c.index(f"int {name}_energy(")
    entry = [n for n in g.metadata["param_names"] if n.startswith("limit_kd_")]
    return g.metadata["nq"], c, c[start:c.index("\n}\n", start)], len(entry)


def test_energy_is_a_sum_of_named_body_and_joint_shares(tmp_path):
    nq, c, body, entry = _law_arm_energy(tmp_path, "en_shares")
    assert "en_shares_energy_part" not in c          # small: one straight body, read as it is
    result = re.search(r"out\[0\] = (t\d+);", body).group(1)
    total = re.search(rf"const double {result} = ([^;]*);", body).group(1)
    terms = total.split(" + ")
    # LAW_ARM: a fixed base, nq revolute joints each with both limits: nq bodies + nq joints' springs
    # + one share per joint whose limit has an entry spring (ce53cfd8: the stiffer spring ENTRY_DEPTH
    # past the bound, where the entry rule is stiffer than the limit's own)
    assert all(re.fullmatch(r"t\d+", t) for t in terms), total
    assert entry >= 1 and len(terms) == 2 * nq + entry


def test_each_limit_side_is_one_call_of_the_stored_energy(tmp_path):
    """Each side of each limit is one call of eomc_limit_stored (joint_laws.stored), defined once
    in the file, not its sum spelled out per joint and side.  Why: spelled out, the limits were 17
    of NAME_energy's 67 kB of C on G1 and the build's Python and gcc work grew with them
    (benchmarks/results/derivative_build.md, session 20)."""
    nq, c, body, entry = _law_arm_energy(tmp_path, "en_calls")
    # both limits of each joint, and both sides of each entry spring
    assert entry >= 1 and body.count("eomc_limit_stored(") == 2 * nq + 2 * entry
    assert "log(" not in body
    assert c.count("static double eomc_limit_stored(double r, double E)") == 1


def test_the_stored_energy_call_is_its_sum():
    """joint_laws.stored evaluates and differentiates as the sum it stands for."""
    import sympy as sm

    from eomc.compiler.tree.joint_laws import _stored_sum, stored
    r, E = sm.symbols("r E", positive=True)
    s = stored(r, E)
    for arg in (r, E):
        assert sm.simplify(sm.diff(s, arg) - sm.diff(_stored_sum(r, E), arg)) == 0
    at = {r: sm.Float("0.37"), E: sm.Float("0.02")}
    assert abs(s.subs(at).evalf() - _stored_sum(r, E).subs(at).evalf()) < 1e-14


def test_outputs_batch_keeps_its_lanes_with_the_stored_energy_call(tmp_path):
    """NAME_outputs_batch (compiler/emit/batch.py) writes eomc_limit_stored as its sum in lanes:
    vectorized, and equal to the scalar outputs past and inside the limits.  Without it the lanes
    rewrite refused the call and the batch fell back to the scalar form."""
    import numpy as np

    from eomc.compiler.build.builder import machine_lanes
    from eomc.compiler.driver import compile as compile_model
    path = tmp_path / "law_arm.urdf"
    path.write_text(LAW_ARM)
    model = compile_model(str(path), "en_lanes", functions=("rhs", "outputs", "outputs_batch"),
                          formulation="recursive", cache_dir=tmp_path / "c", progress=False)
    assert model.metadata["outputs_batch"]["vectorized"], model.metadata["outputs_batch"]
    X = np.random.default_rng(5).uniform(-3.0, 3.0, (3 * machine_lanes() + 3, model.nx))
    want = np.array([list(model.outputs(0.0, x).values()) for x in X])
    got = model.outputs_batch(0.0, X)
    assert np.abs(want).max() > 100.0          # some states are far past a limit
    assert (np.abs(got - want) / np.maximum(np.abs(want), 1.0)).max() < 1e-14


def test_the_stored_energy_helper_is_defined_only_where_called(tmp_path):
    """eomc_limit_stored is a static (not inline) function: a file that defines it without calling
    it fails -Wunused-function under -Werror.  So printer.CALLED_C's helpers are not in MINMAX_C
    (whose inline forms some C defines whole, tests/compiler/emit/test_batch.py), and a build
    without the energy output defines none (the fresh-clone CI of session 20 failed on both)."""
    from eomc.compiler.emit.printer import CALLED_C, MINMAX_C
    assert "eomc_limit_stored" in CALLED_C and not set(CALLED_C) & set(MINMAX_C)
    path = tmp_path / "law_arm.urdf"
    path.write_text(LAW_ARM)
    g = generate(str(path), "en_none", functions=("rhs", "jac_x"), formulation="recursive",
                 use_cache=False, progress=False)[1]
    assert "eomc_limit_stored" not in g.c_source


def test_the_float_target_has_the_stored_energy_in_float(tmp_path):
    """c99-f32 (compiler/emit/target.py) takes the helper to float like the rest (its twin:
    float arguments, logf), and the float outputs' energy agrees with the double build's past and
    inside the limits to float's rounding."""
    import numpy as np

    import eomc
    path = tmp_path / "law_arm.urdf"
    path.write_text(LAW_ARM)
    kw = dict(functions=("rhs", "outputs"), formulation="recursive", cache_dir=tmp_path / "c", progress=False)
    f32 = eomc.compile(str(path), "en_f32", target="c99-f32", **kw)
    f64 = eomc.compile(str(path), "en_f64", **kw)
    c = (Path(f32.directory) / "en_f32.c").read_text()
    assert c.count("static float eomc_limit_stored(float r, float E)") == 1
    helper = c[c.index("static float eomc_limit_stored"):]
    helper = helper[:helper.index("\n}\n")]
    assert "logf(" in helper and not re.search(r"\blog\(|\bdouble\b", helper)
    X = np.random.default_rng(7).uniform(-3.0, 3.0, (64, f64.nx)).astype(np.float32)
    want = np.array([f64.outputs(0.0, x.astype(np.float64))["energy"] for x in X])
    got = np.array([f32.outputs(0.0, x)["energy"] for x in X], dtype=np.float64)
    assert np.abs(want).max() > 100.0          # some states are far past a limit
    assert (np.abs(got - want) / np.maximum(np.abs(want), 1.0)).max() < 1e-4
