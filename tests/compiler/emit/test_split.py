"""Long straight-line runs become bounded sub-functions (eomc.compiler.emit.split).

The split C must compute exactly what the unsplit C computes (the same expressions in
the same order; only where values live changes), stay strict-warning clean and
byte-identical across runs.  The models here are small, so the thresholds are lowered
to split them into many pieces.
"""
import re

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import numpy as np
import pytest
from sympy.physics import mechanics as me

import eomc
import eomc.mechanics as em
from eomc.compiler.emit import generate_c, split, symbolic
from eomc.compiler.tree import chain_loop
from helpers import emit_support as es
from helpers import zoo
from helpers.trees import cart_relative

STRICT_EXTRA = ("-O2", "-Wshadow", "-Wconversion")


@pytest.fixture
def tiny(monkeypatch):
    monkeypatch.setattr(split, "SPLIT_MIN", 6)
    monkeypatch.setattr(split, "CHUNK", 5)


def _chain_lines(n):
    lines = ["    const double t0 = x[0]*p[1];"]
    lines += [f"    const double t{i} = t{i - 1}*x[{i % 3}] + p[0];" for i in range(1, n)]
    return lines + [f"    out[0] = t{n - 1} + t3;", "    return 0;"]


def test_short_runs_are_left_alone():
    lines = _chain_lines(20)
    assert split.split_body(lines, "m_f_part") == (lines, [])


def test_long_run_is_cut_into_chunks_with_a_scratch_array(tiny):
    lines, parts = split.split_body(_chain_lines(23), "m_f_part")
    assert len(parts) == 5                                      # 23 temporaries + 1 store, by 5
    for part in parts:
        assert part.startswith("static EOMC_NOINLINE void m_f_part0_")
        assert len(re.findall(r"const double t\d+ =", part)) <= 5
    # t3 (read by the store) and the running value, which crosses each boundary: its slot
    # is reused only from the chunk after its last reader, so two slots alternate
    assert lines[0] == "    double S_[3];"
    assert lines[1:5] == [f"    m_f_part0_{c}(p, x, S_);" for c in range(4)]
    assert lines[5:] == ["    m_f_part0_4(out, p, x, S_);", "    return 0;"]
    assert parts[4].startswith("static EOMC_NOINLINE void m_f_part0_4(double *out, const double *p, "
                               "const double *x, double *S_)")
    assert "    out[0] = t22 + S_[0];" in parts[4]


def test_restrict_scratch_is_asked_for(tiny):
    """restrict=True: every sub-function takes the scratch array as ``double *restrict S_``
    (nothing else changes); the default leaves the C as it was."""
    plain, plain_parts = split.split_body(_chain_lines(23), "m_f_part")
    lines, parts = split.split_body(_chain_lines(23), "m_f_part", restrict=True)
    assert lines == plain
    assert all("restrict" not in part for part in plain_parts)
    assert [part.replace("double *restrict S_)", "double *S_)", 1) for part in parts] == plain_parts
    assert all(part.split("\n", 1)[0].endswith("double *restrict S_)") for part in parts)


def test_chunks_are_bounded_in_bytes_too(tiny, monkeypatch):
    monkeypatch.setattr(split, "CHUNK_BYTES", 60)        # two of these statements
    lines, parts = split.split_body(_chain_lines(12), "m_f_part")
    assert len(parts) == 7 and all(len(re.findall(r" = ", p)) <= 4 for p in parts)


def test_a_run_reading_an_unknown_identifier_stays_whole(tiny):
    lines = _chain_lines(20)
    lines[5] = "    const double t5 = t4*x[k];"     # a loop counter: not a sub-function's to read
    assert split.split_body(lines, "m_f_part") == (lines, [])


def test_earlier_temporaries_are_stored_for_the_chunks(tiny):
    lines = ["    const double t100 = x[1]*x[2];", "    F[0] = t100;", "    status = 1;"]
    lines += _chain_lines(12)
    lines[4] = "    const double t1 = t0*t100;"
    out, parts = split.split_body(lines, "m_f_part")
    assert out[1:5] == ["    const double t100 = x[1]*x[2];", "    S_[0] = t100;", "    F[0] = t100;",
                        "    status = 1;"]
    assert "t100" not in "".join(parts) and "S_[0]" in parts[0]


