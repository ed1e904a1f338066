"""Issue 3 §8a: model -> loaded module, cold and warm cache, against PyDy's Cython backend.

eomc cold: derivation (eomc.mechanics KanesMethod) + eomc.compile(functions=
["rhs"]) into a fresh, empty cache directory (EOMC_CACHE_DIR too), i.e.
generation, gcc and loading -- like for like with PyDy, which generates only
the rhs.  A last column repeats it with eomc's default function set.
eomc warm: eomc.compile of the same formed system again, into the now-filled
cache (key computation + dlopen), and eomc.load of the built directory.
PyDy: `generate_ode_function(..., generator='cython')` alone into a fresh temp
dir: its derivation (sympy KanesMethod) is NOT included, only shown beside it.
SymPy's global cache is cleared before every cold measurement of either tool,
so neither profits from expressions the other (or an earlier repeat) built.

Goal (issue 3 §8a): eomc cold (derivation included) >= 5x faster than PyDy's
generation alone at every n, >= 10x at n >= 20; warm <= 50 ms.
"""
import contextlib
import io
import os
import re
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import (Timing, environment_header, format_table, parse_args,  # noqa: E402
                    ratio, time_once, write_results)
import models  # noqa: E402

DEFAULT_N = [1, 2, 4, 8, 12, 20, 30]


def _clear_sympy_cache():
    from sympy.core.cache import clear_cache
    clear_cache()


def measure_pydy(n, repeat):
    """(sympy derivation seconds, Timing of PyDy Cython generation)."""
    _clear_sympy_cache()
    derive_s, (kane, specified) = time_once(models.sympy_kane, n)
    samples = []
    for _ in range(repeat):
        _clear_sympy_cache()
        with tempfile.TemporaryDirectory(prefix="pydy_bench_") as tmp:
            seconds, _ = time_once(models.pydy_ode_function, n, kane, specified,
                                   "cython", tmp)
        samples.append(seconds)
    return derive_s, Timing(samples)


def _eomc_cold_once(n, root, functions, stages=None):
    """One cold build; `stages` (a dict) receives eomc's own stage timings."""
    cache = Path(tempfile.mkdtemp(prefix="cold_", dir=root))
    os.environ["EOMC_CACHE_DIR"] = str(cache)
    _clear_sympy_cache()
    err = io.StringIO()
    t0 = time.perf_counter()
    kane, _ = models.eomc_kane(n)
    t_derive = time.perf_counter() - t0
    with contextlib.redirect_stderr(err):
        model = models.eomc_compile(n, cache, kane=kane, functions=functions, progress=True)
    seconds = time.perf_counter() - t0
    if stages is not None:
        stages.clear()
        stages["kanes_equations"] = t_derive
        for line in err.getvalue().splitlines():
            m = re.match(r"eomc: (\w+)\s+([0-9.]+) s$", line.strip())
            if m:
                stages[m.group(1)] = float(m.group(2))
    return seconds, kane, model, cache


def format_stages(stages):
    """'kanes 0.8 / derive 0.1 / generate 0.9 / compile 1.2 / load 0.02' in seconds."""
    short = {"kanes_equations": "kanes"}
    return " / ".join(f"{short.get(k, k)} {v:.2g}" for k, v in stages.items()) or None


def measure_eomc_default(n, repeat, root):
    """Timing of a cold build with eomc's default function set (rhs, jac_x, ...), or None."""
    try:
        return Timing([_eomc_cold_once(n, root, None)[0] for _ in range(repeat)])
    except Exception as exc:  # noqa: BLE001
        print(f"  eomc default-functions build failed: {type(exc).__name__}: {exc}", file=sys.stderr)
        return None


def measure_eomc(n, repeat, root):
    """(Timing cold, Timing warm compile, Timing load) for rhs only, or a reason string."""
    ok, why = models.eomc_status()
    if not ok:
        return f"eomc: not available ({why})"
    old = os.environ.get("EOMC_CACHE_DIR")
    try:
        cold, warm, load, stages = [], [], [], {}
        for _ in range(repeat):
            seconds, kane, model, cache = _eomc_cold_once(n, root, ["rhs"], stages)
            cold.append(seconds)
        for _ in range(repeat):
            warm.append(time_once(models.eomc_compile, n, cache, kane=kane,
                                  functions=["rhs"])[0])
        try:
            import eomc
            target = Path(model.library_path).parent
            for _ in range(repeat):
                load.append(time_once(eomc.load, target)[0])
        except Exception as exc:  # noqa: BLE001 - load is optional in this table
            print(f"  eomc.load failed: {type(exc).__name__}: {exc}", file=sys.stderr)
        return Timing(cold), Timing(warm), (Timing(load) if load else None), stages
    except Exception as exc:  # noqa: BLE001 - a half-landed eomc must not kill the run
        return f"eomc: failed ({type(exc).__name__}: {str(exc)[:200]})"
    finally:
        if old is None:
            os.environ.pop("EOMC_CACHE_DIR", None)
        else:
            os.environ["EOMC_CACHE_DIR"] = old


