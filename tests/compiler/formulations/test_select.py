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
from eomc.compiler.formulations.select import rhs_cost

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
    counts = gm.metadata["op_counts"]["rhs"]
    assert rhs_cost(counts, gm.metadata["formulation"], gm.metadata["nu"]) == min(costs.values())


def test_the_cost_weighs_calls_divisions_and_kanes_arithmetic():
    """auto's cost model (issue 31 item 5, refitted by task autocost): at equal counts a call
    outweighs 30 flops, and Kane's arithmetic weighs more than the recursion's, the more so the
    more speeds the model has (benchmarks/results/auto_choice.md)."""
    flops = {"adds": 10, "muls": 10, "divs": 0, "calls": 0}
    assert rhs_cost(flops, "recursive", 2) == rhs_cost(flops, "recursive", 6) == 20
    assert 20 < rhs_cost(flops, "kane", 2) == 21 < rhs_cost(flops, "kane", 3) == 23 < rhs_cost(flops, "kane", 6) == 31
    assert rhs_cost({"adds": 0, "muls": 0, "divs": 0, "calls": 1}, "recursive", 2) > 30
    assert rhs_cost({"adds": 0, "muls": 0, "divs": 1, "calls": 0}, "recursive", 2) > 1
    # the cart at n = 4 (the r4 report): Kane 425 flops + 20 calls, recursive 507 + 8
    assert (rhs_cost({"adds": 200, "muls": 225, "divs": 0, "calls": 20}, "kane", 5)
            > rhs_cost({"adds": 250, "muls": 257, "divs": 0, "calls": 8}, "recursive", 5))


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


def test_rhs_grows_linearly_with_the_chain(monkeypatch):
    """Each added middle link costs the same operations: the traced DAG is linear in n (the
    straight-line rhs: the cart of 6 has a run of 5 identical links, looped by default)."""
    from eomc.compiler.tree import chain_loop
    monkeypatch.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", None)
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
    from eomc.compiler.formulations.select import kane_solve_floor
    kane, inputs = cart_relative(n, em)
    spec, gm = generate(kane, "m", functions=["rhs"], formulation="kane", inputs=inputs,
                        use_cache=False, progress=False)
    floor = kane_solve_floor(spec.formed)
    assert 0 < floor < _total(gm)


def test_auto_skips_lowering_kane_when_its_solve_alone_costs_more(monkeypatch):
    from eomc.compiler.formulations import select
    kane, inputs = cart_relative(2, em)
    monkeypatch.setattr(select, "kane_solve_floor", lambda formed: 10 ** 9)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert gm.metadata["formulation"] == "recursive"
    assert gm.metadata["formulation_costs"]["kane"].startswith(">= 1170000000")   # 10**9 x Kane's flop weight at 3 speeds (1.17)
    monkeypatch.setattr(select, "kane_solve_floor", lambda formed: 0)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert isinstance(gm.metadata["formulation_costs"]["kane"], int)


# --- auto as the default (issue 19) ---------------------------------------------------------

def test_auto_is_the_default_of_generate_compile_and_the_commands():
    import inspect as pyinspect
    import argparse
    from eomc.compiler import driver
    from eomc.cli import build, check, linearize, report
    from eomc.cli import common
    for fn in (driver.generate, driver.compile, common.load_model):
        assert pyinspect.signature(fn).parameters["formulation"].default == "auto", fn
    for module in (build, check, linearize, report):
        parser = argparse.ArgumentParser()
        module.configure(parser)
        assert parser.get_default("formulation") == "auto", module


def test_auto_with_the_default_functions_on_a_formed_kanes_method():
    """The crash of the 2026-11 reports (select.py: `"rhs" in None`): the default function set."""
    kane, inputs = cart_relative(2, em)
    gm = _gen(kane, "auto", None, inputs=inputs)
    assert "linearize" in gm.metadata["functions"]
    costs = gm.metadata["formulation_costs"]
    assert gm.metadata["formulation"] == min(costs, key=costs.get)


@pytest.mark.parametrize("n, expected", [(1, "kane"), (3, "recursive"), (4, "recursive"),
                                         (8, "recursive")])
