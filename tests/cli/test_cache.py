"""`eomc cache`: info lists entries by last use, prune takes sizes and ages, clear empties."""
from eomc.cli import main as eomc_main
from eomc.compiler.build import cache_root
from eomc.compiler.build.cache_admin import entries
from helpers.cache_entries import fake_entry


def test_cli_info_prune_clear(tmp_path, capsys):
    root = cache_root(tmp_path)
    fake_entry(root, "a" * 64, 10_000, used=7200)
    fake_entry(root, "b" * 64, 10_000, used=60)
    assert eomc_main(["cache", "--cache-dir", str(tmp_path), "info", "--list"]) == 0
    out = capsys.readouterr().out
    assert str(root) in out and "models" in out and "2 h ago" in out
    assert eomc_main(["cache", "prune", "--cache-dir", str(tmp_path), "--max-size", "15K"]) == 0
    assert "removed 1 entries" in capsys.readouterr().out
    assert eomc_main(["cache", "prune", "--cache-dir", str(tmp_path)]) == 2
    assert "needs --max-size" in capsys.readouterr().err
    assert eomc_main(["cache", "clear", "--cache-dir", str(tmp_path)]) == 0
    assert entries(root) == []
