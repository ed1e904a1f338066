"""`eomc build -o DIR` never replaces a file eomc did not write, and never copies a bad cache entry.

Reliability report 2026-11, F1 (building into the model's own folder replaced the model file),
F2 (a same-size corrupt cache entry was copied over the user's good output) and F7 (-o onto a file).
"""
import json
import subprocess
import sys

import numpy as np
import pytest

from helpers import model_files, osc_model
from eomc.cli import main
from eomc.compiler.build import build
from eomc.compiler.build.cache import BadEntry, CacheWarning
from eomc.compiler.build.export import export, written_list_name
from eomc.errors import EomcError
from eomc.runtime.loader import load


def _pendulum_file(directory):
    """PENDULUM named by its file (no `name =`), so NAME.py is the model file itself."""
    return model_files.write(directory, model_files.PENDULUM.replace('name = "pend"\n', ""), "pend")


def test_build_into_the_model_folder_keeps_the_model_file(tmp_path, capsys):
    model = _pendulum_file(tmp_path)
    original = model.read_text()
    code = main(["build", str(model), "-o", str(tmp_path), "--cache-dir", str(tmp_path / "c"), "-q"])
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith("eomc build: error: ") and "pend.py" in err
    assert "it is the model file being built" in err and "not overwriting" in err
    assert model.read_text() == original
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c", "pend.py"]  # nothing else written
    # a second attempt still finds the model (the report: "does not define `system`")
    assert main(["build", str(model), "-o", str(tmp_path / "out"), "--cache-dir", str(tmp_path / "c"),
                 "-q"]) == 0


@pytest.mark.parametrize("fname", ["eomc_model.h", "eomc_batch.c", "osc.json", "libosc.so"])
def test_a_users_file_under_a_shipped_name_is_not_replaced(tmp_path, fname):
    out = tmp_path / "out"
    out.mkdir()
    (out / fname).write_text("mine\n")
    built = build(osc_model.oscillator(), cache_dir=tmp_path / "c")
    with pytest.raises(EomcError, match=f"{fname} exists and eomc did not write it"):
        export(built, out)
    assert (out / fname).read_text() == "mine\n"
    assert sorted(p.name for p in out.iterdir()) == [fname]


def test_rebuilding_replaces_the_files_eomc_listed(tmp_path):
    out = tmp_path / "out"
    built = build(osc_model.oscillator(), cache_dir=tmp_path / "c")
    export(built, out)
    listing = json.loads((out / written_list_name("osc")).read_text())["files"]
    assert set(listing) >= {"osc.c", "osc.h", "libosc.so", "osc.json", "osc.py", "eomc_model.h"}
    other = build(osc_model.oscillator(c_source=osc_model.SOURCE.format(n="osc", N="OSC") + "/* v2 */\n"),
                  cache_dir=tmp_path / "c")
    export(other, out)                                  # listed with their sha256: replaced
    assert (out / "osc.c").read_text().endswith("/* v2 */\n")
    (out / "osc.c").write_text("edited by the user\n")  # no longer what eomc wrote, no eomc mark
    with pytest.raises(EomcError, match="osc.c exists and eomc did not write it"):
        export(built, out)
    assert (out / "osc.c").read_text() == "edited by the user\n"


def test_directories_built_before_the_list_are_recognised_by_eomcs_marks(tmp_path):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    out = tmp_path / "out"
    argv = ["build", str(model), "-o", str(out), "--cache-dir", str(tmp_path / "c"), "-q"]
    assert main(argv) == 0
    (out / written_list_name("pend")).unlink()
    first = (out / "libpend.so").read_bytes()
    assert main([*argv, "--cflags", "-O1 -std=c99"]) == 0
    assert (out / "libpend.so").read_bytes() != first
    assert (out / written_list_name("pend")).is_file()


def test_output_onto_an_existing_file_is_a_clear_error(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    (tmp_path / "ofile").write_text("x")
    code = main(["build", str(model), "-o", str(tmp_path / "ofile"), "--cache-dir", str(tmp_path / "c"), "-q"])
    assert code == 1
    assert "ofile is a file, not a directory" in capsys.readouterr().err
    assert (tmp_path / "ofile").read_text() == "x"


def _damage_same_size(path, offset=None):
    data = bytearray(path.read_bytes())
    i = len(data) // 2 if offset is None else offset
    data[i] ^= 0xFF
    path.write_bytes(bytes(data))


def test_same_size_corrupt_library_is_rebuilt_and_never_exported(tmp_path, capsys):
    """F2: the report's case, through `eomc build -o` three times."""
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    out, cache = tmp_path / "out", tmp_path / "cache"
    argv = ["build", str(model), "-o", str(out), "--cache-dir", str(cache), "-q"]
    assert main(argv) == 0
    good = (out / "libpend.so").read_bytes()
    entry = next((cache / "v1" / "models").glob("*/*"))
    lib = entry / "libpend.so"
    lib.write_bytes(b"\0" * lib.stat().st_size)      # same size, garbage
    with pytest.warns(CacheWarning, match="libpend.so differs"):
        assert main(argv) == 0
    assert (out / "libpend.so").read_bytes() == good
    assert lib.read_bytes() == good                  # the entry was rebuilt
    capsys.readouterr()
    assert main(["simulate", str(out), "--t-final", "0.1"]) == 0
    lib.write_bytes(b"\0" * lib.stat().st_size)      # the command line says it in one line
    run = subprocess.run([sys.executable, "-m", "eomc", *argv], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0
    assert run.stderr.startswith("eomc build: warning: the build cache entry ") and run.stderr.count("\n") == 1
    assert "libpend.so differs from the file that was built); rebuilding it" in run.stderr
    assert (out / "libpend.so").read_bytes() == good


def test_same_size_edit_of_the_metadata_is_not_served(tmp_path):
    """F3: a same-size edit of NAME.json in the cache (a default 8.0 -> 1.0) is a miss."""
    built = build(osc_model.oscillator(), cache_dir=tmp_path)
    meta = built.directory / "osc.json"
    text = meta.read_text()
    assert '8.0' in text
    meta.write_text(text.replace("8.0", "1.0"))
    with pytest.warns(CacheWarning, match="osc.json differs"):
        again = build(osc_model.oscillator(), cache_dir=tmp_path)
    assert not again.hit
    model = load(again.directory)
    assert list(model.param_defaults) == [2.0, 0.5, 8.0]
    np.testing.assert_allclose(model.rhs(0.0, [0.3, -0.2]), osc_model.oscillator_rhs(0.0, [0.3, -0.2]))


def test_an_entry_damaged_between_build_and_export_is_not_copied(tmp_path):
    out = tmp_path / "out"
    built = build(osc_model.oscillator(), cache_dir=tmp_path / "c")
    export(built, out)
    good = (out / "libosc.so").read_bytes()
    _damage_same_size(built.directory / "libosc.so")
    with pytest.raises(BadEntry, match="changed while in use"):
        export(built, out)
    assert (out / "libosc.so").read_bytes() == good
    assert not list(out.glob(".eomc-tmp-*"))
