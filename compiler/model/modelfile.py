"""Run a model file and report its mistakes as the user's file:line.

The file is compiled with its own path as the code's filename, so a failure
inside it can be traced to the user's line by walking the traceback; a
wrong value for a model variable is traced to its assignment with ``ast``.
The file's directory is on ``sys.path`` while it runs, so it may import
helper modules kept beside it.
"""
import ast
import io
import sys
import tokenize
import traceback
from pathlib import Path

from eomc.runtime.errors import EomcError, ModelFileError

__all__ = ["run_model_file", "assignment_lines"]


def assignment_lines(source):
    """Module-level name -> line of its last assignment (plain, annotated, augmented or tuple)."""
    lines = {}
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return lines
    for node in tree.body:
        targets = []
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)):
            targets = [node.target]
        for target in targets:
            for sub in ast.walk(target):
                if isinstance(sub, ast.Name):
                    lines[sub.id] = node.lineno
    return lines


def _user_line(exc, filename):
    """The line of the innermost traceback frame that runs the user's file."""
    line = None
    for frame, lineno in traceback.walk_tb(exc.__traceback__):
        if frame.f_code.co_filename == filename:
            line = lineno
    return line


def _plain(exc):
    return str(exc) if isinstance(exc, EomcError) and str(exc) else f"{type(exc).__name__}: {exc}"


def _decode(data, filename):
    """The file's text: UTF-8 unless a PEP 263 coding line says otherwise (as Python reads it)."""
    try:
        try:
            encoding, _ = tokenize.detect_encoding(io.BytesIO(data).readline)
        except SyntaxError as exc:
            if b"coding" in b"\n".join(data.split(b"\n", 2)[:2]):
                raise ModelFileError(f"cannot read the model file: {exc}", filename) from None
            encoding = "utf-8"  # no declaration: the bytes of the first lines are not UTF-8
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ModelFileError(f"not a model file: it is not {exc.encoding.upper()} text (byte "
                             f"0x{data[exc.start]:02x} at position {exc.start}, line {line}); a model "
                             f"file is Python source", filename) from None


def run_model_file(path):
    """Execute the model file; returns (namespace, source, filename) or raises ModelFileError."""
    path = Path(path)
    filename = str(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelFileError(f"cannot read model file ({exc.strerror or exc})", filename) from None
    source = _decode(data, filename)
    try:
        code = compile(source, filename, "exec")
    except SyntaxError as exc:
        raise ModelFileError(f"SyntaxError: {exc.msg}", filename, exc.lineno) from None
    namespace = {"__name__": "__eomc_model__", "__file__": filename, "__builtins__": __builtins__}
    directory = str(path.resolve().parent)
    sys.path.insert(0, directory)
    try:
        exec(code, namespace)
    except SystemExit as exc:
        raise ModelFileError(f"the model file called exit({exc.code})", filename) from None
    except Exception as exc:  # the user's code: report it at the user's line
        raise ModelFileError(_plain(exc), filename, _user_line(exc, filename)) from exc
    finally:
        try:
            sys.path.remove(directory)
        except ValueError:
            pass
    return namespace, source, filename
