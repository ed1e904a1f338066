"""Compiler discovery: $CC, PATH search, and the install hint when there is none."""
import os
import shutil

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
