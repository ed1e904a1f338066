"""``eomc animate MODEL [--t-final T | --from traj.csv] [-o anim.html] [--gif anim.gif | --mp4 anim.mp4]``.

Simulates MODEL (a model file, a URDF robot or a built directory) from its
initial state, or reads a trajectory CSV that ``eomc simulate -o`` wrote, and
writes one self-contained HTML page that animates it in 3-D offline
(eomc.runtime.animate); ``--gif``/``--mp4`` draw a planar motion in 2-D.  The
model must have been built with ``poses`` (the default function set).  With no
output named, the page is MODEL's name + .html in the current folder (a first
run with no flags must work), never over a file eomc did not write.
"""

import os

from . import common as cli_common
from .simulate import events_argument, inputs_argument

__all__ = ["configure", "run", "read_trajectory"]


_NO_FILE = object()      # --gif or --mp4 given without its file


def configure(parser):
    cli_common.add_model_arguments(parser)
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--t-final", type=float, metavar="T",
                        help="simulate from t0 to T (default 10, when no --from)")
    source.add_argument("--from", dest="trajectory", metavar="CSV",
                        help="animate this trajectory (columns t and every state, as eomc simulate "
                             "-o writes) instead of simulating")
    parser.add_argument("--t0", type=float, default=0.0, help="start time")
    parser.add_argument("-o", "--output", metavar="HTML",
                        help="the HTML page to write (default, when no --gif/--mp4 either: MODEL's "
                             "name + .html in the current folder)")
    # nargs="?": a bare --gif (`--gif -o a1.gif`) is told what --gif takes (run), not argparse's
    # "expected one argument" (first hour s28)
    parser.add_argument("--gif", metavar="GIF", nargs="?", const=_NO_FILE,
                        help="also draw a planar motion to this GIF (2-D)")
    parser.add_argument("--mp4", metavar="MP4", nargs="?", const=_NO_FILE,
                        help='... or to this MP4 (ffmpeg on PATH, or the video '
                             'extra: pip install ".[video]" in eomc\'s clone)')
    parser.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                        help="a folder holding the ROS packages a URDF's package:// meshes name "
                             "(repeat for more; searched before ROS_PACKAGE_PATH, AMENT_PREFIX_PATH "
                             "and the example-robot-data layout)")
    parser.add_argument("--axes", choices=("on", "off"),
                        help="draw each body's frame axes (default: off for a robot drawn by its "
                             "meshes, on otherwise; the page has a toggle)")
    parser.add_argument("--fps", type=float, default=60.0, help="frames per second in the page")
    parser.add_argument("--gif-fps", type=float, default=20.0, help="frames per second of --gif/--mp4")
    parser.add_argument("--trace", metavar="NAMES",
                        help="bodies or points whose paths are drawn, comma-separated "
                             "(default: the one that travels farthest; 'none' for none)")
    parser.add_argument("--up", choices=("x", "y", "z", "-x", "-y", "-z"),
                        help="the world axis drawn upwards (default z; a planar motion is seen "
                             "straight onto its plane)")
    parser.add_argument("--method", default="auto", help="integrator (as eomc simulate; default auto)")
    parser.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-8, help="absolute tolerance")
    parser.add_argument("--input", nargs="+", action="extend", metavar="NAME=V|CSV", default=[],
                        help="input values, as eomc simulate")
    parser.add_argument("--events", metavar="LIST", help="events, as eomc simulate")
    parser.add_argument("--formulation", choices=("auto", "kane", "recursive"), default="auto",
                        help="dynamics formulation (model files and URDF)")


def read_trajectory(model, path):
    """A SimulationResult from a CSV with columns t and the model's states (outputs optional).

    ValueError naming the file and the missing column when a state is absent."""
    import numpy as np
    from eomc.runtime.result import SimulationResult
    try:
        with open(path, encoding="utf-8") as f:
            header = [h.strip() for h in f.readline().strip().split(",")]
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except OSError as exc:
        raise ValueError(f"--from {path}: cannot read it ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise ValueError(f"--from {path}: not a numeric CSV with one header row ({exc})") from None
    missing = [n for n in ("t",) + tuple(model.state_names) if n not in header]
    if missing:
        raise ValueError(f"--from {path}: no column {', '.join(missing)} (model {model.name} has states "
                         f"{', '.join(model.state_names)}; the file has {', '.join(header)})")
    if data.shape[1] != len(header):
        raise ValueError(f"--from {path}: {data.shape[1]} values per row but {len(header)} names in the header")
    t = data[:, header.index("t")]
    if len(t) < 1 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(data)):
        raise ValueError(f"--from {path}: times must increase strictly and every value be finite")
    x = np.column_stack([data[:, header.index(n)] for n in model.state_names])
    skip = {"t", "constraint_residual", *model.state_names}
    outputs = {n: data[:, k] for k, n in enumerate(header) if n not in skip}   # as saved, built or not
    return SimulationResult(t=t, x=x, state_names=tuple(model.state_names), stats={}, method="csv",
                            model_name=model.name, outputs=outputs, nq=model.nq, model=model)


# every page eomc.runtime.animate writes carries this element: a page of that name that lacks
# it is the user's file, and the default output does not write over it
_PAGE_MARK = 'id="eomc-main"'


