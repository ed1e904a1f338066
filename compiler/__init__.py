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
SYMPY_CACHE_SIZE = 10000
if "sympy" not in _sys.modules and "SYMPY_CACHE_SIZE" not in _os.environ:
    _os.environ["SYMPY_CACHE_SIZE"] = str(SYMPY_CACHE_SIZE)
    try:
        import sympy as _sympy  # noqa: F401
    finally:
        del _os.environ["SYMPY_CACHE_SIZE"]
