"""A model file built before, found again without deriving it: the command line's second run.

Why: `eomc simulate robot.urdf ...` run twice used to derive the model again (~1 s, more on a
large robot, plus the ~1 s SymPy import) only to find, at the build cache's lookup, the library
it already had -- the build cache's key needs the generated C, and the C needs the derivation.
This cache maps what the command was given -- the model file's bytes, the build options and
eomc's compiler sources -- to the build cache entry the first run loaded, so the second run
goes straight to the library.

What else the first run read is recorded too: a model file may import a module beside it,
load a data file, a URDF may name collision meshes, an MJCF file includes other files and
meshes.  Every file opened for reading while the model was built (Python's ``open`` audit
event, which covers imports) and, for MJCF, every file its XML names (MuJoCo reads those in
C, out of Python's sight) is kept with its sha256; a hit needs each to be unchanged, else the
model is derived as before.  The warnings the build gave are kept and given again on a hit
(a fixed mistake in the file must still be pointed at), but for its BuildNotes: nothing to
act on, said once when the model was built.

This module does not import SymPy: a hit costs reading the file and loading the library.
"""
import contextlib
import contextvars
import hashlib
import importlib
import json
import os
import sys
import warnings
from pathlib import Path

from eomc.runtime.version import __version__

from .cache import entry_path, get_or_build, hash_key, lookup, sha256_file

__all__ = ["source_key", "recording", "find", "remember", "warn_again", "compiler_digest", "generator_switches",
           "KIND"]

KIND = "sources"
_READS = contextvars.ContextVar("eomc_reads", default=None)
_HOOKED = []
_DIGEST = []


def compiler_digest():
    """sha256 over eomc.compiler's .py files, the templates and the shipped C: a changed
    generator is a new key (the generation cache's key holds it too)."""
    if not _DIGEST:
        import eomc.compiler
        import eomc.templates
        from eomc.runtime.header_cdef import C_DIR
        digest = hashlib.sha256()
        for root in (Path(eomc.compiler.__file__).resolve().parent,
                     Path(eomc.templates.__file__).resolve().parent, C_DIR):
            for path in sorted(root.rglob("*")):
                if path.suffix in (".py", ".j2", ".c", ".h") and "__pycache__" not in path.parts:
                    digest.update(str(path.relative_to(root)).encode())
                    digest.update(path.read_bytes())
        _DIGEST.append(digest.hexdigest())
    return _DIGEST[0]


