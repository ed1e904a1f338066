"""Byte-for-byte golden C for two tiny models.

When a change to the generator is intended, regenerate with

    EOMC_REGEN_GOLDEN=1 python3 -m pytest tests/compiler/emit/test_golden.py

and review the diff of tests/compiler/emit/golden/ before committing it.
"""
import os

import pytest
import sympy as sm
from sympy.physics.vector import dynamicsymbols

from eomc.compiler.emit import generate_c
from eomc.compiler.mechanics.formed import FormedSystem

GOLDEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "golden")


def _formed(q, u, kin, M, f, params):
    return FormedSystem(method="kane", coordinates=(q,), speeds=(u,), n_dependent_coordinates=0,
                        n_dependent_speeds=0, kinematics=sm.Matrix([kin]),
                        dynamics_matrix=sm.Matrix([[M]]), dynamics_rhs=sm.Matrix([f]),
                        multipliers=(), holonomic_constraints=sm.zeros(0, 1),
                        velocity_constraints=sm.zeros(0, 1), inputs=(), parameters=params)


def mass_spring():
    x, v = dynamicsymbols("x v")
    m, k = sm.symbols("m k")
    return _formed(x, v, v, m, -k * x, (k, m)), {m: 1.0, k: 4.0}


def pendulum():
    th, om = dynamicsymbols("theta omega")
    m, g, l = sm.symbols("m g l")
    return _formed(th, om, om, m * l**2, -m * g * l * sm.sin(th), (g, l, m)), {m: 1.0, g: 9.81, l: 0.5}


def _normalized(text, gm):
    return text.replace(gm.metadata["eomc_version"], "VERSION")


@pytest.mark.parametrize("name,build", [("mass_spring", mass_spring), ("pendulum", pendulum)])
def test_golden(name, build):
    formed, params = build()
    gm = generate_c(formed, name, parameters=params)
    for ext, text in (("c", gm.c_source), ("h", gm.header)):
        path = os.path.join(GOLDEN, f"{name}.{ext}")
        text = _normalized(text, gm)
        if os.environ.get("EOMC_REGEN_GOLDEN"):
            with open(path, "w") as fh:
                fh.write(text)
        with open(path) as fh:
            expected = fh.read()
        assert text == expected, (
            f"{path} differs from the generator's output; if the change is intended run "
            "EOMC_REGEN_GOLDEN=1 python3 -m pytest tests/compiler/emit/test_golden.py "
            "and review the diff")


def test_ir_listing_names_temporaries_in_order():
    from eomc.compiler.emit import ir_listing
    formed, params = pendulum()
    text = ir_listing(formed, "pendulum", parameters=params, functions=["rhs"])
    assert text.startswith("# pendulum_rhs\n")
    assert "t0 = sin(x_0)" in text and "kin[0] <- x_1" in text


def test_a_zero_work_model_declares_a_work_array_in_strict_c99(tmp_path):
    """NAME_WORK_LEN: the mass-spring needs no work (WORK_SIZE 0), and the array an embedder
    declares from the header must still be legal C99 (a zero-length array is not)."""
    import shutil
    import subprocess
    formed, params = mass_spring()
    gm = generate_c(formed, "ms", parameters=params)
    assert "#define MS_WORK_SIZE 0\n" in gm.header
    (tmp_path / "ms.h").write_text(gm.header)
    (tmp_path / "use.c").write_text('#include "ms.h"\nint main(void) { double work[MS_WORK_LEN]; '
                                    'work[0] = 0.0; return (int)work[0]; }\n')
    cc = shutil.which("gcc") or shutil.which("cc")
    if cc is None:
        pytest.fail("no C compiler (gcc or cc) to check the header with")
    runtime_c = os.path.join(os.path.dirname(__import__("eomc.runtime").runtime.__file__), "c")
    done = subprocess.run([cc, "-std=c99", "-pedantic-errors", "-Wall", "-Wextra", "-Werror", "-I", runtime_c,
                           "-fsyntax-only", str(tmp_path / "use.c")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
