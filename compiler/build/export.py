"""Copy a built model out of the cache into a user's directory (what `eomc build -o DIR` writes).

DIR receives NAME.c, NAME.h, the shipped headers, libNAME.so, NAME.json and
NAME.py (``import NAME`` loads the library through eomc.runtime).  Everything
is first assembled in a temporary directory inside DIR and then moved into
place file by file with ``os.replace``, so a failure leaves no half-written
file behind.
"""
import os
import shutil
import tempfile
from pathlib import Path

import jinja2

from eomc.runtime.version import __version__
import eomc.templates

__all__ = ["export", "render_module"]

_METHODS = ("rhs", "rhs_many", "jacobian", "input_jacobian", "mass_matrix", "forcing", "outputs",
            "constraints", "constraints_jacobian", "inverse_dynamics", "linearize", "simulate")


def _environment():
    directory = Path(eomc.templates.__file__).resolve().parent
    return jinja2.Environment(loader=jinja2.FileSystemLoader(str(directory)),
                              undefined=jinja2.StrictUndefined, keep_trailing_newline=True)


def render_module(name):
    """The text of NAME.py."""
    return _environment().get_template("module.py.j2").render(
        name=name, version=__version__, methods=_METHODS, exported=["model", *_METHODS])


def export(built, output_dir):
    """Publish ``built`` (a BuildResult) into ``output_dir``; returns the directory as a Path."""
    output_dir = Path(output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".eomc-tmp-", dir=output_dir))
    try:
        names = [p.name for p in sorted(built.directory.iterdir())
                 if p.is_file() and p.name != "manifest.json"]
        for name in names:
            shutil.copy2(built.directory / name, tmp / name)
        (tmp / f"{built.name}.py").write_text(render_module(built.name))
        names.append(f"{built.name}.py")
        for name in names:
            os.replace(tmp / name, output_dir / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return output_dir.resolve()
