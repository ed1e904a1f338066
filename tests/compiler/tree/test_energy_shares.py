"""The tree's ``energy`` output (compiler/tree/contacts._energy) is a sum of named shares: one
temporary per body (its kinetic and gravity terms) and one per limited joint (its limit springs'
stored energy), so the printed C has no one giant statement.  Why: printed as one sum it was a
33 kB C statement on Talos, and gcc compiled the file 0.15-0.17 s slower on G1 and Talos
(benchmarks/results/derivative_build.md, session 20).  The energy's value is checked elsewhere
(test_energy_function.py against NAME_outputs, tests/runtime/test_limit_energy.py)."""
import re

from eomc.compiler.driver import generate
from helpers.urdf_arm import LAW_ARM


def test_energy_is_a_sum_of_named_body_and_joint_shares(tmp_path):
    path = tmp_path / "law_arm.urdf"
    path.write_text(LAW_ARM)
    g = generate(str(path), "en_shares", formulation="recursive", use_cache=False, progress=False)[1]
    nq = g.metadata["nq"]
    c = g.c_source
    start = c.index("int en_shares_energy(")
    body = c[start:c.index("\n}\n", start)]
    assert "en_shares_energy_part" not in c          # small: one straight body, read as it is
    result = re.search(r"out\[0\] = (t\d+);", body).group(1)
    total = re.search(rf"const double {result} = ([^;]*);", body).group(1)
    terms = total.split(" + ")
    # LAW_ARM: a fixed base, nq revolute joints each with both limits: nq bodies + nq joints' springs
    assert all(re.fullmatch(r"t\d+", t) for t in terms), total
    assert len(terms) == 2 * nq
