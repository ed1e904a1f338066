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
    parser.add_argument("--connect-timeout", type=float, default=10.0, metavar="S",
                        help="seconds to wait for the Dask scheduler to answer and for its first worker")
    parser.add_argument("--consistent", action="store_true",
                        help="complete each case's dependent coordinates and speeds on the model's "
                             "constraints (keeping the independent ones) before it runs")
    parser.add_argument("--method", default="auto",
                        help="auto (as eomc simulate), rk4 (needs --dt), dopri5 (rk45), dop853, radau, bdf, implicitfast (needs --dt)")
    parser.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-9, help="absolute tolerance")
    parser.add_argument("--dt", type=float, help="fixed step (rk4)")
    parser.add_argument("--max-steps", type=int, default=None, metavar="N",
                        help="step limit per case (default 100000; a robot on the ground: 100000 per simulated second)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def read_cases(path, with_lines=False):
    """(ids or None, {column: float array}) from a CSV with a header row; errors name file:line.

    with_lines=True adds a third item: the file's line number of each case (for errors found
    later, e.g. a non-finite value).  An Excel byte-order mark before the header is dropped.
    """
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the cases ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a UTF-8 text CSV file (byte 0x{exc.object[exc.start]:02x} at "
                         f"position {exc.start})") from None
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
    columns = {k: np.array(v) for k, v in columns.items()}
    if with_lines:
        return ids, columns, [line for line, _ in rows[1:]]
    return ids, columns


def _executor(args):
    if args.scheduler:
        return _dask_client(args.scheduler, args.connect_timeout)
    if args.workers < 1:
        raise ValueError(f"--workers must be at least 1; got {args.workers}")
    from concurrent.futures import ProcessPoolExecutor
    return ProcessPoolExecutor(max_workers=args.workers)


def _stop_workers(executor):
    """Ctrl-C or SIGTERM: the local worker processes end now (SIGKILL), and nothing queued starts.
    Why: a SIGTERM reaches this process only (a scheduler's, `kill`'s), and shutdown() waited for
    every running chunk: 82 s for 20,000 double-pendulum cases of 200 s on 2 workers (s29).  Not
    SIGTERM: a forked worker inherits this command's handler, which turns it into an exception
    the pool's worker reports and then takes the next queued chunk (39 s).  The workers write
    nothing but their results, so nothing is left half-written."""
    for process in list((getattr(executor, "_processes", None) or {}).values()):
        process.kill()
    executor.shutdown(wait=False, cancel_futures=True)


def _dask_client(address, timeout):
    """A Client of the scheduler at ``address`` with at least one worker, or one clear error.

    Connecting is bounded by ``timeout`` (Dask's own default waits 30 s); something at the
    address that is not a Dask scheduler makes Dask misread its bytes (it once tried to
    allocate 3 EiB) -- that too is a connection failure, said as one.
    """
    try:
        from distributed import Client
    except ImportError:
        raise EomcError("--scheduler needs Dask: install the dask extra (pip install '.[dask]' in eomc's "
                        "clone)") from None
    if not timeout > 0:
        raise ValueError(f"--connect-timeout must be > 0 seconds; got {timeout}")
    _quiet_dask_logs()
    try:
        client = Client(address, timeout=timeout)
    except ValueError:
        raise                     # a malformed address: Dask's message says which scheme is wrong
    except Exception as exc:      # OSError, TimeoutError, MemoryError from a non-Dask peer, ...
        raise EomcError(f"cannot connect to a Dask scheduler at {address} within {timeout:g} s "
                        f"({_why(exc)}); is the scheduler running there, and is it a Dask scheduler?") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except Exception as exc:
        client.close()
        raise EomcError(f"the Dask scheduler at {address} has no workers (none joined within "
                        f"{timeout:g} s: {_why(exc)}); start one with `dask worker {address}`") from None
    return client


def _quiet_dask_logs():
    """Dask logs its own errors and tracebacks (a lost scheduler, a reconnect that gave up) on
    stderr; eomc reports the failure as one line, so only CRITICAL records get through.  dask's
    logging config gives some loggers (distributed.client, ...) levels of their own: set each."""
    import logging
    names = [n for n in list(logging.root.manager.loggerDict) if n.split(".")[0] in ("distributed", "tornado")]
    for name in ["distributed", "tornado", "asyncio", *names]:
        logging.getLogger(name).setLevel(logging.CRITICAL)


def _why(exc):
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text[:200]}" if text else type(exc).__name__