def test_sin_and_cos_of_one_argument_stay_adjacent(tiny):
    """A sin temporary's scratch store goes below the cos of the same argument that follows it
    (and a cos's below a sin), so gcc can make the pair one sincos call; a pair of two
    arguments, or one with another statement between, is left as it was."""
    lines = ["    const double t0 = sin(x[1]);", "    const double t1 = cos(x[1]);",
             "    const double t2 = cos(x[2]);", "    const double t3 = sin(x[2]);",
             "    const double t4 = sin(x[0]);", "    const double t5 = cos(x[1]);",
             "    const double t6 = sin(x[0]);", "    const double t7 = x[0]*p[0];",
             "    const double t8 = cos(x[0]);"]
    lines += [f"    const double t{i} = t{i - 1}*x[{i % 3}] + p[0];" for i in range(9, 21)]
    lines += ["    out[0] = t0 + t1 + t2 + t3 + t4 + t5 + t6 + t7 + t8 + t20;", "    return 0;"]
    out, parts = split.split_body(lines, "m_f_part")
    first = parts[0].split("\n")
    assert first[2:10] == ["    const double t0 = sin(x[1]);", "    const double t1 = cos(x[1]);",
                           "    S_[0] = t0;", "    S_[1] = t1;",
                           "    const double t2 = cos(x[2]);", "    const double t3 = sin(x[2]);",
                           "    S_[2] = t2;", "    S_[3] = t3;"]
    second = parts[1].split("\n")            # sin(x[0]) then cos(x[1]): stores stay where they were
    assert second[2:6] == ["    const double t5 = cos(x[1]);", "    S_[5] = t5;",
                           "    const double t6 = sin(x[0]);", "    S_[6] = t6;"]
    # only stores moved: every temporary is still defined once, in the original order
    assert re.findall(r"const double (t\d+) =", "".join(parts)) == [f"t{i}" for i in range(21)]


def _models():
    kane, spec = zoo.n_link_pendulum_on_cart(2, me)
    formed = es.kane_formed(kane, spec)
    q = formed.coordinates
    outs = {"tip": q[0] + q[1] ** 2, "e": formed.speeds[0] ** 2}
    sphere = es.lagrange_formed(es.particle_on_sphere())
    saved = symbolic.TANGENT_MIN_STATES
    symbolic.TANGENT_MIN_STATES = 0
    try:
        looped = generate_c(formed, "looped")
    finally:
        symbolic.TANGENT_MIN_STATES = saved
    return [generate_c(formed, "cartout", outputs=outs), generate_c(sphere, "sphere"), looped]


FUNCTIONS = {"rhs": lambda m: (m["nx"],), "jac_x": lambda m: (m["nx"], m["nx"]),
             "jac_r": lambda m: (m["nx"], m["ninput"]), "mass_matrix": lambda m: (m["nu"], m["nu"]),
             "forcing": lambda m: (m["nu"],), "outputs": lambda m: (m["noutput"],),
             "constraints": lambda m: (m["nhol"] + m["nvel"],),
             "constraints_jac": lambda m: (m["nhol"] + m["nvel"], m["nx"])}


