"""The runtime's C where the x86-64 vector paths are off, as on another CPU (aarch64, a
microcontroller): eomc_fixedstep.c's lanes kernel and AVX2 copy are compiled only under
`__x86_64__ && __GNUC__` (EOMC_FS_LANES, EOMC_FS_AVX2), and what stays must still be clean
under -Wall -Wextra -Werror. Session 32: fsl_grow, used only by the lanes' kernel, was left
defined-but-unused there (a -Werror build on aarch64 would have failed)."""
import shutil
import subprocess

import pytest

from helpers.stand_in import RUNTIME_C

OFF = ["-DEOMC_NO_FS_LANES", "-DEOMC_NO_FS_AVX2"]


@pytest.mark.parametrize("source", sorted(p.name for p in RUNTIME_C.glob("*.c")))
def test_runtime_c_is_clean_with_the_x86_vector_paths_off(source, tmp_path):
    if shutil.which("gcc") is None:
        pytest.fail("gcc is required for the runtime C tests")
    cmd = ["gcc", "-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", *OFF, f"-I{RUNTIME_C}",
           "-c", str(RUNTIME_C / source), "-o", str(tmp_path / "out.o")]
    build = subprocess.run(cmd, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    if source.startswith("eomc_fixedstep"):   # the x86 paths were indeed off there
        symbols = subprocess.run(["nm", str(tmp_path / "out.o")], capture_output=True, text=True).stdout
        assert "fs_lanes_kernel" not in symbols and "eomc_fs_run_avx2" not in symbols, symbols
