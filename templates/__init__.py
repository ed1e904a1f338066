"""Jinja2 templates of the generated files (package data, no code).

``model.c.j2``/``model.h.j2`` (the model's C and header, rendered by eomc.compiler.emit),
``module.py.j2`` (NAME.py, written by ``eomc build``), ``model.pyx.j2`` (the Cython backend).
The plain C shipped with eomc lives in ``runtime/c/``.
"""