def test_split_models_compute_what_unsplit_ones_do(tmp_path, monkeypatch):
    whole = _models()
    monkeypatch.setattr(split, "SPLIT_MIN", 6)
    monkeypatch.setattr(split, "CHUNK", 5)
    parts = _models()
    again = _models()
    rng = np.random.default_rng(7)
    for gw, gs, ga in zip(whole, parts, again):
        assert gs.c_source == ga.c_source and gs.header == ga.header      # byte-identical
        assert "EOMC_NOINLINE void" not in gw.c_source
        assert gs.c_source.count("EOMC_NOINLINE void") >= 2
        (tmp_path / f"{gw.name}_whole").mkdir()
        (tmp_path / f"{gs.name}_split").mkdir()
        cw = es.Compiled(gw, tmp_path / f"{gw.name}_whole", flags=STRICT_EXTRA)
        cs = es.Compiled(gs, tmp_path / f"{gs.name}_split", flags=STRICT_EXTRA)
        meta = gw.metadata
        checked = 0
        for fn, shape in FUNCTIONS.items():
            if fn not in meta["functions"]:
                continue
            for _ in range(3):
                x = rng.uniform(-1, 1, meta["nx"])
                p = rng.uniform(0.5, 1.5, meta["nparam"])
                r = rng.uniform(-1, 1, meta["ninput"])
                sw, vw = cw.call(fn, shape(meta), 0.3, x, p, r)
                ss, vs = cs.call(fn, shape(meta), 0.3, x, p, r)
                assert sw == ss == 0 and np.all(np.isfinite(vw))
                np.testing.assert_allclose(vs, vw, rtol=1e-14, atol=0)
                checked += 1
        assert checked >= 9


def test_split_recursive_formulation_agrees(tmp_path, monkeypatch):
    """The recursive formulation's bodies (eomc.compiler.tree.emit) are split too."""
    kane, inputs = cart_relative(4, em)
    monkeypatch.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", None)   # the straight-line rhs (a run of 4 links is looped)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "whole"))
    mw = eomc.compile(kane, "cart_w", inputs=inputs, progress=False, formulation="recursive")
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "split"))
    monkeypatch.setattr(split, "SPLIT_MIN", 6)
    monkeypatch.setattr(split, "CHUNK", 5)
    ms = eomc.compile(kane, "cart_s", inputs=inputs, progress=False, formulation="recursive")
    assert "EOMC_NOINLINE void cart_s_rhs_part" in ms.source_path.read_text()
    assert "EOMC_NOINLINE void cart_w_rhs_part" not in mw.source_path.read_text()
    rng = np.random.default_rng(3)
    for _ in range(4):
        x = rng.uniform(-1, 1, mw.nx)
        r = rng.uniform(-1, 1, mw.ninput)
        ud = rng.uniform(-1, 1, mw.nu)
        for a, b in ((ms.rhs(0.0, x, r=r), mw.rhs(0.0, x, r=r)),
                     (ms.mass_matrix(0.0, x, r=r), mw.mass_matrix(0.0, x, r=r)),
                     (ms.inverse_dynamics(0.0, x, ud, r=r), mw.inverse_dynamics(0.0, x, ud, r=r)),
                     (ms.jacobian(0.0, x, r=r), mw.jacobian(0.0, x, r=r))):
            np.testing.assert_allclose(a, b, rtol=1e-14, atol=0)


def test_recursive_rhs_parts_restrict_their_scratch(tmp_path, monkeypatch):
    """The recursive formulation's rhs sub-functions take S_ restrict (the compiler may keep
    inputs in registers across scratch stores and pair sin/cos into sincos); its other
    functions' parts do not.  The rhs gives what the rhs without restrict gives (rhs_batch
    rewrites restrict parts too: tests/compiler/emit/test_batch.py, UR5)."""
    from eomc.compiler.formulations.recursive import Recursive
    kane, inputs = cart_relative(4, em)
    monkeypatch.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", None)   # the straight-line rhs (a run of 4 links is looped)
    monkeypatch.setattr(split, "SPLIT_MIN", 6)
    monkeypatch.setattr(split, "CHUNK", 5)
    fns = ["rhs", "jac_x"]
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "restrict"))
    mr = eomc.compile(kane, "cart_rs", inputs=inputs, functions=fns, progress=False, formulation="recursive")
    monkeypatch.setattr(Recursive, "restrict_scratch", lambda self, fn: False)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "plain"))
    mp = eomc.compile(kane, "cart_pl", inputs=inputs, functions=fns, progress=False, formulation="recursive")
    src, plain = mr.source_path.read_text(), mp.source_path.read_text()
    heads = re.findall(r"^static EOMC_NOINLINE void (cart_rs_\w+?)_part\w*\((.*)\)$", src, re.M)
    rhs = [params for fn, params in heads if fn == "cart_rs_rhs"]
    others = [params for fn, params in heads if fn == "cart_rs_jac_x"]
    assert len(rhs) >= 2 and others
    assert all(p.endswith("double *restrict S_") for p in rhs if "S_" in p)
    assert not any("restrict" in p for p in others)
    assert src.replace("double *restrict S_", "double *S_").replace("cart_rs", "cart_pl") == plain
    rng = np.random.default_rng(5)
    X = rng.uniform(-1, 1, (9, mr.nx))
    R = rng.uniform(-1, 1, mr.ninput)
    want = np.array([mp.rhs(0.0, x, r=R) for x in X])
    np.testing.assert_allclose(np.array([mr.rhs(0.0, x, r=R) for x in X]), want, rtol=1e-14, atol=0)


