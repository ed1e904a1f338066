"""eomc's version, in a leaf module: the compiler stamps it into cache keys and
generated modules, the runtime checks it at load, and neither needs the top
package for it.  pyproject.toml's version must match (tests/test_packaging.py)."""
__version__ = "0.1.0"