HEADERS = ["n", "sympy derive [s]", "PyDy gen [s]", "PyDy IQR [s]", "eomc cold [s]",
           "eomc cold IQR [s]", "eomc warm compile [ms]", "eomc load [ms]",
           "PyDy gen / eomc cold", "goal", "eomc cold, default functions [s]",
           "eomc cold stages, last repeat [s]"]


def row_for(n, derive_s, pydy, eo, default):
    if isinstance(eo, str):
        return [n, derive_s, pydy.median, pydy.iqr, None, None, None, None, None, "eomc n/a",
                None, None]
    cold, warm, load, stages = eo
    r = ratio(pydy.median, cold.median)
    need = 10.0 if n >= 20 else 5.0
    verdict = lambda ok: "met" if ok else "MISSED"
    goal = (f"{need:g}x {verdict(r is not None and r >= need)}; warm compile <= 50 ms "
            f"{verdict(warm.median <= 0.050)}; load <= 50 ms "
            f"{verdict(load is not None and load.median <= 0.050)}")
    return [n, derive_s, pydy.median, pydy.iqr, cold.median, cold.iqr, warm.median * 1e3,
            load.median * 1e3 if load else None, r, goal,
            default.median if default else None, format_stages(stages)]


def main(argv=None):
    extra = lambda p: p.add_argument("--skip-default", action="store_true",
                                     help="skip the cold build with eomc's default functions")
    args = parse_args(__doc__.splitlines()[0], DEFAULT_N, default_repeat=3, argv=argv,
                      extra=extra)
    rows, notes = [], []
    with tempfile.TemporaryDirectory(prefix="eomc_bench_build_") as root:
        for n in args.n:
            derive_s, pydy = measure_pydy(n, args.repeat)
            eo = measure_eomc(n, args.repeat, root)
            default = None
            if isinstance(eo, str):
                notes.append(f"n={n}: {eo}")
            elif not args.skip_default:
                default = measure_eomc_default(n, max(1, args.repeat // 2), root)
            rows.append(row_for(n, derive_s, pydy, eo, default))
            print(format_table(HEADERS, [rows[-1]]).splitlines()[-1], flush=True)
    table = format_table(HEADERS, rows)
    print(table)
    header = environment_header(
        "Model to loaded module: eomc vs PyDy 0.9.4 Cython (issue 3 §8a)", args,
        notes=[f"repeats per cell: {args.repeat}; cells are medians, IQR beside them",
               "PyDy gen = generate_ode_function(generator='cython') only (gcc included), "
               "into a fresh temp dir; derivation NOT included (sympy KanesMethod time shown "
               "separately in 'sympy derive', measured once)",
               "eomc cold = eomc.mechanics derivation + eomc.compile(functions=['rhs']) into "
               "a fresh empty cache dir (EOMC_CACHE_DIR), derivation included: like for "
               "like with PyDy, which generates only the rhs",
               "last column: the same with eomc's default function set (rhs, jac_x, jac_r, "
               "mass matrix, forcing, inverse dynamics, linearize, ...); "
               f"{max(1, args.repeat // 2)} repeat(s)",
               "eomc warm compile = eomc.compile of the same formed system again (cache hit); "
               "eomc load = eomc.load(build dir)",
               "stages: kanes = KanesMethod.kanes_equations (eomc.mechanics), then eomc.compile's "
               "own stage timings (derive = forming/conversion, generate = IR+C, compile = gcc, "
               "load = dlopen+cffi)",
               "SymPy's cache is cleared before every cold measurement of either tool",
               *notes])
    if not args.no_write:
        paths = write_results("build", header + "\n" + table + "\n",
                              csv_rows=rows, csv_headers=HEADERS)
        print("wrote", ", ".join(str(p) for p in paths))
    return 0


if __name__ == "__main__":
    sys.exit(main())