def test_recursive_rhs_parts_take_near_pointers(tmp_path, monkeypatch):
    """The recursive formulation's rhs (its long runs: split.WINDOW_MIN) reaches its scratch
    slots through near pointers; its jac_x does not; the rhs's bits are those without them."""
    kane, inputs = cart_relative(4, em)
    monkeypatch.setattr(chain_loop, "CHAIN_LOOP_MIN_LINKS", None)   # the straight-line rhs (a run of 4 links is looped)
    monkeypatch.setattr(split, "SPLIT_MIN", 6)
    monkeypatch.setattr(split, "CHUNK", 5)
    monkeypatch.setattr(split, "WINDOW_MIN", 6)
    monkeypatch.setattr(split, "WINDOW_MIN_REFS", 2)
    fns = ["rhs", "jac_x"]
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "near"))
    mn = eomc.compile(kane, "cart_nr", inputs=inputs, functions=fns, progress=False, formulation="recursive")
    monkeypatch.setattr(split, "WINDOW_MIN", 10 ** 9)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "far"))
    mf = eomc.compile(kane, "cart_fr", inputs=inputs, functions=fns, progress=False, formulation="recursive")
    src = mn.source_path.read_text()
    heads = re.findall(r"^static (EOMC_NOINLINE|EOMC_NEAR) void (cart_nr_\w+?)_part\w*\((.*)\)$", src, re.M)
    rhs = [(attr, params) for attr, fn, params in heads if fn == "cart_nr_rhs"]
    assert rhs and all(attr == "EOMC_NEAR" for attr, _ in rhs)       # compiled without TER
    assert any("double *restrict S_w0" in params for _, params in rhs)
    assert not any("S_w" in params or attr == "EOMC_NEAR" for attr, fn, params in heads if fn != "cart_nr_rhs")
    assert src.count("#define EOMC_NEAR ") == 2 and "EOMC_NEAR" not in mf.source_path.read_text()
    assert "S_w" not in mf.source_path.read_text()
    rng = np.random.default_rng(11)
    for x in rng.uniform(-1, 1, (9, mn.nx)):
        r = rng.uniform(-1, 1, mn.ninput)
        np.testing.assert_array_equal(mn.rhs(0.0, x, r=r), mf.rhs(0.0, x, r=r))
        np.testing.assert_array_equal(mn.jacobian(0.0, x, r=r), mf.jacobian(0.0, x, r=r))


