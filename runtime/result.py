"""SimulationResult: one trajectory with named columns, statistics and outputs.

Why a class: users index states and outputs by name (``res["q1"]``,
``res["energy"]``), write CSV for other tools and draw a quick plot; the raw
arrays stay plain numpy (``res.t``, ``res.x``) for everything else.
"""
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .files import atomic_path

__all__ = ["SimulationResult", "select_columns"]


def select_columns(names, patterns, what="columns"):
    """The indices of ``names`` (a CSV's column names) that any of ``patterns`` (exact names
    or fnmatch globs: "q_*", "*knee*") matches, in the CSV's order, "t" always first.  A
    pattern that matches nothing is a ValueError naming what there is (first hour s26: G1 on
    the ground wrote 4272 columns, 27 MB, with no way to choose)."""
    import difflib
    import fnmatch
    names = list(names)
    unmatched = [p for p in patterns if not fnmatch.filter(names, p)]
    if unmatched:
        near = sorted({m for p in unmatched for m in difflib.get_close_matches(p, names, n=2, cutoff=0.6)})
        shown = ", ".join(names[:12]) + (f", ... ({len(names)} in all)" if len(names) > 12 else "")
        raise ValueError(f"{what}: {', '.join(unmatched)} match{'es' if len(unmatched) == 1 else ''} no column"
                         + (f" (did you mean {', '.join(near)}?)" if near else "")
                         + f"; columns: {shown} (names or glob patterns such as 'q_*')")
    return [i for i, n in enumerate(names)
            if n == "t" or any(fnmatch.fnmatchcase(n, p) for p in patterns)]


