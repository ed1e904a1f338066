"""Issue 8, bad input: a joint loop where a tree is required names the joints and the fallback."""
from pathlib import Path

import pytest

from eomc.cli import main
from eomc.compiler.driver import generate
from eomc.errors import ModelFileError

ROOT = Path(__file__).resolve().parents[3]
FOUR_BAR = ROOT / "examples" / "four_bar_system.py"


def test_recursive_names_the_joints_of_the_loop_and_the_way_out(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(ModelFileError) as info:    # refused while the file is read: file:line
        generate(str(FOUR_BAR), functions=["rhs"], formulation="recursive", use_cache=False,
                 progress=False)
    msg = str(info.value)
    assert msg.startswith(f"{FOUR_BAR}:")
    assert "joints J1, J2, J3 form a closed loop" in msg
    assert "2 holonomic constraints" in msg and "q2, q3" in msg
    assert "'auto' falls back to kane" in msg


def test_auto_says_it_fell_back_to_kane_and_why(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    _, gm = generate(str(FOUR_BAR), functions=["rhs"], formulation="auto", use_cache=False,
                     progress=False)
    assert gm.metadata["formulation"] == "kane"
    assert gm.metadata["formulation_note"].startswith("kane, the fallback (not a tree: joints J1, J2, J3")
    assert main(["inspect", "-q", str(FOUR_BAR), "--outputs", "rhs", "--formulation", "auto"]) == 0
    out = capsys.readouterr().out
    assert "formulation: kane, the fallback (not a tree: joints J1, J2, J3 form a closed loop" in out


def test_hand_built_constrained_kane_names_its_dependent_variables():
    """A hand-built KanesMethod has no joints: the refusal names the dependent q and u."""
    import eomc.mechanics as em
    from eomc.compiler.tree.model import NotATree
    from eomc.compiler.tree.recognize import tree_of
    from helpers import zoo
    km, _ = zoo.four_bar(em)
    with pytest.raises(NotATree, match=r"dependent or auxiliary coordinates or speeds \(q2, q3, u2, u3\)"):
        tree_of(km)


def test_recursive_refuses_before_forming_kanes_equations(tmp_path, monkeypatch):
    """Forming Kane's equations of a System the recursion cannot take would be wasted work
    (minutes for a large one) before the same refusal."""
    from eomc.compiler.mechanics import unformed

    def forbidden(system):
        raise AssertionError("Kane's equations were formed")

    monkeypatch.setattr(unformed, "form_system", forbidden)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(ModelFileError, match="form a closed loop"):
        generate(str(FOUR_BAR), functions=["rhs"], formulation="recursive", use_cache=False,
                 progress=False)
