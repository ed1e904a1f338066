"""Code-generation targets: ``c99-f64`` (the default, what every printer writes) and ``c99-f32``.

Why a pass over the finished C rather than a type threaded through every printer: the
bodies come from a dozen emitters (Kane and recursive bodies, linear solves, split parts,
tangent loops), and the generation cache stores their double text.  The generated C is a
small, regular subset of C99 (no macros of its own but one, no hex floats, no strings in
bodies), so a tokenizer that sees comments, strings, numbers and identifiers retargets it
exactly: ``double`` -> ``float``, every floating literal gets an ``f`` suffix (the compiler
rounds the decimal text straight to float, one rounding), every libm call its ``f``
variant, the DBL_ limits their FLT_ counterparts.  The default target never passes here,
so its C stays byte-identical.  Anything this pass cannot place (an unknown libm function,
a literal outside float's range) is an error naming it, and the result is compiled by the
tests under ``-Wdouble-promotion -Wfloat-conversion -Werror``, which catch any double left.

The f32 target is for firmware: the ``eomc_model`` struct (double function pointers) and
its name tables are left out; the parameter defaults become an exported const array and a
fixed-step RK4 (``NAME_step_rk4``) is appended, so the C file needs nothing of eomc's
runtime library (see :func:`embedded_tail`).
"""
import re
import struct
from dataclasses import replace

from eomc.runtime.errors import ModelError

from .printer import CALLED_C, MINMAX_C

__all__ = ["TARGETS", "DEFAULT_TARGET", "check_target", "check_target_functions", "retarget", "to_float_text",
           "FLT_MAX"]

DEFAULT_TARGET = "c99-f64"
TARGETS = ("c99-f64", "c99-f32")
FLT_MAX = struct.unpack("<f", b"\xff\xff\x7f\x7f")[0]
FLT_TRUE_MIN = struct.unpack("<f", b"\x01\x00\x00\x00")[0]
FLT_EPSILON = 2.0 ** -23

# C99's <math.h> functions of double and their float variants (7.12); the printer uses a few
# of them, the rest are here so that a new printer rule cannot slip a double call through.
_MATH = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh",
         "acosh", "atanh", "exp", "exp2", "expm1", "log", "log2", "log10", "log1p", "sqrt", "cbrt",
         "pow", "fabs", "floor", "ceil", "fmod", "hypot", "fmin", "fmax", "copysign", "round",
         "trunc", "erf", "erfc", "tgamma", "lgamma", "fma", "remainder", "nearbyint", "rint")
_MATH_F = {f: f + "f" for f in _MATH}
_CONSTANTS = {"DBL_EPSILON": "FLT_EPSILON", "DBL_MAX": "FLT_MAX", "DBL_MIN": "FLT_MIN",
              "HUGE_VAL": "HUGE_VALF", "double": "float"}
# identifiers the generated C may call besides its own NAME_* functions and the map above
_KNOWN_CALLS = {"isfinite", "defined", "sizeof", "if", "for", "while", "switch", "return", "__attribute__",
                "noinline", "optimize", "__noinline__",
                *MINMAX_C, *CALLED_C}   # the printer's helpers: their double becomes float like the rest
                                        # (eomc_limit_stored's log -> logf): each one's float twin

# the AVX2 twins of the articulated solve's row helpers and their per-call CPU dispatch
# (compiler/tree/analytic.py AVX2_GUARD): x86 double-precision code chosen by gcc's
# __builtin_cpu_supports; the float target and the lanes kernels keep the portable helpers.
# Likewise the looped rhs's sin and cos in lanes (compiler/tree/chain_loop.py VTRIG_GUARD) and the
# recursive rhs's (compiler/tree/trig.py TRIG_GUARD)
_CPU_DISPATCH = re.compile(r"^#if (?:EOMC_RD_AVX2|EOMC_CHAIN_VTRIG|EOMC_TREE_VTRIG)\n.*?^#endif\n", re.M | re.S)


