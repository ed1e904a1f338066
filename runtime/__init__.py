"""eomc.runtime: load and run built models.  Never imports SymPy or eomc.compiler."""