@dataclass
class SimulationResult:
    """t (n_t,), x (n_t, nx) and what the run measured.

    stats: steps, accepted, rejected, nfev, njev, nlu, nproj, status, t, h, ...
    outputs: {output name: (n_t,)} -- the model's named outputs along the trajectory.
    constraint_residual: (n_t,) max-abs constraint residual, or None without constraints.
    status: 0 on success, else the eomc_status code; message says why.
    """
    t: np.ndarray
    x: np.ndarray
    state_names: tuple
    stats: dict
    status: int = 0
    message: str = "ok"
    method: str = ""
    model_name: str = ""
    outputs: dict = field(default_factory=dict)
    constraint_residual: np.ndarray = None
    x_final: np.ndarray = None
    t_final: float = None
    nq: int = None          # coordinates come first in x; the plot gives them their own panel
    t_events: dict = None   # event name -> times of its occurrences (runs with events)
    x_events: dict = None   # event name -> states there, (k, nx)
    event_stop: str = None  # the terminal event that ended the run, if one did
    # simulate(..., sensitivities=...) (runtime/sensitivity.py): d x(t) / d x0[chosen states],
    # (n_t, nx, len(sensitivity_states)), and d x(t) / d p[chosen parameters]
    dx_dx0: np.ndarray = None
    dx_dp: np.ndarray = None
    sensitivity_states: tuple = None
    sensitivity_params: tuple = None
    # the model, parameters and constant inputs of the run (Model.simulate sets them): poses/animate
    model: object = field(default=None, repr=False, compare=False)
    p: object = field(default=None, repr=False, compare=False)
    r: object = field(default=None, repr=False, compare=False)

    @property
    def success(self):
        return self.status == 0

    def __getitem__(self, name):
        """A state column or a named output by name."""
        if name in self.state_names:
            return self.x[:, self.state_names.index(name)]
        if name in self.outputs:
            return self.outputs[name]
        if name == "t":
            return self.t
        known = ", ".join(("t",) + tuple(self.state_names) + tuple(self.outputs))
        raise KeyError(f"{name!r} is neither a state nor an output; known: {known}")

    def keys(self):
        return ("t",) + tuple(self.state_names) + tuple(self.outputs)

    def columns(self):
        """(names, 2-d array) of everything to_csv writes."""
        names = ["t", *self.state_names, *self.outputs]
        cols = [self.t[:, None], self.x] + [np.asarray(v)[:, None] for v in self.outputs.values()]
        if self.constraint_residual is not None:
            names.append("constraint_residual")
            cols.append(self.constraint_residual[:, None])
        return names, np.hstack(cols)

    def to_csv(self, path, columns=None):
        """Write t, states, outputs (and the constraint residual) as CSV with a header row;
        ``columns``: only these (names or glob patterns over the column names, see
        :func:`select_columns`; t is always kept).

        A failed run's rows (up to where it stopped) are written too, followed by one
        comment line ``# incomplete: <why>`` (numpy.loadtxt and pandas with comment="#"
        skip it), so what was computed is kept and marked as such."""
        names, data = self.columns()
        if columns is not None:
            keep = select_columns(names, list(columns))
            names, data = [names[i] for i in keep], data[:, keep]
        footer = "" if self.status == 0 else "incomplete: " + " ".join(str(self.message).split())
        with atomic_path(path) as tmp:
            np.savetxt(tmp, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
            if footer:
                with open(tmp, "a") as fh:
                    fh.write(f"# {footer}\n")
        return Path(path)

    def plot(self, path=None, names=None):
        """Plot states and outputs (or the given names) against t; saved to ``path`` (PNG) if given.

        Panels by kind (coordinates, speeds, extra states, outputs of one scale, a frame's
        position or velocity), at most 8 curves each with the legend outside the data, at
        most 6 panels a page: a robot's run makes several pages (``traj.png``,
        ``traj-2.png``, ...).  Returns the Path (a list of Paths for several pages), or the
        Figure(s) without ``path``.  See eomc.runtime.plotting.
        """
        from .plotting import plot_result
        return plot_result(self, path, names)

    def __getstate__(self):
        """Pickles carry the numbers, not the model (a model pickles with its library's bytes)."""
        state = dict(self.__dict__)
        state["model"] = None
        return state

    def _model_for(self, what):
        if self.model is None:
            raise ValueError(f"{what} needs the model: this result was not made by Model.simulate "
                             f"in this process (pass model=...)")
        return self.model

    def frame(self, name):
        """Frame output ``name`` along the run (eomc.runtime.frames.Frame, n_t first): ``p``
        (n_t, 3), ``R`` (n_t, 3, 3), ``v``, ``w`` (n_t, 3), ``J`` (n_t, 6, nu); ``com``: p, v."""
        from .frames import frame_from_columns, frame_indices
        names = tuple(self.outputs)
        frame_indices(names, name)
        cols = np.stack([np.asarray(self.outputs[n], dtype=float) for n in names], axis=-1) if names else None
        return frame_from_columns(names, cols, name)

    def poses(self, model=None):
        """Body frames' positions and rotations and named points along the trajectory
        (eomc.runtime.poses.Poses, computed by the generated C ``NAME_poses``)."""
        from .poses import evaluate_poses
        model = model or self._model_for("poses()")
        return evaluate_poses(model, self.t, self.x, self.p, self.r)

    def animate(self, path=None, **options):
        """A self-contained HTML page animating this run in 3-D (eomc.runtime.animate.animate).

        Writes ``path`` if given; returns an :class:`~eomc.runtime.animate.Animation`, which a
        Jupyter notebook displays inline."""
        from .animate import animate
        return animate(self, path, model=options.pop("model", None) or self._model_for("animate()"),
                       **options)

    def __repr__(self):
        s = self.stats
        return (f"<SimulationResult {self.model_name} {self.method}: {len(self.t)} rows, "
                f"t=[{self.t[0] if len(self.t) else float('nan'):.6g}, "
                f"{self.t_final if self.t_final is not None else float('nan'):.6g}], "
                f"steps={s.get('steps')} rejected={s.get('rejected')} nfev={s.get('nfev')}, "
                f"{self.message}>")
