"""The fixed step's trace hook (runtime/c/eomc_fixedstep.c, -DEOMC_FS_TRACE): a library built with
it runs the same steps to the same bits as the installed one and prints one line per try of its fast
path, as benchmarks/trace_fixedstep.py reads them.  Why tested: the hook is compiled out of every
library eomc ships, so only this build shows it still compiles clean and changes nothing."""
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from helpers.stand_in import RUNTIME_C

ROOT = Path(__file__).resolve().parents[2]
SOURCES = ("eomc_integrators.c", "eomc_fixedstep.c", "eomc_fixedstep_avx2.c", "eomc_bdf.c", "eomc_sensitivity.c",
           "eomc_rollout.c", "eomc_adjoint.c", "eomc_rows.c")

# a ball on a hinged stick, thrown onto the floor from MJCF (NAME_implicit: the fast path): it lands,
# so steps split at a located onset; one run in a process that opens the integrator library argv[1]
# ("-": the installed one)
XML = """<mujoco>
  <option timestep="0.005"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body pos="0 0 0.4">
      <freejoint name="root"/>
      <geom type="sphere" size="0.1" mass="1"/>
      <body pos="0 0 0.1">
        <joint name="hinge" type="hinge" axis="0 1 0" range="-60 60"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
RUN = """
import json, sys, warnings
from pathlib import Path
import numpy as np
import eomc, eomc.runtime.native as native
from eomc.compiler.mjcf.model import MjcfModel
if sys.argv[1] != "-":
    native._library_path = lambda: Path(sys.argv[1])
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    m = eomc.compile(MjcfModel(sys.argv[3]), name="trace_ball", cache_dir=sys.argv[2], progress=False)
names = list(m.state_names)
x0 = np.zeros(len(names))
for n, v in (("q_root_z", 0.4), ("u_root_vx", 1.0), ("u_root_wy", 3.0)):
    x0[names.index(n)] = v
x0[names.index("q_root_qw")] = 1.0
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    res = m.simulate(x0, (0.0, 1.0), method="implicitfast", dt=5e-3)
print(json.dumps({"x": [v.hex() for v in res.x[-1]], "nfev": int(res.stats["nfev"]), "status": int(res.status)}))
"""


@pytest.fixture(scope="module")
def traced(tmp_path_factory):
    if shutil.which("gcc") is None:
        pytest.fail("gcc is required for the runtime C tests")
    out = tmp_path_factory.mktemp("trace") / "_eomc_integrators_trace.so"
    cmd = ["gcc", "-std=c99", "-O2", "-pthread", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror",
           "-DEOMC_FS_TRACE", f"-I{RUNTIME_C}", *[str(RUNTIME_C / s) for s in SOURCES], "-lm", "-o", str(out)]
    build = subprocess.run(cmd, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    return out


def _run(library, cache):
    xml = Path(cache) / "ball.xml"
    xml.write_text(XML)
    proc = subprocess.run([sys.executable, "-c", RUN, str(library), str(cache), str(xml)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


def test_the_traced_library_runs_the_same_steps_and_prints_each_try(traced, tmp_path):
    plain, quiet = _run("-", tmp_path)
    got, lines = _run(traced, tmp_path)
    assert got == plain                         # the same end state to the bit, the same calls
    assert plain["status"] == 0
    assert "EOMC_FS_TRY" not in quiet           # the shipped library has no hook
    tries = [line.split() for line in lines.splitlines() if line.startswith("EOMC_FS_TRY ")]
    assert all(len(f) == 12 for f in tries)
    # every try is one model call; the run's first call (the start's terms) is no try
    assert len(tries) == got["nfev"] - 1
    whole = [f for f in tries if f[2] == "0" and f[3] == "64"]
    assert len(whole) == 200                    # one whole try per step of 5 ms over 1 s
    assert len(tries) > len(whole)              # the landing split a step ...
    assert any(f[6] == f[2] and f[3] == "1" for f in tries)      # ... at a located onset cell
    assert any(f[9] == "1" for f in tries) and any(f[10] == "1" for f in tries)   # in touch; a regime change