def generator_switches():
    """The generator's module-level switches: the same sources give other C when one is flipped, so
    every key that holds :func:`compiler_digest` holds these too (a flipped switch found the C of
    the other setting in the cache before).  ``INLINE_NARROW``: the body-body pairs' narrow phase
    inlined as SymPy or called (compiler/contact/pairs.py); ``LAW_ROUTINES``: each pair one call of its
    kinds' law routine; ``PAIR_TABLE``: every pair in one table-driven loop (each held only when
    set; ``TABLE_FROM``, the fewest pairs that take it, only when not its default).  ``TANGENT``: hess_id left along the k-speed joints' tangent for the comparison with
    Pinocchio (compiler/tree/second_order.py); held only when set, so the keys of ordinary builds
    stay what they were; ``HALF_FROM``: the output size from which hess_id is written by halves
    (same module), held only when not its default; ``ZERO`` on: hess_id zeroes its whole output
    every call instead of leaving the entries off the support paths to the caller (same module,
    off by default since session 13), held only when on; ``ROOT_DOTS`` off: no root frame and root
    dots in hess_id (same module, on by default since session 18), held only when off.  ``CHAIN_LOOP_MIN_LINKS``: the repeated
    chain's length from which the rhs is looped (compiler/tree/chain_loop.py), held only when not
    its default.  ``SEED_PAIRS`` off: Kane's jvp tangent as differentiated (compiler/emit/
    seed_pairs.py), held only when off; ``SEED_MONOMIALS`` off: its one-seed monomials as
    differentiated (same module), held only when off.  ``LIMB_MIN_BODIES``: the twin limbs' bodies from which the
    rhs calls limb routines (compiler/tree/limbs.py), held only when not its default.  ``BODY_LOOPS`` off:
    NAME_energy and NAME_poses straight-line (compiler/tree/body_loops.py), held only when off.
    ``GROUND_TABLE`` / ``SLOPES_TABLE`` off and ``TABLE_FROM`` (compiler/contact/ground_table.py: the
    ground points as one C loop, its slopes variant, the fewest points that take it), each held only
    when not its default (before session 29 none was: a build with the loop's threshold lowered found
    the straight-line C of the default in the cache).

    A module not imported yet holds its defaults (nothing in this process can have flipped them),
    so it is not imported here: these modules import SymPy, and the command line's look-up of a
    model built before (common.load_model) paid ~0.7 s for it on every command (s27).  The
    defaults so assumed are checked against the modules' own by tests/compiler/build/test_reuse.py."""
    loaded = sys.modules.get
    switches = {"inline_narrow": True}      # pairs.INLINE_NARROW's default, the one always held
    pairs = loaded("eomc.compiler.contact.pairs")
    if pairs is not None:
        switches["inline_narrow"] = bool(pairs.INLINE_NARROW)
        if pairs.LAW_ROUTINES:
            switches["law_routines"] = True
        if pairs.INLINE_SLOPES:
            switches["inline_slopes"] = True
        if pairs.PAIR_TABLE:
            switches["pair_table"] = True
            if pairs.TABLE_FROM != pairs.TABLE_FROM_DEFAULT:
                switches["pair_table_from"] = pairs.TABLE_FROM
    else:
        switches["pair_table"] = True       # pairs.PAIR_TABLE's default
    second_order = loaded("eomc.compiler.tree.second_order")
    if second_order is not None:
        if second_order.TANGENT:
            switches["hess_tangent"] = True
        if second_order.HALF_FROM != second_order.HALF_FROM_DEFAULT:
            switches["hess_half_from"] = second_order.HALF_FROM
        if second_order.ZERO:
            switches["hess_zero"] = True
        if not second_order.ROOT_DOTS:
            switches["hess_no_root_dots"] = True
    chain_loop = loaded("eomc.compiler.tree.chain_loop")
    if chain_loop is not None and chain_loop.CHAIN_LOOP_MIN_LINKS != chain_loop.CHAIN_LOOP_MIN_LINKS_DEFAULT:
        switches["chain_loop_min_links"] = chain_loop.CHAIN_LOOP_MIN_LINKS
    seed_pairs = loaded("eomc.compiler.emit.seed_pairs")
    if seed_pairs is not None:
        if not seed_pairs.SEED_PAIRS:
            switches["no_seed_pairs"] = True
        if not seed_pairs.SEED_MONOMIALS:
            switches["no_seed_monomials"] = True
    limbs = loaded("eomc.compiler.tree.limbs")
    if limbs is not None and limbs.LIMB_MIN_BODIES != limbs.LIMB_MIN_BODIES_DEFAULT:
        switches["limb_min_bodies"] = limbs.LIMB_MIN_BODIES
    body_loops = loaded("eomc.compiler.tree.body_loops")
    if body_loops is not None and not body_loops.BODY_LOOPS:
        switches["no_body_loops"] = True
    ground_table = loaded("eomc.compiler.contact.ground_table")
    if ground_table is not None:
        if not ground_table.GROUND_TABLE:
            switches["no_ground_table"] = True
        if not ground_table.SLOPES_TABLE:
            switches["no_ground_slopes_table"] = True
        if ground_table.TABLE_FROM != ground_table.TABLE_FROM_DEFAULT:
            switches["ground_table_from"] = ground_table.TABLE_FROM
    return switches


def source_key(path, options):
    """Key of a build of the model file ``path`` with ``options`` (JSON-able: the command
    line's model options, functions, formulation, ...)."""
    return hash_key({"file": sha256_file(path), "suffix": Path(path).suffix.lower(),
                     "name": Path(path).stem, "options": options, "eomc": __version__,
                     "python": list(sys.version_info[:2]), "compiler": compiler_digest(),
                     "switches": generator_switches(),
                     "cc": os.environ.get("CC"), "cflags": os.environ.get("CFLAGS")})


def _outside_python(root):
    """Folders whose files are Python's, the libraries', eomc's own (keyed by
    :func:`compiler_digest`) or the cache's (``root``)."""
    import sysconfig
    import eomc.compiler
    import eomc.runtime
    import eomc.templates
    places = {sys.prefix, sys.base_prefix, sys.exec_prefix, str(root), "/proc", "/dev", "/sys"}
    # the top package (the facade) is loaded whenever a subpackage is: found, not imported
    packages = (sys.modules.get("eomc"), eomc.compiler, eomc.runtime, eomc.templates)
    places |= {str(Path(m.__file__).resolve().parent) for m in packages if getattr(m, "__file__", None)}
    for key in ("stdlib", "platstdlib", "purelib", "platlib"):
        with contextlib.suppress(KeyError):
            places.add(sysconfig.get_paths()[key])
    return tuple(os.path.join(os.path.realpath(p), "") for p in places if p)