def without_cpu_dispatch(source):
    """``source`` without its ``#if EOMC_RD_AVX2`` blocks: the portable code path only."""
    return _CPU_DISPATCH.sub("", source)


_TOKEN = re.compile(r"""
    (?P<comment>/\*.*?\*/|//[^\n]*)
  | (?P<string>"(?:\\.|[^"\\\n])*"|'(?:\\.|[^'\\\n])*')
  | (?P<number>\.?[0-9](?:[eEpP][+-]|[0-9A-Za-z_.])*)
  | (?P<ident>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<other>\s+|.)
""", re.S | re.X)


def check_target(target):
    """The target name, checked: a clear error listing the choices."""
    target = DEFAULT_TARGET if target is None else target
    if target not in TARGETS:
        raise ModelError(f"unknown target {target!r}; choose one of {', '.join(TARGETS)}")
    return target


def check_target_functions(target, functions):
    """A clear error, before anything is derived, for functions ``target`` does not build.

    c99-f32 does not build the batch functions (rhs_batch, jac_x_batch, outputs_batch,
    implicit_batch; compiler/emit/batch.py).  Their C is double SIMD lanes (GCC vector types of
    doubles, ``target("avx2")``/AVX-512 clones chosen per CPU at run time, double sin/cos
    kernels, tiles sized in doubles): a float twin would be a second lanes emitter (float
    vectors of twice the lanes, float trig kernels, float tiles), and firmware, what this
    target is for, has neither the x86 dispatch nor a caller for n states in SoA columns.  So
    the combination is refused by name rather than failing in the float pass.
    ``functions``: the checked list (None: the default set, which has no batch function).
    """
    from .signatures import BATCH_FUNCTIONS
    target = check_target(target)
    if target == DEFAULT_TARGET or not functions:
        return
    batch = [f for f in functions if f in BATCH_FUNCTIONS]
    if batch:
        one = len(batch) == 1
        raise ModelError(f"target {target} does not build the batch function{'' if one else 's'} "
                         f"{', '.join(batch)}: {'its' if one else 'their'} C is SIMD lanes of doubles "
                         f"(x86 vector code chosen per CPU), which the float target for firmware does "
                         f"not take. Build {'it' if one else 'them'} with the double target c99-f64 "
                         f"(the default), or leave {'it' if one else 'them'} out of the {target} "
                         f"build (functions / --outputs without {', '.join(batch)})")


def _pivot_literals():
    """Double pivot tolerances baked into expressions as literals -> their float values.

    The recursive formulation's singularity test is ``D_i > 2^-46 * sum(D)`` (64 DBL_EPSILON,
    PIVOT_TOL of compiler/emit/linsolve.py), printed as a number; in float the same test needs
    64 FLT_EPSILON = 2^-17, or it would pass pivots that are rounding noise.
    """
    from .linsolve import PIVOT_TOL
    return {repr(float(PIVOT_TOL)): repr(64 * FLT_EPSILON)}


def _float_literal(text, where):
    """``1.5`` -> ``1.5f``; refuses a literal float cannot hold (never a silent inf or 0)."""
    low = text.lower()
    if low.startswith("0x") or low[-1] in "fl":
        raise ModelError(f"{where}: cannot retarget the literal {text} to float (compiler bug)")
    value = float(text)
    if abs(value) > FLT_MAX:
        raise ModelError(f"{where}: the constant {text} overflows float (largest {FLT_MAX:.6g}); "
                         f"rescale the model's units or build for c99-f64")
    if value != 0.0 and abs(value) < FLT_TRUE_MIN:
        raise ModelError(f"{where}: the constant {text} underflows float to zero (smallest "
                         f"{FLT_TRUE_MIN:.3g}); rescale the model's units or build for c99-f64")
    return text + "f"


