"""The ``eomc`` command: one dispatcher and one module per subcommand.

- compiler commands (import SymPy): ``show``, ``build``, ``inspect``
- runtime commands (never import SymPy on a built model): ``simulate``, ``report``, ``check``, ``animate``,
  sharing ``common.py`` (which model, from which state); ``cache``

Each subcommand module exposes ``configure(parser)`` and ``run(args) -> int``.
They are imported only when chosen, so ``eomc simulate`` on a built model
never imports SymPy.
"""
import argparse
import os
import signal
import sys
import warnings
from importlib import import_module

from eomc import __version__
from eomc.errors import EomcError, EomcNote, EomcWarning

from .helptext import DESCRIPTION, EPILOG, OptionHelp

# subcommand -> (module, one-line help)
SUBCOMMANDS = {
    "show": ("eomc.cli.show", "derive a model file's equations of motion and print them"),
    "build": ("eomc.cli.build", "compile a model file to C, a shared library and a Python module"),
    "inspect": ("eomc.cli.inspect", "print operation counts, mass-matrix sparsity and sizes"),
    "simulate": ("eomc.cli.simulate", "integrate a model and write its trajectory"),
    "report": ("eomc.cli.report", "compare integration methods and tolerances (error against cost) and "
                                  "recommend one"),
    "check": ("eomc.cli.check", "check a model before trusting its runs: stiffness, accuracy, drift, "
                                "conditioning"),
    "linearize": ("eomc.cli.linearize", "A, B and eigenvalues at a state"),
    "cache": ("eomc.cli.cache", "show, prune or clear the build cache"),
    "sweep": ("eomc.cli.sweep", "simulate every case of a CSV on local processes or a Dask cluster"),
    "animate": ("eomc.cli.animate", "a self-contained HTML page (3-D) or GIF/MP4 (2-D) of the motion"),
}


def _parser():
    parser = argparse.ArgumentParser(prog="eomc", description=DESCRIPTION, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"eomc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        sub.add_parser(name, help=help_text, add_help=False)
    return parser


def command_parser(name):
    """(module, argparse parser) of subcommand ``name``, configured as ``eomc NAME`` parses."""
    module_name, help_text = SUBCOMMANDS[name]
    module = import_module(module_name)
    sub = argparse.ArgumentParser(prog=f"eomc {name}", description=help_text)
    module.configure(sub)
    sub.formatter_class = OptionHelp
    return module, sub


# optional packages -> (what needs them, the extra that installs them): pyproject.toml's extras
_EXTRAS = {"mujoco": ("reading a MuJoCo model", "mujoco"), "matplotlib": ("drawing a plot", "plot"),
           "trimesh": ("drawing a robot's meshes", "mesh"), "collada": ("drawing a robot's meshes", "mesh"),
           "imageio_ffmpeg": ("writing an MP4", "video"), "dask": ("a Dask sweep", "dask"),
           "distributed": ("a Dask sweep", "dask"), "pyarrow": ("a .parquet table", "dask")}


def main(argv=None):
    program = argv is None          # `eomc ...` itself (the console script), not main([...]) from Python
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = _parser()
    if not argv or argv[0] not in SUBCOMMANDS:
        parser.parse_args(argv)  # prints --version / help / usage errors
        parser.print_help()
        return 2
    name, rest = argv[0], argv[1:]
    module_name = SUBCOMMANDS[name][0]
    try:
        module, sub = command_parser(name)
    except ModuleNotFoundError as exc:
        if exc.name == module_name:
            print(f"eomc {name}: not available in this version", file=sys.stderr)
            return 2
        raise
    args = sub.parse_args(rest)
    previous_format = _plain_warnings(name)
    previous = _terminate_as_interrupt()
    try:
        return int(module.run(args) or 0)
    except EomcError as exc:
        print(f"eomc {name}: error: {exc}", file=sys.stderr)
        return 1
    except ValueError as exc:  # bad arguments caught by the runtime's checks
        print(f"eomc {name}: error: {exc}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as exc:    # an optional package the run needs (README's extras table)
        extra = _EXTRAS.get((exc.name or "").partition(".")[0])
        if extra is None:
            raise
        what, key = extra
        model = getattr(args, "model", None)
        print(f"eomc {name}: error: {what}{f' ({model})' if model else ''} needs the {exc.name.partition('.')[0]} "
              f"package, which is not installed: pip install \"eomc[{key}]\" (from a clone of eomc: "
              f"pip install \".[{key}]\")", file=sys.stderr)
        return 1
    except BrokenPipeError:  # `eomc ... | head` closed the pipe: not an error worth a traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except (OSError, MemoryError) as exc:  # a full disk, a vanished file: one line, not a traceback
        detail = f"{exc.strerror}: {exc.filename}" if getattr(exc, "strerror", None) and \
            getattr(exc, "filename", None) else (str(exc) or type(exc).__name__)
        print(f"eomc {name}: error: {detail}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"eomc {name}: interrupted", file=sys.stderr)
        return _stopped(name, 130, program)
    except _Terminated:
        print(f"eomc {name}: terminated", file=sys.stderr)
        return _stopped(name, 143, program)
    finally:
        warnings.formatwarning = previous_format
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _stopped(name, code, program):
    """A stopped command's exit status; the program itself (not a caller of main([...])) ends at once.

    Why: the stop has unwound by now (the C compiler's group killed, temporary directories
    removed, a run's rows written and marked); what was left was the interpreter's teardown,
    freeing the model's SymPy graphs, while the process lived on after saying it stopped:
    9 s on G1 stopped while generating (load 13), ~20 s on dm_control's quadruped (first hour
    s33).  Not for `eomc sweep`, whose workers and clusters are shut down by the interpreter's
    exit as well."""
    if not program or name == "sweep":
        return code
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):   # a closed pipe: nothing more to say
            pass
    os._exit(code)


class _Terminated(BaseException):
    """SIGTERM, raised like KeyboardInterrupt so cleanups run (the C compiler's process group
    is killed, temporary directories are removed) instead of the process just vanishing."""


def _terminate_as_interrupt():
    """Make SIGTERM unwind like Ctrl-C; returns the previous handler (None off the main thread)."""
    def handler(signum, frame):
        raise _Terminated()
    try:
        return signal.signal(signal.SIGTERM, handler)
    except (ValueError, OSError):   # not the main thread (main() called from a thread)
        return None


def _plain_warnings(name):
    """eomc's own warnings as one line, like its errors: `eomc build: warning: ...`.

    Only the formatter changes, so whoever records warnings (``catch_warnings``,
    ``pytest.warns``) still sees them; returns the formatter it replaced, which main()
    puts back so callers of main() in the same process see their own warnings unchanged."""
    default = warnings.formatwarning

    def formatwarning(message, category, filename, lineno, line=None):
        if issubclass(category, EomcNote):      # nothing to act on: a note, as the command's own
            return f"eomc: note: {message}\n"
        if issubclass(category, EomcWarning):
            # stripped: SymPy's deprecation texts (a model file on sympy.physics.mechanics.Body,
            # given again by the build cache's reuse) begin with two blank lines
            return f"eomc {name}: warning: {str(message).strip()}\n"
        return default(message, category, filename, lineno, line)
    warnings.formatwarning = formatwarning
    return default
