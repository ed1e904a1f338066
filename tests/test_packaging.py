"""A wheel installed into a fresh virtual environment works from outside the checkout.

One slow test (~1 min): build the wheel from a copy of the source tree, check
its contents, install it into a new venv (with --system-site-packages so the
dependencies come from this interpreter, not a download), then, from a
directory outside the checkout: `eomc --version`, `eomc build` a model, and
load the built model in a process where importing SymPy fails.
"""
import json
import os
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import pytest

import eomc

ROOT = Path(__file__).resolve().parents[1]
_SKIP_AT_ROOT = {".git", "build", "dist", ".pytest_cache", ".hypothesis", "tests", "benchmarks", "out"}


def _ignore(directory, names):
    skip = {n for n in names if n == "__pycache__" or n.endswith(".egg-info") or n.startswith(".venv")}
    if Path(directory).resolve() == ROOT:
        skip |= _SKIP_AT_ROOT & set(names)
    return skip


def _run(argv, cwd, **kw):
    out = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=600, **kw)
    assert out.returncode == 0, f"{argv}\n{out.stdout}\n{out.stderr}"
    return out.stdout


@pytest.mark.slow
def test_wheel_in_fresh_venv_builds_and_loads_without_sympy(tmp_path):
    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=_ignore)
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
          "-w", str(tmp_path / "wheels"), str(src)], cwd=tmp_path)
    wheel, = (tmp_path / "wheels").glob("eomc-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for needed in ("eomc/__init__.py", "eomc/compiler/build/builder.py", "eomc/runtime/loader.py",
                   "eomc/runtime/c/eomc_model.h", "eomc/runtime/c/eomc_integrators.c",
                   "eomc/runtime/c/eomc_batch.c", "eomc/templates/module.py.j2",
                   "eomc/templates/model.pyx.j2"):
        assert needed in names, needed
    for extension in ("eomc/runtime/_eomc_integrators", "eomc/runtime/_fastcall"):  # built by setup.py
        assert any(n.startswith(extension) and n.endswith(".so") for n in names), extension
    assert not any(n.startswith(("tests/", "examples/", "benchmarks/")) for n in names)
    # every package of the source tree is in the wheel (pyproject lists them one by one)
    for folder, prefix in (("facade", "eomc"), ("compiler", "eomc/compiler"), ("runtime", "eomc/runtime")):
        for init in (ROOT / folder).rglob("__init__.py"):
            inside = init.relative_to(ROOT / folder).as_posix()
            assert f"{prefix}/{inside}" in names, f"{folder}/{inside} is not packaged: list it in pyproject.toml"

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)], cwd=tmp_path)
    python, script = venv / "bin" / "python", venv / "bin" / "eomc"
    # --ignore-installed: the venv sees this interpreter's site-packages, where CI has
    # already installed eomc; without it pip says "already satisfied" and installs nothing.
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index",
          "--ignore-installed", "-q", str(wheel)], cwd=tmp_path)

    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "EOMC_CACHE_DIR")}
    assert _run([str(script), "--version"], cwd=work, env=env).strip() == f"eomc {eomc.__version__}"
    shutil.copy(ROOT / "examples" / "double_pendulum.py", work / "double_pendulum.py")
    _run([str(script), "build", "double_pendulum.py", "-o", "out", "--cache-dir", str(tmp_path / "cache"), "-q"],
         cwd=work, env=env)

    probe = textwrap.dedent("""
        import json, sys
        sys.modules["sympy"] = None  # importing SymPy now fails
        import eomc
        model = eomc.load("out")
        xdot = model.rhs(0.0, [1.0, -0.5, 0.0, 0.0])
        end = model.simulate([1.0, -0.5, 0.0, 0.0], (0.0, 1.0)).x[-1]  # the installed integrators
        print(json.dumps({"file": eomc.__file__, "xdot": list(xdot), "name": model.name,
                          "end": list(end)}))
        """)
    shown = json.loads(_run([str(python), "-c", probe], cwd=work, env=env))
    assert shown["file"].startswith(str(venv))  # the installed wheel, not the checkout
    assert shown["name"] == "double_pendulum" and len(shown["xdot"]) == 4
    assert shown["xdot"][:2] == [0.0, 0.0] and shown["xdot"][2] != 0.0
    assert len(shown["end"]) == 4 and shown["end"] != [1.0, -0.5, 0.0, 0.0]


def test_every_source_package_is_in_the_wheel_list():
    """pyproject lists the packages by hand (the import name differs from the folders), so
    a new folder under compiler/ or runtime/ is missing from a non-editable install until
    it is added there; editable installs hide that. The list must match the folders."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    roots = {folder: name for name, folder in config["package-dir"].items()}
    on_disk = set()
    for folder, name in roots.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            parts = init.parent.relative_to(ROOT / folder).parts
            if "__pycache__" not in parts:
                on_disk.add(".".join((name, *parts)))
    assert on_disk - listed == set(), "add these to [tool.setuptools] packages in pyproject.toml"