def default_page(model_path):
    """MODEL's name + .html in the current folder: ``eomc animate go2.urdf`` writes go2.html.

    ValueError when a file of that name exists that eomc did not write (no eomc page mark)."""
    from pathlib import Path
    source = Path(model_path)
    page = Path(f"{(source.name if source.is_dir() else source.stem) or 'animation'}.html")
    if page.exists():
        try:
            with open(page, encoding="utf-8", errors="replace") as f:
                ours = _PAGE_MARK in f.read(1 << 16)
        except OSError:
            ours = False
        if not ours:
            raise ValueError(f"{page} exists and eomc did not write it; say where to write: "
                             f"-o anim.html, --gif anim.gif or --mp4 anim.mp4")
    return str(page)


def run(args):
    from eomc.runtime.animate import animate, animate_2d
    for value, what in ((args.gif, "--gif"), (args.mp4, "--mp4")):
        if value is _NO_FILE:
            suffix = what[2:]
            raise ValueError(f"{what} takes the {suffix.upper()} file to write, e.g. {what} anim.{suffix} "
                             f"(a 2-D drawing of a planar motion; -o names the 3-D HTML page)")
    if not (args.output or args.gif or args.mp4):
        args.output = default_page(args.model)
    for value, what, suffix in ((args.output, "-o", ".html"), (args.gif, "--gif", ".gif"),
                                (args.mp4, "--mp4", ".mp4")):
        cli_common.writable_file(value, what)
        if value and not value.lower().endswith(suffix) and not (what == "-o" and value.lower().endswith(".htm")):
            raise ValueError(f"{what} {value}: expected a {suffix} file")
    for folder in args.package_dir:
        if not os.path.isdir(folder):
            raise ValueError(f"--package-dir {folder}: no such folder")
    if args.fps <= 0 or args.gif_fps <= 0:
        raise ValueError("--fps and --gif-fps must be positive")
    if args.mp4:        # no ffmpeg: said now, not after the build and the run
        from eomc.runtime.animate import ffmpeg_path
        ffmpeg_path()
    options = {**cli_common.model_options(args), **cli_common.read_checks(args)}   # --param: once read
    if args.trajectory and os.path.isfile(args.model):
        # drawing a saved run needs the bodies' poses only: no Jacobians, frames or events to
        # build (a robot's full build took 42 s); the CSV's other columns are plotted as saved
        options.pop("frames", None)
        options["functions"] = ["rhs", "poses"]
    model = cli_common.load_model(args.model, args.quiet, **options, methods=(args.method,))
    if "poses" not in model.functions:
        raise ValueError(f"{model.name} was built without poses (its bodies' positions); rebuild it "
                         f"with the default functions or --outputs ...,poses")
    params = cli_common.parameter_values(model, cli_common.parse_assignments(args.param, "param"))
    if args.trajectory:
        res = read_trajectory(model, args.trajectory)
        res.p = params
    else:
        x0 = cli_common.initial_state(model, cli_common.parse_assignments(args.x0, "x0"))
        if args.gif or args.mp4:
            _planar_start(model, x0, params, args.t0, args.gif or args.mp4)
        t_final = 10.0 if args.t_final is None else args.t_final
        res = model.simulate(x0, (args.t0, t_final), p=params, method=args.method, rtol=args.rtol,
                             atol=args.atol, r=inputs_argument(model, args.input),
                             events=events_argument(args.events),
                             n_points=max(2, int((t_final - args.t0) * args.fps) + 1),
                             raise_on_failure=False)
        res.p = params
        if res.status != 0 and len(res.t) < 2:
            from eomc.runtime.errors import SimulationError
            raise SimulationError(res.message)
    from .simulate import _no_ground
    _no_ground(model, res)          # a floating base falling out of the picture: said, with the way out
    trace = None if args.trace is None else (
        [] if args.trace.strip().lower() == "none" else [s.strip() for s in args.trace.split(",") if s.strip()])
    if args.output:
        anim = animate(res, args.output, model=model, fps=args.fps, trace=trace, up=args.up,
                       axes=None if args.axes is None else args.axes == "on",
                       package_dirs=args.package_dir)
        print(f"wrote {args.output} ({len(anim.html) / 1e6:.2f} MB, {len(res.t)} rows, "
              f"t = [{res.t[0]:g}, {res.t[-1]:g}])")
    for path in (args.gif, args.mp4):
        if path:
            animate_2d(res, path, model=model, fps=args.gif_fps, trace=trace)
            # as the HTML's line: its size and span (first hour s26: "wrote dp.gif" alone)
            print(f"wrote {path} ({os.path.getsize(path) / 1e6:.2f} MB, {args.gif_fps:g} frames/s, "
                  f"t = [{res.t[0]:g}, {res.t[-1]:g}])")
    if res.status != 0:     # what was computed is drawn; the command still fails
        from eomc.runtime.errors import SimulationError
        raise SimulationError(f"{res.message}; the animation shows the {len(res.t)} rows computed up to "
                              f"t={res.t[-1]:.9g} (incomplete)")
    return 0


def _planar_start(model, x0, params, t0, path):
    """ValueError before the run when the start already leaves every coordinate plane: the 2-D
    drawing needs one coordinate constant for every body and point over the whole run
    (eomc.runtime.animate.plane_of), the start among them.  First hour s28: an A1's --gif was
    refused only after its 11 s run."""
    import numpy as np
    from eomc.runtime.animate import plane_of
    from eomc.runtime.poses import evaluate_poses
    start = np.array([[float(x0[n]) for n in model.state_names]]) if isinstance(x0, dict) else \
        np.asarray(x0, dtype=float)[None, :]
    poses = evaluate_poses(model, np.array([t0]), start, params)
    if plane_of(poses) is None:
        raise ValueError(f"{path}: {model.name} is not planar at its start (no coordinate x, y or z is the "
                         f"same for every body and point), so its motion has no 2-D drawing; use the HTML "
                         f"animation (-o anim.html)")