def test_auto_on_the_cart_system_kane_at_1_link_recursive_from_3(n, expected, monkeypatch):
    """A System of joints (equations not formed): Kane's are formed and compared only for a
    small tree; from 3 links (a chain of 4 joints, select.kane_skip_reason) they are not formed
    at all.  By cost, Kane's rhs (sin/cos of sums of angles: 12 calls at n = 3, 20 at n = 4,
    against 6 and 8) is kept only at n = 1, where it is measured faster
    (benchmarks/results/auto_choice.md); n = 3 and 4 pick the recursive rhs as before, now
    without forming Kane's (session 25: before, they were formed and lost, 579/491 and 1003/836)."""
    from eomc.compiler.mechanics import unformed
    formed = []
    original = unformed.form_system
    monkeypatch.setattr(unformed, "form_system", lambda s: formed.append(s) or original(s))
    system, inputs = cart_joints(n)
    gm = _gen(system, "auto", ["rhs"], inputs=inputs)
    assert gm.metadata["formulation"] == expected
    costs = gm.metadata["formulation_costs"]
    if n == 1:
        assert costs["kane"] < costs["recursive"] and formed
    else:
        assert str(costs["kane"]).startswith("not formed") and not formed


def _forming_counted(monkeypatch):
    from eomc.compiler.mechanics import unformed
    formed = []
    original = unformed.form_system
    monkeypatch.setattr(unformed, "form_system", lambda s: formed.append(s) or original(s))
    return formed


@pytest.mark.parametrize("n", [3, 4, 5])
def test_auto_does_not_form_kanes_equations_for_a_chain_of_more_than_3_joints(n, monkeypatch, capsys):
    """Task autoskip: the cart at n links is a chain of n + 1 joints; past 3, Kane's rhs has not won
    on any tree measured (benchmarks/results/auto_skip.md), so auto keeps the recursive rhs without
    forming Kane's equations, and the metadata and the build's formulation line say why.  With the
    skip off, the same builds form them (so it is the skip that saves them) and still pick the
    recursive rhs: the choice is the same either way."""
    from eomc.compiler.formulations import select
    from eomc.cli.build import formulation_line
    formed = _forming_counted(monkeypatch)
    system, inputs = cart_joints(n)
    gm = _gen(system, "auto", None, inputs=inputs)
    why = f"not formed (a chain of {n + 1} joints > 3: Kane's rhs has not won there)"
    assert gm.metadata["formulation"] == "recursive" and not formed
    assert gm.metadata["formulation_costs"]["kane"] == why
    assert why in formulation_line(gm.metadata, "auto")
    monkeypatch.setattr(select, "AUTO_SKIP_KANE", False)
    system, inputs = cart_joints(n)
    before = _gen(system, "auto", None, inputs=inputs)
    costs = before.metadata["formulation_costs"]
    assert formed and before.metadata["formulation"] == "recursive" and costs["kane"] > costs["recursive"]
    assert before.c_source == gm.c_source       # the same C: the skip changes the build time only


@pytest.mark.parametrize("n, expected", [(1, "kane"), (2, "recursive")])
def test_the_short_cart_is_compared_kane_kept_at_1_link_recursive_at_2(n, expected, monkeypatch):
    """A chain of at most 3 joints is still compared (Kane's equations formed).  The cart at 1 link
    keeps Kane's rhs (measured 15.2 against 18.4 ns); at 2 links the recursive one, measured 1.12x
    faster (39.3 against 44.0 ns, task autocost, benchmarks/results/auto_choice.md): Kane's 2 more
    sin/cos calls and its dearer arithmetic at 3 speeds outweigh its 71 fewer flops (the cost model
    before, a call 25 and Kane's flop 1.15 whatever the speeds, kept Kane's: 276 against 278)."""
    formed = _forming_counted(monkeypatch)
    system, inputs = cart_joints(n)
    gm = _gen(system, "auto", ["rhs"], inputs=inputs)
    costs = gm.metadata["formulation_costs"]
    assert formed and isinstance(costs["kane"], int)
    assert gm.metadata["formulation"] == expected == min(costs, key=costs.get)


@pytest.mark.parametrize("rel, expected", [
    ("bolt_description/robots/bolt.urdf", "recursive"),
    ("double_pendulum_description/urdf/double_pendulum.urdf", "kane"),
    ("asr_twodof_description/urdf/TwoDofs.urdf", "kane")])
