"""Choosing the formulation, the generated C of the recursive one, and its growth with n."""
import shutil
import subprocess
from pathlib import Path

import pytest

import eomc.mechanics as em
from eomc.cli import main
from eomc.compiler.driver import generate
from eomc.errors import ModelError
from helpers import zoo
from helpers.trees import cart_joints, cart_relative

ROOT = Path(__file__).resolve().parents[3]
RUNTIME_C = ROOT / "runtime" / "c"


def _gen(system, formulation, functions=None, **kw):
    return generate(system, "m", functions=functions, formulation=formulation, use_cache=False,
                    progress=False, **kw)[1]


def _total(gm, fn="rhs"):
    return sum(gm.metadata["op_counts"][fn].values())


def test_auto_picks_the_cheaper_rhs():
    kane, inputs = cart_relative(2, em)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    costs = gm.metadata["formulation_costs"]
    assert set(costs) == {"kane", "recursive"}
    assert gm.metadata["formulation"] == min(costs, key=costs.get)
    assert _total(gm) == min(costs.values())


def test_auto_falls_back_to_kane_and_says_why():
    kane, inputs = zoo.n_link_pendulum_on_cart(2, em)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert gm.metadata["formulation"] == "kane"
    assert "not a tree" in gm.metadata["formulation_note"] and "Pa2" in gm.metadata["formulation_note"]


def test_recursive_refusal_names_the_body():
    kane, inputs = zoo.n_link_pendulum_on_cart(2, em)
    with pytest.raises(ModelError, match=r"recursive formulation: body Pa2 \(joint of Pa2\)"):
        _gen(kane, "recursive", ["rhs"], inputs=inputs)
    with pytest.raises(ModelError, match="unknown formulation 'fast'"):
        _gen(kane, "fast", ["rhs"], inputs=inputs)


def test_generated_c_is_clean_and_deterministic(tmp_path):
    kane, inputs = cart_relative(2, em, torques=True)
    a = _gen(kane, "recursive", inputs=inputs)
    b = _gen(kane, "recursive", inputs=inputs)
    assert a.c_source == b.c_source and a.header == b.header
    assert "EOMC_SINGULAR_MASS_MATRIX" in a.c_source
    (tmp_path / "m.c").write_text(a.c_source)
    (tmp_path / "m.h").write_text(a.header)
    gcc = shutil.which("gcc") or shutil.which("cc")
    subprocess.run([gcc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O1", f"-I{RUNTIME_C}",
                    f"-I{tmp_path}", "-c", str(tmp_path / "m.c"), "-o", str(tmp_path / "m.o")],
                   check=True)


def test_rhs_grows_linearly_with_the_chain():
    """Each added middle link costs the same operations: the traced DAG is linear in n."""
    ops = [_total(_gen(cart_joints(n)[0], "recursive", ["rhs"])) for n in (2, 4, 6)]
    assert ops[2] - ops[1] == ops[1] - ops[0] > 0


def test_inspect_shows_both_formulations(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("EOMC_N_LINKS", "2")
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    model = tmp_path / "cart.py"
    model.write_text((ROOT / "benchmarks" / "tree_models" / "cart_rel_kane.py").read_text())
    assert main(["inspect", str(model), "--outputs", "rhs,mass_matrix", "--formulation", "auto"]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines() if line.startswith("  rhs:")}
    kane_ops, rec_ops = map(int, rows["rhs:"])
    assert "formulation: " in out and kane_ops > 0 and rec_ops > 0


def test_zero_articulated_inertia_is_a_status_not_a_nan(tmp_path, monkeypatch):
    """Massless links and cart at run time: ABA's D is 0, rhs reports a singular mass matrix."""
    import numpy as np
    import eomc
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    system, _ = cart_joints(2)
    model = eomc.compile(system, "massless", functions=["rhs"], formulation="recursive",
                         progress=False)
    p = {"m0": 0.0, "m": 0.0, "l": 0.75, "g": 9.81}
    pv = np.array([p[k] for k in model.metadata["param_names"]])
    with pytest.raises(Exception, match="singular"):
        model.rhs(0.0, np.zeros(6), p=pv, r=[0.0])
    pv[model.metadata["param_names"].index("m")] = 0.5
    pv[model.metadata["param_names"].index("m0")] = 2.0
    assert np.all(np.isfinite(model.rhs(0.0, np.zeros(6), p=pv, r=[0.0])))


@pytest.mark.parametrize("n", [1, 3, 5])
def test_kane_solve_floor_is_a_lower_bound_on_kanes_rhs(n):
    """auto may skip lowering Kane's form on this bound: it must never exceed Kane's real rhs."""
    from eomc.compiler.tree.select import kane_solve_floor
    kane, inputs = cart_relative(n, em)
    spec, gm = generate(kane, "m", functions=["rhs"], formulation="kane", inputs=inputs,
                        use_cache=False, progress=False)
    floor = kane_solve_floor(spec.formed)
    assert 0 < floor < _total(gm)


def test_auto_skips_lowering_kane_when_its_solve_alone_costs_more(monkeypatch):
    from eomc.compiler.tree import select
    kane, inputs = cart_relative(2, em)
    monkeypatch.setattr(select, "kane_solve_floor", lambda formed: 10 ** 9)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert gm.metadata["formulation"] == "recursive"
    assert gm.metadata["formulation_costs"]["kane"].startswith(">= 1000000000")
    monkeypatch.setattr(select, "kane_solve_floor", lambda formed: 0)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert isinstance(gm.metadata["formulation_costs"]["kane"], int)
