"""The C integrators under AddressSanitizer and UBSan (a plain C driver, no Python in the loop)."""
import shutil
import subprocess

import pytest

from helpers.stand_in import MODELS_DIR, SOURCES, RUNTIME_C


def test_integrators_clean_under_address_and_undefined_sanitizers(tmp_path):
    if shutil.which("gcc") is None:
        pytest.fail("gcc is required for the C integrator tests")
    exe = tmp_path / "sanitize_driver"
    cmd = ["gcc", "-std=c99", "-g1", "-O1", "-Wall", "-Wextra", "-Werror",
           "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
           f"-I{RUNTIME_C}", "-o", str(exe), str(MODELS_DIR / "sanitize_driver.c"),
           *(str(MODELS_DIR / s) for s in SOURCES), str(RUNTIME_C / "eomc_integrators.c"),
           str(RUNTIME_C / "eomc_fixedstep.c"), str(RUNTIME_C / "eomc_fixedstep_avx2.c"), str(RUNTIME_C / "eomc_bdf.c"), "-lm"]
    build = subprocess.run(cmd, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120,
                          env={"ASAN_OPTIONS": "detect_leaks=1", "UBSAN_OPTIONS": "print_stacktrace=1"})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "SANITIZE OK" in proc.stdout and "runtime error" not in proc.stderr
