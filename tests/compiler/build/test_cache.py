"""The content-addressed build cache: hits, key coverage, corrupt entries, compile errors, races."""
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from helpers import osc_model
from eomc.compiler.build import build, cache_root, find_compiler
from eomc.compiler.build.toolchain import machine_flags
from eomc.compiler.build.cache import CacheWarning
from eomc.errors import CompileError, CompilerNotFoundError
from eomc.runtime.loader import load


def test_miss_then_hit_same_entry(tmp_path):
    first = build(osc_model.oscillator(), cache_dir=tmp_path)
    second = build(osc_model.oscillator(), cache_dir=tmp_path)
    assert not first.hit and second.hit
    assert first.directory == second.directory and first.key == second.key
    manifest = json.loads((first.directory / "manifest.json").read_text())
    assert manifest["key"] == first.key
    assert set(manifest["files"]) >= {"osc.c", "osc.h", "libosc.so", "osc.json", "eomc_model.h"}
    # the defaults, plus -mavx2 -ffp-contract=off on an AVX2 machine (tests/compiler/build/test_machine_flags.py)
    assert manifest["inputs"]["cflags"] == ["-O2", "-fPIC", "-std=c99", *machine_flags(find_compiler())]
    assert cache_root(tmp_path) == tmp_path.resolve() / "v1"


def test_key_covers_source_flags_and_name(tmp_path):
    base = build(osc_model.oscillator(), cache_dir=tmp_path)
    other_source = osc_model.oscillator(c_source=osc_model.SOURCE.format(n="osc", N="OSC") + "\n/* x */\n")
    keys = {base.key,
            build(other_source, cache_dir=tmp_path).key,
            build(osc_model.oscillator(), cache_dir=tmp_path, cflags="-O1 -std=c99").key,
            build(osc_model.oscillator("osc2"), cache_dir=tmp_path).key}
    assert len(keys) == 4


def test_env_var_selects_cache_root(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "envcache"))
    result = build(osc_model.oscillator(), cache_dir=None)
    assert str(result.directory).startswith(str((tmp_path / "envcache" / "v1").resolve()))


@pytest.mark.parametrize("damage", ["truncate_library", "drop_manifest", "bad_manifest_key"])
def test_corrupt_entry_is_rebuilt(tmp_path, damage):
    entry = build(osc_model.oscillator(), cache_dir=tmp_path).directory
    if damage == "truncate_library":
        (entry / "libosc.so").write_bytes(b"\x7fELF garbage")
    elif damage == "drop_manifest":
        (entry / "manifest.json").unlink()
    else:
        manifest = json.loads((entry / "manifest.json").read_text())
        manifest["key"] = "0" * 64
        (entry / "manifest.json").write_text(json.dumps(manifest))
    with pytest.warns(CacheWarning, match=r"the build cache entry .* was damaged .*; rebuilding it"):
        again = build(osc_model.oscillator(), cache_dir=tmp_path)
    assert not again.hit and again.directory == entry
    model = load(again.directory)
    assert np.allclose(model.rhs(0.0, [0.3, -0.2]), osc_model.oscillator_rhs(0.0, [0.3, -0.2]))


def test_compile_error_shows_compiler_message_and_keeps_source(tmp_path):
    broken = osc_model.oscillator("bad", c_source='#include "bad.h"\nint bad_rhs(void) { return oops; }\n')
    with pytest.raises(CompileError) as info:
        build(broken, cache_dir=tmp_path)
    message = str(info.value)
    assert "oops" in message  # the compiler's own diagnostic
    kept = [line.split("source kept in ")[1].strip() for line in message.splitlines() if "source kept in" in line]
    assert kept and os.path.isfile(os.path.join(kept[0], "bad.c"))
    assert "oops" in open(os.path.join(kept[0], "bad.c")).read()
    assert not list((cache_root(tmp_path) / "models").rglob("libbad.so"))


def test_missing_compiler_is_reported_before_anything_is_written(tmp_path, monkeypatch):
    monkeypatch.setenv("CC", str(tmp_path / "nowhere" / "cc"))
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(CompilerNotFoundError, match="install"):
        build(osc_model.oscillator(), cache_dir=tmp_path / "cache")


_RACE = textwrap.dedent('''
    import sys
    sys.path.insert(0, {tests!r})
    import numpy as np
    from helpers import osc_model
    from eomc.compiler.build import build
    from eomc.runtime.loader import load
    sys.stdin.readline()  # start together
    result = build(osc_model.oscillator("race"), cache_dir={cache!r})
    model = load(result.directory)
    print(result.key, result.hit, model.rhs(0.0, np.array([0.3, -0.2]))[1])
    ''')


def test_concurrent_builds_of_one_model_share_one_entry(tmp_path):
    tests_dir = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    code = _RACE.format(tests=tests_dir, cache=str(tmp_path))
    procs = [subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(4)]
    for p in procs:
        p.stdin.write("go\n")
        p.stdin.flush()
    outputs = [p.communicate(timeout=240) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err for _, err in outputs]
    rows = [out.split() for out, _ in outputs]
    assert len({row[0] for row in rows}) == 1
    assert [row[1] for row in rows].count("False") >= 1  # someone built it
    expected = osc_model.oscillator_rhs(0.0, [0.3, -0.2])[1]
    assert all(abs(float(row[2]) - expected) < 1e-14 for row in rows)
    entries = list((tmp_path / "v1" / "models").glob("*/*"))
    assert len(entries) == 1
    assert not list((tmp_path / "v1" / "tmp").iterdir())  # no leftovers


def test_library_builds_with_strict_warnings(tmp_path):
    """Generated C and the batch helper are clean under -Wall -Wextra -Werror (the integrators: tests/runtime)."""
    from helpers import model_files
    from eomc.compiler.driver import generate
    flags = "-O2 -std=c99 -Wall -Wextra -Werror"
    _, generated = generate(model_files.write(tmp_path, model_files.CART, "cart"), cache_dir=tmp_path,
                            progress=False)
    result = build(generated, cflags=flags, cache_dir=tmp_path)
    assert load(result.directory).rhs(0.0, [0.0, 0.4, 0.0, 0.0], r=[0.0])[0] == 0.0
    assert build(osc_model.oscillator(), cflags=flags, cache_dir=tmp_path).library.is_file()


def test_unwritable_cache_root_says_what_to_do(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    from eomc.errors import EomcError
    with pytest.raises(EomcError, match="set EOMC_CACHE_DIR to a writable directory"):
        cache_root(blocker / "cache")
