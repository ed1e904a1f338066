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