def test_long_bodies_are_compiled_lean(tmp_path, monkeypatch):
    """A body the split leaves longer than LEAN_MIN lines gets EOMC_LEAN (jac_x) or
    EOMC_LEAN_PRE (rhs) before its definition, and the macros once; nothing else in the C
    changes, it is clean under -Wall -Wextra, and it computes the same bits."""
    import subprocess
    kane, inputs = cart_relative(4, em)
    fns = ["rhs", "jac_x", "mass_matrix"]
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "plain"))
    mp = eomc.compile(kane, "cart_pl", inputs=inputs, functions=fns, progress=False, formulation="recursive")
    monkeypatch.setattr(split, "LEAN_MIN", 0)
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "lean"))
    ml = eomc.compile(kane, "cart_ln", inputs=inputs, functions=fns, progress=False, formulation="recursive")
    src, plain = ml.source_path.read_text(), mp.source_path.read_text()
    assert "EOMC_LEAN" not in plain
    assert src.count(split.LEAN_MACRO) == 1
    assert re.findall(r"^(EOMC_LEAN\w*) int cart_ln_(\w+)\(", src, re.M) == [
        ("EOMC_LEAN_PRE", "rhs"), ("EOMC_LEAN", "jac_x")]                  # not mass_matrix
    unlean = src.replace("\n\n" + split.LEAN_MACRO + "\n", "\n").replace("EOMC_LEAN_PRE int ", "int ")
    assert unlean.replace("EOMC_LEAN int ", "int ").replace("cart_ln", "cart_pl") == plain
    subprocess.run(["cc", "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror", "-c", str(ml.source_path),
                    "-o", str(tmp_path / "lean.o")], check=True, cwd=ml.source_path.parent)
    rng = np.random.default_rng(11)
    for x in rng.uniform(-1, 1, (6, ml.nx)):
        r = rng.uniform(-1, 1, ml.ninput)
        np.testing.assert_array_equal(ml.rhs(0.0, x, r=r), mp.rhs(0.0, x, r=r))
        np.testing.assert_array_equal(ml.jacobian(0.0, x, r=r), mp.jacobian(0.0, x, r=r))


_SCRIPT = """
import sys
sys.path[:0] = {paths!r}
from helpers import zoo, emit_support as es
from sympy.physics import mechanics as me
from eomc.compiler.emit import generate_c, split
split.SPLIT_MIN, split.CHUNK = 6, 5
kane, spec = zoo.n_link_pendulum_on_cart(2, me)
sys.stdout.write(generate_c(es.kane_formed(kane, spec), "det").c_source)
"""


def test_split_c_is_byte_identical_across_hash_seeds():
    import os
    import subprocess
    import sys
    here = os.path.dirname(os.path.abspath(__file__))
    script = _SCRIPT.format(paths=[here, os.path.dirname(os.path.dirname(here))])
    outs = [subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True,
                           env=dict(os.environ, PYTHONHASHSEED=seed)).stdout for seed in ("1", "999")]
    assert outs[0] == outs[1] and outs[0].count("EOMC_NOINLINE void det_") >= 4


def _random_body(draw_ops):
    """C lines of a random straight-line body: temporaries reading earlier ones (far back
    too), broken into runs by updates ``P[k] += ...`` that later lines read back."""
    lines, temps, stores = [], [], 0
    for kind, a, b, c in draw_ops:
        if kind == 1 and temps:       # a block redefining an existing name (a column loop's)
            name, other = temps[a % len(temps)], temps[b % len(temps)]
            lines += ["    {", f"        const double {name} = 0.5*{other} + x[{c % 4}];",
                      f"        P[0] += {name};", "    }"]
            stores = max(stores, 1)
            continue
        if kind == 2 and temps:       # a guard block (compiler/emit/guards.py's shape)
            own = f"t{10000 + len(lines)}"
            lines += [f"    if (!({temps[a % len(temps)]} > 0.5)) {{",
                      f"        const double {own} = 0.5*{temps[b % len(temps)]} + x[{c % 4}];",
                      f"        P[{stores}] = {own}*{own};", "    } else {", f"        P[{stores}] = 0.0;", "    }"]
            stores += 1
            continue
        if kind == 0 and temps:
            lines.append(f"    P[{stores}] += {temps[a % len(temps)]} + x[{c % 4}];")
            stores += 1
            continue
        terms = [f"x[{c % 4}]"]
        if temps:
            terms = [temps[a % len(temps)], f"sin({temps[b % len(temps)]})"] + terms
        if stores:
            terms.append(f"P[{b % stores}]")
        name = f"t{len(temps)}"
        expr = " + ".join(f"{0.5 ** (k + 1)}*{term}" for k, term in enumerate(terms))
        lines.append(f"    const double {name} = {expr};")
        temps.append(name)
    outs = [f"    out[{i}] = {t};" for i, t in enumerate(temps[::-1][:3] + temps[:3])]
    return lines + outs, max(stores, 1)


