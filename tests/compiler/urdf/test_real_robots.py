"""Real URDFs that eomc used to refuse, straight to the tree, against Pinocchio.

HyQ (floating base; its base link's inertia has principal moments -4e-22 and a
triangle miss: repaired / kept with a warning), the Allegro hand (finger links
whose tensors miss the triangle inequality: kept as given, as Pinocchio does),
and Romeo (floating base; eight massless hands' fingers on 24 joints: locked and
merged -- Pinocchio's own ABA gives NaN there -- so Pinocchio's model gets the same
joints locked with buildReducedModel).  Built
under the recursive formulation from the file (no SymPy System); forward
dynamics, inverse dynamics and the mass matrix agree with ABA, RNEA and CRBA
to 1e-12 relative at random states.
"""
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.urdf import build_tree, read_urdf
from eomc.compiler.urdf.model import UrdfModel
from eomc.runtime.errors import EomcWarning
from helpers.robots import PinRef, relative_error, robot_path

CASES = {"hyq": ("hyq_description/robots/hyq_no_sensors.urdf", True),
         "allegro": ("allegro_hand_description/urdf/allegro_right_hand.urdf", False),
         "romeo": ("romeo_description/urdf/romeo.urdf", True)}
FUNCTIONS = ["rhs", "inverse_dynamics", "mass_matrix"]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    out = {}
    for name, (rel, floating) in CASES.items():
        path = robot_path(rel)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            tree = build_tree(read_urdf(path), floating_base=floating)
            model = eomc.compile(UrdfModel(path, floating_base=floating, limits=False), name, functions=FUNCTIONS,
                                 formulation="recursive", cache_dir=cache, progress=False)
        notes = [w.message for w in caught if issubclass(w.category, EomcWarning)]
        ref = PinRef(path, [(j.name, j.type) for j in tree.joints], floating=floating, locked=tree.locked)
        out[name] = model, ref, floating, notes, tree
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_agrees_with_pinocchio(built, name):
    model, ref, floating, _, _ = built[name]
    rng = np.random.default_rng(19)
    worst = 0.0
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, model.nq)
        if floating:
            q[:3], q[3:6] = rng.normal(size=3), rng.uniform(-1.2, 1.2, 3)
        v, tau, a = rng.normal(size=model.nu), rng.normal(size=model.ninput), rng.normal(size=model.nu)
        x = np.concatenate([q, v])
        worst = max(worst,
                    relative_error(model.rhs(0.0, x, r=tau)[model.nq:], ref.aba(q, v, tau)),
                    relative_error(model.inverse_dynamics(0.0, x, a, r=np.zeros(model.ninput)), ref.rnea(q, v, a)),
                    relative_error(model.mass_matrix(0.0, x), ref.mass_matrix(q)))
    assert worst < 1e-12, f"{name}: {worst:.3g}"


def _kept(notes, link):
    """The kept-inertia note naming ``link`` in its one line, and its details' line for it (the note
    is one short line since c3e78551: each link's moments and line are its details, which
    `eomc inspect` prints)."""
    for n in notes:
        details = [d for d in getattr(n, "details", ()) if d.startswith(f"link '{link}' (line ")]
        if link in str(n) and "kept as given" in str(n) and details:
            return str(n), details
    return None, []


def test_each_repair_and_merge_is_one_warning_naming_the_link(built):
    _, _, _, notes, _ = built["hyq"]
    note, details = _kept(notes, "base_link")
    assert note is not None and "hyq_no_sensors.urdf:" in note, [str(n) for n in notes]
    _, _, _, notes, _ = built["allegro"]
    note, details = _kept(notes, "link_3.0")
    assert note is not None and "triangle" in note, [str(n) for n in notes]
    assert all("\n" not in str(n) for n in notes)
    model, ref, _, notes, tree = built["romeo"]
    assert len(tree.locked) == 24 and "LHand" in tree.locked
    assert any("link 'LFinger11Link'" in str(n) and "carries no mass" in str(n) and "joint 'LHand'" in str(n)
               for n in notes), [str(n) for n in notes]
    assert model.nu == ref.model.nv == 37          # 6 + 55 - 24
