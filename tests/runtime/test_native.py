"""The integrator library's staleness check (runtime/native.py stale_sources): in a source checkout
installed editable, C sources newer than the built library are named; an installed package is not
checked."""
import os
import time

from eomc.runtime.native import stale_sources


def _layout(tmp_path, checkout):
    runtime = tmp_path / "runtime"
    (runtime / "c").mkdir(parents=True)
    if checkout:
        (tmp_path / "pyproject.toml").write_text("[project]\nname = 'eomc'\n")
    library = runtime / "_eomc_integrators.so"
    for name in ("eomc_fixedstep.c", "eomc_bdf.h", "README.txt"):
        (runtime / "c" / name).write_text("/* */\n")
    library.write_bytes(b"\x7fELF")
    old = time.time() - 100
    for f in (runtime / "c").iterdir():
        os.utime(f, (old, old))
    return runtime, library


def test_sources_newer_than_the_library_are_named_in_a_checkout(tmp_path):
    runtime, library = _layout(tmp_path, checkout=True)
    assert stale_sources(library, runtime) == []
    later = time.time() + 100
    for name in ("eomc_fixedstep.c", "eomc_bdf.h", "README.txt"):
        os.utime(runtime / "c" / name, (later, later))
    assert stale_sources(library, runtime) == ["eomc_bdf.h", "eomc_fixedstep.c"]


def test_an_installed_package_is_not_checked(tmp_path):
    runtime, library = _layout(tmp_path, checkout=False)
    later = time.time() + 100
    os.utime(runtime / "c" / "eomc_fixedstep.c", (later, later))
    assert stale_sources(library, runtime) == []


def test_this_install_is_not_stale():
    """The library this test run uses was built from the C beside it (CI installs fresh; in a
    developer's editable checkout a failure here says: rebuild with pip install -e .)."""
    from eomc.runtime import native
    library = native._library_path()
    assert stale_sources(library, library.parent) == []