def test_auto_picks_the_measured_faster_rhs_on_the_small_urdf_trees(rel, expected):
    """Task autocost: the picks whose measured gap is over 10 % (benchmarks/results/auto_choice.md,
    both rhs at the default flags, 3 harness copies).  Bolt (6 speeds, two 3-joint legs): the
    recursive rhs, 1.10-1.13x faster (two runs), where the cost model before kept Kane's (1836 against 1993: it
    weighed Kane's flop the same at 6 speeds as at 2).  The double pendulum and TwoDofs (2 speeds):
    Kane's, 1.13x and 1.26x faster."""
    from eomc.compiler.urdf.model import UrdfModel
    from helpers.robots import robot_path
    gm = generate(UrdfModel(robot_path(rel)), "m", functions=["rhs"], formulation="auto",
                  use_cache=False, progress=False)[1]
    costs = gm.metadata["formulation_costs"]
    assert isinstance(costs["kane"], int) and isinstance(costs["recursive"], int)   # both formed
    assert gm.metadata["formulation"] == expected == min(costs, key=costs.get)


def test_chain_length_counts_moving_joints_on_the_longest_path():
    """Bolt's two 3-joint legs are two chains of 3 (compared: Kane's rhs is cheaper there by cost),
    a 6-joint arm one chain of 6; a free joint counts once, a fixed one not at all; a tree closed
    by constraints is always compared."""
    from types import SimpleNamespace as NS
    from eomc.compiler.formulations.select import chain_length, kane_skip_reason

    def tree(shape, loops=None):    # (parent, number of speeds) per body
        return NS(bodies=[NS(parent=p, dofs=(None,) * k) for p, k in shape], loops=loops)
    legs = tree([(-1, 1), (0, 1), (1, 1), (-1, 1), (3, 1), (4, 1)])
    arm = tree([(-1, 1), (0, 1), (1, 0), (2, 1), (3, 1), (4, 1), (5, 1)])
    assert chain_length(legs) == 3 and kane_skip_reason(legs) is None
    assert chain_length(arm) == 6 and "a chain of 6 joints > 3" in kane_skip_reason(arm)
    assert chain_length(tree([(-1, 6), (0, 1), (1, 1)])) == 3
    assert chain_length(tree([])) == 0
    assert kane_skip_reason(tree([(-1, 1)] + [(k, 1) for k in range(5)], loops=object())) is None


def test_auto_does_not_ask_a_kanes_method_for_its_formed_equations_on_a_large_tree(monkeypatch):
    """A model file's KanesMethod: auto reads its tree from bodies, loads and kinematics; the
    formed equations (which eomc's KanesMethod may form lazily) are not asked for."""
    from eomc.compiler.mechanics.kane import KanesMethod
    kane, inputs = cart_relative(7, em)
    asked = []
    original = KanesMethod.formed
    monkeypatch.setattr(KanesMethod, "formed", lambda self: asked.append(1) or original(self))
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert gm.metadata["formulation"] == "recursive" and not asked
    gm = _gen(kane, "kane", ["rhs"], inputs=inputs)
    assert asked


def test_auto_falls_back_to_kane_when_the_recursive_lowering_fails(monkeypatch):
    """Anything the recursive path raises: Kane's form, with the reason in the metadata."""
    from eomc.compiler.formulations import select
    def broken(*args, **kwargs):
        raise RuntimeError("a bug in the recursion")
    monkeypatch.setattr(select, "check_tree_finite", broken)
    kane, inputs = cart_relative(2, em)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert gm.metadata["formulation"] == "kane"
    assert "RuntimeError: a bug in the recursion" in gm.metadata["formulation_note"]
    with pytest.raises(RuntimeError):
        _gen(kane, "recursive", ["rhs"], inputs=inputs)


def test_auto_keeps_the_recursive_form_when_kanes_fails(monkeypatch):
    from eomc.compiler.formulations import select
    original = select._generate_kane

    def broken(spec, *args):
        raise ModelError("kane broke here")
    monkeypatch.setattr(select, "_generate_kane", broken)
    kane, inputs = cart_relative(2, em)
    gm = _gen(kane, "auto", ["rhs"], inputs=inputs)
    assert gm.metadata["formulation"] == "recursive"
    assert gm.metadata["formulation_note"] == "recursive (kane formulation: kane broke here)"
    monkeypatch.setattr(select, "_generate_kane", original)


