"""A test module's own build cache: $EOMC_CACHE_DIR set to a fresh directory for the module's
tests and restored after them.

Why: the sensitivity, jac_p and seed-pair tests each build models whose libraries must not be
shared with other files' (their flags and switches differ), and each carried the same fixture.
Import it into a test module (``from helpers.module_cache import cache``); it overrides pytest's
own ``cache`` fixture there, as the copies did."""
import os

import pytest


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    old = os.environ.get("EOMC_CACHE_DIR")
    os.environ["EOMC_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    yield
    if old is None:
        del os.environ["EOMC_CACHE_DIR"]
    else:
        os.environ["EOMC_CACHE_DIR"] = old
