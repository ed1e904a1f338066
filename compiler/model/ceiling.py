"""The largest robot a build with dense Jacobians takes, refused up front with the figure.

Why: the default function set holds the state Jacobian (jac_x, 2n x 2n for n coordinates),
the input Jacobian (jac_r) and linearize (both together).  A chain's Jacobian is dense, so
its C grows with n^2 and the C compiler's time and memory faster still: measured
(benchmarks/bench_build_ceiling.py, benchmarks/results/build_ceiling.md) a 100-link chain's
default build writes 6.9 MB of C (gcc: 58 s, 0.84 GB), a 200-link chain's 27 MB (gcc:
6 min, 3.5 GB).  A 1000-link chain would need some 0.7 GB of C and far more memory than a
workstation has; a 5000-link one built for 20 minutes and 8 GB before it was stopped, saying
nothing.  The rhs alone grows linearly (about 0.1 s of CPU per link), so past the ceiling
the build is refused at once, naming the figure and the way out (``--outputs rhs,...``).
``EOMC_BUILD_CEILING=off`` builds anyway.  Without dense Jacobians a robot of more than
LARGE_COORDINATES coordinates is built, after one warning stating the time and memory to
expect (generating a 2000-link chain's rhs: 147 s of CPU and 1.7 GB; it grows a little faster
than linearly).
"""
import os

from eomc.runtime.errors import ModelError

__all__ = ["MAX_DENSE_COORDINATES", "LARGE_COORDINATES", "check_ceiling"]

# coordinates above which a build with dense Jacobians is refused (a 300-link chain: ~60 MB
# of C, about 8 GB and half an hour of gcc by the measured n^2 growth)
MAX_DENSE_COORDINATES = 300
DENSE = ("jac_x", "jac_r", "linearize")
# measured on a chain of 200 links (benchmarks/results/build_ceiling.md): C bytes, gcc's
# seconds and peak bytes; each grows at least with the square of the coordinates
_AT_200 = (27.3e6, 372.0, 3.5e9)
# without them (the rhs): CPU seconds and peak bytes of generating a 2000-link chain's C (the C
# compiler's own cost comes on top), growing about as n^1.45 from 500 to 2000 links
_RHS_AT_2000 = (147.0, 1.66e9)
_GROWTH = 1.45
LARGE_COORDINATES = 1000       # a build this large says what it will cost before it starts


def _defaults():
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    return [f for f in FUNCTION_ORDER if f not in ON_REQUEST]


def _say_the_cost(name, n):
    """One warning before a long build without dense Jacobians: what it will take, from the
    measured growth (a build of minutes and gigabytes must not look like a hang)."""
    import warnings
    from eomc.runtime.errors import EomcWarning
    cpu, peak = (v * (n / 2000.0) ** _GROWTH for v in _RHS_AT_2000)
    warnings.warn(f"{name}: {n} coordinates: expect this build to take about {_duration(cpu)} of CPU and "
                  f"{_size(peak)} of memory (measured on a 2000-link chain: {_duration(_RHS_AT_2000[0])}, "
                  f"{_size(_RHS_AT_2000[1])}; growing as n^{_GROWTH})", EomcWarning, stacklevel=4)


def _size(n):
    if n >= 1e12:
        return f"{n / 1e12:.2g} TB"
    return f"{n / 1e9:.2g} GB" if n >= 1e9 else f"{n / 1e6:.0f} MB"


def _duration(seconds):
    return f"{seconds / 3600:.2g} h" if seconds >= 3600 else f"{seconds / 60:.2g} min"


def check_ceiling(read, functions, name=None):
    """ModelError when the robot ``read`` (a Reading) has more coordinates than
    MAX_DENSE_COORDINATES and ``functions`` (None: the defaults) hold a dense Jacobian."""
    if os.environ.get("EOMC_BUILD_CEILING", "").strip().lower() in ("off", "0", "no"):
        return
    model = getattr(read, "model", None)
    if model is None or getattr(read, "kind", None) != "robot":
        return
    n = len(model.coordinates)
    asked = _defaults() if functions is None else ["jac_x" if f == "jacobian" else f for f in functions]
    wanted = [f for f in asked if f in DENSE]
    if not wanted and n > LARGE_COORDINATES:
        _say_the_cost(name or read.name, n)
    if n <= MAX_DENSE_COORDINATES or not wanted:
        return
    scale = (n / 200.0) ** 2
    c_bytes, seconds, peak = (v * scale for v in _AT_200)
    # the defaults that apply to most robots (absent ones, e.g. outputs, are skipped by the build)
    kept = [f for f in asked if f not in DENSE and (functions is not None or f in
                                                      ("rhs", "mass_matrix", "forcing", "inverse_dynamics",
                                                       "outputs", "events", "poses"))]
    raise ModelError(
        f"{name or read.name}: {n} coordinates: the dense Jacobians ({', '.join(wanted)}) of the default build "
        f"grow with the square of that -- about {_size(c_bytes)} of C, and by the growth measured "
        f"at 200 links at least {_duration(seconds)} and {_size(peak)} of memory to compile it "
        f"(builds with them stop at {MAX_DENSE_COORDINATES} coordinates); build without them: "
        f"--outputs {','.join(kept)} (linear, about 0.1 s per link), or set "
        f"EOMC_BUILD_CEILING=off to try anyway")
