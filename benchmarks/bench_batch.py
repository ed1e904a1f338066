"""Issue 4 §4: how simulate_many scales from one thread to two.

Each case is one call into the C integrator with the GIL released, so the
cases of a batch run on as many cores as there are threads.  The workload is
64 initial states of the n-link cart, 10 s each, DOP853 at rtol = atol = 1e-8.
"""
import tempfile

import numpy as np

from common import environment_header, fmt, format_table, median_iqr, parse_args, time_once, write_results
from models import eomc_compile, eomc_p, initial_state

CASES = 64


def _states(n, count, seed=0):
    rng = np.random.default_rng(seed)
    base = initial_state(n)
    X = np.tile(base, (count, 1))
    X[:, 1:n + 1] += rng.uniform(-0.2, 0.2, size=(count, n))
    return X


def main():
    args = parse_args(__doc__.splitlines()[0], default_n=[4, 8], default_repeat=5)
    from eomc.runtime.batch import simulate_many
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        for n in args.n:
            model = eomc_compile(n, cache, functions=["rhs"])
            X, p = _states(n, CASES), eomc_p(model, n)
            kw = dict(p=p, method="dop853", rtol=1e-8, atol=1e-8, n_points=101, progress=False)
            times = {}
            for threads in (1, 2):
                simulate_many(model, X[:4], (0.0, 10.0), threads=threads, **kw)  # warm up
                samples = [time_once(simulate_many, model, X, (0.0, 10.0), threads=threads, **kw)[0]
                           for _ in range(args.repeat)]
                times[threads] = median_iqr(samples)
            one, two = times[1][0], times[2][0]
            rows.append([n, CASES, fmt(one * 1e3), fmt(two * 1e3), fmt(one / two),
                         fmt(one / CASES * 1e3)])
    headers = ["n", "cases", "1 thread [ms]", "2 threads [ms]", "speed-up", "per case, 1 thread [ms]"]
    table = format_table(headers, rows)
    print(table)
    if not args.no_write:
        text = environment_header("Batch simulation: one thread against two (issue 4 §4)", args, notes=[
            f"{CASES} initial states of the n-link cart, 10 s each, DOP853 rtol=atol=1e-8, 101 output times",
            "medians of repeats; the machine has 2 cores, so 2.0 is the ceiling",
        ]) + "\n" + table + "\n"
        print("wrote", ", ".join(map(str, write_results("batch", text, rows, headers))))


if __name__ == "__main__":
    main()
