"""MISRA C:2012 evidence for the c99-f32 target: cppcheck's MISRA addon over the generated float C
reports no rule but the advisory deviations docs/misra.md lists and justifies (see there)."""
import re
import shutil
import subprocess
import warnings
from pathlib import Path

import pytest

from eomc.compiler.driver import generate
from eomc.compiler.urdf.model import with_options
from eomc.runtime.header_cdef import C_DIR

from tests.helpers.robots import robot_path

ROOT = Path(__file__).resolve().parents[3]
RECORD = ROOT / "docs" / "misra.md"
# MISRA C:2012's advisory rules (Amendment 1 and 2 included); every other rule is required or
# mandatory and may not appear at all
ADVISORY = {"1.2", "2.3", "2.4", "2.5", "2.6", "2.7", "4.2", "5.9", "8.7", "8.9", "8.11", "8.13",
            "10.5", "11.4", "11.5", "12.1", "12.3", "12.4", "13.3", "13.4", "15.1", "15.4", "15.5",
            "17.5", "17.8", "18.4", "18.5", "19.2", "20.1", "20.5", "20.10", "21.12"}

pytestmark = pytest.mark.skipif(shutil.which("cppcheck") is None,
                                reason="cppcheck is not installed (.ci/run installs it from Debian)")


def _deviations():
    """Rules of docs/misra.md's deviation table."""
    text = RECORD.read_text()
    table = text.split("## Deviations", 1)[1]
    return {m.group(1) for m in re.finditer(r"^\| (\d+\.\d+) \| advisory \|", table, flags=re.M)}


def _models():
    return {"double_pendulum": (str(ROOT / "examples" / "double_pendulum.py"), None, {}),
            "cart_pole": (str(ROOT / "examples" / "cart_pole_system.py"), None, {}),
            # a 3-dof arm carries every shape of the recursive rhs and jac_x (the column loop, the
            # tangent block) that UR5 did, at 1/30 of cppcheck's time (UR5's jac_x: ~140 s CPU)
            "finger": (str(robot_path("finger_edu")), "finger", {"functions": ["rhs", "jac_x"]}),
            "solo": with_options(str(robot_path("solo12")), "solo", floating_base=True)
            + ({"functions": ["rhs"]},)}


def test_record_lists_only_advisory_rules():
    deviations = _deviations()
    assert deviations and deviations <= ADVISORY, deviations - ADVISORY


def test_float_c_has_no_finding_outside_the_record(tmp_path):
    deviations = _deviations()
    shutil.copy(C_DIR / "eomc_model.h", tmp_path)
    seen = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for key, (source, name, kw) in _models().items():
            g = generate(source, name or key, target="c99-f32", **kw)[1]
            (tmp_path / f"{g.name}.c").write_text(g.c_source)
            (tmp_path / f"{g.name}.h").write_text(g.header)
            # one configuration, the C99 translation unit a C compiler sees (a -D makes cppcheck
            # check only it); by default it also re-checks each #ifdef variant (__cplusplus ...),
            # twice the time
            run = subprocess.run(["cppcheck", "--addon=misra", "--std=c99", "--quiet", "-D__STDC_VERSION__=199901L",
                                  "--error-exitcode=0",
                                  "--template={file}:{line}:{id}", f"{g.name}.c"],
                                 cwd=tmp_path, capture_output=True, text=True, timeout=600)
            assert run.returncode == 0, run.stdout + run.stderr
            for line in run.stderr.splitlines():
                where, _, rule_id = line.rpartition(":")
                assert rule_id.startswith("misra-c2012-"), f"{key}: cppcheck: {line}"   # no syntaxError
                rule = rule_id[len("misra-c2012-"):]
                seen.setdefault(rule, []).append(f"{key}: {where}")
    unlisted = {r: v[:3] for r, v in seen.items() if r not in deviations}
    assert not unlisted, f"MISRA findings not in docs/misra.md: {unlisted}"
    assert not {r for r in seen if r not in ADVISORY}
    assert "12.1" in seen   # the addon ran and found what the record says it finds
