"""``eomc build MODEL.py [-o DIR]``: write NAME.c, NAME.h, libNAME.so, NAME.json and NAME.py into DIR.

Everything is built in the cache first and then copied into DIR through a
temporary directory, so a failed build leaves DIR as it was.  A file in DIR
that eomc did not write (the model file itself, your own eomc_model.h) is never
replaced: the build stops with an error naming it (eomc.compiler.build.export).
"""

__all__ = ["configure", "run", "add_generate_options"]


def add_generate_options(parser):
    """Options shared by the commands that generate code (build, inspect)."""
    parser.add_argument("model", help="model file (Python) defining `system`, a robot's URDF file or a "
                                      "MuJoCo model (.xml)")
    parser.add_argument("--name", help="model name (default: the file's `name` or its stem)")
    parser.add_argument("--outputs", metavar="LIST",
                        help="comma-separated functions to generate, e.g. rhs,jacobian,mass_matrix "
                             "(default: all the model supports but jac_p, jvp, vjp, hvp, regressor, jac_id, hess_id and rhs_batch, which are "
                             "generated only when named)")
    parser.add_argument("--fold-parameters", action="store_true",
                        help="fold parameter defaults into literals instead of runtime arguments")
    from .common import add_formulation_argument, add_robot_arguments
    add_robot_arguments(parser)
    add_formulation_argument(parser)


def configure(parser):
    add_generate_options(parser)
    parser.add_argument("-o", "--output", metavar="DIR", help="directory to write into (default: ./NAME, the "
                                                               "model's --name or its file's stem)")
    parser.add_argument("--target", choices=("c99-f64", "c99-f32"), default="c99-f64",
                        help="generated C: c99-f64 (default; double, loads into Python) or c99-f32 "
                             "(float for microcontrollers: sinf/sqrtf only, no heap, a stack bound per "
                             "function in NAME.h, a fixed-step NAME_step_rk4)")
    parser.add_argument("--backend", choices=("cffi", "cython"), default="cffi",
                        help="Python binding: cffi (ABI mode, no extension to compile; default) or cython")
    parser.add_argument("--cflags", help="C compiler flags replacing the default '-O2 -fPIC -std=c99' "
                                         "(plus '-mavx2 -ffp-contract=off', and '-fno-ipa-ra -fno-math-errno -mmemset-strategy=...' with gcc, "
                                         "on an x86-64 CPU with AVX2; "
                                         "write --cflags='-O3 -march=native'); after -ffast-math, -Ofast "
                                         "or -ffinite-math-only eomc adds -fno-finite-math-only, so NaN "
                                         "and inf are still reported as errors")
    parser.add_argument("--portable", action="store_true",
                        help="build the library for any CPU of this platform, not for this machine's "
                             "(no -mavx2: for a directory copied to other machines; results are the "
                             "same bits, the machine's build is faster)")
    parser.add_argument("--cache-dir", help="build cache root (default $EOMC_CACHE_DIR or ~/.cache/eomc)")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="print no progress and no summary; warnings (and the note of a start moved "
                             "into its joints' ranges) and errors still go to stderr")
    from .common import add_frame_argument
    add_frame_argument(parser)


def run(args):
    from .common import fixed_base_note, floating_base_of, with_options
    if not args.quiet:
        fixed_base_note(args.model, args.floating_base)
    if args.output is None:
        from pathlib import Path
        args.output = Path(args.name or Path(args.model).stem)
    import contextlib
    import warnings
    from eomc.compiler.build import reuse
    from eomc.runtime.errors import DefaultStartWarning
    key = _reuse_key(args)
    model = None
    if key is not None:
        with warnings.catch_warnings():     # a reused build's warnings, said again as a build's are
            warnings.filterwarnings("ignore", category=DefaultStartWarning)
            model = _reused(args, key)
    if model is not None:
        key = None       # recorded already: nothing new to remember
    recorded = []
    try:
        with contextlib.ExitStack() as stack:
            reads = stack.enter_context(reuse.recording()) if key is not None else None
            if key is not None:       # the warnings kept for the reuse shortcut's replay
                recorded = stack.enter_context(warnings.catch_warnings(record=True))
            else:
                stack.enter_context(warnings.catch_warnings())
            # the default start's warning speaks to Python (x0=, model.metadata): the note below says
            # it as the other commands do (first hour s22: `eomc build hyq.urdf` gave the API's text)
            warnings.filterwarnings("ignore", category=DefaultStartWarning)
            if model is None:      # here: a build served by the reuse key imports no SymPy
                from eomc.compiler.driver import compile
                source, name = with_options(args.model, args.name, floating_base=floating_base_of(args),
                                            allow_nonphysical_inertia=args.allow_nonphysical_inertia,
                                            limits=args.limits != "off", ignore=args.ignore,
                                            orientation=getattr(args, "orientation", None),
                                            pairs=getattr(args, "pairs", None))
                model = compile(source, name, functions=args.outputs, fold_parameters=args.fold_parameters,
                                backend=args.backend, cflags=args.cflags, cache_dir=args.cache_dir,
                                portable=args.portable, output_dir=args.output,
                                progress="quiet" if args.quiet else True, formulation=args.formulation,
                                contacts=args.contact, frames=args.frame, target=args.target)
    finally:    # the build's warnings (recorded for the reuse shortcut), as if nothing had listened
        for w in recorded:
            reuse.warn_again(w.message, w.filename, w.lineno, w.source)
    if key is not None:
        from eomc.compiler.build.cache import cache_root
        reuse.remember(cache_root(None), key, args.model, model, reads, recorded)
    from .common import _start_note
    # said under -q too: the note is the CLI's form of the default start's warning (first hour s22)
    _start_note(model, {}, f"{model.name}.json's initial_state; simulate --x0 chooses another")
    if args.quiet:     # quiet means quiet (session 31): a script's `eomc build -q` wants the files, not the summary
        return 0
    files = sorted(p.name for p in model.directory.iterdir() if p.is_file() and not p.name.startswith("."))
    print(f"built model {model.name!r} (nq={model.nq}, nu={model.nu}, nparam={model.nparam}, "
          f"ninput={model.ninput}) in {model.directory}:")
    for name in files:
        print(f"  {name}")
    stack = model.metadata.get("stack")
    if stack:                # the worst-case stack measured at build time (gcc 10+)
        print(f"stack (bytes, worst case over the calls inside {model.name}.c): "
              + ", ".join(f"{fn} {s['bytes']}" for fn, s in stack.items()))
    print(formulation_line(model.metadata, args.formulation))
    return 0


