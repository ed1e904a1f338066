"""The c99-f32 target (compiler/emit/target.py): float C that compiles without a single double
under -Wdouble-promotion -Wfloat-conversion -Werror (gcc and clang), agrees with the double
build within a bound set by M's condition number, keeps the status codes, and states its
stack; the default c99-f64 stays the double C it always was."""
import re
import shutil
import subprocess
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.driver import generate
from eomc.compiler.emit.target import FLT_MAX, check_target, retarget, to_float_text
from eomc.compiler.urdf.model import with_options
from eomc.runtime.errors import EomcError, ModelError
from eomc.runtime.float32 import Float32Model

from tests.helpers.robots import robot_path

EXAMPLES = __import__("pathlib").Path(__file__).resolve().parents[3] / "examples"
STRICT = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wdouble-promotion", "-Wfloat-conversion",
          "-Wpedantic", "-Werror"]
EPS32 = float(np.finfo(np.float32).eps)


def _models():
    """A shipped example (Kane, LDLᵀ), a URDF arm (recursive ABA) and a floating-base robot."""
    return {"double_pendulum": (str(EXAMPLES / "double_pendulum.py"), None, {}),
            "ur5": (str(robot_path("ur5")), None, {}),
            "solo": with_options(str(robot_path("solo12")), "solo", floating_base=True) + ({"functions": ["rhs", "jac_x", "mass_matrix"]},)}


@pytest.fixture(scope="module")
def generated():
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for key, (source, name, kw) in _models().items():
            out[key] = (generate(source, name or key, target="c99-f32", **kw)[1],
                        generate(source, name or key, **kw)[1])
    return out


@pytest.mark.parametrize("cc", ["gcc", "clang"])
def test_float_c_compiles_clean_without_any_double(generated, cc, tmp_path):
    if shutil.which(cc) is None:
        pytest.skip(f"{cc} is not installed")
    shutil.copy(eomc.runtime.header_cdef.C_DIR / "eomc_model.h", tmp_path)
    for key, (f32, _) in generated.items():
        (tmp_path / f"{f32.name}.c").write_text(f32.c_source)
        (tmp_path / f"{f32.name}.h").write_text(f32.header)
        run = subprocess.run([cc, *STRICT, "-c", f"{f32.name}.c"], cwd=tmp_path, capture_output=True,
                             text=True, timeout=300)
        assert run.returncode == 0, f"{key} ({cc}):\n{run.stderr[:3000]}"
        code = re.sub(r"/\*.*?\*/", "", f32.c_source, flags=re.S)
        assert not re.search(r"\bdouble\b", code.replace(f"{f32.name}_", "")), key
        # no call of a double libm function, no unsuffixed floating literal, no heap, no static mutable
        assert not re.search(r"\b(sin|cos|tan|sqrt|exp|log|pow|fabs|fmax|fmin|atan2)\s*\(", code), key
        assert not re.search(r"(?<![\w.])\d+\.\d*(e[+-]?\d+)?(?![\w.])", code), key
        assert not re.search(r"\b(malloc|calloc|realloc|free|alloca)\b", code), key
        # a static variable (mutable state) is a declaration with no parameter list before its = or ;
        # (static functions, whatever they return, are no state)
        assert not re.search(r"^\s*static\s+(?!const\b)[\w\s*]*?\w+\s*(\[[^\]]*\])?\s*[=;]", code, flags=re.M), key
        assert "static const eomc_model" not in code and "DBL_" not in code and "HUGE_VAL)" not in code


def test_default_target_is_the_double_code(generated):
    for key, (f32, f64) in generated.items():
        assert retarget(f64, "c99-f64") is f64 and retarget(f64, None) is f64
        assert "target" not in f64.metadata and f32.metadata["target"] == "c99-f32"
        assert f"int {f64.name}_rhs(double t," in f64.c_source and "step_rk4" not in f64.c_source


