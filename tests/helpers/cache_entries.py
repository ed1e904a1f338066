"""Fake build-cache entries for the pruning tests: a size and a last use, no compile."""
import os
import time

from eomc.compiler.build.cache import get_or_build


def fake_entry(root, key, size, used):
    """Publish an entry of ``size`` bytes (libx.so) whose last use was ``used`` seconds ago."""
    entry, _ = get_or_build(root, "models", key, lambda tmp: (tmp / "libx.so").write_bytes(b"x" * size),
                            {"argv": ["cc"]})
    stamp = time.time() - used
    os.utime(entry / "manifest.json", (stamp, stamp))
    return entry
