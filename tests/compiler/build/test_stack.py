"""compiler/build/stack.py: the worst case is the frame plus the deepest chain of calls inside the
file, libm calls are named, a dynamic frame makes the bound unknown rather than wrong."""
from eomc.compiler.build.stack import measure_stack, stack_header_block, supports_callgraph
from eomc.compiler.build.toolchain import Toolchain

CI = r'''graph: { title: "m.c"
node: { title: "m.c:m_dynamics" label: "m_dynamics\nm.c:5:13\n112 bytes (static)" }
node: { title: "sincosf" label: "__builtin_sincosf\n<built-in>" shape : ellipse }
edge: { sourcename: "m.c:m_dynamics" targetname: "sincosf" }
node: { title: "m.c:m_factor" label: "m_factor\nm.c:20:12\n8 bytes (static)" }
node: { title: "m_rhs" label: "m_rhs\nm.c:30:5\n80 bytes (static)" }
edge: { sourcename: "m_rhs" targetname: "m.c:m_dynamics" label: "m.c:33:5" }
edge: { sourcename: "m_rhs" targetname: "m.c:m_factor" label: "m.c:34:5" }
node: { title: "m_step_rk4" label: "m_step_rk4\nm.c:50:5\n160 bytes (static)" }
edge: { sourcename: "m_step_rk4" targetname: "m_rhs" label: "m.c:55:18" }
node: { title: "m_odd" label: "m_odd\nm.c:70:5\n40 bytes (dynamic)" }
}
'''


def test_worst_case_is_frame_plus_deepest_chain(tmp_path):
    (tmp_path / "libm.so-m.ci").write_text(CI)
    stack = measure_stack(tmp_path, "m", ["rhs", "step_rk4", "odd", "jac_x"])
    assert stack["rhs"] == {"bytes": 80 + 112, "frame": 80, "external": ["sincosf"]}
    assert stack["step_rk4"]["bytes"] == 160 + 80 + 112
    assert stack["odd"]["bytes"] is None          # alloca/VLA: no bound claimed
    assert "jac_x" not in stack                   # not in the dump: not reported
    block = stack_header_block("m", stack, "gcc 12")
    assert "#define M_STACK_RHS 192\n" in block and "#define M_STACK_STEP_RK4 352\n" in block
    assert "M_STACK_ODD" not in block
    assert measure_stack(tmp_path / "none", "m", ["rhs"]) is None


def test_only_gcc_10_or_later_dumps_a_call_graph():
    assert supports_callgraph(Toolchain(("gcc",), "/usr/bin/gcc", "gcc (Debian 12.2.0-14) 12.2.0"))
    assert supports_callgraph(Toolchain(("cc",), "/usr/bin/x86_64-linux-gnu-gcc-12", "cc (Debian 12.2.0-14) 12.2.0"))
    assert not supports_callgraph(Toolchain(("gcc",), "/usr/bin/gcc-9", "gcc (Ubuntu 9.4.0-1) 9.4.0"))
    assert not supports_callgraph(Toolchain(("clang",), "/usr/bin/clang", "Debian clang version 14.0.6"))


# --- a real double (c99-f64) build: the figures come from the compile that built the library ---
import shutil
import subprocess
from pathlib import Path

import pytest

import eomc
from eomc.compiler.build.toolchain import find_compiler

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"


@pytest.fixture(scope="module")
def dp64(tmp_path_factory):
    return eomc.compile(str(EXAMPLES / "double_pendulum.py"), "dp64",
                        cache_dir=tmp_path_factory.mktemp("cache"), progress=False)


