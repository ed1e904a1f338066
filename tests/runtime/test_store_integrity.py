"""The runtime's cache lookup checks every file's sha256; a full disk is one clear error
(reliability report 2026-11-r3, N10).

A same-size edit in a worker's cache entry (``initial_state`` 1.0 -> 7.0 in NAME.json) was
served on unpickling because ``store.find`` checked sizes; unpickling into a full cache, a
cold build whose failed-source copy fails and ``eomc build -o`` on a full disk were tracebacks.
"""
import errno
import json
import pickle
import shutil

import pytest

from helpers import osc_model
from eomc.compiler.build import build, toolchain
from eomc.compiler.build import export as export_module
from eomc.runtime import store, travel
from eomc.runtime.errors import CompileError, EomcError
from eomc.runtime.loader import load


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "worker-cache"))
    monkeypatch.setattr(travel, "_RESTORED", {})  # each test arrives afresh


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    generated = osc_model.oscillator()
    return build(generated, cache_dir=tmp_path_factory.mktemp("cache"),
                 extra_metadata={"initial_state": [1.0, 0.5]})


def _full(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_same_size_edit_in_the_workers_entry_is_not_served(built, tmp_path):
    blob = pickle.dumps(load(built.directory))
    first = pickle.loads(blob)
    entry = store.entry_path(store.cache_root(), "models", built.key)
    assert first.arrival == "library" and (entry / "osc.json").is_file()
    text = (entry / "osc.json").read_text()
    edited = text.replace('"initial_state": [\n  1.0,', '"initial_state": [\n  7.0,')
    assert edited != text and len(edited) == len(text)
    (entry / "osc.json").write_text(edited)
    assert store.find(store.cache_root(), "models", built.key, verify=("libosc.so",)) is None
    travel._RESTORED.clear()
    again = pickle.loads(blob)
    assert again.arrival == "library"  # republished from the payload, not served as edited
    assert list(again.initial_state) == [1.0, 0.5]
    assert json.loads((entry / "osc.json").read_text())["initial_state"] == [1.0, 0.5]


def test_unpickling_into_a_full_cache_is_one_clear_error(built, monkeypatch):
    blob = pickle.dumps(load(built.directory))
    monkeypatch.setattr(store, "write_manifest", _full)
    with pytest.raises(travel.TravelError, match=r"cannot unpickle model 'osc' here: cannot write into the "
                                                 r"build cache at .*: the file system is full") as info:
        pickle.loads(blob)
    assert "\n" not in str(info.value)
    tmp = store.cache_root() / "tmp"
    assert [p.name for p in tmp.iterdir()] == []  # nothing half-written left behind


def test_a_failed_compile_whose_source_cannot_be_kept_still_says_why(tmp_path, monkeypatch):
    root = tmp_path / "v1"
    (root / "tmp").mkdir(parents=True)
    work = tmp_path / "work"
    work.mkdir()
    (work / "bad.c").write_text("this is not C\n")

    def copytree(src, dst, *args, **kwargs):
        raise shutil.Error([(str(src), str(dst), "[Errno 28] No space left on device")])
    monkeypatch.setattr(toolchain.shutil, "copytree", copytree)
    with pytest.raises(CompileError, match=r"the source could not be kept \(\[Errno 28\] No space left"):
        toolchain.run_compiler(["cc", "-c", "bad.c"], work, "bad", "0" * 64, root)
    assert not (root / "failed" / f"bad-{'0' * 12}").exists()


def test_a_cold_build_into_a_full_cache_is_one_clear_error(tmp_path, monkeypatch):
    from eomc.compiler.build import cache
    monkeypatch.setattr(cache, "write_manifest", _full)
    with pytest.raises(EomcError, match=r"cannot build into the cache at .*: the file system is full"):
        build(osc_model.oscillator(), cache_dir=tmp_path / "cache")
    assert list((tmp_path / "cache" / "v1" / "tmp").iterdir()) == []


def test_build_o_on_a_full_disk_is_one_clear_error(built, tmp_path, monkeypatch):
    out = tmp_path / "out"
    monkeypatch.setattr(export_module.shutil, "copy2", _full)
    with pytest.raises(EomcError, match=r"cannot write the model into .*out: the file system is full"):
        export_module.export(built, out)
    assert list(out.iterdir()) == []  # DIR left as it was: nothing partial
