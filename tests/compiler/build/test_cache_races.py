"""The build cache under other processes: clear/prune racing builds, builds killed midway.

Reliability report 2026-11, F4 (a build racing `eomc cache clear`/prune died with a raw
FileNotFoundError) and F7 (a killed build's temporary directory stayed in the cache).
"""
import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from helpers import osc_model
from helpers.slow_cc import alive, slow_compiler, wait_for_pid
from eomc.compiler.build import build, cache_root
from eomc.compiler.driver import build_and_load

_CLEARER = textwrap.dedent('''
    import sys, time
    from eomc.compiler.build.cache import cache_root
    from eomc.compiler.build.cache_admin import clear, prune
    root = cache_root(sys.argv[1])
    end = time.time() + float(sys.argv[2])
    rounds = removed = 0
    print("ready", flush=True)
    while time.time() < end:
        removed += len(prune(root, max_size=0))
        clear(root)
        rounds += 1
    print(rounds, removed)
    ''')


def test_builds_racing_clear_and_prune_never_fail(tmp_path):
    """One process clears and prunes the cache in a loop; this one builds, exports and loads."""
    cache, out = tmp_path / "cache", tmp_path / "out"
    build(osc_model.oscillator(), cache_dir=cache)
    clearer = subprocess.Popen([sys.executable, "-c", _CLEARER, str(cache), "4"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    assert clearer.stdout.readline().strip() == "ready"
    expected = osc_model.oscillator_rhs(0.0, [0.3, -0.2])
    loads = 0
    while clearer.poll() is None:
        model = build_and_load(osc_model.oscillator(), cache_dir=cache,
                               output_dir=out if loads % 2 else None, progress=False)
        np.testing.assert_allclose(model.rhs(0.0, [0.3, -0.2]), expected, rtol=1e-14)
        loads += 1
    stdout, stderr = clearer.communicate(timeout=60)
    assert clearer.returncode == 0, stderr
    rounds, removed = map(int, stdout.split())
    assert loads >= 2 and rounds >= 2
    assert removed >= 1     # the clearer did take entries away between builds


@pytest.mark.parametrize("next_build", ["same model", "another model"])
def test_a_killed_builds_temporary_directory_is_reclaimed_by_the_next_build(tmp_path, next_build):
    cache = tmp_path / "cache"
    victim = "osc" if next_build == "same model" else "victim"
    code = (f"import sys; sys.path.insert(0, {os.path.dirname(os.path.dirname(os.path.dirname(__file__)))!r});"
            f"from helpers import osc_model; from eomc.compiler.build import build;"
            f"build(osc_model.oscillator({victim!r}), cache_dir={str(cache)!r})")
    script, pidfile = slow_compiler(tmp_path)
    proc = subprocess.Popen([sys.executable, "-c", code], env={**os.environ, "CC": str(script)})
    child = wait_for_pid(pidfile)
    try:
        tmp = cache_root(cache) / "tmp"
        assert [p.name[:64] for p in tmp.iterdir()] != []       # the build's directory
        proc.kill()                                              # kill -9: no cleanup runs
        proc.wait(timeout=30)
        assert list(tmp.iterdir())
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("CC", str(script))        # "same model": the same key as the killed build
            mp.setattr("eomc.compiler.build.builder.run_compiler", lambda *a, **k: None)  # no wait
            mp.setattr("eomc.compiler.build.builder.auto_prune", lambda *a, **k: [])
            build(osc_model.oscillator(), cache_dir=cache)       # a miss: it builds
        assert list(tmp.iterdir()) == []
    finally:
        if alive(child):
            os.kill(child, signal.SIGKILL)


def test_an_entry_held_by_a_reader_survives_clear_and_prune(tmp_path):
    """F4, deterministically: while held (copied or loaded), clear and prune skip the entry."""
    import contextlib
    from eomc.compiler.build.cache_admin import clear, prune
    root = cache_root(tmp_path)
    with contextlib.ExitStack() as held:
        built = build(osc_model.oscillator(), cache_dir=tmp_path, hold_in=held)
        assert built.hit is False
        assert prune(root, max_size=0) == []
        clear(root)
        assert (built.directory / "libosc.so").is_file()
    with contextlib.ExitStack() as held:
        again = build(osc_model.oscillator(), cache_dir=tmp_path, hold_in=held)
        assert again.hit and again.directory == built.directory
        clear(root)
        assert again.directory.is_dir()
    clear(root)                                   # released: now it goes
    assert not built.directory.exists()
