"""Every generated function, not only the default set, compiles under
``gcc -std=c99 -pedantic -Wall -Wextra -Werror -O2`` on a handful of models: a SymPy mechanics
System with inputs and outputs, a closed loop (Kane's constraints and the recursive form's tree
closed by them), a URDF arm with joint laws, a floating-base URDF robot with ground contacts, an
MJCF tree whose bodies touch each other (self-pairs) over a floor.

Why: the strict tests elsewhere (test_c_quality, the batch tests) build the default set or a few
functions, and the on-request ones (hvp, hess_id, jac_x_batch, implicit_batch ...) on the models
that need them most went unchecked: session 12 left unused temporaries in hess_id and hvp, and
jac_x_batch on a URDF robot with ground contacts did not compile at all.

Each case asks for the whole of FUNCTION_ORDER less what its formulation refuses (named below,
with the reason): a function added to the generator is checked here without editing this file.
The same -O2 the builder uses, so gcc's flow warnings (-Wmaybe-uninitialized) are in."""
import shutil
import subprocess
import warnings
from pathlib import Path

import pytest

from eomc.compiler.build.builder import shipped_c_dir
from eomc.compiler.driver import generate
from eomc.compiler.emit.signatures import FUNCTION_ORDER

from helpers.emit_support import STRICT, write_sources
from helpers.urdf_arm import FLOATING_FEET, LAW_ARM

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
RECURSIVE_ONLY = {"regressor", "jac_id", "hess_id", "implicit", "implicit_batch"}
KANE_ONLY = {"jvp_more"}
NO_GROUND = {"implicit", "implicit_batch"}            # the recursive form builds them with ground contacts only
CLOSED = {"regressor", "jac_id", "vjp", "hvp", "hess_id"}   # need the open tree / M without multipliers


def _limbs_over_floor(directory):
    from test_narrow import LIMBS        # capsules and spheres on a ball joint (tests/compiler/contact)
    from eomc.compiler.mjcf.model import MjcfModel
    path = directory / "limbs.xml"
    path.write_text(LIMBS.replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="2 2 0.1"/>'))
    return MjcfModel(path, pairs=True), {}


def _cartpole(directory):
    return EXAMPLES / "cart_pole_system.py", {}


def _four_bar(directory):
    return EXAMPLES / "four_bar_system.py", {}


def _arm(directory):
    path = directory / "arm.urdf"
    path.write_text(LAW_ARM)
    return path, {}


def _hopper(directory):
    from eomc.compiler.urdf.model import UrdfModel
    path = directory / "hop.urdf"
    path.write_text(FLOATING_FEET)
    return UrdfModel(path, floating_base=True), {"contacts": "@collision"}


# name: (model, formulation, functions refused, functions absent for the model's lack of
# inputs, outputs, events, constraints or an energy output (NAME_energy))
CASES = {
    "system-kane": (_cartpole, "kane", RECURSIVE_ONLY, {"constraints", "constraints_jac", "events", "energy"}),
    "system-recursive": (_cartpole, "recursive", KANE_ONLY | NO_GROUND, {"constraints", "constraints_jac", "events",
                                                                       "energy"}),
    "closed-kane": (_four_bar, "kane", RECURSIVE_ONLY | {"vjp", "hvp"}, {"events", "energy"}),
    "closed-recursive": (_four_bar, "recursive", KANE_ONLY | NO_GROUND | CLOSED, {"events", "energy"}),
    # its limits give it the energy output (and NAME_energy) since session 17
    "urdf-arm": (_arm, "recursive", KANE_ONLY | NO_GROUND, {"constraints", "constraints_jac", "events"}),
    "urdf-floating-contacts": (_hopper, "recursive", KANE_ONLY, {"constraints", "constraints_jac"}),
    "mjcf-self-pairs": (_limbs_over_floor, "recursive", KANE_ONLY, {"jac_r", "constraints", "constraints_jac"}),
}
SLOW = {"mjcf-self-pairs"}      # the pairs' narrow phases: ~10 s to generate, ~35 s of gcc -O2


def _compile(gm, directory):
    """gcc's errors and warnings (empty when clean) of the model's C, compiled as the builder
    does (the shipped headers, the lanes' width set) under the strict flags."""
    source = write_sources(gm, str(directory))
    proc = subprocess.run([shutil.which("gcc"), *STRICT, "-O2", "-fPIC", f"-I{shipped_c_dir()}",
                           "-DEOMC_BATCH_LANES=4", "-c", source, "-o", f"{gm.name}.o"], cwd=directory,
                          capture_output=True, text=True)
    return "" if proc.returncode == 0 else proc.stderr


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.slow) if c in SLOW else c for c in CASES])
def test_every_function_compiles_strict(case, tmp_path, monkeypatch):
    make, formulation, refused, absent = CASES[case]
    if case.startswith("mjcf"):
        pytest.importorskip("mujoco")
        monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "contact"))
    model, options = make(tmp_path)
    asked = [f for f in FUNCTION_ORDER if f not in refused]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, gm = generate(model, "every", functions=asked, formulation=formulation, progress=False,
                         cache_dir=tmp_path / "cache", **options)
    built = gm.metadata["functions"]
    assert set(asked) - set(built) == set(absent), "functions asked for but not generated"
    assert _compile(gm, tmp_path) == ""
