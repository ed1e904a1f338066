"""``eomc sweep MODEL --cases cases.csv --t-final T -o results.csv|.parquet [--scheduler ADDRESS]``.

One simulation per row of cases.csv, whose header names the model's states,
parameters and inputs (an optional ``case`` column is an identifier copied to
the output); unset states start at the model's initial state, unset
parameters keep their defaults.  The cases run through ``eomc.sweep`` on
local processes, or on a Dask cluster when ``--scheduler`` gives its address
(``tcp://host:8786``).  Each output row is one case: its columns from the
CSV, then status, t_final, the final state and outputs (``final_NAME``) and
the failure message, if any.  Whole trajectories stay on the workers.
"""
import argparse
import csv
import os
from pathlib import Path

import numpy as np

from eomc.errors import EomcError
from eomc.runtime.files import atomic_path

from . import common as cli_common

__all__ = ["configure", "run", "read_cases"]


def configure(parser):
    parser.add_argument("model", help="model file (.py) or built model directory / NAME.json")
    parser.add_argument("--cases", required=True, metavar="CSV",
                        help="one case per row; columns named by states, parameters and inputs")
    parser.add_argument("--t-final", type=float, required=True, metavar="T", help="end time")
    parser.add_argument("--t0", type=float, default=0.0, help="start time")
    parser.add_argument("-o", "--output", required=True, metavar="FILE",
                        help="results: .csv, or .parquet (needs pyarrow)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="a Dask scheduler (tcp://host:8786); default: local processes")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="local processes when no --scheduler is given")
    parser.add_argument("--chunk-size", type=int, help="cases per chunk (default: ~4 chunks per worker, >= 100)")
    parser.add_argument("--method", default="dop853", help="rk4 (needs --dt), dopri5 (rk45), dop853, radau")
    parser.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-9, help="absolute tolerance")
    parser.add_argument("--dt", type=float, help="fixed step (rk4)")
    parser.add_argument("--max-steps", type=int, default=100000, help="step limit")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    parser.formatter_class = argparse.ArgumentDefaultsHelpFormatter


def read_cases(path):
    """(ids or None, {column: float array}) from a CSV with a header row; errors name file:line."""
    path = Path(path)
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the cases ({exc.strerror or exc})") from None
    rows = [(i, r) for i, r in enumerate(rows, 1) if any(cell.strip() for cell in r)]
    if len(rows) < 2:
        raise ValueError(f"{path}: expected a header row naming states, parameters or inputs, "
                         f"then one row per case")
    header = [h.strip() for h in rows[0][1]]
    columns = {h: [] for h in header}
    if len(columns) != len(header):
        raise ValueError(f"{path}:{rows[0][0]}: a column name appears twice")
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise ValueError(f"{path}:{line}: {len(row)} values for {len(header)} columns")
        for name, cell in zip(header, row):
            if name == "case":
                columns[name].append(cell.strip())
                continue
            try:
                columns[name].append(float(cell))
            except ValueError:
                raise ValueError(f"{path}:{line}: column {name!r}: {cell.strip()!r} is not a number") from None
    ids = columns.pop("case", None)
    return ids, {k: np.array(v) for k, v in columns.items()}


def _executor(args):
    if args.scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise EomcError("--scheduler needs Dask: pip install 'eomc[dask]'") from None
        return Client(args.scheduler)
    if args.workers < 1:
        raise ValueError(f"--workers must be at least 1; got {args.workers}")
    from concurrent.futures import ProcessPoolExecutor
    return ProcessPoolExecutor(max_workers=args.workers)


def _write(path, table):
    """Write the results table; a half-written file never takes the place of ``path``
    (it is written beside it under a temporary name, then renamed)."""
    path = Path(path)
    if path.suffix not in (".csv", ".parquet"):
        raise ValueError(f"-o {path}: write .csv or .parquet")
    if path.suffix == ".parquet":
        try:
            import pyarrow
            import pyarrow.parquet
        except ImportError:
            raise EomcError("writing .parquet needs pyarrow: pip install pyarrow (or write .csv)") from None
    with atomic_path(path) as tmp:
        if path.suffix == ".parquet":
            pyarrow.parquet.write_table(pyarrow.table(table), tmp)
        else:
            with open(tmp, "w", newline="") as fh:
                writer = csv.writer(fh)
                writer.writerow(table)
                columns = [[repr(float(v)) if isinstance(v, (float, np.floating)) else v for v in col]
                           for col in table.values()]
                writer.writerows(zip(*columns))
    return path


def run(args):
    from eomc.runtime.sweep import sweep
    if Path(args.output).suffix not in (".csv", ".parquet"):
        raise ValueError(f"-o {args.output}: write .csv or .parquet")
    ids, columns = read_cases(args.cases)
    model = cli_common.load_model(args.model, quiet=args.quiet)
    executor = _executor(args)
    try:
        res = sweep(model, columns, (args.t0, args.t_final), map=executor, chunk_size=args.chunk_size,
                    reduce="final", progress=not args.quiet, raise_on_failure=False, method=args.method,
                    rtol=args.rtol, atol=args.atol, dt=args.dt, max_steps=args.max_steps)
    finally:
        (executor.close if args.scheduler else executor.shutdown)()
    n = len(res.status)
    table = {} if ids is None else {"case": ids}
    table.update({k: v.tolist() for k, v in columns.items()})
    table["status"] = res.status.astype(int).tolist()
    table["t_final"] = [float(s["t"]) for s in res.stats]
    for j, name in enumerate(model.state_names):
        table[f"final_{name}"] = res.x[:, 0, j].tolist()
    for name, values in res.outputs.items():
        table[f"final_{name}"] = values[:, 0].tolist()
    table["message"] = ["" if s == 0 else m for s, m in zip(res.status, res.messages)]
    failed = int(np.count_nonzero(res.status))
    where = args.scheduler or f"{args.workers} local process{'es' if args.workers > 1 else ''}"
    print(f"{model.name}: {n} cases on {where}, {failed} failed; wrote {_write(args.output, table)}")
    if failed:
        first = int(np.flatnonzero(res.status)[0])
        print(f"  first failure, case {first}: {res.messages[first]}")
    return 1 if failed == n else 0