# a static function's definition at the start of a line: its name (the text before it has no
# parentheses: a return type, ``inline``, the part macros; comments are blanked first)
_STATIC_DEFINITION = re.compile(r"^static\b[^;{}()]*?\b(?P<name>[A-Za-z_]\w*)\s*\([^;{}]*\)\s*\{", re.M)


def _defined_functions(tokens):
    """The static functions a source defines (``tokens``: its _TOKEN tokens).

    Why: the contact routines of compiler/contact/ (eomc_narrow_<kind>_<kind> and their
    variants, eomc_pair_law, eomc_pairs_slopes, ...) are not named NAME_*, but the file defines
    them, so this same pass takes their double text to float, and a call of one is as known as a
    call of NAME_rhs.  Before session 51 such a call was "unknown": 9 of the 31 gymnasium and
    dm_control MJCF files (those whose pairs call a narrow routine: gymnasium's humanoid, dm_control's
    quadruped, stacker, ...) failed to build for c99-f32 with a message calling it a compiler bug."""
    blank = "".join(" " * len(text) if kind == "comment" else text for kind, text in tokens)
    return {m.group("name") for m in _STATIC_DEFINITION.finditer(blank)}


def to_float_text(source, where, own_prefix=None):
    """C99 double source -> float source (see the module docstring)."""
    pivots = _pivot_literals()
    out = []
    tokens = [(m.lastgroup, m.group()) for m in _TOKEN.finditer(source)]
    own = _defined_functions(tokens)
    for i, (kind, text) in enumerate(tokens):
        if kind == "number" and ("." in text or "e" in text.lower()) and not text.lower().startswith("0x"):
            text = _float_literal(pivots.get(text, text), where)
        elif kind == "ident":
            if text in _CONSTANTS:
                text = _CONSTANTS[text]
            elif _next_is_call(tokens, i):
                if text in _MATH_F:
                    text = _MATH_F[text]
                elif not (text in _KNOWN_CALLS or text in own
                          or (own_prefix and text.lower().startswith(own_prefix.lower()))):
                    raise ModelError(f"{where}: the generated C calls {text}(), which the c99-f32 "
                                     f"target does not know how to take to float (compiler bug)")
        elif kind == "comment":
            text = text.replace(" doubles", " floats")
        out.append(text)
    return "".join(out)


# eomc_status's constants (runtime/c/eomc_model.h): an enum, while the functions return int
_STATUS = {"EOMC_OK", "EOMC_SINGULAR_MASS_MATRIX", "EOMC_SINGULAR_CONSTRAINTS", "EOMC_NONFINITE",
           "EOMC_BAD_ARGUMENT", "EOMC_NOT_AVAILABLE"}
_RESTRICT = re.compile(r"\brestrict\b\s*")
_SIGN = re.compile(r"\(\(\((?P<a>[\w\[\]]+)\) > 0\) - \(\((?P=a)\) < 0\)\)")
_BARE_HEAD = re.compile(r"^([ \t]*)(?:if|for) \(")


def misra_fixes(source):
    """What MISRA C:2012's required rules ask of the float C that a rewrite can give (docs/misra.md).

    * 10.3/10.4 (essential types): the status constants are an enum and the functions return int;
      every use becomes ``(int)EOMC_...``, so comparisons and returns stay within signed int.
    * 10.3/10.4 again: SymPy's sign(a), ``(((a) > 0) - ((a) < 0))``, an int difference of
      comparisons assigned to a float, becomes ``((a > 0.0f) ? 1.0f : ((a < 0.0f) ? -1.0f : 0.0f))``.
    * 15.6 (compound bodies): ``if (c) stmt;`` on one line becomes ``if (c) { stmt; }``.
    * 8.14 (no ``restrict``): the recursive rhs's sub-functions take their scratch array
      ``restrict`` in the default target (a promise of no aliasing, which lets gcc keep the inputs
      in registers); here the qualifier is dropped: the same operations, a plain pointer.
    The default target keeps its bytes; this runs on the c99-f32 text only.
    """
    source = _RESTRICT.sub("", source)
    source = _SIGN.sub(lambda m: f"(({m['a']} > 0.0f) ? 1.0f : (({m['a']} < 0.0f) ? -1.0f : 0.0f))", source)
    out = []
    for kind, text in ((m.lastgroup, m.group()) for m in _TOKEN.finditer(source)):
        out.append(f"(int){text}" if kind == "ident" and text in _STATUS else text)
    return "\n".join(_braced(line) for line in "".join(out).split("\n"))


