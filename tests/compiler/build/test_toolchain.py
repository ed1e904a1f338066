"""Compiler discovery: $CC, PATH search, the install hint when there is none; flags; interrupted compiles."""
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from eomc.compiler.build import find_compiler, resolve_cflags
from eomc.compiler.build.toolchain import install_hint
from eomc.errors import CompilerNotFoundError, EomcError


def test_finds_a_working_compiler_with_version():
    tc = find_compiler()
    assert os.path.isabs(tc.path) and os.access(tc.path, os.X_OK)
    assert tc.version  # `--version` ran


def test_cc_with_arguments_is_split(tmp_path):
    gcc = shutil.which("gcc") or shutil.which("cc")
    tc = find_compiler({"CC": f"{gcc} ", "PATH": os.environ["PATH"]})
    assert tc.argv == (gcc,)


def test_cc_pointing_nowhere_says_how_to_install(tmp_path):
    with pytest.raises(CompilerNotFoundError) as info:
        find_compiler({"CC": str(tmp_path / "no-such-cc"), "PATH": str(tmp_path)})
    message = str(info.value)
    assert "no-such-cc" in message and install_hint() in message
    assert "apt-get install gcc" in message or "xcode-select --install" in message


def test_no_compiler_on_path_says_how_to_install(tmp_path):
    (tmp_path / "cc").write_text("not executable")  # present but not runnable: skipped
    with pytest.raises(CompilerNotFoundError) as info:
        find_compiler({"PATH": str(tmp_path)})
    assert "no C compiler found" in str(info.value)
    assert install_hint() in str(info.value)
    assert isinstance(info.value, EomcError)


def test_cflags_default_and_override_keep_fpic():
    assert resolve_cflags(None) == ["-O2", "-fPIC", "-std=c99"]
    assert resolve_cflags("-O3 -march=native") == ["-O3", "-march=native", "-fPIC"]
    assert resolve_cflags(["-O1", "-fPIC"]) == ["-O1", "-fPIC"]


@pytest.mark.parametrize("flags", ["-Ofast", "-O2 -ffast-math", "-O2 -ffinite-math-only"])
def test_fast_math_keeps_the_non_finite_checks(flags):
    """F12: the flags that assume no NaN/inf get -fno-finite-math-only after them."""
    resolved = resolve_cflags(flags)
    assert resolved[-1] == "-fno-finite-math-only" and resolved[:len(flags.split())] == flags.split()
    assert resolve_cflags(flags + " -fno-finite-math-only").count("-fno-finite-math-only") == 1
    assert "-fno-finite-math-only" not in resolve_cflags("-O3 -march=native")


def test_nan_state_is_reported_under_ofast(tmp_path):
    """F12, the report's case: a model built with -Ofast still refuses a NaN state."""
    from helpers import model_files
    from eomc.compiler.driver import compile as compile_model
    from eomc.errors import SimulationError
    model = compile_model(model_files.write(tmp_path, model_files.PENDULUM, "p"), cflags="-Ofast -std=c99",
                          cache_dir=tmp_path / "c", progress=False)
    assert "-fno-finite-math-only" in model.metadata["build"]["cflags"]
    with pytest.raises(SimulationError, match="non-finite"):
        model.rhs(0.0, [float("nan"), 0.0])
    with pytest.raises(SimulationError, match="non-finite"):
        model.rhs(0.0, [0.3, 0.0], p=[2.0, 0.5, float("nan")])


@pytest.mark.parametrize("sig, status, word", [(signal.SIGINT, 130, "interrupted"),
                                                (signal.SIGTERM, 143, "terminated")])
def test_signal_to_eomc_alone_also_ends_its_compiler(tmp_path, sig, status, word):
    """F9: `kill -INT <eomc pid>` (a job runner, not a terminal) left cc1 compiling, orphaned."""
    from helpers import model_files
    from helpers.slow_cc import alive, slow_compiler, wait_for_pid
    script, pidfile = slow_compiler(tmp_path)
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    proc = subprocess.Popen([sys.executable, "-m", "eomc", "build", str(model), "-o", str(tmp_path / "o"),
                             "--cache-dir", str(tmp_path / "c"), "-q"], env={**os.environ, "CC": str(script)},
                            stderr=subprocess.PIPE, text=True)
    child = wait_for_pid(pidfile)
    try:
        assert alive(child)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == status and f"eomc build: {word}" in err
        deadline = time.time() + 10
        while alive(child) and time.time() < deadline:
            time.sleep(0.05)
        assert not alive(child)
        assert list((tmp_path / "c" / "v1" / "tmp").iterdir()) == []
    finally:
        if alive(child):
            os.kill(child, signal.SIGKILL)
