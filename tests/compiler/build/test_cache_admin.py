"""Pruning the build cache: least recently used first, held locks respected, automatic past a limit."""
import numpy as np
import pytest

from helpers import osc_model
from eomc.compiler.build import build, cache_root
from eomc.compiler.build.cache import lookup, try_locked
from eomc.compiler.build.cache_admin import (auto_prune, clear, entries, parse_age, parse_size,
                                             prune, usage)
from eomc.runtime.loader import load
from helpers.cache_entries import fake_entry


@pytest.fixture
def root(tmp_path):
    return cache_root(tmp_path)


def test_entries_report_size_name_and_last_use_oldest_first(root):
    fake_entry(root, "a" * 64, 1000, used=3600)
    fake_entry(root, "b" * 64, 2000, used=60)
    listed = entries(root)
    assert [e.key[0] for e in listed] == ["a", "b"]
    assert all(e.size > size for e, size in zip(listed, (1000, 2000)))   # plus the manifest
    assert listed[0].name == "x"       # from libx.so
    u = usage(root)
    assert u["by_kind"]["models"][0] == 2 and u["total"] >= 3000


def test_a_hit_counts_as_a_use(root):
    fake_entry(root, "a" * 64, 10, used=3600)
    fake_entry(root, "b" * 64, 10, used=60)
    assert lookup(root, "models", "a" * 64) is not None
    assert [e.key[0] for e in entries(root)] == ["b", "a"]


def test_prune_to_size_drops_least_recently_used_first(root):
    for key, used in (("a", 300), ("b", 200), ("c", 100)):
        fake_entry(root, key * 64, 10_000, used=used)
    removed = prune(root, max_size=25_000)
    assert [e.key[0] for e in removed] == ["a"]
    assert [e.key[0] for e in entries(root)] == ["b", "c"]
    assert not (root / "models" / "aa" / ("a" * 64)).exists()


def test_prune_by_age_and_dry_run(root):
    fake_entry(root, "a" * 64, 10, used=40 * 86400)
    fake_entry(root, "b" * 64, 10, used=86400)
    would = prune(root, older_than=parse_age("30d"), dry_run=True)
    assert [e.key[0] for e in would] == ["a"] and len(entries(root)) == 2
    assert [e.key[0] for e in prune(root, older_than=parse_age("30d"))] == ["a"]
    assert [e.key[0] for e in entries(root)] == ["b"]


def test_an_entry_being_built_is_not_removed(root):
    fake_entry(root, "a" * 64, 10, used=3600)
    with try_locked(root, "a" * 64) as got:
        assert got
        assert prune(root, max_size=0) == []
    assert [e.key[0] for e in prune(root, max_size=0)] == ["a"]


def test_clear_removes_entries_and_failed_sources(root):
    fake_entry(root, "a" * 64, 10, used=1)
    (root / "failed" / "m-123").mkdir(parents=True)
    (root / "failed" / "m-123" / "m.c").write_text("int x;")
    in_progress = root / "tmp" / "0123456789ab-build"       # another process's fresh build
    in_progress.mkdir()
    assert clear(root) > 0
    assert entries(root) == [] and not (root / "failed").exists()
    assert in_progress.exists()


def test_a_new_build_prunes_past_the_limit_but_keeps_itself(tmp_path, monkeypatch):
    root = cache_root(tmp_path)
    for key, used in (("a", 300), ("b", 200)):
        fake_entry(root, key * 64, 50_000, used=used)
    monkeypatch.setenv("EOMC_CACHE_MAX_SIZE", "60K")
    result = build(osc_model.oscillator(), cache_dir=tmp_path)
    kept = {e.key for e in entries(root)}
    assert result.key in kept and "a" * 64 not in kept and "b" * 64 not in kept
    xdot = load(result.directory).rhs(0.0, [1.0, 0.0])
    assert np.all(np.isfinite(xdot))


def test_limit_zero_turns_automatic_pruning_off(root, monkeypatch):
    fake_entry(root, "a" * 64, 50_000, used=300)
    monkeypatch.setenv("EOMC_CACHE_MAX_SIZE", "0")
    assert auto_prune(root) == [] and len(entries(root)) == 1
    monkeypatch.setenv("EOMC_CACHE_MAX_SIZE", "10K")
    assert len(auto_prune(root)) == 1


@pytest.mark.parametrize("text, size", [("500", 500), ("2K", 2048), ("1.5M", 1572864), ("2GiB", 2 << 30)])
def test_parse_size(text, size):
    assert parse_size(text) == size


@pytest.mark.parametrize("bad", ["", "lots", "5 parsecs", "-1M"])
def test_bad_sizes_and_ages_are_named(bad):
    with pytest.raises(ValueError, match="not a size"):
        parse_size(bad)
    with pytest.raises(ValueError, match="not an age"):
        parse_age(bad)