# --- no NaN or inf constant in generated C ---------------------------------------------------

def _spring_on_a_pathway(nan_force=False):
    """A carriage on a slider with a LinearSpring and LinearDamper on a LinearPathway and a
    pendulum below it (the hanging arm of the 2026-11 first-hour report, smaller)."""
    import sympy as sm
    import sympy.physics.mechanics as me
    q0, q1, u0, u1 = me.dynamicsymbols("q0 q1 u0 u1")
    M, m, L, k, c, h, g = sm.symbols("M m L k c h g", positive=True)
    ceiling = me.RigidBody("ceiling")
    carriage = me.RigidBody("carriage", mass=M)
    carriage.central_inertia = me.inertia(carriage.frame, 0, 0, M / 10)
    link = me.RigidBody("link", mass=m)
    link.central_inertia = me.inertia(link.frame, 0, 0, m * L ** 2 / 12)
    system = me.System.from_newtonian(ceiling)
    system.add_joints(
        me.PrismaticJoint("slider", ceiling, carriage, q0, u0, joint_axis=-ceiling.y),
        me.PinJoint("pin", carriage, link, q1, u1, child_point=L / 2 * link.y, joint_axis=carriage.z))
    pathway = me.LinearPathway(ceiling.masscenter, carriage.masscenter)
    system.add_actuators(me.LinearSpring(k, pathway, equilibrium_length=h), me.LinearDamper(c, pathway))
    if nan_force:
        # (SymPy's Vector cannot be multiplied by nan; built from its components instead)
        system.add_loads(me.Force(link.masscenter, me.Vector([(sm.Matrix([sm.nan, 0, 0]),
                                                               ceiling.frame)])))
    system.apply_uniform_gravity(-g * ceiling.y)
    return system


def test_a_nan_in_a_load_is_refused_naming_the_body_and_what_acts_there():
    system = _spring_on_a_pathway(nan_force=True)
    with pytest.raises(ModelError, match=r"recursive formulation: the force of load \d+ on body "
                                         r"link \(joint pin; acting there: Force"):
        _gen(system, "recursive", ["rhs"])
    with pytest.raises(ModelError, match=r"the forcing row \d contains nan"):
        _gen(system, "kane", ["rhs"])
    with pytest.raises(ModelError, match=r"contains nan.*auto tried the recursive form first"):
        _gen(system, "auto", ["rhs"])


def test_the_printer_refuses_a_nonfinite_constant_naming_the_function():
    """The last guard: whatever reaches the printer (here an output that skipped the model's
    validation), no NAN/HUGE_VAL literal is written; the error names the function."""
    import sympy as sm
    from eomc.compiler.emit import generate_c
    from eomc.compiler.model import model_spec
    from eomc.compiler.emit.formulation import KANE
    from eomc.compiler.formulations.recursive import Recursive
    from eomc.compiler.formulations.select import _find_tree
    kane, inputs = cart_relative(1, em)
    spec = model_spec(kane, inputs=inputs)
    for bad, formulation in ((sm.nan, KANE), (sm.oo, Recursive(_find_tree(spec)))):
        with pytest.raises(ModelError, match=rf"m_outputs would compute the constant {bad}"):
            generate_c(spec.formed, "m", functions=["rhs", "outputs"], inputs=inputs,
                       formulation=formulation, outputs={"bad": bad + kane.q[0]})


def test_spring_and_damper_on_a_pathway_never_writes_nan():
    """The reported case: recursive either agrees with Kane or is refused before C, and auto
    builds (recursive or Kane) without a NaN literal."""
    system = _spring_on_a_pathway()
    gm = _gen(system, "auto", ["rhs"])
    assert "NAN" not in gm.c_source
    try:
        rec = _gen(system, "recursive", ["rhs"])
    except ModelError as exc:
        assert "carriage" in str(exc)
    else:
        assert "NAN" not in rec.c_source


