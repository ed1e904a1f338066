"""Which outputs and events make the recursive formulation build M by CRBA and f by RNEA
(compiler/tree/lower.py with compiler/emit/symbolic.reads_solve): only those that read the
dynamics solve's unknowns (u', q'', a multiplier), whose C solves A·u' = b.  An energy output
alone (a URDF robot with limits, recursive: its default output) reads none, and its build computes
neither recursion.  Oracles: a model whose CRBA raises still builds its energy; outputs and
events reading u' or q'' equal the rhs's u' (the cart's q' = u, so q'' = u')."""
import numpy as np
import pytest
import sympy as sm

import eomc
import eomc.mechanics as em
import eomc.compiler.tree.lower as tree_lower
from eomc.compiler.driver import generate
from eomc.compiler.emit.symbolic import _solved_quantities
from eomc.compiler.model.spec import formed_system
from helpers.trees import cart_relative
from helpers.urdf_arm import LAW_ARM

t = sm.Symbol("t")


def test_an_energy_output_alone_builds_no_mass_matrix(tmp_path, monkeypatch):
    path = tmp_path / "law_arm.urdf"
    path.write_text(LAW_ARM)

    def refuse(*args, **kwargs):
        raise AssertionError("CRBA built for outputs that read no acceleration")
    monkeypatch.setattr(tree_lower, "crba", refuse)
    _, g = generate(str(path), "law_en", functions=("rhs", "outputs", "energy"), use_cache=False,
                    progress=False, formulation="recursive")
    assert g.metadata["output_names"] == ["energy"]
    assert g.metadata["functions"] == ["rhs", "outputs", "energy"]
    # asked for, the mass matrix still comes from CRBA
    with pytest.raises(AssertionError, match="CRBA"):
        generate(str(path), "law_m", functions=("rhs", "mass_matrix"), use_cache=False, progress=False,
                 formulation="recursive")


def _event_values(model, x, r):
    ffi = model.ffi
    out = ffi.new(f"double[{len(model.metadata['events'])}]")
    work = ffi.new("double[]", max(1, model.c_model.work_size))
    p = ffi.new("double[]", list(model.param_defaults))
    status = getattr(model.model_lib, f"{model.name}_events")(
        0.0, ffi.new("double[]", list(x)), p, ffi.new("double[]", list(r)), out, work)
    assert status == 0
    return [out[k] for k in range(len(model.metadata["events"]))]


def test_events_and_second_derivatives_that_read_the_solve_still_solve(tmp_path):
    kane, inputs = cart_relative(2, em)
    ud = [s.diff() for s in kane.u]
    qdd = [q.diff(t, 2) for q in kane.q]
    x = np.array([0.1, 0.4, -0.3, 0.2, -0.5, 0.7])
    r = np.array([0.8])
    ev = eomc.compile(kane, "ev_r", inputs=inputs, events={"a1": ud[1] - 0.25}, functions=["rhs", "events"],
                      progress=False, formulation="recursive", cache_dir=tmp_path)
    xd = ev.rhs(0.0, x, r=r)
    assert abs(xd[4]) > 0.1
    assert _event_values(ev, x, r) == pytest.approx([xd[4] - 0.25], rel=1e-12, abs=1e-13)
    acc = eomc.compile(kane, "qdd_r", inputs=inputs, outputs={"q2dd": qdd[2]}, functions=["rhs", "outputs"],
                       progress=False, formulation="recursive", cache_dir=tmp_path)
    assert acc.outputs(0.0, x, r=r)["q2dd"] == pytest.approx(xd[5], rel=1e-12, abs=1e-13)


def test_second_derivatives_are_differentiated_only_where_an_expression_holds_them():
    formed = formed_system(cart_relative(2, em)[0], "kane")
    W = tuple(sm.Symbol(f"w_{j}", real=True) for j in range(formed.nu))
    q1dd = formed.coordinates[1].diff(t, 2)
    _, qdd, _ = _solved_quantities(formed, W, [3 * q1dd + formed.speeds[0].diff(t)])
    assert list(qdd) == [q1dd]
    assert _solved_quantities(formed, W, [formed.speeds[0]])[1] == {}
    assert len(_solved_quantities(formed, W)[1]) == formed.nq      # without expressions: all of them