def _hook(event, args):
    reads = _READS.get()
    if reads is None or event != "open" or not args:
        return
    path, mode = args[0], args[1] if len(args) > 1 else None
    if isinstance(path, int):
        return
    flags = args[2] if len(args) > 2 and isinstance(args[2], int) else 0
    if (isinstance(mode, str) and any(c in mode for c in "wax+")) or flags & (os.O_WRONLY | os.O_RDWR):
        return
    try:
        reads.add(os.path.realpath(os.fsdecode(path)))
    except (TypeError, ValueError):
        pass


@contextlib.contextmanager
def recording():
    """Collect the files opened for reading in this context (and in the threads it starts
    with its context); yields the set."""
    if not _HOOKED:
        sys.addaudithook(_hook)      # process-wide and permanent: idle unless a recording is on
        _HOOKED.append(True)
    reads = set()
    token = _READS.set(reads)
    try:
        yield reads
    finally:
        _READS.reset(token)


def _dependencies(root, path, reads):
    """{file: sha256} of what the build read besides ``path`` (see the module docstring), or
    None when it cannot be told."""
    outside = _outside_python(root)
    files = {Path(p) for p in reads}
    from ..model.spec import named_files
    named = named_files(path)
    if named is None:
        return None
    files |= set(named)
    main = Path(path).resolve()
    deps = {}
    for f in sorted(files):
        text = os.path.join(str(f), "")
        if f == main or text.startswith(outside) or not f.is_file() or "__pycache__" in f.parts:
            continue
        deps[str(f)] = sha256_file(f)
    return deps


def remember(root, key, path, model, reads, recorded):
    """Record that ``key`` built ``model`` (loaded from a build cache entry), having read
    ``reads`` and given the warnings ``recorded``.  Best effort: a cache that cannot be
    written only costs the next run its derivation."""
    build = (getattr(model, "metadata", None) or {}).get("build") or {}
    if not build.get("key"):
        return
    try:
        deps = _dependencies(root, path, reads)
        if deps is None:
            return
        shown = [[w.category.__module__, w.category.__qualname__, str(w.message), str(w.filename), w.lineno]
                 for w in recorded]
        data = {"build": build["key"], "name": model.name, "dependencies": deps, "warnings": shown}

        def write(tmp):
            (tmp / "source.json").write_text(json.dumps(data, sort_keys=True))
        get_or_build(root, KIND, key, write, {"name": model.name}, force=entry_path(root, KIND, key).exists())
    except Exception:       # noqa: BLE001 -- a cache shortcut must never fail the build it follows
        return


def _category(module, qualname):
    from eomc.runtime.errors import EomcWarning
    try:
        found = importlib.import_module(module)
        for part in qualname.split("."):
            found = getattr(found, part)
        return found if isinstance(found, type) and issubclass(found, Warning) else EomcWarning
    except Exception:       # noqa: BLE001
        return EomcWarning


def find(root, key, held):
    """The build cache entry (a directory) ``key`` was built into, held in ``held`` (an
    ExitStack) while it is loaded, with the warnings of that build (not its BuildNotes) given again; None when
    there is none, a file it read changed, or the entry is gone."""
    entry = lookup(root, KIND, key)
    if entry is None:
        return None
    try:
        data = json.loads((entry / "source.json").read_text())
        for dep, digest in data["dependencies"].items():
            if not os.path.isfile(dep) or sha256_file(dep) != digest:
                return None
        built = lookup(root, "models", data["build"], hold_in=held)
        if built is None:
            return None
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    from eomc.runtime.errors import BuildNote
    for module, qualname, message, filename, lineno in data.get("warnings", ()):
        if issubclass(_category(module, qualname), BuildNote):
            continue        # said when it was built, not on every command that reuses it
        try:
            warning = _category(module, qualname)(message)
        except Exception:       # noqa: BLE001 -- a category that wants more than its text
            from eomc.runtime.errors import EomcWarning
            warning = EomcWarning(message)
        warn_again(warning, filename, lineno)
    return built, data["name"]


def warn_again(message, filename, lineno, source=None):
    """Give a warning again where it was first given (a recorded or remembered one), with
    its module when that is imported (warning filters match on it)."""
    module = next((n for n, m in list(sys.modules.items()) if getattr(m, "__file__", None) == filename), None)
    # module=None given explicitly would match no filter and show nothing: left out instead
    where = {} if module is None else {"module": module}
    warnings.warn_explicit(message, type(message), filename, lineno, registry={}, source=source, **where)
