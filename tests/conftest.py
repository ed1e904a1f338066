"""Suite-wide fixtures: the test run never writes into the user's build cache, and does not
warn about its own models.

Why: tests that build a model without a tmp_path cache of their own used to
leave entries in ``~/.cache/eomc`` (or the user's ``$EOMC_CACHE_DIR``); the
first-hour report found six after one run.  Every test now starts with
EOMC_CACHE_DIR pointing to a directory of this session's temporary tree;
a test that sets its own (``monkeypatch.setenv``) still wins, and monkeypatch
puts this session's value back afterwards.  Subprocesses (``eomc`` commands,
spawned workers) inherit it through the environment.
"""
import os

import pytest

# eomc warns when a model has no `parameters` dict (every parameter then defaults to 1.0).  Many
# tests build throw-away mechanisms that way on purpose; the warning points at the first frame
# outside eomc, so the filter below silences it only where that frame is the suite's own code
# (tests.* modules, helpers.*) -- a test that checks the warning (pytest.warns) still sees it.
OWN_MODEL_WARNING = r"ignore:.* no .parameters. dict:eomc.errors.EomcWarning:(tests|helpers)(\.|$)"


def pytest_configure(config):
    config.addinivalue_line("filterwarnings", OWN_MODEL_WARNING)


@pytest.fixture(scope="session", autouse=True)
def _session_cache(tmp_path_factory):
    previous = os.environ.get("EOMC_CACHE_DIR")
    os.environ["EOMC_CACHE_DIR"] = str(tmp_path_factory.mktemp("eomc-cache"))
    try:
        yield os.environ["EOMC_CACHE_DIR"]
    finally:
        if previous is None:
            os.environ.pop("EOMC_CACHE_DIR", None)
        else:
            os.environ["EOMC_CACHE_DIR"] = previous
