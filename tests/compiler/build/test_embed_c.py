"""examples/embed_c: a C program built with make against the generated header and library.

It integrates the double pendulum with its own fixed-step RK4; the result must
match an RK4 over the Python model's rhs step for step, and the runtime's own
rk4 integrator.
"""
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import eomc

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "embed_c"


def _rk4(model, x, dt, steps):
    t = 0.0
    for i in range(steps):
        k1 = model.rhs(t, x)
        k2 = model.rhs(t + 0.5 * dt, x + 0.5 * dt * k1)
        k3 = model.rhs(t + 0.5 * dt, x + 0.5 * dt * k2)
        k4 = model.rhs(t + dt, x + dt * k3)
        x = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        t = (i + 1) * dt
    return x


_SANITIZE = "-O1 -g -std=c99 -Wall -Wextra -Werror -fsanitize=address,undefined -fno-sanitize-recover=all"


@pytest.fixture(scope="module")
def program(tmp_path_factory):
    """The example built out of tree with make, under AddressSanitizer/UBSan (leaks on exit count)."""
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    tmp_path = tmp_path_factory.mktemp("embed")
    model_dir, program = tmp_path / "model", tmp_path / "embed"
    make = subprocess.run(
        ["make", "-C", str(EXAMPLE), f"MODEL_DIR={model_dir}", f"OUT={program}", f"CFLAGS={_SANITIZE}",
         f"EOMC={sys.executable} -m eomc", f"EOMC_FLAGS=--cache-dir {tmp_path / 'cache'}"],
        capture_output=True, text=True, timeout=300)
    assert make.returncode == 0, make.stdout + make.stderr
    return model_dir, program


def test_c_program_matches_python(program):
    model_dir, program = program
    x0 = np.array([1.0, -0.5, 0.2, 0.0])
    run = subprocess.run([str(program), "2", "0.001", *map(repr, x0.tolist())], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == "# double_pendulum t=2 steps=2000"
    names = [line.split()[0] for line in lines[1:]]
    final = np.array([float(line.split()[1]) for line in lines[1:]])

    model = eomc.load(model_dir)
    assert names == list(model.state_names) == ["q1", "q2", "u1", "u2"]
    np.testing.assert_allclose(final, _rk4(model, x0, 0.001, 2000), rtol=1e-10, atol=1e-12)
    result = model.simulate(x0, (0.0, 2.0), method="rk4", dt=0.001)
    np.testing.assert_allclose(final, np.asarray(result.x)[-1], rtol=1e-9, atol=1e-11)
    assert not (EXAMPLE / "embed").exists() and not (EXAMPLE / "build").exists()  # built out of tree


@pytest.mark.parametrize("args, message", [
    ("1 0 1 1 1 1", "need T_END >= 0 and DT > 0"),
    ("1 -0.01 1 1 1 1", "need T_END >= 0 and DT > 0"),
    ("inf 0.1 1 0 0 0", "T_END: must be finite"),
    ("1 1e-320 1 0 0 0", "at most 1e+09"),
    ("abc 0.1 0 0 0 0", "T_END: expected a number, got 'abc'"),
    ("1 0.01 nan 0 0 0", "q1: must be finite"),
    ("1 0.01 1x 0 0 0", "q1: expected a number, got '1x'"),
    ("1 0.01 1 2", "usage: "),
])
def test_bad_arguments_are_refused(program, args, message):
    """Reliability report 2026-11, F11: these printed x0 as the final state and exited 0."""
    run = subprocess.run([str(program[1]), *args.split()], capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and message in run.stderr and run.stdout == ""
    assert "Sanitizer" not in run.stderr


def test_a_failed_step_is_named_and_frees_everything(program):
    """F11: status 3 was printed as a bare number at the end of the step, and leaked 80 bytes."""
    run = subprocess.run([str(program[1]), "1", "0.01", "0", "0", "1e200", "0"], capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 1 and run.stdout == ""
    assert "rhs failed with status 3, EOMC_NONFINITE (a non-finite value appeared), in the step from t=0" \
        in run.stderr
    assert "Sanitizer" not in run.stderr and "leak" not in run.stderr


@pytest.mark.parametrize("cc", ["gcc", "clang"])
def test_name_c_compiles_into_a_program_as_docs_say(tmp_path_factory, cc):
    """docs/embedding.md (s30): without the library, NAME.c compiles into one's own program with
    the headers beside it and libm -- clean under -std=c99 -Wall -Wextra -pedantic (-Wno-psabi: gcc's
    note on the AVX2 helpers' vector arguments) and under ASan/UBSan -- and integrates as the
    library does.  Here gymnasium's hopper (contacts, limits, 76 parameters) from its qpos0."""
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed")
    gymnasium = pytest.importorskip("gymnasium")
    tmp = tmp_path_factory.mktemp(f"embed_src_{cc}")
    xml = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    model = eomc.compile(str(xml), cache_dir=tmp / "cache", output_dir=tmp / "hopper", progress=False)
    out = tmp / "embed"
    flags = _SANITIZE.replace("-Werror", "-pedantic -Werror -Wno-psabi").split()
    build = subprocess.run([cc, *flags, f"-I{tmp / 'hopper'}", '-DMODEL_HEADER="hopper.h"',
                            "-DMODEL_FN=hopper_model", "-o", str(out), str(EXAMPLE / "main.c"),
                            str(tmp / "hopper" / "hopper.c"), "-lm"], capture_output=True, text=True, timeout=300)
    assert build.returncode == 0 and not build.stderr.strip(), build.stderr
    x0 = np.asarray(model.initial_state, dtype=float)
    run = subprocess.run([str(out), "1", "0.001", *map(repr, x0.tolist())], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0 and not run.stderr, run.stderr
    final = np.array([float(line.split()[1]) for line in run.stdout.splitlines()[1:]])
    ref = model.simulate(x0, (0.0, 1.0), method="rk4", dt=0.001, t_eval=[1.0]).x_final
    assert np.max(np.abs(final - x0)) > 0.01          # it moved (falls onto its foot)
    np.testing.assert_allclose(final, ref, rtol=1e-9, atol=1e-11)