def test_unknown_target_and_bad_literals_are_clear_errors():
    with pytest.raises(ModelError, match="unknown target 'c99-f16'; choose one of c99-f64, c99-f32"):
        check_target("c99-f16")
    with pytest.raises(ModelError, match=r"m.c: the constant 1e\+300 overflows float"):
        to_float_text("const double a = 1e+300;", "m.c")
    with pytest.raises(ModelError, match="underflows float to zero"):
        to_float_text("const double a = 1e-60;", "m.c")
    with pytest.raises(ModelError, match="calls lgammaq"):
        to_float_text("const double a = lgammaq(1.0);", "m.c")
    assert to_float_text("x = 3.4e38 + sqrt(2.0) + q[3]; /* 3 doubles */", "m.c") == \
        "x = 3.4e38f + sqrtf(2.0f) + q[3]; /* 3 floats */"
    assert 3.4e38 < FLT_MAX


def test_pivot_tests_are_scaled_for_float(generated):
    """LDLᵀ: 64·FLT_EPSILON·max|diag|; the recursive ABA's 2^-46·sum(D) becomes 2^-17·sum(D)."""
    dp = generated["double_pendulum"][0].c_source
    assert "tol = 64.0f * FLT_EPSILON * scale;" in dp
    from eomc.compiler.tree.aba import PIVOT_TOL
    assert float(PIVOT_TOL) == 2.0 ** -46
    assert to_float_text("const double t9 = 1.4210854715202004e-14*S_[3] + t2;", "m.c") == \
        "const float t9 = 7.62939453125e-06f*S_[3] + t2;"
    for f32, _ in generated.values():
        assert "1.4210854715202004e-14" not in f32.c_source


