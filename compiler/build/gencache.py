"""Cache of generated C, keyed by the formed equations: a warm compile skips code generation.

Generating C (IR, passes, printing) costs far more than loading a cached
library, and the build cache's key needs the C text.  This cache maps a
digest of the *inputs* of generation -- the formed system, names, options,
and the source of eomc.compiler and its templates -- to the GeneratedModel,
so a second compile of the same model goes straight to the library.

The digest walks each SymPy expression as a DAG (memoized by object id):
far cheaper than printing it (srepr of a 20-link model takes seconds).
Equal digests need equal expression trees; different trees for the same
mathematics only cost a miss.
"""
import contextlib
import hashlib
import json
import sys

import sympy as sm

from eomc.runtime.version import __version__

from ..mechanics.formed import FormedSystem
from .cache import get_or_build, hash_key
from .reuse import compiler_digest, generator_switches

__all__ = ["generation_key", "cached_generate"]


class _Digester:
    """Structural digest of SymPy objects, memoized per object."""

    def __init__(self):
        self.memo = {}

    def __call__(self, expr):
        key = id(expr)
        found = self.memo.get(key)
        if found is not None:
            return found[0]
        if isinstance(expr, (list, tuple)):
            text = "[" + ",".join(self(e) for e in expr) + "]"
        elif isinstance(expr, sm.MatrixBase):
            text = f"M{expr.shape}" + self(list(expr))
        elif isinstance(expr, sm.Symbol):
            text = f"S:{expr.name}:{sorted(expr.assumptions0.items())}"
        elif isinstance(expr, sm.Basic) and expr.args:
            head = type(expr).__name__
            if isinstance(expr, sm.core.function.AppliedUndef):
                head = f"F:{expr.func.__name__}"
            text = head + "(" + ",".join(self(a) for a in expr.args) + ")"
        else:
            text = f"{type(expr).__name__}:{expr!r}"
        digest = hashlib.sha256(text.encode()).hexdigest()[:32]
        self.memo[key] = (digest, expr)  # keep expr alive so its id is not reused
        return digest


def generation_key(spec, functions, fold_parameters, extra=None):
    """Key of everything generate_c reads for this model (``extra``: more of it, e.g. the
    formulation and a formed-less System's tree)."""
    d = _Digester()
    f = spec.formed
    kind = f.method if isinstance(f, FormedSystem) else "multibody model"     # formed by, or as read
    formed = [kind, f.n_dependent_coordinates, f.n_dependent_speeds] + [
        d(getattr(f, k, ())) for k in ("coordinates", "speeds", "kinematics", "dynamics_matrix", "dynamics_rhs",
                                       "multipliers", "holonomic_constraints", "velocity_constraints",
                                       "inputs", "parameters")] + [
        d(tuple(getattr(f, k, ()))) for k in ("extra_states", "extra_rhs")]
    return hash_key({
        "formed": formed, "name": spec.name,
        "parameters": None if spec.parameters is None else [[d(k), v] for k, v in spec.parameters.items()],
        "inputs": None if spec.inputs is None else d(list(spec.inputs)),
        "outputs": None if spec.outputs is None else [[k, d(v)] for k, v in spec.outputs.items()],
        "functions": functions, "fold": bool(fold_parameters),
        **({} if getattr(spec, "events", None) is None else
           {"events": [[k, d(v)] for k, v in spec.events.items()], "event_options": spec.event_options}),
        **({} if extra is None else {"extra": d(list(extra))}),
        "eomc": __version__, "sympy": sm.__version__, "python": sys.version_info[:2],
        "source": compiler_digest(), "switches": generator_switches()})


def cached_generate(spec, functions, fold_parameters, generate, cache_root_dir, extra=None):
    """``generate()`` through the cache; returns (GeneratedModel, hit).

    The entry is held while it is read, so a concurrent prune cannot remove it midway;
    one that is unreadable anyway is generated again.
    """
    from eomc.compiler.emit import GeneratedModel
    key = generation_key(spec, functions, fold_parameters, extra)

    def read(entry):
        try:
            return GeneratedModel(**json.loads((entry / "generated.json").read_text()))
        except (OSError, ValueError, TypeError):
            return None

    produced = []

    def write(tmp):
        gm = generate()
        produced.append(gm)
        data = {"name": gm.name, "c_source": gm.c_source, "header": gm.header, "cdef": gm.cdef,
                "metadata": gm.metadata}
        (tmp / "generated.json").write_text(json.dumps(data, sort_keys=True))
    for force in (False, True):     # an entry that is whole but unreadable is generated again
        with contextlib.ExitStack() as held:
            entry, _ = get_or_build(cache_root_dir, "generated", key, write, {"name": spec.name},
                                    force=force, hold_in=held)
            if produced:
                return produced[0], False
            found = read(entry)
        if found is not None:
            return found, True
    return generate(), False  # pragma: no cover (only if the rebuilt entry is unreadable)
