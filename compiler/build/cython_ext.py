"""The Cython backend: an extension module NAME_cy that calls the model's C functions.

It is built inside the model's cache entry, after libNAME.so, and links to it
(rpath $ORIGIN), so both backends run the very same machine code.  Its key
inputs add what makes an extension binary-specific: the interpreter's SOABI,
the Cython version and the Python headers.
"""
import sys
import sysconfig
from pathlib import Path

import jinja2

import eomc.templates
from eomc.runtime.errors import MissingExtraError

from .cache import sha256_file
from .toolchain import run_compiler

__all__ = ["extension_key_inputs", "build_extension"]

_TEMPLATE = "model.pyx.j2"
_VECTOR_FUNCTIONS = ("rhs", "jac_x", "jac_r", "jac_p", "mass_matrix", "forcing", "outputs",
                     "constraints", "constraints_jac")


def _template_dir():
    return Path(eomc.templates.__file__).resolve().parent


def extension_key_inputs():
    try:
        import Cython
    except ImportError:
        raise MissingExtraError("the Cython backend (backend='cython', --backend cython)", "cython",
                                ["Cython"]) from None
    import numpy
    return {"cython": Cython.__version__, "numpy": numpy.__version__, "numpy_include": numpy.get_include(), "soabi": sysconfig.get_config_var("SOABI"),
            "ext_suffix": sysconfig.get_config_var("EXT_SUFFIX"),
            "python_include": sysconfig.get_paths()["include"],
            "template": sha256_file(_template_dir() / _TEMPLATE)}


def _render(generated):
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(_template_dir())),
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    functions = list(generated.metadata.get("functions", ()))
    return env.get_template(_TEMPLATE).render(
        name=generated.name, functions=functions,
        vector_functions=[f for f in _VECTOR_FUNCTIONS if f in functions])


def build_extension(tmp, generated, tc, flags, key, root):
    """Write NAME_cy.pyx, cythonize and compile it in ``tmp``; returns the extension's file name."""
    name = generated.name
    module = f"{name}_cy"
    (tmp / f"{module}.pyx").write_text(_render(generated))
    run_compiler([sys.executable, "-m", "cython", "-3", "-o", f"{module}.c", f"{module}.pyx"],
                 tmp, name, key, root)
    filename = module + sysconfig.get_config_var("EXT_SUFFIX")
    if sys.platform == "darwin":
        link = ["-undefined", "dynamic_lookup", "-Wl,-rpath,@loader_path"]
    else:
        link = ["-Wl,-rpath,$ORIGIN"]
    # The glue is Cython's boilerplate (argument passing): -O1 halves its compile
    # time, and warnings about Cython's own C (-Werror, -pedantic) are not the user's.
    glue_flags = [f for f in flags if not f.startswith(("-O", "-Werror", "-pedantic", "-W"))] + ["-O1", "-w"]
    import numpy
    argv = [*tc.argv, *glue_flags, "-shared", "-I", sysconfig.get_paths()["include"], "-I", numpy.get_include(),
            "-DNPY_NO_DEPRECATED_API=NPY_1_7_API_VERSION", "-o", filename,
            f"{module}.c", "-L.", f"-l{name}", *link]
    run_compiler(argv, tmp, name, key, root)
    (tmp / f"{module}.c").unlink()
    return filename