def _braced(line):
    """``if (c) stmt;`` / ``for (...) stmt;`` on one line -> ``... { stmt; }`` (else the line)."""
    m = _BARE_HEAD.match(line)
    if m is None:
        return line
    depth = 0
    for i in range(m.end() - 1, len(line)):
        depth += {"(": 1, ")": -1}.get(line[i], 0)
        if depth == 0:
            head, stmt = line[:i + 1], line[i + 1:].strip()
            if stmt.endswith(";") and "{" not in stmt and "}" not in stmt and stmt != ";":
                return f"{head} {{ {stmt} }}"
            return line
    return line


def _next_is_call(tokens, i):
    """Is token i followed (past white space) by "("?  By index, not over ``tokens[i + 1:]``: that
    slice copied the rest of the file's tokens at every identifier, so the pass was quadratic in
    the file -- gymnasium's humanoid (1.7 MB of C, ~10^6 tokens) took 7 min to retarget (its
    double generation: 5 s), before session 51."""
    for j in range(i + 1, len(tokens)):
        kind, text = tokens[j]
        if kind == "other" and text.isspace():
            continue
        return text == "("
    return False


def retarget(generated, target):
    """A :class:`GeneratedModel` for ``target`` (the default target: ``generated`` itself)."""
    target = check_target(target)
    if target == DEFAULT_TARGET:
        return generated
    name = generated.name
    meta = dict(generated.metadata)
    check_target_functions(target, meta["functions"])
    source = without_cpu_dispatch(_cut_struct(generated.c_source, name))
    source = to_float_text(source, f"{name}.c", own_prefix=f"{name}_")
    source = misra_fixes(source + embedded_tail(name, meta))
    header = _f32_header(generated.header, name, meta)
    cdef = to_float_text("\n".join(l for l in generated.cdef.split("\n")
                                   if not l.startswith(f"const eomc_model *{name}_model(")),
                         f"{name} declarations", own_prefix=f"{name}_")
    step = "rhs" in meta["functions"]   # the step calls NAME_rhs
    if step:
        cdef += f"int {name}_step_rk4(float t, float h, float *x, const float *p, const float *r, float *work);\n"
    meta["target"] = target
    meta["embedded"] = {"step": f"{name}_step_rk4" if step else None,
                        "param_defaults": f"{name}_param_defaults" if meta["nparam"] else None}
    return replace(generated, c_source=source, header=header, cdef=cdef, metadata=meta)


def _cut_struct(source, name):
    """The C without the name tables, the eomc_model struct and NAME_model (double ABI)."""
    marker = f"\nstatic const char *const {name}_state_names[]"
    at = source.find(marker)
    if at < 0 or f"static const eomc_model {name}_model_data" not in source[at:]:
        raise ModelError(f"{name}.c does not end with the model struct the c99-f32 target replaces "
                         f"(compiler bug)")
    head = source[:at].rstrip("\n") + "\n"
    return head.replace(" * Reentrant: no globals except the static const tables at the end.",
                        " * Target c99-f32: float only, no heap, no mutable static state; reentrant.")


