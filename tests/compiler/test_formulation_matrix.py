"""The formulation matrix (issue 19): every System SymPy 1.14's own mechanics tests build, the
project's zoo and every shipped example, under ``kane``, ``recursive`` and ``auto``.

For each model and formulation either C is generated, or the formulation is refused with
an eomc error (a ModelError/ModelFileError saying why) before any C is written -- never
another exception.  ``auto`` generates wherever kane or recursive does, and its C is
byte-identical to the formulation it chose.  Where both kane and recursive generate, the
two libraries agree at random states (rhs and mass matrix) to 1e-12.  No generated C holds
a NaN or infinite literal.

Cheap by construction: each model is generated once per formulation with rhs and
mass_matrix only (one small tree with the default function set, which auto once crashed
on), and all models' C of one formulation is compiled at -O0 into one shared library by
one compiler call, called through ctypes.
SymPy's test Systems are found the way test_sympy_suite runs SymPy's suite: its test files
are copied and run by pytest (in this process), with System and JointsMethod recording
every instance they make.
"""
import ctypes
import os
import re
import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy
import sympy.physics.mechanics as sme

import eomc.mechanics as em
from eomc.compiler.driver import generate
from eomc.errors import EomcError
from helpers import zoo
from helpers.trees import cart_joints, cart_relative

ROOT = Path(__file__).resolve().parents[2]
RUNTIME_C = ROOT / "runtime" / "c"
FORMULATIONS = ("kane", "recursive", "auto")
SYMPY_TEST_FILES = ("test_system_class.py", "test_jointsmethod.py")
CHECKED = ["rhs", "mass_matrix"]      # what the agreement reads; one case has the default set


def _harvest_sympy(dest):
    """Every System (and formed JointsMethod) SymPy 1.14's System tests make, one per shape."""
    src = Path(sympy.__file__).parent / "physics" / "mechanics" / "tests"
    for f in SYMPY_TEST_FILES:
        shutil.copy(src / f, dest / f)
    made = []
    init, form = sme.System.__init__, sme.JointsMethod.form_eoms

    def record_init(self, *args, **kwargs):
        init(self, *args, **kwargs)
        made.append(self)

    def record_form(self, *args, **kwargs):      # JointsMethod.__init__ warns with a stacklevel
        result = form(self, *args, **kwargs)
        made.append(self)
        return result
    sme.System.__init__, sme.JointsMethod.form_eoms = record_init, record_form
    try:
        code = pytest.main(["-q", "-p", "no:cacheprovider", "-p", "no:randomly", "-o", "addopts=",
                            "--rootdir", str(dest), *(str(dest / f) for f in SYMPY_TEST_FILES)])
    finally:
        sme.System.__init__, sme.JointsMethod.form_eoms = init, form
    assert code == 0, "SymPy's own System tests failed"
    seen, out = set(), []
    for s in made:
        try:
            if not (len(s.q) and len(s.u) and len(s.bodies)):
                continue
            if isinstance(s, sme.System):
                key = ("System", str(list(s.q)), str(list(s.u)), str([b.name for b in s.bodies]),
                       str([j.name for j in s.joints]), str(list(s.kdes)), str(s.loads),
                       str([type(a).__name__ for a in s.actuators]), str(list(s.holonomic_constraints)),
                       str(list(s.nonholonomic_constraints)), type(s.eom_method).__name__)
            else:
                key = ("JointsMethod", str(list(s.q)), str(list(s.u)), str([b.name for b in s.bodies]),
                       type(s.method).__name__)
        except Exception:      # noqa: BLE001 -- a System a test left half-built: nothing to compile
            continue
        if key not in seen:
            seen.add(key)
            out.append(s)
    return out


def _cases(tmp):
    """(id, model, generate keywords, parameter values or None for random ones)."""
    cheap = {"functions": CHECKED}
    cases = [(f"sympy{i}_{type(s).__name__}", s, dict(cheap)) for i, s in enumerate(_harvest_sympy(tmp))]
    for label, (model, inputs) in {
            "zoo_pendulum_on_cart": zoo.n_link_pendulum_on_cart(2, em, joint_torques=True),
            "zoo_pendulum_on_cart_lagrange": zoo.n_link_pendulum_on_cart_lagrange(2, em),
            "zoo_heavy_top": zoo.heavy_top(em),
            "zoo_rolling_disc": zoo.rolling_disc(em),
            "zoo_rolling_disc_aux": zoo.rolling_disc_aux(em),
            "zoo_four_bar": zoo.four_bar(em),
            "zoo_spring_damper_chain": zoo.spring_damper_chain(3, em),
            "cart_relative_kane": cart_relative(3, em, torques=True),
            "cart_relative_kane_sympy": cart_relative(2, sme),
            "cart_joints_system": cart_joints(3),
            "cart_joints_system_6": cart_joints(6)}.items():
        # the default function set (auto's crash of the 2026-11 reports) on a small tree
        functions = None if label == "cart_relative_kane" else CHECKED
        cases.append((label, model, {"inputs": inputs, "functions": functions}))
    for path in sorted((ROOT / "examples").glob("*.py")):
        cases.append((f"example_{path.stem}", str(path), dict(cheap)))
    return cases