def _run_c(tmp_path, tag, lines, helpers, nP):
    import ctypes
    import subprocess
    src = tmp_path / f"{tag}.c"
    src.write_text("#include <math.h>\n" + split.NOINLINE_MACRO + "\n" + "\n".join(helpers)
                   + f"\nvoid f(const double *x, double *out)\n{{\n    double P[{nP}] = {{0.0}};\n"
                   + "\n".join(lines) + "\n}\n")
    lib = tmp_path / f"lib{tag}.so"
    subprocess.run(["gcc", "-O2", "-std=c99", "-shared", "-fPIC",
                    str(src), "-o", str(lib), "-lm"], check=True)
    f = ctypes.CDLL(str(lib)).f
    x = (ctypes.c_double * 4)(0.3, -0.7, 1.1, 0.2)
    out = (ctypes.c_double * 6)()
    f(x, out)
    return list(out)


_ops = st.lists(st.tuples(st.integers(0, 11), st.integers(0, 10**6), st.integers(0, 10**6),
                          st.integers(0, 3)), min_size=60, max_size=120)


@settings(max_examples=8, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=_ops)
def test_random_bodies_compute_the_same_values_split(tmp_path_factory, monkeypatch, ops):
    """Random bodies of many short runs, cut into chunks of 5: a value defined before one
    run and read by a later one must survive the runs in between (a reused scratch slot
    once overwrote it)."""
    monkeypatch.setattr(split, "SPLIT_MIN", 6)
    monkeypatch.setattr(split, "CHUNK", 5)
    tmp = tmp_path_factory.mktemp("body")
    lines, nP = _random_body(ops)
    new, helpers = split.split_body(lines, "f_part")
    whole = _run_c(tmp, "whole", lines, [], nP)
    assert _run_c(tmp, "split", new, helpers, nP) == whole
    # the guard blocks as statements of the runs (blocks=True): the same values again
    new, helpers = split.split_body(lines, "f_part", blocks=True)
    assert _run_c(tmp, "blocks", new, helpers, nP) == whole


def test_a_value_read_across_two_split_runs_survives_the_first(tmp_path, tiny):
    """t1 is defined before run 1 and read only in run 2: its scratch slot must not be one
    that run 1 frees and reuses for its own values while it runs."""
    lines = ["    const double t0 = x[0];", "    const double t1 = 0.5*x[1];", "    P[0] += t0;"]
    lines += [f"    const double t{i} = 0.5*t{i - 1} + 0.25*x[{i % 4}];" for i in range(2, 12)]
    # the last two chunks of run 1 read nothing across: the slot t6 used comes free
    lines += [f"    const double t{i} = 0.5*x[{i % 4}] + {i};" for i in range(12, 22)]
    lines += ["    P[1] += x[0];", "    const double t22 = 0.5*t1 + P[1];"]
    lines += [f"    const double t{i} = 0.5*t{i - 1} + 0.25*t1;" for i in range(23, 42)]
    lines += ["    out[0] = t41;", "    out[1] = P[1];", "    out[2] = P[0] + t11;"]
    new, helpers = split.split_body(lines, "f_part")
    assert any("void f_part0_" in h for h in helpers) and any("void f_part1_" in h for h in helpers)
    assert _run_c(tmp_path, "split", new, helpers, 2) == _run_c(tmp_path, "whole", lines, [], 2)


def test_a_name_redefined_in_an_inner_block_is_not_renamed_there(tmp_path, tiny):
    """A Jacobian's column loop defines t3 again in its own block: inside it, t3 is that
    block's value (not the split run's scratch slot); after it, the outer t3 again."""
    lines = ["    int k;"]
    lines += ["    const double t0 = x[0];"]
    lines += [f"    const double t{i} = 0.5*t{i - 1} + 0.25*x[{i % 4}];" for i in range(1, 20)]
    lines += ["    for (k = 0; k < 2; k++) {",
              "        const double t3 = x[1]*k + t2;",
              "        const double t4 = t3*t3 + t19;",
              "        out[k] = t4;",
              "    }",
              "    out[2] = t3 + t4;", "    out[3] = P[0];"]
    new, helpers = split.split_body(lines, "f_part")
    assert helpers and "const double S_" not in "\n".join(new)
    assert _run_c(tmp_path, "split", new, helpers, 1) == _run_c(tmp_path, "whole", lines, [], 1)