def _cluster_failure(exc, address):
    """An exception from the Dask machinery during a sweep, as one EomcError (else None)."""
    import concurrent.futures
    import asyncio
    module = type(exc).__module__ or ""
    if module.startswith(("distributed", "tornado", "dask")) or isinstance(
            exc, (OSError, TimeoutError, concurrent.futures.CancelledError, asyncio.CancelledError)):
        return EomcError(f"the Dask cluster at {address} failed during the sweep ({_why(exc)}); a worker "
                         f"or the scheduler was lost -- no results were written")
    return None


def _pyarrow():
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        # first hour s28: as every other missing extra is named (README's sweep line writes .parquet)
        raise EomcError("writing .parquet needs pyarrow, which is not installed: pip install \"eomc[dask]\" "
                        "(from a clone of eomc: pip install \".[dask]\"), or pyarrow alone; or write .csv") from None
    return pyarrow


def _write(path, table, partial=None):
    """Write the results table; a half-written file never takes the place of ``path``
    (it is written beside it under a temporary name, then renamed).  ``partial``: why the
    table is not whole (a stopped sweep), as a last line ``# partial: <why>`` of a CSV
    (as simulate's ``# incomplete``; numpy.loadtxt and pandas with comment="#" skip it) and
    as the schema's metadata ``eomc_partial`` of a .parquet."""
    path = Path(path)
    if path.suffix not in (".csv", ".parquet"):
        raise ValueError(f"-o {path}: write .csv or .parquet")
    with atomic_path(path) as tmp:
        if path.suffix == ".parquet":
            pyarrow = _pyarrow()
            arrow = pyarrow.table(table)
            if partial:
                arrow = arrow.replace_schema_metadata({**(arrow.schema.metadata or {}), b"eomc_partial": partial})
            pyarrow.parquet.write_table(arrow, tmp)
        else:
            with open(tmp, "w", newline="") as fh:
                writer = csv.writer(fh)
                writer.writerow(table)
                columns = [[repr(float(v)) if isinstance(v, (float, np.floating)) else v for v in col]
                           for col in table.values()]
                writer.writerows(zip(*columns))
                if partial:
                    fh.write(f"# partial: {partial}\n")
    return path


