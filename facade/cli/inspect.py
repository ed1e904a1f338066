"""``eomc inspect MODEL.py``: sizes, per-function operation counts and M's sparsity, without compiling."""
from .build import add_generate_options

__all__ = ["configure", "run", "format_report"]

_SIZES = ("nq", "nu", "nx", "nparam", "ninput", "noutput", "nhol", "nvel", "work_size")


def configure(parser):
    add_generate_options(parser)
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
        lines.append(f"{function:<18}" + "".join(f"{v:>8}" for v in ops) + f"{sum(ops):>9}")
    sparsity = metadata.get("mass_matrix_sparsity") or []
    if sparsity:
        nonzero = sum(row.count("x") for row in sparsity)
        lines.append("")
        lines.append(f"mass matrix sparsity ({nonzero} of {len(sparsity) ** 2} entries nonzero):")
        lines.extend("  " + " ".join(row) for row in sparsity)
    return "\n".join(lines)


def run(args):
    from eomc.compiler.driver import generate
    from eomc.compiler.urdf.model import with_options
    from eomc.errors import ModelError
    source, name = with_options(args.model, args.name, floating_base=args.floating_base)
    spec, generated = generate(source, name, functions=args.outputs,
                               fold_parameters=args.fold_parameters,
                               progress=False if args.quiet else None, formulation=args.formulation)
    print(format_report(generated.metadata))
    print("")
    print(compare_formulations(args, spec, generated, generate, ModelError))
    return 0


def compare_formulations(args, spec, generated, generate, error):
    """Total operations per function in both formulations (the other one generated too)."""
    chosen = generated.metadata.get("formulation", "kane")
    other = "kane" if chosen == "recursive" else "recursive"
    note = generated.metadata.get("formulation_note")
    if note:                 # auto fell back: the other form does not exist, and the note says why
        return f"formulation: {note}"
    if spec.formed.method == "tree":
        return (f"formulation: {chosen} (kane not compared: the System's equations are not formed, "
                f"and forming them is what the recursive formulation avoids)")
    try:
        _, alt = generate(args.model, args.name, functions=args.outputs,
                          fold_parameters=args.fold_parameters, progress=False, formulation=other)
        alt_counts = alt.metadata["op_counts"]
    except error as exc:
        return f"formulation: {chosen} (no {other} form: {exc})"
    counts = {chosen: generated.metadata["op_counts"], other: alt_counts}
    lines = [f"formulation: {chosen}; total operations per function:",
             f"  {'':<18}{'kane':>10}{'recursive':>11}"]
    for fn in generated.metadata["op_counts"]:
        cells = []
        for f in ("kane", "recursive"):
            c = counts[f].get(fn)
            cells.append(sum(c.values()) if c else "-")
        lines.append(f"  {fn + ':':<18}{cells[0]:>10}{cells[1]:>11}")
    return "\n".join(lines)
