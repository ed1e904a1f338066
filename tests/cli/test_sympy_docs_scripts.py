"""Scripts a SymPy user brings, written from SymPy's "Kane's Method in Physics/Mechanics" page
(its own forms: ``kanes_equations(FL, BL)``, ``LagrangesMethod(..., coneqs=...)``) and ending in
``system = ...``, through ``eomc simulate`` with no other flag (s30 first hour): the results are
the closed forms (a force of 7 on a mass of 5: q = 0.7 t^2; L = q1'^2 + q2'^2, a force of 7 on
q1 and q1' = q2': q1 = q2 = 7/8 t^2)."""
import csv

import pytest

from eomc.cli import main

KANE = """\
from eomc.mechanics import *
N = ReferenceFrame('N')
q, u = dynamicsymbols('q u')
qd, ud = dynamicsymbols('q u', 1)
P = Point('P')
P.set_vel(N, u * N.x)
Pa = Particle('Pa', P, 5)
BL = [Pa]
FL = [(P, 7 * N.x)]
KM = KanesMethod(N, [q], [u], [qd - u])
(fr, frstar) = KM.kanes_equations(FL, BL)
system = KM
"""

LAGRANGE = """\
from eomc.mechanics import *
q1, q2 = dynamicsymbols('q1 q2')
q1d, q2d = dynamicsymbols('q1 q2', 1)
L = q1d**2 + q2d**2
N = ReferenceFrame('N')
P = Point('P')
P.set_vel(N, q1d * N.x)
FL = [(P, 7 * N.x)]
LM = LagrangesMethod(L, [q1, q2], forcelist = FL, frame = N, coneqs = [q1d - q2d])
LM.form_lagranges_equations()
system = LM
"""


@pytest.mark.parametrize("name, text, expected", [
    ("kane_particle", KANE, {"q": 2.8, "u": 2.8}),
    ("lagrange_coneqs", LAGRANGE, {"q1": 3.5, "q2": 3.5, "q1'": 3.5, "q2'": 3.5}),
])
def test_a_sympy_docs_script_simulates_to_its_closed_form(tmp_path, monkeypatch, capsys, name, text, expected):
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    model = tmp_path / f"{name}.py"
    model.write_text(text)
    out = tmp_path / "run.csv"
    assert main(["simulate", str(model), "--t-final", "2", "-o", str(out)]) == 0
    rows = [r for r in csv.DictReader(line for line in out.read_text().splitlines() if not line.startswith("#"))]
    assert float(rows[-1]["t"]) == 2.0
    for column, value in expected.items():
        assert float(rows[-1][column]) == pytest.approx(value, rel=1e-7), (column, rows[-1])
