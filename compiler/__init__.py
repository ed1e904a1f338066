"""eomc.compiler: the symbolic half -- model in, built library out (uses SymPy).

Stages, as ``driver.generate`` runs them (docs/architecture.md draws them):

    read      model/ (model files, system objects), urdf/, mjcf/ (robot files)  -> multibody.Model
    derive    formulations/: recursive (tree/: a System's or a Model's joint tree, the recursions)
              or Kane's (mechanics/: Kane's, Lagrange's methods -> FormedSystem); model/ checks
              the variables
    lower     emit/ (C-slot layout, function bodies, solvers) onto ir/ programs
    optimize  passes/ (cse, differentiation, sin/cos sharing, folding, dce, powers)
    emit      emit/ + templates: C99 source, header, cdef, metadata
    build     build/ (C compiler, content-addressed caches, export) -> eomc.runtime loads it

The subpackages:

- ``formulations/`` the formulations as peers (Kane's is emit's base Formulation, the recursive one
                  here) and ``auto``'s choice between them on one reading
- ``multibody/``  the format-neutral multibody Model every reader produces (tree, frames, collision
                  geometry, poses), and the Model of a joint tree (formed.py); joint formulas
- ``model/``      read a model file or a system object once; check it (errors as file:line)
- ``urdf/``       URDF robots: read (lxml), merge fixed links, -> Model (or a SymPy System for Kane)
- ``mjcf/``       MJCF models through MuJoCo's compiler -> Model; couplings; a MuJoCo oracle
- ``contact/``    Hunt-Crossley ground contact: the law, SymPy loads, loads on the tree, shapes
- ``tree/``       the joint-tree IR, ABA/RNEA/CRBA and derivatives, loops, body placement
                  (frame outputs, contacts, a robot's poses), the SymPy System reader
- ``mechanics/``  Kane's and Lagrange's methods, System, linearizer -> ``FormedSystem``
- ``emit/``       FormedSystem or tree -> IR programs -> C99 source, header, cdef, metadata
- ``ir/``         the single-assignment program the optimizer works on
- ``passes/``     optimizer: cse, folding, sin/cos sharing, powers, dce, differentiation
- ``build/``      C compiler, content-addressed caches, export into a user's folder
- ``driver.py``   the whole pipeline in one function

Layers point one way: eomc (facade, cli) -> eomc.compiler -> eomc.runtime.
Nothing here imports the top package ``eomc``; errors come from ``eomc.runtime.errors``.
"""
import os as _os
import sys as _sys

# SymPy's expression cache (sympy.core.cache, read once when SymPy is imported): 10,000 entries
# instead of its 1,000 where the user has not chosen.  Why: a build rebuilds the same products
# and powers many times over (renames, xreplace, diff) and each rebuild a cache miss makes asks
# SymPy's assumptions again (Add._eval_power's is_infinite walks its whole base); gymnasium's
# humanoid generated in 6.5 s instead of 7.1 s CPU (benchmarks/results/mjcf_build.md), for ~15 MB.
# Nothing else changes: the C is the same (benchmarks/c_identity.py).  Only when SymPy is not
# imported yet, and the environment is left as it was.
#
# Set when SymPy is first imported, not by importing this package: the command line's look-up of
# a model built before (build/reuse.py) and the build cache's modules import eomc.compiler without
# needing SymPy, and importing it there cost every command ~0.7 s before it could start (s27).
SYMPY_CACHE_SIZE = 10000


class _SizedSympyCache:
    """A finder on sys.meta_path that finds nothing itself: for ``sympy``, unless the user set
    SYMPY_CACHE_SIZE, it hands out the other finders' spec with a loader that runs sympy with
    SYMPY_CACHE_SIZE set (removed again once the package has run) and takes this finder off the
    path (a find_spec without an import, importlib.util.find_spec("sympy"), leaves it on)."""

    def find_spec(self, name, path=None, target=None):
        if name != "sympy" or "SYMPY_CACHE_SIZE" in _os.environ:
            return None
        for finder in _sys.meta_path:
            if isinstance(finder, _SizedSympyCache):
                continue
            find = getattr(finder, "find_spec", None)
            spec = find(name, path, target) if find is not None else None
            if spec is not None:
                break
        else:
            return None
        if spec.loader is not None and hasattr(spec.loader, "exec_module"):
            spec.loader = _SizedLoader(spec.loader)
        return spec


class _SizedLoader:
    """sympy's own loader, run with SYMPY_CACHE_SIZE in the environment; the module keeps the
    original loader (``__loader__``, ``__spec__.loader``)."""

    def __init__(self, loader):
        self.loader = loader

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        module.__spec__.loader = module.__loader__ = self.loader
        _sys.meta_path[:] = [f for f in _sys.meta_path if not isinstance(f, _SizedSympyCache)]
        _os.environ["SYMPY_CACHE_SIZE"] = str(SYMPY_CACHE_SIZE)
        try:
            self.loader.exec_module(module)
        finally:
            _os.environ.pop("SYMPY_CACHE_SIZE", None)


if "sympy" not in _sys.modules and not any(isinstance(f, _SizedSympyCache) for f in _sys.meta_path):
    _sys.meta_path.insert(0, _SizedSympyCache())
