"""eomc.runtime: load and run built models.  Never imports SymPy or eomc.compiler.

The lowest layer: the compiler builds on it, nothing in it depends on the compiler.

- leaves shared with the compiler: ``errors.py`` (every deliberate error), ``version.py``,
  ``c/`` (the plain C shipped with eomc: the model ABI ``eomc_model.h``, the integrators
  compiled once at install, the batch helper compiled into each model)
- loading: ``loader.py`` (a built directory -> ``Model``), ``metadata.py`` (what NAME.json may say,
  checked against the library), ``header_cdef.py/``cdef.py``/
  ``integrators_api.py`` (cffi declarations read from ``c/``), ``native.py`` (the integrator library),
  ``names.py`` (how a key names a state, parameter, input or output)
- running: ``model.py`` (checked numpy calls), ``simulate.py`` + ``result.py`` (one trajectory,
  loop in C), ``batch.py`` (many, on threads), ``_fastcall.pyx`` (the compiled call path)
- travelling: ``travel.py`` (a Model pickles by content and loads on any worker), ``store.py`` (the
  build cache's entries and locks, usable without the compiler), ``sweep.py`` (``eomc.sweep``: chunks
  of ``simulate_many`` on any map-like executor, Dask included)
- judging: ``reference.py``, ``report.py`` (measure) -> ``report_output.py`` (present),
  ``stability.py`` (``eomc check``; its two references run at once: ``check_references.py``)
"""
