"""``eomc inspect MODEL.py``: sizes, per-function operation counts and M's sparsity, without compiling.

A built model (a directory of `eomc build -o DIR`, or its NAME.json) is inspected from its NAME.json,
which holds the same sizes, counts and sparsity: nothing is derived or compiled, and no library
is opened."""
from .build import add_generate_options

__all__ = ["configure", "run", "format_report"]

_SIZES = ("nq", "nu", "nx", "nparam", "ninput", "noutput", "nhol", "nvel", "work_size")


def configure(parser):
    add_generate_options(parser)
    model, = [action for action in parser._actions if action.dest == "model"]
    model.help += ", or a directory written by `eomc build` (or its NAME.json): inspected as built"
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")


def format_report(metadata):
    """The inspect report for a generated model's metadata, as text."""
    lines = [f"model {metadata['name']}"]
    lines.append("sizes: " + ", ".join(f"{k}={metadata[k]}" for k in _SIZES if k in metadata))
    for label, key in (("states", "state_names"), ("parameters", "param_names"),
                       ("inputs", "input_names"), ("outputs", "output_names")):
        lines.append(f"{label}: {', '.join(metadata.get(key, ())) or '-'}")
    lines.append("")
    lines.append(f"{'function':<18}{'adds':>8}{'muls':>8}{'divs':>8}{'calls':>8}{'total':>9}")
    for function, counts in metadata.get("op_counts", {}).items():
        ops = [int(counts.get(k, 0)) for k in ("adds", "muls", "divs", "calls")]
        label = function + ("*" if function == "linearize" else "")
        lines.append(f"{label:<18}" + "".join(f"{v:>8}" for v in ops) + f"{sum(ops):>9}")
    if "linearize" in metadata.get("op_counts", {}):
        lines.append("* a call of linearize runs jac_x and jac_r (no code of its own): "
                     "these are their operations")
    sparsity = metadata.get("mass_matrix_sparsity") or []
    if sparsity:
        nonzero = sum(row.count("x") for row in sparsity)
        lines.append("")
        lines.append(f"mass matrix sparsity ({nonzero} of {len(sparsity) ** 2} entries nonzero):")
        lines.extend("  " + " ".join(row) for row in sparsity)
    return "\n".join(lines)


def run(args):
    from pathlib import Path
    if Path(args.model).is_dir() or Path(args.model).suffix.lower() == ".json":
        return _run_built(args)
    from eomc.compiler.driver import generate
    from .common import floating_base_of, with_options
    from eomc.errors import ModelError
    source, name = with_options(args.model, args.name, floating_base=floating_base_of(args),
                                allow_nonphysical_inertia=args.allow_nonphysical_inertia,
                                limits=args.limits != "off", ignore=args.ignore,
                                orientation=getattr(args, "orientation", None), pairs=getattr(args, "pairs", None))
    import warnings
    with warnings.catch_warnings(record=True) as said:
        spec, generated = generate(source, name, functions=args.outputs,
                                   fold_parameters=args.fold_parameters,
                                   progress=False if args.quiet else None, formulation=args.formulation,
                                   contacts=args.contact)
    for w in said:      # said as they were (on stderr), and their details below
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    print(format_report(generated.metadata))
    details = [line for w in said for line in getattr(w.message, "details", ())]
    if details:     # a note's one line names what it is about; the numbers are here (BuildNote.details)
        print("")
        print("the build's notes in detail:")
        print("\n".join(f"  {line}" for line in details))
    print("")
    print(compare_formulations(args, spec, generated, generate, ModelError, source=source, name=name))
    return 0


