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


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_c_program_matches_python(tmp_path):
    model_dir, program = tmp_path / "model", tmp_path / "embed"
    make = subprocess.run(
        ["make", "-C", str(EXAMPLE), f"MODEL_DIR={model_dir}", f"OUT={program}",
         f"EOMC={sys.executable} -m eomc", f"EOMC_FLAGS=--cache-dir {tmp_path / 'cache'}"],
        capture_output=True, text=True, timeout=300)
    assert make.returncode == 0, make.stdout + make.stderr
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
