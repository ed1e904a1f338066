"""SymPy 1.14's own biomechanics test suite, run with eomc's classes swapped in.

As tests/compiler/mechanics/test_sympy_suite.py does for mechanics and vector: the
tests SymPy ships (``sympy/physics/biomechanics/tests``) are copied unchanged into a
temporary directory whose ``conftest.py`` replaces every name of
``sympy.physics.mechanics`` that eomc defines itself by eomc's before any test module
imports it; pytest runs them in one subprocess.  SymPy's biomechanics tests build
musculotendons, activation dynamics and curves on SymPy's pathways and actuators (which
eomc uses unchanged) and never form equations, so this shows that eomc's mechanics
leaves the biomechanics module intact; compiling musculotendons is checked against
SymPy in tests/compiler/model/test_muscles.py and test_biomechanical_arm.py.

Every test must pass; the only skips allowed are SymPy's own for missing optional
packages (JAX) and the Python version.  About 5 s of CPU (350 tests at SymPy 1.14.0).
"""
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import sympy

pytestmark = pytest.mark.slow

_CONFTEST = '''
"""Written by eomc's tests/compiler/mechanics/test_sympy_biomechanics_suite.py."""
import json, os
import sympy.physics.mechanics as sme
import eomc.mechanics as em

SWAPPED = sorted(n for n in em.__all__
                 if n in sme.__all__ and getattr(em, n) is not getattr(sme, n))
for _name in SWAPPED:
    setattr(sme, _name, getattr(em, _name))
with open(os.environ["EOMC_SUITE_SWAPPED"], "w") as _f:
    json.dump(SWAPPED, _f)
'''

EXPECTED_SWAPPED = ["JointsMethod", "KanesMethod", "LagrangesMethod", "Lagrangian", "System",
                    "kinetic_energy"]
# SymPy's own skips (they skip in SymPy's CI too): optional JAX, a Python-version guard
ALLOWED_SKIPS = ("JAX not installed", "kw_only dataclasses only valid in Python")


def test_sympy_biomechanics_suite_passes_with_eomc_classes(tmp_path):
    src = Path(sympy.__file__).parent / "physics" / "biomechanics" / "tests"
    if not src.is_dir():
        pytest.fail(f"this SymPy ({sympy.__version__}) ships no {src}: cannot run its suite")
    shutil.copytree(src, tmp_path / "biomechanics_tests",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (tmp_path / "conftest.py").write_text(_CONFTEST)
    env = {**os.environ, "EOMC_SUITE_SWAPPED": str(tmp_path / "swapped.json"),
           "PYTHONDONTWRITEBYTECODE": "1"}
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
           "-o", "addopts=", "-rfs", "--rootdir", str(tmp_path), "biomechanics_tests"]
    result = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
    out = result.stdout
    assert json.loads((tmp_path / "swapped.json").read_text()) == EXPECTED_SWAPPED
    tail = out.strip().splitlines()[-1] if out.strip() else result.stderr[-2000:]
    counts = {k: int(v) for v, k in re.findall(r"(\d+) (passed|failed|errors?|skipped)", tail)}
    assert result.returncode == 0 and not counts.get("failed") and not counts.get("error"), out[-6000:]
    skips = re.findall(r"^SKIPPED \[\d+\] \S+: (.*)$", out, flags=re.M)
    assert all(s.startswith(ALLOWED_SKIPS) for s in skips), skips
    assert len(skips) == counts.get("skipped", 0)
    assert counts.get("passed", 0) >= 300, tail
    if sympy.__version__ == "1.14.0":
        assert counts["passed"] == 350, tail