def run(args):
    from eomc.runtime.batch import CaseError
    from eomc.runtime.sweep import sweep
    if Path(args.output).suffix not in (".csv", ".parquet"):
        raise ValueError(f"-o {args.output}: write .csv or .parquet")
    cli_common.writable_file(args.output, "-o")     # before any work: a typo must not cost the sweep
    if args.output.endswith(".parquet"):
        _pyarrow()
    if args.chunk_size is not None and args.chunk_size < 1:
        raise ValueError(f"--chunk-size must be a positive number of cases; got {args.chunk_size}")
    from eomc.runtime.simulate import resolve_method
    resolve_method(args.method)                     # a misspelt --method before the build
    ids, columns, lines = read_cases(args.cases, with_lines=True)
    model = cli_common.load_model(args.model, quiet=args.quiet)
    try:
        from eomc.runtime.sweep import case_arrays
        case_arrays(model, columns, rows=False)      # every cell checked before any worker starts
    except CaseError as exc:
        raise ValueError(f"{args.cases}:{lines[exc.case]}: {exc.detail}") from None
    executor = _executor(args)
    stopping = False
    try:
        res = sweep(model, columns, (args.t0, args.t_final), map=executor, chunk_size=args.chunk_size,
                    reduce="final", progress=not args.quiet, raise_on_failure=False, method=args.method,
                    rtol=args.rtol, atol=args.atol, dt=args.dt, max_steps=args.max_steps,
                    consistent=True if args.consistent else None)
    except CaseError as exc:
        raise ValueError(f"{args.cases}:{lines[exc.case]}: {exc.detail}") from None
    except (EomcError, ValueError):
        raise
    except Exception as exc:
        failure = _cluster_failure(exc, args.scheduler) if args.scheduler else None
        if failure is None:
            raise
        raise failure from None
    except BaseException as stop:   # Ctrl-C, SIGTERM (raised like it by the command line): stop the workers
        stopping = stop
        raise
    finally:
        try:
            if args.scheduler:
                executor.close()
            elif stopping:
                _stop_workers(executor)
            else:
                executor.shutdown()
        except Exception:       # a lost scheduler cannot be closed politely; the error above says so
            pass
        if stopping is not False:
            _write_partial(args, model, ids, columns, getattr(stopping, "partial_result", None))
    n = len(res.status)
    table = _table(model, ids, columns, res)
    failed = int(np.count_nonzero(res.status))
    where = args.scheduler or f"{args.workers} local process{'es' if args.workers > 1 else ''}"
    print(f"{model.name}: {n} cases on {where}, {failed} failed; wrote {_write(args.output, table)}")
    if failed:
        first = int(np.flatnonzero(res.status)[0])
        print(f"  first failure, case {first} ({args.cases}:{lines[first]}): {res.messages[first]}")
    return 1 if failed == n else 0


def _write_partial(args, model, ids, columns, res):
    """A stopped sweep (Ctrl-C, SIGTERM): the cases of the chunks that came back, written to -o
    marked partial (the others status 9, NaN, "not run: ..."), and a line on stderr saying so.
    Why: a sweep stopped after hours wrote nothing (s29).  Nothing came back: nothing written."""
    import sys
    from eomc.runtime.sweep import STOPPED
    if res is None or not np.any(res.status != STOPPED):
        print(f"eomc sweep: stopped before any chunk of cases came back: nothing written to {args.output}",
              file=sys.stderr)
        return
    n, ran = len(res.status), int(np.count_nonzero(res.status != STOPPED))
    why = (f"the sweep was stopped; {ran} of {n} cases ran, the other {n - ran} have status {STOPPED} "
           f"and message 'not run'")
    try:
        _write(args.output, _table(model, ids, columns, res), partial=why)
    except Exception as exc:    # noqa: BLE001 -- the stop goes on; say why nothing was kept
        print(f"eomc sweep: stopped; could not write the {ran} finished cases to {args.output}: {exc}",
              file=sys.stderr)
        return
    print(f"eomc sweep: stopped: wrote the {ran} of {n} cases whose chunks had finished to {args.output}, "
          f"marked partial (the other {n - ran}: status {STOPPED}, 'not run')", file=sys.stderr)


def _table(model, ids, columns, res):
    """The results table: the cases' columns, then status, t_final, final_* and message."""
    table = {} if ids is None else {"case": ids}
    table.update({k: v.tolist() for k, v in columns.items()})
    table["status"] = res.status.astype(int).tolist()
    table["t_final"] = res.t_final.tolist()
    for j, name in enumerate(model.state_names):
        table[f"final_{name}"] = res.x_final[:, j].tolist()
    for name, values in res.outputs.items():
        table[f"final_{name}"] = values[:, 0].tolist()
    if res.t_events is not None:
        table["event_stop"] = [e or "" for e in res.event_stop]
        for name in next(e for e in res.t_events if e is not None):
            table[f"events_{name}"] = [0 if e is None else len(e[name]) for e in res.t_events]
            table[f"first_{name}"] = [float("nan") if e is None or not len(e[name]) else float(e[name][0])
                                      for e in res.t_events]
    table["message"] = ["" if s == 0 else m for s, m in zip(res.status, res.messages)]
    return table
