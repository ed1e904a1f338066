"""The joint laws' slopes in NAME_dyn_inputs as one loop per shape of law (compiler/tree/law_loop.py).

A default build with the loop against the same build with the slopes unrolled (law_loop.LAW_LOOPS
off, the C before session 24): the functions that read NAME_dyn_inputs (jac_x, mass_matrix,
forcing, inverse_dynamics, jac_id) give the same bits at random states whose joints are inside,
on and past their limits (both sides, within a few widths and far past); the c99-f32 target
compiles the helper's float twin under -Werror.
"""
import re
import shutil
import subprocess

import numpy as np
import pytest

import eomc
from eomc.compiler.tree import law_loop
from eomc.compiler.urdf.model import UrdfModel
from helpers.robots import robot_path

G1 = "g1_description/urdf/g1_29dof_rev_1_0.urdf"


def _build(path, name, tmp_path, on, monkeypatch, floating):
    monkeypatch.setattr(law_loop, "LAW_LOOPS", on)
    system = UrdfModel(robot_path(path), floating_base=floating) if floating else str(robot_path(path))
    model = eomc.compile(system, name, progress=False, cache_dir=tmp_path / f"c{int(on)}",
                         output_dir=tmp_path / f"o{int(on)}")
    return model


def _states(model, rng, n):
    """Random states: each law's coordinate inside, near or past one of its limits."""
    p = model.param_defaults
    names = model.param_names
    X = []
    for k in range(n):
        x = rng.uniform(-0.5, 0.5, model.nx)
        for i, s in enumerate(model.state_names[:model.nq]):
            s = s[2:]       # q_<joint>: the laws' parameters are <name>_<joint>
            lo = f"limit_lo_{s}" in names and p[names.index(f"limit_lo_{s}")]
            hi = f"limit_hi_{s}" in names and p[names.index(f"limit_hi_{s}")]
            if lo is False or hi is False:
                continue
            e = p[names.index(f"limit_e_{s}")]
            side = lo if rng.random() < 0.5 else hi
            x[i] = side + e * rng.choice([-30.0, -3.0, -0.5, 0.0, 0.5, 3.0, 30.0]) * rng.uniform(0.5, 1.5)
            if k == 0:
                x[i] = side     # exactly on the boundary
        X.append(x)
    return X


@pytest.mark.parametrize("path,floating", [(G1, True), ("panda", False)])
def test_law_loop_gives_the_unrolled_bits(path, floating, tmp_path, monkeypatch):
    name = re.sub(r"\W", "_", path.split("/")[-1].split(".")[0])
    on = _build(path, f"{name}_ll", tmp_path, True, monkeypatch, floating)
    off = _build(path, f"{name}_ll", tmp_path, False, monkeypatch, floating)
    text, before = on.source_path.read_text(), off.source_path.read_text()
    assert f"static void {on.name}_law0(" in text and f"{on.name}_law0(" not in before
    assert len(text) < len(before)
    law_states = [s for s in on.state_names[:on.nq] if f"limit_lo_{s[2:]}" in on.param_names]
    assert law_states, "the model has joint laws"
    rng = np.random.default_rng(24)
    fns = [f for f in ("jacobian", "mass_matrix", "forcing") if f in on.functions or f == "jacobian"]
    for x in _states(on, rng, 12):
        if on.quaternions:
            for i in on.quaternions:
                x[i:i + 4] /= np.linalg.norm(x[i:i + 4])
        for fn in fns:
            a, b = getattr(on, fn)(0.0, x), getattr(off, fn)(0.0, x)
            assert np.isfinite(a).all()
            assert a.tobytes() == b.tobytes(), fn
        if "inverse_dynamics" in on.functions:
            ud = rng.uniform(-1, 1, on.nu)
            assert on.inverse_dynamics(0.0, x, ud).tobytes() == off.inverse_dynamics(0.0, x, ud).tobytes()


@pytest.mark.parametrize("cc", ["gcc", "clang"])
def test_law_loop_float_target(cc, tmp_path, monkeypatch):
    """c99-f32: the helper and its call become float (target.py's pass), clean under -Werror with
    -Wdouble-promotion -Wfloat-conversion (tests/compiler/emit/test_target_f32.py's flags)."""
    from eomc.compiler.driver import generate
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed")
    monkeypatch.setattr(law_loop, "LAW_LOOPS", True)
    g = generate(str(robot_path("panda")), "panda_f32", progress=False, use_cache=False, target="c99-f32",
                 functions=["rhs", "jac_x", "jac_r", "mass_matrix"])[1]
    code = re.sub(r"/\*.*?\*/", "", g.c_source, flags=re.S)
    assert "static void panda_f32_law0(float a0" in code and re.search(r"panda_f32_law0\(\w\[li0\[j\]\[0\]\]", code)
    assert not re.search(r"\bdouble\b", code.replace("panda_f32_", ""))
    (tmp_path / "panda_f32.c").write_text(g.c_source)
    (tmp_path / "panda_f32.h").write_text(g.header)
    shutil.copy(eomc.runtime.header_cdef.C_DIR / "eomc_model.h", tmp_path)
    run = subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Wextra", "-Wdouble-promotion", "-Wfloat-conversion",
                          "-Wpedantic", "-Werror", "-c", "panda_f32.c"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr[:3000]


@pytest.mark.parametrize("seed", range(5))
def test_index_needs_what_needed_assignments_needs(seed):
    """law_loop._Index (the program's temporaries indexed once for all laws) gives, for any
    results, the very list needed_assignments gives: the same assignments in program order."""
    import sympy as sm
    from eomc.compiler.ir.program import needed_assignments
    rng = np.random.default_rng(seed)
    x = sm.symbols("x0:4", real=True)
    assignments = []
    for k in range(60):     # each temporary reads inputs and up to three earlier temporaries
        earlier = [t for t, _ in assignments]
        reads = [x[i] for i in rng.choice(4, 2)] + ([earlier[i] for i in rng.choice(len(earlier), 3)] if k else [])
        assignments.append((sm.Symbol(f"_t{k}", real=True), sm.Add(*reads) * reads[0]))
    index = law_loop._Index(assignments)
    for _ in range(20):
        exprs = [assignments[i][0] * x[0] for i in rng.choice(60, int(rng.integers(1, 4)))]
        got = index.needed(exprs)
        assert got == needed_assignments(assignments, exprs)