def _f32_header(header, name, meta):
    upper = name.upper()
    line = f"const eomc_model *{name}_model(void);\n"
    if line not in header:
        raise ModelError(f"{name}.h lacks the {name}_model declaration the c99-f32 target replaces "
                         f"(compiler bug)")
    extra = f"#define {upper}_TARGET_F32 1\n"      # NAME_WORK_LEN comes from the template (both targets)
    if meta["nparam"]:
        extra += f"extern const float {name}_param_defaults[{upper}_NPARAM];\n"
    if "rhs" in meta["functions"]:
        extra += (f"/* One fixed step of the classical RK4 from (t, x) with step h, inputs r held over the\n"
                  f" * step; x is updated in place only when every stage succeeded (else left as it was). */\n"
                  f"int {name}_step_rk4(float t, float h, float *x, const float *p, const float *r, float *work);\n")
    header = header.replace(line, extra)
    return to_float_text(header, f"{name}.h", own_prefix=f"{name}_")


def _default_literal(value, where):
    """A parameter default as a float literal; one below float's smallest number is its signed
    zero.  Why not an error, as a constant of the code is: a default is data the caller may
    replace (p), and a value that small is 0 to any float arithmetic -- iCub's URDF has a joint
    offset of -2.7e-51 m (rounding in its exporter), and the whole robot was refused for c99-f32,
    with advice (rescale the units) that cannot help.  The build says it (Float32Model.float_concerns:
    the parameter, its value, "it is 0 in float")."""
    value = float(value)
    if value != 0.0 and abs(value) < FLT_TRUE_MIN:
        return "-0.0f" if value < 0.0 else "0.0f"
    return _float_literal(repr(value), where)


def embedded_tail(name, meta):
    """Parameter defaults (exported const) and NAME_step_rk4, in float C99.

    The step keeps its stages in automatic arrays sized by NAME_NX: no heap, no static state,
    its stack is measured with the rest (-fstack-usage).  One exit (MISRA C:2012 15.5).
    """
    upper = name.upper()
    parts = []
    if meta["nparam"]:
        vals = ", ".join(_default_literal(v, f"{name}: parameter {pname}'s default")
                         for pname, v in zip(meta["param_names"], meta["param_defaults"]))
        parts.append(f"const float {name}_param_defaults[{upper}_NPARAM] = {{{vals}}};\n")
    nx = f"{upper}_NX"
    if "rhs" not in meta["functions"]:   # built without rhs (--outputs): no step to write
        return "\n" + "\n".join(parts) if parts else ""
    parts.append(f"""int {name}_step_rk4(float t, float h, float *x, const float *p, const float *r, float *work)
{{
    float k1[{nx}];
    float k2[{nx}];
    float k3[{nx}];
    float k4[{nx}];
    float xs[{nx}];
    const float half = 0.5f * h;
    const float sixth = h / 6.0f;
    int i;
    int status = {name}_rhs(t, x, p, r, k1, work);
    if (status == EOMC_OK) {{
        for (i = 0; i < {nx}; i++) {{
            xs[i] = x[i] + (half * k1[i]);
        }}
        status = {name}_rhs(t + half, xs, p, r, k2, work);
    }}
    if (status == EOMC_OK) {{
        for (i = 0; i < {nx}; i++) {{
            xs[i] = x[i] + (half * k2[i]);
        }}
        status = {name}_rhs(t + half, xs, p, r, k3, work);
    }}
    if (status == EOMC_OK) {{
        for (i = 0; i < {nx}; i++) {{
            xs[i] = x[i] + (h * k3[i]);
        }}
        status = {name}_rhs(t + h, xs, p, r, k4, work);
    }}
    if (status == EOMC_OK) {{
        for (i = 0; i < {nx}; i++) {{
            xs[i] = x[i] + (sixth * (k1[i] + (2.0f * (k2[i] + k3[i])) + k4[i]));
        }}
        status = {name}_finite(xs, {nx});
    }}
    if (status == EOMC_OK) {{
        for (i = 0; i < {nx}; i++) {{
            x[i] = xs[i];
        }}
    }}
    return status;
}}
""")
    return "\n" + "\n".join(parts)
