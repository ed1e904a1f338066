"""examples/embed_cortex_m: the float C of a 7-dof arm (rhs, jac_x, step_rk4) and a floating-base
quadruped (rhs) cross-compiled for a Cortex-M4 with its FPU and run under QEMU; every number
the firmware prints (as float bits) is checked against the host's double build at the very
same inputs, within a bound set by the mass matrix's condition number."""
import os
import shutil
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import eomc
from eomc.compiler.urdf.model import with_options

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "embed_cortex_m"
EPS32 = float(np.finfo(np.float32).eps)

pytestmark = pytest.mark.skipif(
    any(shutil.which(t) is None for t in ("make", "arm-none-eabi-gcc", "qemu-system-arm")),
    reason="the Cortex-M toolchain or QEMU is not installed (.ci/run installs them from Debian)")


def _floats(words):
    return np.array([struct.unpack("<f", bytes.fromhex(w)[::-1])[0] for w in words], dtype=np.float32)


def parse(stdout):
    """[(model, what, status, float32 values)] in order."""
    rows = []
    for line in stdout.splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[2].isdigit():
            rows.append((parts[0], parts[1], int(parts[2]), _floats(parts[3:])))
    return rows


@pytest.fixture(scope="module")
def firmware(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cortex_m")
    env = dict(os.environ, EOMC_CACHE_DIR=str(tmp / "cache"))
    common = [f"BUILD={tmp / 'build'}", f"EOMC={sys.executable} -m eomc", f"PYTHON={sys.executable}"]
    make = subprocess.run(["make", "-C", str(EXAMPLE), *common], capture_output=True, text=True,
                          timeout=900, env=env)
    assert make.returncode == 0, make.stdout[-3000:] + make.stderr[-3000:]
    # semihosting's text comes out on QEMU's stderr or stdout depending on its version: both read
    run = subprocess.run(["make", "-s", "-C", str(EXAMPLE), *common, "run"], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, timeout=300, env=env)
    assert run.returncode == 0 and run.stdout.rstrip().endswith("done"), run.stdout[-2000:]
    size = subprocess.run(["make", "-s", "-C", str(EXAMPLE), *common, "size"], capture_output=True,
                          text=True, timeout=60, env=env)
    return tmp / "build", parse(run.stdout), size.stdout


@pytest.fixture(scope="module")
def doubles(firmware):
    build, _, _ = firmware
    cache = build.parent / "cache"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        arm = eomc.compile(str(_robot("xarm_description/urdf/xarm7.urdf")), "arm64",
                           functions=["rhs", "jac_x", "mass_matrix"], cache_dir=cache, progress=False)
        source, _ = with_options(str(_robot("solo_description/robots/solo12.urdf")), "quad64", floating_base=True)
        quad = eomc.compile(source, "quad64", functions=["rhs", "mass_matrix"], cache_dir=cache, progress=False)
    return arm, quad


def _robot(rel):
    from tests.helpers.robots import robot_path
    return robot_path(rel)


def _bound(model, x, p, ref):
    """64·eps32·cond(M)·(|xdot| + |f|/min diag M): float's rounding through the solve."""
    M = model.mass_matrix(0.0, x, p)
    return 64 * EPS32 * np.linalg.cond(M) * (np.abs(ref).max() + 1.0)


def test_firmware_rhs_and_jacobian_match_double(firmware, doubles):
    _, rows, _ = firmware
    arm, quad = doubles
    models = {"arm": arm, "quad": quad}
    p32 = {k: np.float32(m.param_defaults).astype(np.float64) for k, m in models.items()}
    checked = {"arm rhs": 0, "arm jac_x": 0, "quad rhs": 0, "arm step_rk4": 0}
    x = None
    for model, what, status, values in rows:
        if model not in models:
            continue
        m = models[model]
        if what == "x":
            x = values.astype(np.float64)
            continue
        assert status == 0, (model, what)
        r = np.zeros(m.ninput)
        if what == "rhs":
            ref = m.rhs(0.0, x, p32[model], r)
            assert np.abs(values - ref).max() <= _bound(m, x, p32[model], ref), (model, values, ref)
            assert np.abs(values - ref).max() <= 1e-3 * (np.abs(ref).max() + 1.0)
        elif what == "jac_x":
            ref = m.jacobian(0.0, x, p32[model], r).ravel()
            scale = np.abs(ref).max()
            assert np.abs(values - ref).max() <= 64 * EPS32 * np.linalg.cond(m.mass_matrix(0.0, x, p32[model])) * scale
        elif what == "step_rk4":
            h = 0.001
            k1 = m.rhs(0.0, x, p32[model], r)
            k2 = m.rhs(h / 2, x + h / 2 * k1, p32[model], r)
            k3 = m.rhs(h / 2, x + h / 2 * k2, p32[model], r)
            k4 = m.rhs(h, x + h * k3, p32[model], r)
            ref = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            assert np.abs(values - ref).max() <= 1e-3 * (np.abs(ref).max() + 1.0), (values, ref)
        checked[f"{model} {what}"] += 1
    assert checked == {"arm rhs": 8, "arm jac_x": 8, "quad rhs": 8, "arm step_rk4": 1}


def test_instruction_counts_and_sizes_are_reported(firmware):
    build, rows, size = firmware
    ticks = {what: float(v[0]) for model, what, _, v in rows if model == "ticks"}
    # -icount shift=0 and SysTick at 25 MHz: 40 instructions a tick, checked by a known loop
    assert ticks["calibration_20000_instructions"] == pytest.approx(500, abs=2)
    assert 0 < ticks["arm_rhs"] < ticks["arm_jac_x"]
    assert "arm.o" in size and "firmware.elf" in size
    assert (build / "arm.ci").is_file()   # the ARM stack figures (benchmarks/bench_embedded.py)
