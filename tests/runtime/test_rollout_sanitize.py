"""eomc_rollout (runtime/c/eomc_rollout.c) under ThreadSanitizer and under ASan/UBSan: a plain C
driver runs 9 rows on 3 threads and compares each with a single eomc_integrate call byte for byte."""
import shutil
import subprocess

import pytest

from helpers.stand_in import MODELS_DIR, SOURCES, RUNTIME_C


@pytest.mark.parametrize("sanitizers", ["thread", "address,undefined"])
def test_rollout_threads_clean_under_sanitizers(tmp_path, sanitizers):
    if shutil.which("gcc") is None:
        pytest.fail("gcc is required for the C rollout tests")
    exe = tmp_path / "rollout_driver"
    cmd = ["gcc", "-std=c99", "-g1", "-O1", "-Wall", "-Wextra", "-Werror", "-pthread",
           f"-fsanitize={sanitizers}", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
           f"-I{RUNTIME_C}", "-o", str(exe), str(MODELS_DIR / "rollout_driver.c"),
           *(str(MODELS_DIR / s) for s in SOURCES), str(RUNTIME_C / "eomc_integrators.c"),
           str(RUNTIME_C / "eomc_fixedstep.c"), str(RUNTIME_C / "eomc_fixedstep_avx2.c"), str(RUNTIME_C / "eomc_bdf.c"), str(RUNTIME_C / "eomc_rollout.c"), "-lm"]
    build = subprocess.run(cmd, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120,
                          env={"ASAN_OPTIONS": "detect_leaks=1", "UBSAN_OPTIONS": "print_stacktrace=1",
                               "TSAN_OPTIONS": "halt_on_error=1"})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "ROLLOUT SANITIZE OK" in proc.stdout and "WARNING: ThreadSanitizer" not in proc.stderr
