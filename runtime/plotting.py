"""A run's states and outputs as pictures a person can read: panels by kind, a few curves each.

Why panels by kind and a cap per panel: a robot has dozens of states and
outputs; drawn in one axes they are a tangle of repeated colours under a
legend that hides the data.  Here every panel holds one kind of quantity --
coordinates, speeds, extra states (a muscle's activation, a controller's
integral), outputs of one scale, one frame's position or velocity -- and at
most :data:`MAX_CURVES` curves, each with its own colour, with the legend
outside the axes, to the right.  A page holds at most :data:`MAX_PANELS`
panels; more make more pages (``traj.png``, ``traj-2.png``, ...).

Frames' rotations and Jacobians (``tool0.R[0][1]``, ``tool0.J[2][5]``) and
twists are never plotted: a frame is shown by its position and velocity.
"""
import re
from pathlib import Path

import numpy as np

from .files import atomic_path

__all__ = ["panels", "plot_result", "untouched", "idle_outputs", "contacts_last", "MAX_CURVES", "MAX_PANELS"]

MAX_CURVES = 8     # curves in one panel (tab10's distinct colours, with room to tell them apart)
MAX_PANELS = 6     # panels on one page
_SCALE_RATIO = 8.0  # outputs whose magnitudes differ by more than this share no panel

_FRAME = re.compile(r"(.+)\.(?:(R|J)\[\d+\]\[\d+\]|(p|v|w)\.[xyz])")


def _frame_part(name):
    m = _FRAME.fullmatch(name)
    return None if m is None else (m.group(1), m.group(2) or m.group(3))