@pytest.fixture(scope="module")
def pendulums(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    path = str(EXAMPLES / "double_pendulum.py")
    return (eomc.compile(path, "dp32", target="c99-f32", cache_dir=cache, progress=False),
            eomc.compile(path, "dp64", cache_dir=cache, progress=False))


def test_float_rhs_agrees_with_double_within_the_condition_bound(pendulums):
    f32, f64 = pendulums
    assert isinstance(f32, Float32Model)
    rng = np.random.default_rng(3)
    for _ in range(200):
        x = rng.uniform(-3, 3, 4).astype(np.float32)
        p = (f64.param_defaults * rng.uniform(0.5, 2.0, 5)).astype(np.float32)
        x64, p64 = x.astype(np.float64), p.astype(np.float64)   # the same inputs, exactly
        ref = f64.rhs(0.0, x64, p64)
        got = f32.rhs(0.0, x, p)
        cond = np.linalg.cond(f64.mass_matrix(0.0, x64, p64))
        scale = np.abs(ref).max() + np.abs(f64.forcing(0.0, x64, p64)).max() / np.abs(
            np.diag(f64.mass_matrix(0.0, x64, p64))).min()
        assert np.abs(got - ref).max() <= 64 * EPS32 * cond * scale, (x, p, got, ref)
        assert np.allclose(f32.mass_matrix(0.0, x, p), f64.mass_matrix(0.0, x64, p64), rtol=1e-5, atol=1e-6)
        assert np.allclose(f32.jacobian(0.0, x, p), f64.jacobian(0.0, x64, p64), rtol=1e-3,
                           atol=1e-3 * np.abs(f64.jacobian(0.0, x64, p64)).max())


def test_step_rk4_is_one_classical_rk4_step(pendulums):
    f32, f64 = pendulums
    x, h = np.array([1.0, 0.5, 0.1, -0.2]), 0.01
    k1 = f64.rhs(0.0, x)
    k2 = f64.rhs(h / 2, x + h / 2 * k1)
    k3 = f64.rhs(h / 2, x + h / 2 * k2)
    k4 = f64.rhs(h, x + h * k3)
    ref = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert np.allclose(f32.step_rk4(0.0, h, x), ref, rtol=0, atol=2e-6)


def test_too_ill_conditioned_for_float_is_a_singular_status_not_noise(pendulums):
    """m1/m2 = 1e-6: M's second pivot is ~1e-6 of its diagonal, above double's 64 eps but below
    float's, so the double build solves and the float build says the matrix is singular."""
    f32, f64 = pendulums
    x = np.array([0.3, 0.3, 0.0, 0.0])
    p = np.array([1e-6, 1.0, 1.0, 1.0, 9.81])
    assert np.isfinite(f64.rhs(0.0, x, p)).all()
    with pytest.raises(EomcError, match="dp32_rhs \\(float\\) failed at t=0: the mass matrix is singular"):
        f32.rhs(0.0, x, p)
    with pytest.raises(EomcError, match="dp32_step_rk4 \\(float\\) failed .* singular"):
        f32.step_rk4(0.0, 0.01, x, p)


def test_float_model_refuses_what_needs_double(pendulums):
    f32, _ = pendulums
    with pytest.raises(EomcError, match="built for c99-f32 .* simulate runs on double builds: rebuild "
                                        "with --target c99-f64"):
        f32.simulate((0, 1), [1, 0, 0, 0])
    with pytest.raises(EomcError, match="x has 3 entries; the model expects 4"):
        f32.rhs(0.0, [1, 2, 3])


def test_stack_bound_and_work_size_in_header_and_json(pendulums):
    f32, _ = pendulums
    header = (f32.directory / "dp32.h").read_text()
    stack = f32.metadata["stack"]
    if stack is None:
        assert "not measured" in f32.metadata["stack_note"]
        pytest.skip("the compiler has no -fcallgraph-info")
    for fn in ("rhs", "jac_x", "mass_matrix", "step_rk4"):
        assert f"#define DP32_STACK_{fn.upper()} {stack[fn]['bytes']}\n" in header
        assert stack[fn]["bytes"] >= stack[fn]["frame"] > 0
    # the step calls rhs: its bound holds rhs's
    assert stack["step_rk4"]["bytes"] >= stack["step_rk4"]["frame"] + stack["rhs"]["bytes"]
    assert "#define DP32_WORK_SIZE 0\n" in header
    assert "#define DP32_WORK_LEN (DP32_WORK_SIZE > 0 ? DP32_WORK_SIZE : 1)" in header
    assert "extern const float dp32_param_defaults[DP32_NPARAM];" in header


def test_cython_backend_is_refused_for_float(tmp_path):
    with pytest.raises(ValueError, match="built for c99-f32: its Python module loads through cffi only"):
        eomc.compile(str(EXAMPLES / "double_pendulum.py"), "dpcy", target="c99-f32", backend="cython",
                     cache_dir=tmp_path, progress=False)


def _pendulum_file(tmp_path, parameters=None, initial=None):
    text = (EXAMPLES / "double_pendulum.py").read_text()
    if parameters:
        text = text.replace("parameters = {m1: 1.0, m2: 1.0, l1: 1.0, l2: 1.0, g: 9.81}", parameters)
    if initial:
        text = text.replace("initial_state = {q1: 1.0, q2: 0.5, u1: 0.0, u2: 0.0}", initial)
    path = tmp_path / "pendulum.py"
    path.write_text(text)
    return str(path)


def test_build_warns_when_m_is_too_ill_conditioned_for_float(tmp_path):
    # rods in line (q1 = q2) and m1 = 1e-6 m2: M's second pivot is ~1e-6 of its diagonal
    path = _pendulum_file(tmp_path, parameters="parameters = {m1: 1e-6, m2: 1.0, l1: 1.0, l2: 1.0, g: 9.81}",
                          initial="initial_state = {q1: 0.3, q2: 0.3, u1: 0.0, u2: 0.0}")
    with pytest.warns(eomc.runtime.errors.EomcWarning) as record:
        eomc.compile(path, "illcond", target="c99-f32", cache_dir=tmp_path / "cache", progress=False)
    text = "\n".join(str(w.message) for w in record)
    assert "illcond (c99-f32): the mass matrix is ill-conditioned for float at the default state" in text
    assert "mostly the speed u" in text
    assert "at the default state the float rhs fails: illcond_rhs (float) failed at t=0: the mass matrix is singular" in text
    # the double build of the same model is quiet
    with warnings.catch_warnings():
        warnings.simplefilter("error", eomc.runtime.errors.EomcWarning)
        eomc.compile(path, "illcond64", cache_dir=tmp_path / "cache", progress=False)


def test_state_or_parameter_beyond_float_is_named(tmp_path):
    path = _pendulum_file(tmp_path, initial="initial_state = {q1: 1.0, q2: 0.5, u1: 1e39, u2: 0.0}")
    with pytest.warns(eomc.runtime.errors.EomcWarning, match=r"big \(c99-f32\): state u1 = 1e\+39 overflows float"):
        eomc.compile(path, "big", target="c99-f32", cache_dir=tmp_path / "cache", progress=False)
    path = _pendulum_file(tmp_path, parameters="parameters = {m1: 1.0, m2: 1e39, l1: 1.0, l2: 1.0, g: 9.81}")
    with pytest.raises(ModelError, match=r"bigp: parameter m2's default: the constant 1e\+39 overflows float"):
        eomc.compile(path, "bigp", target="c99-f32", cache_dir=tmp_path / "cache", progress=False)


def test_parameter_default_below_float_is_its_zero_and_said(tmp_path):
    # a default float cannot hold even as a subnormal (iCub's URDF: a joint offset of -2.7e-51 m)
    # is written as 0 with a warning naming it; before session 51 the whole build was refused
    path = _pendulum_file(tmp_path, parameters="parameters = {m1: 1.0, m2: 1.0, l1: 1.0, l2: 1.0, g: -1e-50}")
    with pytest.warns(eomc.runtime.errors.EomcWarning) as record:
        f32 = eomc.compile(path, "tiny", target="c99-f32", cache_dir=tmp_path / "cache", progress=False)
    text = "\n".join(str(w.message) for w in record)
    assert "tiny (c99-f32): parameter g = -1e-50 is below float's smallest number (1.4e-45): it is 0 in float " \
           "(its default is written as 0)" in text, text
    source = (f32.directory / "tiny.c").read_text()
    assert re.search(r"const float tiny_param_defaults\[TINY_NPARAM\] = \{1\.0f, 1\.0f, 1\.0f, 1\.0f, -0\.0f\};", source)
    assert np.array_equal(f32.rhs(0.0, [1.0, 0.5, 0.0, 0.0])[2:], np.zeros(2, dtype=np.float32))   # no gravity


@pytest.mark.parametrize("functions", [["rhs", "rhs_batch"], ["rhs", "jac_x", "jac_x_batch"],
                                       ["rhs", "outputs", "outputs_batch"],
                                       ["rhs", "rhs_batch", "jac_x", "jac_x_batch"]])
def test_float_target_refuses_batch_functions_before_reading(functions, tmp_path):
    # the batch functions are double SIMD lanes: c99-f32 refuses them by name, before the
    # model is read (check is never called), instead of failing in the float pass
    batch = [f for f in functions if f.endswith("_batch")]
    read = []
    with pytest.raises(ModelError) as info:
        generate(str(EXAMPLES / "double_pendulum.py"), "dpb32", target="c99-f32", functions=functions,
                 check=read.append, cache_dir=tmp_path)
    text = str(info.value)
    assert text.startswith(f"target c99-f32 does not build the batch function{'s' if len(batch) > 1 else ''} "
                           f"{', '.join(batch)}: "), text
    assert "with the double target c99-f64" in text and f"without {', '.join(batch)})" in text, text
    assert "compiler bug" not in text and read == []


def test_float_target_refuses_batch_functions_of_generated_double_c(tmp_path):
    # retarget itself (a double GeneratedModel, e.g. from the generation cache) says the same
    f64 = generate(str(EXAMPLES / "double_pendulum.py"), "dpb64", functions=["rhs", "rhs_batch"],
                   cache_dir=tmp_path)[1]
    assert "dpb64_rhs_batch" in f64.c_source
    with pytest.raises(ModelError, match=r"^target c99-f32 does not build the batch function rhs_batch: "):
        retarget(f64, "c99-f32")
    with pytest.raises(ModelError, match=r"^target c99-f32 does not build the batch function rhs_batch: "):
        eomc.compile(str(EXAMPLES / "double_pendulum.py"), "dpb32c", target="c99-f32",
                     functions=["rhs", "rhs_batch"], cache_dir=tmp_path, progress=False)


# Five free bodies of every pair kind family a file may hold (capsules, a sphere, a box, an
# ellipsoid: 10 body-body pairs, so the pair table and its narrow routines) over a floor.
SHAPES_XML = """<mujoco model="shapes">
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="a" pos="0 0 0.30"><freejoint/><geom name="cap_a" type="capsule" size="0.05 0.2" euler="0 90 0"/></body>
    <body name="b" pos="0.05 0 0.395"><freejoint/><geom name="cap_b" type="capsule" size="0.05 0.2" euler="90 0 0"/></body>
    <body name="c" pos="0.24 0.0 0.39"><freejoint/><geom name="ball_c" type="sphere" size="0.05"/></body>
    <body name="d" pos="-0.2 0.0 0.395"><freejoint/><geom name="box_d" type="box" size="0.05 0.05 0.05"/></body>
    <body name="e" pos="0 0.24 0.49"><freejoint/><geom name="ell_e" type="ellipsoid" size="0.06 0.04 0.05"/></body>
  </worldbody>
</mujoco>"""


def test_body_body_pairs_build_for_float_and_agree_with_double(tmp_path):
    """An MJCF model with body-body pairs builds for c99-f32 (its contact routines, static
    functions not named NAME_*, are taken to float with the rest: before session 51 their calls
    were refused as "a compiler bug", so gymnasium's humanoid could not be built for firmware),
    compiles clean under the strict flags, and its rhs agrees with the double build's at poses
    where pairs press (within a penetration below the radii: deeper, a capsule's core inside a
    box has no nearest points and the direction of its force is not defined in either precision)."""
    from eomc.compiler.mjcf.model import MjcfModel
    xml = tmp_path / "shapes.xml"
    xml.write_text(SHAPES_XML)
    kw = dict(cache_dir=tmp_path / "cache", functions=["rhs", "mass_matrix", "outputs"], progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f32 = eomc.compile(MjcfModel(str(xml)), "sh32", target="c99-f32", **kw)
        f64 = eomc.compile(MjcfModel(str(xml)), "sh64", **kw)
    source = (f32.directory / "sh32.c").read_text()
    assert "eomc_pairs(" in source and "eomc_narrow_" in source            # the table's routines, in float
    shutil.copy(eomc.runtime.header_cdef.C_DIR / "eomc_model.h", tmp_path)
    for cc in ("gcc", "clang"):
        if shutil.which(cc) is None:
            continue
        run = subprocess.run([cc, *STRICT, "-I", str(f32.directory), "-c", str(f32.directory / "sh32.c"), "-o",
                              str(tmp_path / f"sh32_{cc}.o")], cwd=tmp_path, capture_output=True, text=True,
                             timeout=300)
        assert run.returncode == 0, f"{cc}:\n{run.stderr[:3000]}"
        assert not re.search(r"\bdouble\b", re.sub(r"/\*.*?\*/", "", source, flags=re.S))
    x0 = np.asarray(f64.initial_state, dtype=float)
    rng = np.random.default_rng(1)
    pressed, errors = set(), []
    for _ in range(120):
        x = x0.copy()
        for w in f64.quaternions:                  # each body turned a little, at random
            x[w:w + 4] += np.r_[0.0, rng.normal(0.0, 0.08, 3)]
            x[w:w + 4] /= np.linalg.norm(x[w:w + 4])
        x[f64.nq:] = rng.normal(0.0, 0.3, f64.nu)
        x32, p32 = x.astype(np.float32), f64.param_defaults.astype(np.float32)
        x64, p64 = x32.astype(np.float64), p32.astype(np.float64)     # the same inputs, exactly
        out = f64.outputs(0.0, x64, p64)
        depths = {n[6:]: v for n, v in out.items() if n.startswith("depth_") and "__" in n}
        if max(depths.values()) > 0.02:
            continue
        pressed |= {n for n, v in depths.items() if v > 0}
        ref, got = f64.rhs(0.0, x64, p64), f32.rhs(0.0, x32, p32)
        errors.append(np.abs(got - ref).max() / np.abs(ref).max())
    assert len(errors) >= 40 and {"cap_a__cap_b", "cap_a__box_d", "cap_a__ball_c", "cap_b__ell_e"} <= pressed
    assert np.median(errors) < 1e-5 and max(errors) < 2e-3, (np.median(errors), max(errors))
