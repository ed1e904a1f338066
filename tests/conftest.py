"""Suite-wide fixtures: the test run never writes into the user's build cache, and does not
warn about its own models.

Why: tests that build a model without a tmp_path cache of their own used to
leave entries in ``~/.cache/eomc`` (or the user's ``$EOMC_CACHE_DIR``); the
first-hour report found six after one run.  Every test now starts with
EOMC_CACHE_DIR pointing to a directory of this session's temporary tree;
a test that sets its own (``monkeypatch.setenv``) still wins, and monkeypatch
puts this session's value back afterwards.  Subprocesses (``eomc`` commands,
spawned workers) inherit it through the environment.

A run of more than one test file is spread over the machine's cores by pytest-xdist (see
pytest_cmdline_main below); each worker is its own session with its own temporary tree, so its
cache is its own too.
"""
import os
from pathlib import Path

import pytest

# eomc warns when a model has no `parameters` dict (every parameter then defaults to 1.0).  Many
# tests build throw-away mechanisms that way on purpose; the warning points at the first frame
# outside eomc, so the filter below silences it only where that frame is the suite's own code
# (tests.* modules, helpers.*) -- a test that checks the warning (pytest.warns) still sees it.
OWN_MODEL_WARNING = r"ignore:.* no .parameters. dict:eomc.errors.EomcWarning:(tests|helpers)(\.|$)"


def _spans_several_files(config):
    """True when the run names a folder, or more than one file (its arguments, else testpaths)."""
    files = set()
    for arg in config.args:
        path = Path(config.invocation_params.dir, arg.split("::", 1)[0])
        if path.is_dir():
            return True
        files.add(path.resolve())
    return len(files) > 1


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config):
    """Run the suite on every core this process may use, one test file per worker at a time.

    Why: CI runs the README's `python3 -m pytest` as written and must stay within its budget; the
    suite is CPU-bound (SymPy, gcc), so N cores take ~1/N of the time.  Why here and not `-n` in
    pyproject's addopts: a checkout whose environment lacks pytest-xdist (it is in the `test`
    extra) still runs, serially, instead of failing on an unknown option.  `--dist loadfile`
    keeps each file on one worker, so module-scoped fixtures (built models) are built once and
    tests that share them in order still do.  An explicit `-n N` (`-n0`: one process) or
    `-p no:xdist` wins; a run of a single file stays in this process (nothing to spread).
    """
    if not config.pluginmanager.hasplugin("xdist") or hasattr(config, "workerinput"):
        return
    if config.option.numprocesses is not None or not _spans_several_files(config):
        return
    workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    if workers > 1:
        config.option.numprocesses = workers
        if config.option.dist == "no":
            config.option.dist = "loadfile"


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