def _chunks(label, names):
    """``names`` in panels of at most MAX_CURVES, labelled "label (1/3)" when split, the curves
    shared evenly (a walker's 9 coordinates: 5 and 4, not 8 and a panel of one)."""
    count = -(-len(names) // MAX_CURVES)
    size = -(-len(names) // max(count, 1))
    parts = [names[k:k + size] for k in range(0, len(names), size)] if names else []
    if len(parts) == 1:
        return [(label, parts[0])]
    return [(f"{label} ({k + 1}/{len(parts)})", part) for k, part in enumerate(parts)]


def _magnitude(values):
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float(np.max(np.abs(v))) if len(v) else 0.0


def _by_scale(res, names):
    """Groups of ``names`` whose largest magnitudes lie within _SCALE_RATIO of each other
    (an energy of -19 J does not flatten tip positions of +-2 m)."""
    if not names:
        return []
    scaled = sorted(names, key=lambda n: _magnitude(res[n]))
    groups, low = [[scaled[0]]], max(_magnitude(res[scaled[0]]), 1e-300)
    for name in scaled[1:]:
        m = _magnitude(res[name])
        if m > _SCALE_RATIO * low:
            groups.append([])
            low = max(m, 1e-300)
        groups[-1].append(name)
    order = {n: k for k, n in enumerate(names)}     # within a group, the model's order
    return [sorted(g, key=order.get) for g in groups]


_CONTACT_KINDS = ("Fn", "Ftx", "Fty", "Ftz", "depth", "px", "py", "pz")


def untouched(res):
    """The contacts (names) whose normal force stayed 0 over the run, whose outputs (Fn_, Ftx_,
    Fty_, Ftz_, depth_, a pair's px_/py_/pz_) :func:`panels` leaves out unless named: gymnasium's
    ant touched with 4 of its 25 contacts, and its --plot spent pages on flat zeros."""
    model = getattr(res, "model", None)
    if model is None or not getattr(model, "noutput", 0):
        return []
    from .switching import find_switches
    out = []
    for c in find_switches(model).contacts:
        force = res.outputs.get(f"Fn_{c.name}")
        if force is not None and not np.any(np.asarray(force, dtype=float) > 0):
            out.append(c.name)
    return out


def flat_zero(res):
    """The outputs of contacts that did touch but stayed exactly 0 at every row (a flat ground's
    Ftz_: its tangential force has no vertical part), which :func:`panels` leaves out unless
    named: Go2's four feet drew a panel of four zero lines (first hour s23)."""
    model = getattr(res, "model", None)
    if model is None or not getattr(model, "noutput", 0):
        return []
    from .switching import find_switches
    idle = set(untouched(res))
    out = []
    for c in find_switches(model).contacts:
        if c.name in idle:
            continue
        for kind in _CONTACT_KINDS:
            values = res.outputs.get(f"{kind}_{c.name}")
            if values is not None and len(values) and not np.any(np.asarray(values, dtype=float) != 0):
                out.append(f"{kind}_{c.name}")
    return out


def _contact_outputs(names):
    return {f"{k}_{c}" for c in names for k in _CONTACT_KINDS}


def idle_outputs(res):
    """The outputs a picture leaves out unless they are named: those of contacts that never
    touched (:func:`untouched`) and those of touched ones that stayed 0 (:func:`flat_zero`).
    One rule for --plot's panels and the animation page's strips."""
    return _contact_outputs(untouched(res)) | set(flat_zero(res))


# a contact's outputs by kind, in the order pictures draw them (one kind to a panel)
_CONTACT_PANELS = (("contact normal forces", ("Fn",)), ("contact friction forces", ("Ftx", "Fty", "Ftz")),
                   ("contact depths", ("depth",)), ("contact points", ("px", "py", "pz")))


def _contact_kind(res):
    """{output name: its kind ("Fn", "Ftx", ..., "pz")} over every contact of the run's model."""
    model = getattr(res, "model", None)
    if model is None or not getattr(model, "noutput", 0):
        return {}
    from .switching import find_switches
    return {f"{k}_{c.name}": k for c in find_switches(model).contacts for k in _CONTACT_KINDS}


def contacts_last(res, names):
    """``names`` with the model's own outputs (the energy, frames' positions, a file's outputs)
    first, then the contacts' normal forces (Fn_), then their other outputs (Ftx_, depth_, ...),
    each in the model's order.  Why: the animation page draws its first 8 strips, and A1 with
    --ground (first hour s28) drew two contacts' force components and depths and no energy,
    which came after its 32 contact outputs in the model's order."""
    kind = _contact_kind(res)
    own = [n for n in names if n not in kind]
    normal = [n for n in names if kind.get(n) == "Fn"]
    return own + normal + [n for n in names if n in kind and kind[n] != "Fn"]


def panels(res, names=None):
    """[(label, [names])] of a run: what :func:`plot_result` draws, one entry per panel.  Without
    ``names``, the outputs of contacts that never touched (:func:`untouched`) are left out, and
    those of touched ones that stayed 0 (:func:`flat_zero`)."""
    states = list(res.state_names)
    nq = res.nq if res.nq and 0 < res.nq < len(states) else None
    model = getattr(res, "model", None)
    nu = getattr(model, "nu", None) if model is not None else None
    if names is not None:
        unknown = [n for n in names if n not in res.keys()]
        if unknown:
            raise ValueError(f"cannot plot {', '.join(unknown)}: not a state or output of {res.model_name} "
                             f"(states: {', '.join(states)}; outputs: {', '.join(res.outputs) or 'none'})")
        wanted = set(names)
    else:
        wanted = None

    def keep(seq):
        return [n for n in seq if wanted is None or n in wanted]
    out = []
    if nq is None:
        out += _chunks("states", keep(states))
    else:
        speeds_end = nq + nu if nu is not None and nq + nu <= len(states) else len(states)
        out += _chunks("coordinates", keep(states[:nq]))
        out += _chunks("speeds", keep(states[nq:speeds_end]))
        out += _chunks("extra states", keep(states[speeds_end:]))
    frames, plain = {}, []
    idle = idle_outputs(res) if names is None else set()
    for name in res.outputs:
        if name in idle:
            continue
        part = _frame_part(name)
        if part is None:
            plain.append(name)
        elif part[1] in ("p", "v") and (wanted is None or name in wanted):
            frames.setdefault((part[0], part[1]), []).append(name)
        elif wanted is not None and name in wanted:     # asked for by name: drawn, in its own panel
            frames.setdefault((part[0], part[1]), []).append(name)
    # the model's own outputs (the energy) first, then the contacts' by kind, one kind to a panel
    # (first hour s28: A1's --plot drew its energy as the 8th curve among friction forces)
    kind = _contact_kind(res)
    out += _scaled("outputs", res, keep([n for n in plain if n not in kind]))
    for (frame, part), group in frames.items():
        label = {"p": "position", "v": "velocity", "w": "angular velocity",
                 "R": "rotation", "J": "Jacobian"}[part]
        out += _chunks(f"{frame} {label}", group)
    for label, kinds in _CONTACT_PANELS:
        out += _scaled(label, res, keep([n for n in plain if kind.get(n) in kinds]))
    return [(label, group) for label, group in out if group]


def _scaled(label, res, names):
    """``names`` in panels by scale (:func:`_by_scale`), each split by :func:`_chunks`, all
    numbered as one kind: "contact depths (1/3)" ... "(3/3)", not two runs of "(1/2)" under one
    label (A1's 18 touching contacts' normal forces, first hour s28)."""
    parts = [group for scale in _by_scale(res, names) for _, group in _chunks(label, scale)]
    if len(parts) == 1:
        return [(label, parts[0])]
    return [(f"{label} ({k + 1}/{len(parts)})", part) for k, part in enumerate(parts)]


def _nearly_constant(values):
    """Each curve's first finite value when every curve of a panel moves by less than 1e-4 of
    its size (a conserved energy's drift), else None.  Such a panel plots the change from the
    start: its values themselves share their first digits, which matplotlib writes as an offset
    over the axis ("1e-5-1.92098e1", the quick start's energy panel, first hour s28)."""
    starts = []
    for v in values:
        finite = v[np.isfinite(v)]
        if not len(finite):
            return None
        size, span = float(np.max(np.abs(finite))), float(np.ptp(finite))
        if not (0.0 < span < 1e-4 * size):
            return None
        starts.append(float(finite[0]))
    return starts or None


def _page_paths(path, pages):
    path = Path(path)
    return [path] + [path.with_name(f"{path.stem}-{k}{path.suffix}") for k in range(2, pages + 1)]


def plot_result(res, path=None, names=None):
    """Draw ``res`` (see the module docstring).  With ``path``: the pages written, a Path
    (one page) or a list of Paths; without: the Figure (one page) or a list of Figures."""
    import matplotlib
    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    chosen = panels(res, names)
    left = untouched(res) if names is None else []
    if not chosen:
        raise ValueError(f"{res.model_name}: nothing to plot")
    pages = [chosen[k:k + MAX_PANELS] for k in range(0, len(chosen), MAX_PANELS)]
    colors = plt.get_cmap("tab10").colors
    figures = []
    for number, page in enumerate(pages, 1):
        fig, axes = plt.subplots(len(page), 1, figsize=(10, 1.2 + 2.3 * len(page)), sharex=True,
                                 squeeze=False, layout="constrained")
        for ax, (label, group) in zip(axes[:, 0], page):
            values = [np.asarray(res[name], dtype=float) for name in group]
            starts = _nearly_constant(values)
            for k, (name, v) in enumerate(zip(group, values)):
                if starts is None:
                    ax.plot(res.t, v, label=name, color=colors[k % len(colors)], lw=1.3)
                else:
                    ax.plot(res.t, v - starts[k], label=f"{name} (start {starts[k]:.10g})",
                            color=colors[k % len(colors)], lw=1.3)
            ax.set_ylabel(label if starts is None else f"{label}: change from the start")
            # never matplotlib's offset ("1e-5-1.92098e1" over the axis); a factor as x10^-5
            ax.ticklabel_format(axis="y", useOffset=False, useMathText=True)
            ax.grid(True, alpha=0.3)
            # outside the data, to the right: a legend never hides a curve
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", borderaxespad=0.0,
                      frameon=False)
        axes[-1, 0].set_xlabel("t")
        more = f", page {number} of {len(pages)}" if len(pages) > 1 else ""
        idle = f"; {len(left)} contacts that never touched not drawn" if left else ""
        axes[0, 0].set_title(f"{res.model_name} ({res.method}{more}{idle})")
        figures.append(fig)
    if path is None:
        return figures[0] if len(figures) == 1 else figures
    written = []
    for fig, target in zip(figures, _page_paths(path, len(figures))):
        with atomic_path(target) as tmp:
            fig.savefig(tmp, dpi=110, format=Path(target).suffix[1:] or "png")
        plt.close(fig)
        written.append(Path(target))
    return written[0] if len(written) == 1 else written
