"""eomc.compiler: the symbolic half -- model in, built library out (uses SymPy).

The pipeline, in order (``driver.compile`` runs it top to bottom):

- ``model/``      read a model file or a system object; check it (errors as file:line)
- ``urdf/``       a URDF robot as a SymPy mechanics System (read, merge fixed links, build)
- ``mechanics/``  front end: Kane's and Lagrange's methods -> ``FormedSystem``
- ``emit/``       FormedSystem -> IR programs -> C99 source, header, cdef, metadata
- ``ir/``         the single-assignment program the optimizer works on
- ``passes/``     optimizer: cse, folding, sin/cos sharing, powers, dce, differentiation
- ``build/``      C compiler, content-addressed caches, export into a user's folder
- ``driver.py``   the whole pipeline in one function

Layers point one way: eomc (facade, cli) -> eomc.compiler -> eomc.runtime.
Nothing here imports the top package ``eomc``; errors come from ``eomc.runtime.errors``.
"""