def _run_built(args):
    """Inspect a built model from its NAME.json; the options that shape a build are refused (they
    apply to a model file, and this build's are already made)."""
    import argparse
    import json
    from pathlib import Path
    parser = argparse.ArgumentParser()
    configure(parser)
    defaults = vars(parser.parse_args([args.model]))
    given = sorted(k for k, v in vars(args).items() if k in defaults and k not in ("model", "quiet")
                   and v != defaults[k])
    if given:
        options = ", ".join("--" + k.replace("_", "-") for k in given)
        raise ValueError(f"{args.model}: {options} shape a build: a built model is inspected as it was "
                         f"built; give them with the model file it was built from")
    path = Path(args.model)
    if path.is_dir():
        built = sorted(p for p in path.glob("*.json")
                       if not p.name.startswith(".") and (path / f"lib{p.stem}.so").exists())
        if len(built) != 1:
            raise ValueError(f"{path}: " + (f"holds {len(built)} built models ({', '.join(p.name for p in built)}): "
                                            f"inspect one's NAME.json" if built else
                                            "a directory with no built model in it (NAME.json beside libNAME.so): "
                                            "inspect takes a model file (.py, .urdf or MuJoCo's .xml) or a built "
                                            "model directory"))
        path = built[0]
    try:
        metadata = json.loads(path.read_text())
    except ValueError as exc:
        raise ValueError(f"{path}: cannot read model metadata ({exc}); rebuild the model") from None
    if not isinstance(metadata, dict) or not {"name", "op_counts", "state_names"} <= set(metadata):
        raise ValueError(f"{path}: not the NAME.json of a built model (no name, op_counts, state_names)")
    print(format_report(metadata))
    print("")
    note = metadata.get("formulation_note")
    print(f"formulation: {note or metadata.get('formulation', 'kane')} (as built)")
    return 0


def compare_formulations(args, spec, generated, generate, error, *, source=None, name=None):
    """Which formulation generated the model and why (auto's reason for a fallback, its cost
    comparison, the joints the tree reader read through SymPy's kinematics), then total
    operations per function in both formulations (the other one generated too, unless that
    means forming a large System's equations).

    ``source``, ``name``: the model as the first generation got it (a URDF with its options,
    e.g. ``--floating-base``: eomc.compiler.urdf.model.with_options); the other formulation is
    generated from the same, so both columns describe the same robot."""
    source = args.model if source is None else source
    name = args.name if name is None else name
    from eomc.compiler.formulations.select import AUTO_KANE_MAX_SPEEDS, COST_MODEL
    meta = generated.metadata
    chosen = meta.get("formulation", "kane")
    other = "kane" if chosen == "recursive" else "recursive"
    note = meta.get("formulation_note")
    # auto fell back: the other form failed, and the note says which was used and why
    head = [f"formulation: {note}" if note else
            f"formulation: {chosen}" + (f" (asked for: {args.formulation})"
                                        if args.formulation != chosen else "")]
    for tree_note in meta.get("tree_notes") or ():   # the System -> tree reader's fallbacks
        head.append(f"  tree reader: {tree_note}")
    costs = meta.get("formulation_costs")
    if costs:
        head.append(f"  auto compared rhs costs ({COST_MODEL}): " +
                    ", ".join(f"{k} {v}" for k, v in sorted(costs.items())))
    if note and chosen == "kane":
        return "\n".join(head)
    from eomc.compiler.multibody import Model
    if isinstance(spec.formed, Model) and spec.formed.nu > AUTO_KANE_MAX_SPEEDS:
        head.append(f"  kane not compared: the System's equations are not formed ({spec.formed.nu} "
                    f"speeds), and forming them is what the recursive formulation avoids")
        return "\n".join(head)
    try:
        _, alt = generate(source, name, functions=args.outputs,
                          fold_parameters=args.fold_parameters, progress=False, formulation=other,
                          contacts=getattr(args, "contact", None))
        alt_counts = alt.metadata["op_counts"]
    except error as exc:
        head.append(f"  no {other} form: {exc}")
        return "\n".join(head)
    counts = {chosen: meta["op_counts"], other: alt_counts}
    lines = head + ["total operations per function:", f"  {'':<18}{'kane':>10}{'recursive':>11}"]
    for fn in meta["op_counts"]:
        cells = []
        for f in ("kane", "recursive"):
            c = counts[f].get(fn)
            cells.append(sum(c.values()) if c else "-")
        label = fn + ":" if fn != "linearize" else "linearize*:"
        lines.append(f"  {label:<18}{cells[0]:>10}{cells[1]:>11}")
    if "linearize" in meta["op_counts"]:
        lines.append("  * linearize calls jac_x and jac_r (its count is theirs; it has no code of its own)")
    return "\n".join(lines)