def _guarded_lines():
    """Short runs (4 temporaries) between guard blocks, each block reading the run before it."""
    lines = ["    const double t0 = x[0];"]
    for k in range(6):
        lines += [f"    const double t{5 * k + i} = 0.5*t{5 * k + i - 1} + 0.25*x[{i % 4}];" for i in range(1, 5)]
        last = f"t{5 * k + 4}"
        lines += [f"    if (!({last} > 0.2)) {{", f"        const double t{100 + k} = {last}*{last};",
                  f"        if (!(t{100 + k} > 0.1)) {{", f"            P[{k}] = t{100 + k} + x[1];",
                  "        } else {", f"            P[{k}] = 0.5;", "        }",
                  "    } else {", f"        P[{k}] = 0.0;", "    }",
                  f"    const double t{5 * k + 5} = {last} + P[{k}];"]
    return lines + ["    out[0] = t30;", "    out[1] = P[2] + t12;", "    out[2] = P[5];"]


def test_guard_blocks_are_statements_of_a_run_when_asked(tmp_path, tiny):
    """Issue 33 (build time): a contact model's guard blocks cut its rhs into runs shorter than
    SPLIT_MIN, which stayed in the function's own body.  With ``blocks`` the blocks are
    statements of a run: the whole body goes into sub-functions, each block whole in one, the
    values the same; the sub-functions holding a block take ``block_attribute``."""
    lines = _guarded_lines()
    assert split.split_body(lines, "f_part") == (lines, [])        # runs of 4-5 < SPLIT_MIN 6
    new, helpers = split.split_body(lines, "f_part", blocks=True, block_attribute="EOMC_PART_LEAN")
    assert not any("if (" in line for line in new)
    assert sum(h.count("} else {") for h in helpers) == 12
    for h in helpers:
        assert h.count("{") == h.count("}")
        assert h.startswith("static EOMC_PART_LEAN void" if "if (" in h else "static EOMC_NOINLINE void")
    whole = _run_c(tmp_path, "whole", lines, [], 6)
    src = [split.PART_LEAN_MACRO] + helpers
    assert _run_c(tmp_path, "blocks", new, src, 6) == whole


def test_a_block_defining_a_name_defined_elsewhere_stays_in_the_body(tiny):
    """A block whose temporary is defined again elsewhere in the function (a scope's shadowing)
    is not folded: the split would not know which one a later line reads."""
    lines = _guarded_lines()
    lines.insert(1, "    const double t100 = x[3];")   # the first block's own name, outside too
    new, _ = split.split_body(lines, "f_part", blocks=True)
    assert sum("if (!(t4 > 0.2)) {" in line for line in new) == 1
    assert not any("if (!(t9 > 0.2)) {" in line for line in new)