IMPLICIT_LIMBS = """<mujoco model="limbs"><worldbody>
<body name="a" pos="0 0 0.3"><freejoint/><geom name="ga" type="sphere" size="0.05"/></body>
<body name="b" pos="0.08 0 0.3"><freejoint/><geom name="gb" type="sphere" size="0.05"/></body>
</worldbody></mujoco>"""


def _implicit_refusal(model, formulation, **kw):
    with pytest.raises(ModelError) as info:
        _gen(model, formulation, ["rhs", "implicit"], **kw)
    return str(info.value)


def test_implicit_refused_for_its_real_reason_first(tmp_path):
    """functions=["implicit"] where it cannot be built: the message opens with what implicit is and
    needs, then this model's reason in the user's words (bodies, ground contacts, the options that
    give them), not formulation internals.  An MJCF file without a floor said "an MJCF model has
    the recursive formulation only ..." first and the real reason (no ground contacts) last, in
    parentheses."""
    pytest.importorskip("mujoco")
    from eomc.compiler.mjcf.model import MjcfModel
    opening = ("implicit (the terms of method='implicitfast') needs a tree of bodies, with ground contacts where its "
               "bodies touch")
    path = tmp_path / "limbs.xml"          # two balls that touch each other, no floor
    path.write_text(IMPLICIT_LIMBS)
    for formulation in ("auto", "recursive"):
        text = _implicit_refusal(MjcfModel(path, pairs=True), formulation)
        assert text.startswith(opening), text
        assert "this model's bodies touch each other but no ground" in text
        assert "a plane geom in the file's worldbody" in text and "--contact" in text
        assert "build without 'implicit'" in text and "recursive formulation only" not in text
    arm = tmp_path / "arm.urdf"
    from helpers.urdf_arm import ARM
    arm.write_text(ARM)
    # a tree that touches nothing has NAME_implicit on request (its joint laws' slopes: session 53)
    assert "implicit" in _gen(arm, "auto", ["rhs", "implicit"]).metadata
    text = _implicit_refusal(arm, "kane")
    assert text.startswith(opening) and "this build is Kane's formulation" in text, text
    assert "formulation='recursive'" in text


def test_nonfinite_finds_each_constant_in_order_through_shared_subtrees():
    """select.nonfinite walks each distinct subexpression once (it was four has() walks of the
    whole tree, ~3.2 s CPU of so101's build; benchmarks/bench_nonfinite_check.py): the answer is the
    one has() gives, the first of nan, zoo, oo, -oo present, however deep and shared."""
    import sympy as sm
    from eomc.compiler.formulations.select import nonfinite
    x, f = sm.Symbol("x"), sm.Function("f")
    e = sm.sin(x)
    for _ in range(18):                    # a DAG: 2**18 paths through one chain of nodes
        e = f(e, e)
    assert nonfinite(e) is None
    assert nonfinite(f(e, -sm.oo * x)) == -sm.oo
    assert nonfinite(f(e, sm.Max(x, -sm.oo))) is None   # Max drops -oo
    for bad in (sm.nan, sm.zoo, sm.oo, -sm.oo):
        assert nonfinite(f(e, sm.Piecewise((bad, x > 0), (x, True)))) == bad
    assert nonfinite(f(e, sm.Piecewise((sm.oo, x > 0), (sm.nan, True)))) == sm.nan   # nan first
    assert nonfinite(sm.Matrix([[x, f(e, sm.zoo)]])) == sm.zoo
    assert nonfinite(1.0) is None and nonfinite(float("inf")) == sm.oo


