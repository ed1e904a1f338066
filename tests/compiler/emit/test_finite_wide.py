"""NAME_finite_wide (templates/model.c.j2), NAME_implicit's finiteness check: a plain sum of the
outputs first, the exact v - v check only when that sum is not finite.  Its verdict must be the
exact one: EOMC_NONFINITE for any NaN or infinity at any place and length, EOMC_OK for finite
outputs -- also for finite outputs whose sum overflows (there the plain sum alone would say
non-finite: the fallback decides)."""
import re
import subprocess

import numpy as np
import pytest

BALL = """<mujoco model="ball">
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="ball" pos="0 0 0.2">
      <freejoint name="root"/>
      <geom name="ball" type="sphere" size="0.05" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""

HARNESS = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#define EOMC_OK 0
#define EOMC_NONFINITE 3
%(functions)s
int main(void)
{
    static double v[80];
    int n, i;
    while (scanf("%%d", &n) == 1) {
        for (i = 0; i < n; i++) {
            char word[64];
            if (scanf("%%63s", word) != 1) return 2;
            v[i] = strtod(word, NULL);
        }
        printf("%%d\n", %(name)s_finite_wide(v, n));
    }
    return 0;
}
"""


@pytest.fixture(scope="module")
def finite_wide(tmp_path_factory):
    """A program that reads cases (n, then n numbers) and prints the ball's NAME_finite_wide of each."""
    from eomc.compiler.build.toolchain import find_compiler, machine_flags
    tc = find_compiler()
    from eomc.compiler.driver import generate
    from eomc.compiler.mjcf.model import MjcfModel
    d = tmp_path_factory.mktemp("finite_wide")
    (d / "ball.xml").write_text(BALL)
    _, gen = generate(MjcfModel(d / "ball.xml"), name="fw_ball", use_cache=False, progress=False)
    # every static finiteness function the generated C has (finite_wide and what it calls)
    functions = re.findall(r"^static int fw_ball_finite\w*\(const double \*v, int n\)\n\{.*?\n\}\n",
                           gen.c_source, re.S | re.M)
    assert any("fw_ball_finite_wide(" in f for f in functions)
    (d / "h.c").write_text(HARNESS % {"functions": "\n".join(functions), "name": "fw_ball"})
    exe = d / "h"
    flags = list(machine_flags(tc))         # the flags models are built with here (-mavx2 ...)
    subprocess.run([*tc.argv, "-O2", "-std=c99", *flags, "-o", str(exe), str(d / "h.c"), "-lm"], check=True)

    def run(cases):
        text = "".join(f"{len(c)} " + " ".join(repr(float(x)) for x in c) + "\n" for c in cases)
        out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True).stdout
        return [int(s) for s in out.split()]
    return run


def test_the_verdict_is_the_exact_one(finite_wide):
    rng = np.random.default_rng(7)
    cases, want = [], []
    for n in (0, 1, 15, 16, 17, 33, 47, 64, 79):
        base = rng.standard_normal(n) * 10.0 ** rng.integers(-300, 300, n)
        cases.append(base)
        want.append(0)
        for bad in (np.nan, np.inf, -np.inf):
            for i in range(n):
                c = base.copy()
                c[i] = bad
                cases.append(c)
                want.append(3)
        if n >= 2:      # +inf and -inf together (their sum is NaN)
            c = base.copy()
            c[0], c[-1] = np.inf, -np.inf
            cases.append(c)
            want.append(3)
            # finite outputs whose plain sum overflows (to inf, and to NaN through +inf + -inf)
            for signs in ((1.0, 1.0), (1.0, -1.0)):
                c = np.zeros(n)
                c[: n // 2 + 1] = signs[0] * 1.7e308
                c[n // 2 + 1:] = signs[1] * 1.7e308
                cases.append(c)
                want.append(0)
    got = finite_wide(cases)
    assert got == want