def _generate_all(case_id, model, kwargs, index):
    out = {}
    for f in FORMULATIONS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                spec, gm = generate(model, f"m{index}", formulation=f, use_cache=False,
                                    progress=False, **kwargs)
                out[f] = gm
            except EomcError as exc:
                out[f] = exc
    return out


def _compile(tmp, label, generated):
    """One -O0 shared library of every model's C of one formulation (names are unique)."""
    if not generated:
        return None
    sources = []
    for gm in generated:
        (tmp / f"{gm.name}.c").write_text(gm.c_source)
        (tmp / f"{gm.name}.h").write_text(gm.header)
        sources.append(str(tmp / f"{gm.name}.c"))
    lib = tmp / f"lib{label}.so"
    cc = shutil.which("gcc") or shutil.which("cc")
    subprocess.run([cc, "-std=c99", "-O0", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror",
                    f"-I{RUNTIME_C}", f"-I{tmp}", *sources, "-o", str(lib), "-lm"], check=True)
    return ctypes.CDLL(str(lib))


@pytest.fixture(scope="module")
def matrix(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("matrix")
    harvest = tmp / "sympy_tests"
    harvest.mkdir()
    rows = {}
    for index, (case_id, model, kwargs) in enumerate(_cases(harvest)):
        rows[case_id] = _generate_all(case_id, model, kwargs, index)
    libs = {f: _compile(tmp, f, [r[f] for r in rows.values() if not isinstance(r[f], Exception)])
            for f in ("kane", "recursive")}
    return rows, libs


def _call(lib, gm, fn, x, p, r, size):
    f = getattr(lib, f"{gm.name}_{fn}")
    f.restype = ctypes.c_int
    dp = ctypes.POINTER(ctypes.c_double)
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (x, p if len(p) else [0.0],
                                                               r if len(r) else [0.0])]
    out = np.zeros(size)
    work = np.zeros(max(1, gm.metadata["work_size"]))
    status = f(ctypes.c_double(0.0), *(a.ctypes.data_as(dp) for a in arrays),
               out.ctypes.data_as(dp), work.ctypes.data_as(dp))
    return status, out


def test_the_matrix_covers_sympys_systems_the_zoo_and_the_examples(matrix):
    rows, _ = matrix
    ids = list(rows)
    assert sum(i.startswith("sympy") for i in ids) >= 8
    assert {f"example_{p.stem}" for p in (ROOT / "examples").glob("*.py")} <= set(ids)
    # both formulations generate somewhere, and each is refused somewhere (the matrix is not trivial)
    for f in ("kane", "recursive"):
        assert any(not isinstance(r[f], Exception) for r in rows.values()), f
    assert any(isinstance(r["recursive"], Exception) for r in rows.values())


def test_auto_never_fails_where_either_formulation_works(matrix):
    rows, _ = matrix
    failed = {i: r["auto"] for i, r in rows.items() if isinstance(r["auto"], Exception)
              and not (isinstance(r["kane"], Exception) and isinstance(r["recursive"], Exception))}
    assert not failed, failed


def test_refusals_say_why_and_auto_says_why_it_fell_back(matrix):
    rows, _ = matrix
    for case_id, r in rows.items():
        for f in FORMULATIONS:
            if isinstance(r[f], Exception):
                assert len(str(r[f])) > 20, (case_id, f, r[f])
        auto = r["auto"]
        if isinstance(auto, Exception) or not isinstance(r["recursive"], Exception):
            continue
        assert auto.metadata["formulation"] == "kane"
        note = auto.metadata["formulation_note"]
        assert note.startswith("kane, the fallback (") and len(note) > 30, (case_id, note)


def test_auto_writes_exactly_the_c_of_the_formulation_it_chose(matrix):
    rows, _ = matrix
    for case_id, r in rows.items():
        auto = r["auto"]
        if isinstance(auto, Exception):
            continue
        chosen = r[auto.metadata["formulation"]]
        assert not isinstance(chosen, Exception), (case_id, chosen)
        assert auto.c_source == chosen.c_source, case_id