def _limited_hinge(tmp_path, **kw):
    """The one-hinge URDF arm with a limit and no contact (helpers.urdf_arm.LIMITED_HINGE) built
    with ``kw`` (rhs and outputs)."""
    import warnings
    import eomc
    from eomc.compiler.urdf.model import UrdfModel
    from helpers.urdf_arm import LIMITED_HINGE
    path = tmp_path / "arm.urdf"
    path.write_text(LIMITED_HINGE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(UrdfModel(path), functions=("rhs", "outputs"), progress=False,
                            cache_dir=tmp_path / kw.get("formulation", "auto"), **kw)


def test_auto_picks_kanes_cheaper_rhs_on_a_limited_urdf_arm_with_its_energy_output(tmp_path):
    """A one-joint URDF arm with a limit and no contact: its energy output (the limit's spring;
    the run's energy verdict reads it) was on the recursive side only (Kane's side is formed
    from the robot's SymPy System), so auto kept the recursive form though Kane's rhs costs less
    (select._kane_lacks, lead f4ab51fa; before that it picked Kane's and lost the output).  Kane's
    side now gets the same energy output (urdf.model._kane_energy): auto picks by cost again and
    the model keeps its output, whose text the runtime's verdict reads.  Before: formulation
    recursive, note "recursive (Kane's form has no output energy)"."""
    auto = _limited_hinge(tmp_path)
    costs = auto.metadata["formulation_costs"]
    assert costs["kane"] < costs["recursive"]
    assert auto.metadata["formulation"] == "kane" and "formulation_note" not in auto.metadata
    assert auto.output_names == ("energy",) and "joint limits" in auto.metadata["energy"]


def test_auto_does_not_pick_a_kane_form_that_lacks_the_models_outputs(tmp_path, monkeypatch):
    """Where Kane's side still lacks an output the recursive side has (here: the robot's energy
    output taken away from Kane's route, as it was before urdf.model._kane_energy), auto keeps
    the recursive form and says why, though Kane's rhs costs less: picking by cost dropped the
    output and the run's energy verdict (session 25, test_limit_energy in CI)."""
    import eomc.compiler.urdf.model as urdf_model
    monkeypatch.setattr(urdf_model, "_kane_energy", lambda read, system, overrides: (overrides, ()))
    kane = _limited_hinge(tmp_path, formulation="kane")
    auto = _limited_hinge(tmp_path)
    assert kane.output_names == ()
    costs = auto.metadata["formulation_costs"]
    assert costs["kane"] < costs["recursive"]           # Kane's would win by cost alone ...
    assert auto.metadata["formulation"] == "recursive" and auto.output_names == ("energy",)
    assert auto.metadata["formulation_note"].startswith("recursive (Kane's form has no output energy)")


def test_kane_lacks_names_outputs_and_events_only_where_the_build_evaluates_them():
    """select._kane_lacks on the candidates' metadata: what the recursive one has and Kane's not,
    outputs only where the build evaluates outputs (or energy), events where it evaluates events."""
    from types import SimpleNamespace
    from eomc.compiler.formulations.select import _kane_lacks

    def built(functions, outputs=(), events=()):
        return SimpleNamespace(metadata={"functions": list(functions), "output_names": list(outputs),
                                         "events": [{"name": e} for e in events]})
    full = ("rhs", "outputs", "events")
    assert _kane_lacks(built(full, ["energy"]), built(full, ["energy"])) == ""
    assert _kane_lacks(built(full), built(full, ["energy", "h"])) == "outputs energy, h"
    assert _kane_lacks(built(full, ["energy"]), built(full, ["energy"], ["hit"])) == "event hit"
    assert _kane_lacks(built(full), built(full, ["energy"], ["hit"])) == "output energy or event hit"
    assert _kane_lacks(built(("rhs",)), built(("rhs",), ["energy"], ["hit"])) == ""     # rhs only: nothing lost
    assert _kane_lacks(built(("rhs", "energy")), built(("rhs", "energy"), ["energy"])) == "output energy"


def test_auto_on_an_mjcf_model_names_the_recursive_form_as_the_only_one(tmp_path):
    """An MJCF model has no Kane's form (no SymPy System behind it).  auto on a small one (within
    the speeds it would compare) said "recursive (kane formulation: an MJCF model has the recursive
    formulation only: ...)", which reads as if the user had asked for Kane's and it failed (first
    hour, session 26: `eomc build hopper.xml`); it now gives the refusal as the reason of the choice."""
    pytest.importorskip("mujoco")
    from eomc.compiler.mjcf.model import MjcfModel
    path = tmp_path / "pendulum.xml"
    path.write_text('<mujoco model="pendulum"><worldbody><body name="arm">'
                    '<joint name="hinge" type="hinge" axis="0 1 0"/>'
                    '<geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05" mass="1"/>'
                    '</body></worldbody></mujoco>')
    note = _gen(MjcfModel(path), "auto", ["rhs"]).metadata["formulation_note"]
    assert note.startswith("recursive (an MJCF model has the recursive formulation only"), note
    assert "kane formulation:" not in note
