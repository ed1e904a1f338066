"""Issue 8 / issue 19: a joint loop closed by constraints runs on the tree; what the tree does not
build is refused naming it, and auto says why it fell back."""
from pathlib import Path

import pytest

from eomc.cli import main
from eomc.compiler.driver import generate
from eomc.compiler.formulations.select import COST_MODEL
from eomc.errors import ModelError

ROOT = Path(__file__).resolve().parents[3]
FOUR_BAR = ROOT / "examples" / "four_bar_system.py"


def test_recursive_builds_the_loop_and_names_what_it_does_not_build(tmp_path, monkeypatch):
    """Closed loops run on the tree (issue 19, tests/compiler/tree/test_closed_loops.py), their
    derivatives too (test_closed_loop_derivatives.py); the regressor is not built: refused,
    naming it."""
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    _, gm = generate(str(FOUR_BAR), functions=["rhs", "jac_x"], formulation="recursive",
                     use_cache=False, progress=False)
    assert gm.metadata["formulation"] == "recursive"
    with pytest.raises(ModelError) as info:
        generate(str(FOUR_BAR), functions=["rhs", "regressor"], formulation="recursive",
                 use_cache=False, progress=False)
    assert "regressor of a tree closed by constraints is not generated" in str(info.value)


def test_auto_compares_the_two_with_the_default_functions_and_says_so(tmp_path, monkeypatch, capsys):
    """The default functions (jac_x, jac_r, linearize) no longer force Kane: auto builds both
    and keeps the cheaper rhs (Kane's at the four-bar's 3 speeds, benchmarks/results/loops.md)."""
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    _, gm = generate(str(FOUR_BAR), formulation="auto", use_cache=False, progress=False)
    costs = gm.metadata["formulation_costs"]
    assert gm.metadata["formulation"] == min(("kane", "recursive"), key=lambda f: costs[f])
    assert "formulation_note" not in gm.metadata
    assert main(["inspect", "-q", str(FOUR_BAR), "--formulation", "auto"]) == 0
    out = capsys.readouterr().out
    assert (f"auto compared rhs costs ({COST_MODEL}): kane {costs['kane']}, "
            f"recursive {costs['recursive']}"
            in out)


def test_hand_built_constrained_kane_says_why_it_is_no_tree():
    """A hand-built KanesMethod with dependent speeds is read like any KanesMethod (its loops
    are closed by its constraint matrices); the zoo's four-bar uses absolute angles, which
    are no relative-coordinate tree: refused, naming the body and coordinate."""
    import eomc.mechanics as em
    from eomc.compiler.tree.model import NotATree
    from eomc.compiler.tree.recognize import tree_of
    from helpers import zoo
    km, _ = zoo.four_bar(em)
    with pytest.raises(NotATree, match=r"body Link2 .*depends on more than its own coordinate q2"):
        tree_of(km)


def test_recursive_never_forms_kanes_equations_of_the_loop(tmp_path, monkeypatch):
    """The loop's tree and constraints are read from the System; Kane's equations (minutes for
    a large one) are never formed."""
    from eomc.compiler.mechanics import unformed

    def forbidden(system):
        raise AssertionError("Kane's equations were formed")

    monkeypatch.setattr(unformed, "form_system", forbidden)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    _, gm = generate(str(FOUR_BAR), functions=["rhs"], formulation="recursive", use_cache=False,
                     progress=False)
    assert gm.metadata["nhol"] == gm.metadata["nvel"] == 2