def test_double_build_states_each_functions_stack_in_header_and_json(dp64, tmp_path):
    tc = find_compiler()
    stack = dp64.metadata["stack"]
    if not supports_callgraph(tc):
        assert stack is None and "not measured" in dp64.metadata["stack_note"]
        pytest.skip(f"{tc.version} has no -fcallgraph-info")
    header = (dp64.directory / "dp64.h").read_text()
    assert set(stack) == set(dp64.metadata["functions"])
    for fn, info in stack.items():
        assert info["bytes"] >= info["frame"] > 0
        assert f"#define DP64_STACK_{fn.upper()} {info['bytes']}\n" in header
    assert "(listed in dp64.json under stack.external)" in header
    assert "sincos" in stack["rhs"]["external"] or "sin" in stack["rhs"]["external"]
    # the deepest function is at least its own frame; linearize calls jac_x: its bound holds jac_x's
    deepest = max(stack, key=lambda fn: stack[fn]["bytes"])
    assert stack[deepest]["bytes"] >= stack[deepest]["frame"]
    assert stack["linearize"]["bytes"] >= stack["linearize"]["frame"] + stack["jac_x"]["bytes"]
    # rhs calls the LDLt factorisation (a static helper gcc keeps out of line here): re-measure the
    # same C with the same compiler and flags, and find the helper's frame inside rhs's bound
    shutil.copyfile(dp64.directory / "dp64.c", tmp_path / "dp64.c")
    for name in ("eomc_model.h", "eomc_integrators.h", "eomc_batch.h", "dp64.h"):
        shutil.copyfile(dp64.directory / name, tmp_path / name)
    subprocess.run([*tc.argv, *dp64.metadata["build"]["cflags"], "-fcallgraph-info=su", "-c", "dp64.c"],
                   cwd=tmp_path, check=True)
    again = measure_stack(tmp_path, "dp64", ["rhs", "jac_x", "ldlt_factor", "dynamics"])
    assert again["rhs"] == stack["rhs"] and again["jac_x"] == stack["jac_x"]
    if "ldlt_factor" not in again:
        pytest.skip("this compiler inlined the LDLt helper: no callee frame to check")
    assert stack["rhs"]["bytes"] >= stack["rhs"]["frame"] + again["ldlt_factor"]["frame"]
    assert stack["rhs"]["bytes"] >= stack["rhs"]["frame"] + again["dynamics"]["bytes"]
    assert stack["jac_x"]["bytes"] >= stack["jac_x"]["frame"] + again["ldlt_factor"]["frame"]
    # the dumps are not left in the cache entry
    assert not list(dp64.directory.glob("*.ci")) and not list(dp64.directory.glob("*.su"))


def test_double_build_key_ignores_the_measurement_and_rebuilds_byte_identical(dp64, tmp_path, monkeypatch):
    """The flag is not in a double build's key (keys are what they were before the measurement:
    an unmeasured build has the same key), the generated header is untouched (only the built copy
    carries the block), and a rebuild from scratch writes the same files byte for byte."""
    again = eomc.compile(str(EXAMPLES / "double_pendulum.py"), "dp64", cache_dir=tmp_path / "a", progress=False)
    assert again.metadata["build"]["key"] == dp64.metadata["build"]["key"]
    for name in ("dp64.h", "dp64.json", "dp64.c", "libdp64.so"):
        assert (again.directory / name).read_bytes() == (dp64.directory / name).read_bytes(), name
    import eomc.compiler.build.builder as builder
    monkeypatch.setattr(builder, "supports_callgraph", lambda tc: False)
    unmeasured = eomc.compile(str(EXAMPLES / "double_pendulum.py"), "dp64", cache_dir=tmp_path / "b",
                              progress=False)
    assert unmeasured.metadata["build"]["key"] == dp64.metadata["build"]["key"] and unmeasured.metadata["stack"] is None
    assert (unmeasured.directory / "libdp64.so").read_bytes() == (dp64.directory / "libdp64.so").read_bytes()
    assert "DP64_STACK_" not in (unmeasured.directory / "dp64.h").read_text()


@pytest.mark.skipif(shutil.which("clang") is None, reason="no clang installed")
def test_clang_double_build_says_why_there_is_no_figure(tmp_path, monkeypatch):
    monkeypatch.setenv("CC", shutil.which("clang"))
    model = eomc.compile(str(EXAMPLES / "double_pendulum.py"), "dpclang", cache_dir=tmp_path, progress=False)
    assert model.metadata["stack"] is None
    assert "not measured" in model.metadata["stack_note"] and "clang" in model.metadata["stack_note"]
    assert "DPCLANG_STACK_" not in (model.directory / "dpclang.h").read_text()
