"""A cache that cannot be written, and a cache size limit that is not a size: plain errors.

Reliability report 2026-11, F6 (read-only cache: OSError tracebacks from cold builds, clear
and prune) and F7 (EOMC_CACHE_MAX_SIZE=abc, -1, 1e3 silently turned auto-pruning off).
"""
import errno

import pytest

from helpers import model_files, osc_model
from eomc.cli import main
from eomc.compiler.build import build, cache
from eomc.errors import EomcError


@pytest.fixture
def read_only_locks(monkeypatch):
    """The cache's lock files open read-only, as on a read-only mount (tests run as root,
    where chmod does not stop writes)."""
    real = cache._open_lock

    def open_lock(path, mode="a+"):
        if mode != "r":
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        return real(path, mode)
    monkeypatch.setattr(cache, "_open_lock", open_lock)


def test_cold_build_in_a_read_only_cache_says_what_to_do(tmp_path, read_only_locks):
    with pytest.raises(EomcError, match=r"cannot build: the build cache at .* is not writable "
                                        r"\(Read-only file system\); set EOMC_CACHE_DIR to a writable"):
        build(osc_model.oscillator(), cache_dir=tmp_path)


def test_cold_cli_build_in_a_read_only_cache_is_one_line(tmp_path, read_only_locks, capsys):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    code = main(["build", str(model), "-o", str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c"), "-q"])
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith("eomc build: error: cannot build: the build cache at ") and "Traceback" not in err
    assert err.count("\n") == 1


def test_warm_build_in_a_read_only_cache_still_works(tmp_path, monkeypatch):
    first = build(osc_model.oscillator(), cache_dir=tmp_path)
    real = cache._open_lock
    monkeypatch.setattr(cache, "_open_lock", lambda path, mode="a+": real(path, "r") if mode == "r" else
                        (_ for _ in ()).throw(OSError(errno.EROFS, "Read-only file system")))
    again = build(osc_model.oscillator(), cache_dir=tmp_path)
    assert again.hit and again.directory == first.directory


@pytest.mark.parametrize("argv", [["cache", "clear"], ["cache", "prune", "--max-size", "1K"]])
def test_clear_and_prune_of_a_read_only_cache_are_one_line(tmp_path, argv, capsys, monkeypatch):
    entry = build(osc_model.oscillator(), cache_dir=tmp_path).directory
    real = cache._open_lock
    monkeypatch.setattr(cache, "_open_lock", lambda path, mode="a+": real(path, "r") if mode == "r" else
                        (_ for _ in ()).throw(OSError(errno.EROFS, "Read-only file system")))
    assert main([*argv, "--cache-dir", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("eomc cache: error: cannot change the build cache: the build cache at ")
    assert "not writable (Read-only file system); set EOMC_CACHE_DIR" in err
    assert entry.is_dir()


@pytest.mark.parametrize("value", ["abc", "-1", "1e3"])
def test_invalid_cache_size_limit_is_an_error(tmp_path, monkeypatch, capsys, value):
    monkeypatch.setenv("EOMC_CACHE_MAX_SIZE", value)
    with pytest.raises(EomcError, match=f"EOMC_CACHE_MAX_SIZE='{value}' is not a size"):
        build(osc_model.oscillator(), cache_dir=tmp_path)
    assert main(["cache", "--cache-dir", str(tmp_path)]) == 1
    assert f"EOMC_CACHE_MAX_SIZE='{value}' is not a size; use e.g. 500M" in capsys.readouterr().err