def _reused(args, key):
    """The model the commands built before under ``key`` (what this build would write), exported
    into ``args.output`` and loaded from there; None when there is none.  First hour s28: `eomc
    build a1.urdf --floating-base --ground -o DIR` after `eomc simulate` of the robot derived and
    generated it again (257 s wall, 31 s CPU at load 20) -- the build never looked.  A contact-free
    model's simulate records the default set (NAME_implicit is built for contacts only), as does a
    run of implicitfast; a contact model simulated with the default method has no NAME_implicit,
    which this build writes: that one is built, and the note says why."""
    import contextlib
    from pathlib import Path
    from eomc.compiler.build import reuse
    from eomc.compiler.build.builder import BuildResult
    from eomc.compiler.build.cache import BadEntry, cache_root
    from eomc.compiler.build.export import export
    from eomc.runtime.loader import LoadError, load
    from .common import model_options, reuse_options, without_implicit
    root = cache_root(None)
    with contextlib.ExitStack() as held:
        found = reuse.find(root, key, held)
        if found is None:
            _without_implicit_note(args, root, reuse_options(**{**model_options(args),
                                                                "functions": without_implicit()}))
            return None
        directory, name = Path(found[0]), found[1]
        built = BuildResult(name=name, directory=directory, library=directory / f"lib{name}.so",
                            key="", hit=True, backend="cffi")
        try:
            return load(export(built, args.output, source=args.model), name)
        except (BadEntry, LoadError, OSError):
            return None      # built as if nothing had been found


def _without_implicit_note(args, root, options):
    """Say why this build derives the model again when a command built it without NAME_implicit."""
    import contextlib
    import sys
    from pathlib import Path
    from eomc.compiler.build import reuse
    if args.quiet:
        return
    try:
        with contextlib.ExitStack() as held:
            if reuse.find(root, reuse.source_key(Path(args.model), options), held) is None:
                return
    except (OSError, ValueError):
        return
    print(f"eomc: note: {Path(args.model).name} was built before without NAME_implicit (the contacts' "
          "implicitfast step, which simulate's default method does not read); eomc build writes it, "
          "so the model is derived again", file=sys.stderr)


def _reuse_key(args):
    """The reuse key (eomc.compiler.build.reuse) under which the commands that read a model file
    (simulate, check, ...: cli.common.load_model) look up what this build makes, or None when
    they would build something else (other functions, name, flags or cache).  Sweep s27: after
    `eomc build hopper.xml`, `eomc simulate hopper.xml` derived, generated and compiled the model
    again (4.5 s CPU; humanoid_CMU 41 s): its lookup asks for the default set without
    NAME_implicit, which no build had recorded, and the build's generation cache holds the
    default set; recorded here, the build serves every command, as a command's own build does."""
    from pathlib import Path
    from .common import model_options, reuse_options
    default = (args.name is None and args.outputs is None and not args.fold_parameters and
               args.backend == "cffi" and args.cflags is None and args.cache_dir is None and
               not args.portable and args.target == "c99-f64")
    path = Path(args.model)
    if not default or not path.is_file() or path.suffix.lower() not in (".py", ".urdf", ".xml", ".mjcf"):
        return None
    from eomc.compiler.build import reuse
    try:
        return reuse.source_key(path, reuse_options(**model_options(args)))
    except (OSError, ValueError):
        return None


def formulation_line(meta, asked):
    """One line: the formulation that generated the model and why (auto's comparison of rhs
    operations, its fallback's reason, or the user's choice)."""
    chosen = meta.get("formulation", "kane")
    note = meta.get("formulation_note")
    if note:                 # auto fell back, or left something out: say to what and why
        return f"formulation: {note}"
    if asked not in (None, "auto"):
        return f"formulation: {chosen} (asked for)"
    costs = meta.get("formulation_costs")
    if costs:
        from eomc.compiler.formulations.weights import COST_MODEL
        return (f"formulation: {chosen} (auto: the cheaper rhs; costs " +
                ", ".join(f"{k} {v}" for k, v in sorted(costs.items())) +
                f"; {COST_MODEL})")
    return f"formulation: {chosen} (auto)"