def test_no_generated_c_holds_a_nonfinite_literal(matrix):
    rows, _ = matrix
    for case_id, r in rows.items():
        for f in FORMULATIONS:
            if not isinstance(r[f], Exception):
                # SymPy's C99 printer writes nan as NAN and ±oo as ±HUGE_VAL (the LU solver's
                # own `a < HUGE_VAL` test is no literal of the model)
                assert not re.search(r"\bNAN\b|\bINFINITY\b|(?<!< )HUGE_VAL", r[f].c_source), (case_id, f)


def test_kane_and_recursive_agree_at_random_states(matrix):
    rows, libs = matrix
    compared = 0
    for case_id, r in rows.items():
        kane, rec = r["kane"], r["recursive"]
        if isinstance(kane, Exception) or isinstance(rec, Exception):
            continue
        rng = np.random.default_rng(len(case_id))
        names = sorted(set(kane.metadata["param_names"]) | set(rec.metadata["param_names"]))
        nx, nu = kane.metadata["nx"], kane.metadata["nu"]
        assert (rec.metadata["state_names"], rec.metadata["input_names"]) == \
            (kane.metadata["state_names"], kane.metadata["input_names"]), case_id
        checked = 0
        for _ in range(40):
            vals = {k: rng.uniform(0.5, 1.5) for k in names}
            pk = [vals[k] for k in kane.metadata["param_names"]]
            pr = [vals[k] for k in rec.metadata["param_names"]]
            x = rng.uniform(-1.0, 1.0, nx)
            u = rng.uniform(-1.0, 1.0, kane.metadata["ninput"])
            sk, M = _call(libs["kane"], kane, "mass_matrix", x, pk, u, nu * nu)
            if sk != 0 or np.linalg.cond(M.reshape(nu, nu)) > 1e8:
                continue          # near-singular M: a difference would measure conditioning
            sr, Mr = _call(libs["recursive"], rec, "mass_matrix", x, pr, u, nu * nu)
            assert sr == 0 and np.max(np.abs(Mr - M) / np.maximum(1, np.abs(M))) < 1e-12, case_id
            (sk, fk), (sr, fr) = (_call(libs[f], g, "rhs", x, p, u, nx)
                                  for f, g, p in (("kane", kane, pk), ("recursive", rec, pr)))
            assert sk == sr == 0, (case_id, sk, sr)
            assert np.max(np.abs(fr - fk) / np.maximum(1, np.abs(fk))) < 1e-12, (case_id, fk, fr)
            checked += 1
            if checked == 3:
                break
        assert checked == 3, f"{case_id}: no well-conditioned state found"
        compared += 1
    assert compared >= 5


def test_constrained_systems_run_on_the_tree_unless_nonholonomic(matrix):
    """Issue 19 item 3: a System whose loops holonomic constraints close runs on the tree
    (spanning tree + constraint solve) and agrees with Kane (the test above); nonholonomic
    constraints and hand-built KanesMethods with dependent speeds stay Kane's, refused with
    the reason, as does a System formed by Lagrange's method with dependent coordinates only.
    Before, every constrained case went to Kane."""
    rows, _ = matrix
    on_tree, kane_only = [], []
    for case_id, r in rows.items():
        kane = r["kane"]
        if isinstance(kane, Exception) or not kane.metadata["nvel"]:
            continue
        rec = r["recursive"]
        nonholonomic = kane.metadata["nvel"] > kane.metadata["nhol"]
        if isinstance(rec, Exception):
            kane_only.append(case_id)
            # holonomic only: a hand-built KanesMethod with dependent speeds, or a System
            # formed by Lagrange's method (q_dep but no u_dep: multipliers, not a Kane state)
            why = str(rec)
            # nonholonomic; a System formed by Lagrange's method (dependent coordinates, no
            # dependent speeds); hand-built KanesMethods that are no relative-coordinate tree
            # (absolute angles, a body moving with two new speeds, auxiliary speeds)
            reasons = ("nonholonomic", "0 dependent speed(s)", "depends on more than its own",
                       "moves with speeds", "auxiliary speeds")
            assert any(r in why for r in reasons), (case_id, rec)
            assert not nonholonomic or "nonholonomic" in why or "System" not in case_id, case_id
            continue
        assert not nonholonomic, case_id
        on_tree.append(case_id)
        assert (rec.metadata["nhol"], rec.metadata["nvel"]) == (kane.metadata["nhol"], kane.metadata["nvel"])
        assert rec.metadata["state_names"] == kane.metadata["state_names"]
    # SymPy's constrained test Systems and the four-bar example run on the tree now
    assert "example_four_bar_system" in on_tree, (on_tree, kane_only)
    assert sum(i.startswith("sympy") for i in on_tree) >= 1, (on_tree, kane_only)
    print("on the tree:", on_tree, "Kane only:", kane_only)