def _wide_body(n):
    """A run of ``n`` statements reading scratch-bound values far apart (every temporary is
    read again 3 and 40 statements later) and inputs x[0..59], p[0..79]."""
    lines = [f"    const double t{i} = 0.5*x[{i % 60}] + 0.25*p[{(7 * i) % 80}]"
             + (f" + 0.125*t{i - 3}" if i >= 3 else "") + (f" - 0.0625*t{i - 40}" if i >= 40 else "") + ";"
             for i in range(n)]
    return lines + [f"    out[{k}] = t{i};" for k, i in enumerate((n - 1, n - 2, n - 3, n // 2, n // 3, 5))]


def _near_refs(parts):
    """{array: (references, of which within an 8-bit displacement)} over the parts' bodies."""
    out = {}
    for part in parts:
        body = part.split("{", 1)[1]
        for name, k in re.findall(r"(?<![\w&])(S_w\d+|S_|x|p)\[(-?\d+)\]", body):
            key = "S_" if name.startswith("S_") else name
            total, near = out.get(key, (0, 0))
            out[key] = (total + 1, near + (-16 <= int(k) <= 15))
    return out


def _run_wide(tmp_path, tag, lines, helpers):
    """out[0..5] of ``lines`` as ``f(x, p, out)`` (x: 60, p: 80 doubles), built -Wall -Wextra -Werror."""
    import ctypes
    import subprocess
    src = tmp_path / f"{tag}.c"
    src.write_text("#include <math.h>\n" + split.NOINLINE_MACRO + "\n" + split.NEAR_MACRO + "\n"
                   + "\n".join(helpers) + "\nvoid f(const double *x, const double *p, double *out);\n"
                   + "void f(const double *x, const double *p, double *out)\n{\n" + "\n".join(lines) + "\n}\n")
    lib = tmp_path / f"lib{tag}.so"
    subprocess.run(["gcc", "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC",
                    str(src), "-o", str(lib), "-lm"], check=True)
    f = ctypes.CDLL(str(lib)).f
    x = (ctypes.c_double * 60)(*np.linspace(-1.0, 1.0, 60))
    p = (ctypes.c_double * 80)(*np.linspace(0.5, 1.5, 80))
    out = (ctypes.c_double * 6)()
    f(x, p, out)
    return list(out)


def test_long_runs_reach_their_slots_through_near_pointers(tmp_path, monkeypatch):
    """windows=True (the recursive rhs): in a run of WINDOW_MIN statements or more, each
    sub-function reads its scratch slots through pointers ``&S_[b]`` (``S_w0``, ...) and x and p
    through shifted pointers, so most references take an 8-bit displacement (floating-base
    humanoids' rhs: 7 % fewer bytes, 3-5 % faster on Zen 5); each slot through one pointer
    (restrict holds); the values are the unsplit function's; a shorter run, or windows=False,
    is the C as before."""
    monkeypatch.setattr(split, "CHUNK", 40)
    monkeypatch.setattr(split, "WINDOW_MIN", 300)
    lines = _wide_body(400)
    plain, plain_parts = split.split_body(lines, "f_part", restrict=True)
    new, parts = split.split_body(lines, "f_part", restrict=True, windows=True)
    assert len(parts) == len(plain_parts) == 11           # 406 statements by 40
    before, after = _near_refs(plain_parts), _near_refs(parts)
    assert before["S_"][1] < before["S_"][0] / 4                 # slots far apart: mostly 4-byte
    assert after["S_"][1] > 0.9 * after["S_"][0] and after["S_"][0] == before["S_"][0]
    assert after["x"][1] > before["x"][1] and after["p"][1] > before["p"][1]
    assert all(part.startswith("static EOMC_NEAR void f_part0_") for part in parts)   # no TER
    assert all(part.startswith("static EOMC_NOINLINE void f_part0_") for part in plain_parts)
    declared = [re.findall(r"double \*restrict (S_w\d+)", part.split("\n", 1)[0]) for part in parts]
    assert sum(bool(names) for names in declared) >= 9     # the last one reads 6 scattered slots
    for part, names in zip(parts, declared):
        assert set(re.findall(r"\b(S_w\d+)\[", part.split("\n", 1)[1])) == set(names)
    # each slot reached through one pointer in a part; every pointer inside the scratch array
    size = int(re.fullmatch(r"    double S_\[(\d+)\];", new[0]).group(1))
    for call, part in zip([c for c in new if "f_part0_" in c], parts):
        names = re.findall(r"double \*restrict (S_w\d+)", part.split("\n", 1)[0])
        bases = dict(zip(names, map(int, re.findall(r"&S_\[(\d+)\]", call))))
        assert len(bases) == len(names) and all(0 <= b < size for b in bases.values())
        pointer = {}
        for name, k in re.findall(r"(?<![\w&])(S_w\d+|S_)\[(-?\d+)\]", part):
            slot = bases.get(name, 0) + int(k)
            assert 0 <= slot < size and pointer.setdefault(slot, name) == name
    whole = _run_wide(tmp_path, "whole", lines, [])
    assert _run_wide(tmp_path, "near", new, parts) == whole == _run_wide(tmp_path, "plain", plain, plain_parts)
    monkeypatch.setattr(split, "WINDOW_MIN", 407)                 # the run: 400 + 6 stores
    assert split.split_body(lines, "f_part", restrict=True, windows=True) == (plain, plain_parts)
