"""Which of a built model's functions return with the ymm/zmm upper halves dirty (XINUSE bit 2).

A function compiled with AVX that returns without ``vzeroupper`` leaves the CPU's upper state
in use; the SSE-compiled runtime that calls it then pays a transition penalty on every SSE
instruction (measured up to 2.5x on a whole run, /work/notes/s6/report-sens.md).  This helper
writes a small C harness from the model's header: it calls every ``NAME_*`` function with
zero-ish buffers (parameters at their defaults, states 0.1), twice, and reads ``xgetbv(1)``
right after the second call, with no other code in between that could clear or dirty the
state (the harness itself is compiled without AVX, the library is bound with RTLD_NOW so the
lazy-binding trampoline never runs between the call and the read).
"""
import os
import re
import subprocess

import eomc.runtime
from eomc.compiler.build import find_compiler

_PROTO = re.compile(r"^int (\w+)\(([^)]*)\);", re.M)


def _argument(decl, i, k):
    decl = decl.strip()
    if decl.startswith("double ") and "*" not in decl:
        return "0.25"
    if decl.startswith("int ") and "*" not in decl:
        return str(k)
    if "int *" in decl or "int*" in decl:
        return "ibuf"
    if "double" in decl and "*" in decl:
        name = decl.rsplit("*", 1)[1].strip()
        return "pbuf" if name in ("p", "P") else f"buf[{i}]"
    return None


def harness_source(header_text, name, k=4):
    """The C harness for a model named ``name`` with header ``header_text``; (source, functions)."""
    calls, names = [], []
    for fn, args in _PROTO.findall(header_text):
        if not fn.startswith(name + "_"):
            continue
        decls = [a for a in args.split(",") if a.strip()]
        vals = [_argument(d, i, k) for i, d in enumerate(decls)]
        if None in vals:
            continue
        names.append(fn)
        params = ", ".join(d.strip() for d in decls)
        calls.append(
            f'    {{ int (*f)({params}) = (int (*)({params}))dlsym(h, "{fn}");\n'
            f'      if (f) {{ int s; f({", ".join(vals)}); __asm__ volatile("vzeroupper");\n'
            f'        s = f({", ".join(vals)}); unsigned u = xinuse();\n'
            f'        printf("{fn} %d %u\\n", s, (u >> 2) & 1u); }} }}\n')
    src = f"""#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "eomc_model.h"
static unsigned xinuse(void) {{ unsigned lo, hi; __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(1)); (void)hi; return lo; }}
int main(int argc, char **argv) {{
    enum {{ LEN = 1 << 18 }};
    double *buf[16]; double *pbuf = calloc(LEN, sizeof(double)); int *ibuf = calloc(LEN, sizeof(int));
    char mode = argc > 2 ? argv[2][0] : 'c';
    int i, j; void *h; const eomc_model *m;
    const eomc_model *(*info)(void);
    for (i = 0; i < 16; i++) {{ buf[i] = malloc(LEN * sizeof(double)); for (j = 0; j < LEN; j++) buf[i][j] = mode == 'r' ? (double)(rand() % 2001 - 1000) / 1000.0 : mode == 'n' ? 0.0 / 0.0 : 0.1; }}
    h = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!h) {{ printf("dlopen %s\\n", dlerror()); return 2; }}
    info = (const eomc_model *(*)(void))dlsym(h, "{name}_model");
    m = info();
    for (j = 0; j < LEN; j++) pbuf[j] = mode == 'z' ? 0.0 : m->nparam ? m->param_defaults[j % m->nparam] : 0.1;
{''.join(calls)}    return 0;
}}
"""
    return src, names


def dirty_functions(model, tmp_path, k=4, mode="const"):
    """{function: (status, dirty)} for every NAME_* function of the loaded ``model``."""
    directory = str(model.directory)
    with open(os.path.join(directory, os.path.basename(model.header_path))) as fh:
        header = fh.read()
    name = re.search(r"const eomc_model \*(\w+)_model\(void\);", header).group(1)
    src, _ = harness_source(header, name, k)
    c = os.path.join(tmp_path, "avx_harness.c")
    exe = os.path.join(tmp_path, "avx_harness")
    with open(c, "w") as fh:
        fh.write(src)
    cc = find_compiler()
    runtime_c = os.path.join(os.path.dirname(eomc.runtime.__file__), "c")     # eomc_model.h
    proc = subprocess.run([*cc.argv, "-O1", "-std=gnu99", "-I", directory, "-I", runtime_c, c, "-o", exe, "-ldl"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    out = subprocess.run([exe, str(model.library_path), mode], capture_output=True, text=True, check=True).stdout
    result = {}
    for line in out.splitlines():
        fn, status, dirty = line.split()
        result[fn] = (int(status), dirty == "1")
    return result
