"""The whole pipeline in one function: model -> formed system -> C -> library -> loaded Model.

    derive    eomc.compiler.model.model_spec   (run the model file, .formed(), check variables)
    generate  eomc.compiler.emit.generate_c    (IR, optimization passes, C text, metadata;
                                                cached by the formed equations: build.gencache)
    compile   eomc.compiler.build.build        (content-addressed cache; C compiler on a miss)
    export    eomc.compiler.build.export       (only with output_dir: the files `eomc build` writes)
    load      eomc.runtime.loader.load         (cffi dlopen or the Cython extension)
"""
import sys
import time

from eomc.runtime.errors import ModelError

from .build import build, cache_root
from .build.gencache import cached_generate
from .build.export import export
from .model import model_spec
from .model.validate import Invalid, check_functions
from .passes.timing import reporting

__all__ = ["compile", "generate", "Progress"]


class Progress:
    """Stage timings on stderr, e.g. ``eomc: generate  0.84 s``; silent when off."""

    PASS_SHOWN = 0.25   # seconds: compiler passes at least this long are listed under their stage
    PASS_LABELS = {"cse": "common subexpressions", "differentiate": "Jacobians",
                   "tangent": "Jacobians (tangent)", "share_sincos": "sharing sin/cos",
                   "fold_constants": "folding constants", "fold_parameters": "folding parameters",
                   "dce": "dropping unused code", "expand_powers": "powers to products"}

    def __init__(self, enabled=None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else bool(enabled)
        self.timings = {}

    def stage(self, label):
        progress = self

        class _Stage:
            def __enter__(self):
                if progress.enabled:
                    print(f"eomc: {label} ...", file=progress.stream, flush=True)
                self.start = time.perf_counter()

            def __exit__(self, *exc):
                progress.timings[label] = elapsed = time.perf_counter() - self.start
                if progress.enabled and exc[0] is None:
                    print(f"eomc: {label:<9} {elapsed:7.3f} s", file=progress.stream, flush=True)
        return _Stage()

    def pass_done(self, name, seconds):
        """A compiler pass finished: shown when it took long enough to be noticed."""
        if self.enabled and seconds >= self.PASS_SHOWN:
            label = self.PASS_LABELS.get(name, name.replace("_", " "))
            print(f"eomc:   {label:<22} {seconds:7.3f} s", file=self.stream, flush=True)


def generate(system, name=None, *, parameters=None, inputs=None, outputs=None, functions=None,
             fold_parameters=False, progress=None, cache_dir=None, use_cache=True,
             formulation="kane"):
    """Derive and generate C without compiling: returns (ModelSpec, GeneratedModel).

    ``formulation``: "kane" (formed A, b; numeric LDLᵀ), "recursive" (ABA/RNEA/CRBA
    over the joint tree, eomc.compiler.tree) or "auto" (the cheaper rhs).

    With ``use_cache`` the C comes from the generation cache when the formed
    equations and options were seen before (see eomc.compiler.build.gencache).
    """
    from .tree.select import check_formulation, generate_formulation, tree_digest
    progress = progress if isinstance(progress, Progress) else Progress(progress)
    check_formulation(formulation)
    try:
        functions = check_functions(functions)
    except Invalid as exc:
        raise ModelError(str(exc)) from None
    with progress.stage("derive"):
        spec = model_spec(system, name, parameters=parameters, inputs=inputs, outputs=outputs)
    def run_generator():
        return generate_formulation(spec, functions, fold_parameters, formulation)
    with progress.stage("generate"), reporting(progress.pass_done):
        if use_cache:
            generated, _ = cached_generate(spec, functions, fold_parameters, run_generator,
                                           cache_root(cache_dir),
                                           extra=[formulation, tree_digest(spec)])
        else:
            generated = run_generator()
    return spec, generated


def compile(system, name=None, *, parameters=None, inputs=None, outputs=None, functions=None,
            fold_parameters=False, backend="cffi", cflags=None, cache_dir=None, output_dir=None,
            progress=None, formulation="kane"):
    """Compile a model file (path) or a formed system into a loaded :class:`eomc.runtime.model.Model`.

    ``formulation``: "kane" (default), "recursive" or "auto" (see :func:`generate`).

    Progress (stage timings on stderr) defaults to on when stderr is a terminal.
    """
    from eomc.runtime.loader import LoadError, load
    progress = Progress(progress)
    spec, generated = generate(system, name, parameters=parameters, inputs=inputs, outputs=outputs,
                               functions=functions, fold_parameters=fold_parameters, progress=progress,
                               cache_dir=cache_dir, formulation=formulation)
    extra = {"initial_state": spec.initial_state} if spec.initial_state is not None else None
    with progress.stage("compile"):
        built = build(generated, backend=backend, cflags=cflags, cache_dir=cache_dir, extra_metadata=extra)
    directory = export(built, output_dir) if output_dir is not None else built.directory
    with progress.stage("load"):
        try:
            return load(directory, generated.name, backend=backend)
        except LoadError:
            if output_dir is not None:
                raise
            # a cache entry that looked whole but does not load is a miss: rebuild it once
            built = build(generated, backend=backend, cflags=cflags, cache_dir=cache_dir,
                          extra_metadata=extra, force=True)
            return load(built.directory, generated.name, backend=backend)
