"""Body poses from the generated ``NAME_poses``: labelled positions and rotations, one time or many.

The C function writes, per body frame, its origin (3) and rotation matrix (9,
row-major: columns are the body axes in world components), then each named
point's position (3).  The names come from NAME.json (``poses``), checked
against the library's own ``NAME_pose_count`` so a stale or edited JSON cannot
make the C write past the buffer.
"""
from dataclasses import dataclass

import numpy as np

from eomc.runtime.errors import ModelError

from .metadata import LoadError

__all__ = ["Poses", "pose_kernel", "pose_layout", "evaluate_poses"]


@dataclass(frozen=True)
class Poses:
    """Where the bodies are: at one time (no leading axis) or along a trajectory (n_t first).

    ``positions[..., i, :]`` / ``rotations[..., i, :, :]``: origin and rotation matrix of
    frame ``frame_names[i]`` in the world; ``points[..., j, :]``: point ``point_names[j]``.
    ``lines``: (j, k) pairs of point indices a default drawing joins.
    """
    t: object
    frame_names: tuple
    point_names: tuple
    positions: np.ndarray
    rotations: np.ndarray
    points: np.ndarray
    lines: tuple = ()

    def __getitem__(self, name):
        """Position of a body frame's origin or of a point, by name."""
        if name in self.frame_names:
            return self.positions[..., self.frame_names.index(name), :]
        if name in self.point_names:
            return self.points[..., self.point_names.index(name), :]
        raise KeyError(f"{name!r} is no body or point of the poses; bodies: "
                       f"{', '.join(self.frame_names) or 'none'}; points: {', '.join(self.point_names) or 'none'}")

    def rotation(self, name):
        """Rotation matrix of body ``name`` (columns: its axes in world components)."""
        if name not in self.frame_names:
            raise KeyError(f"{name!r} is no body frame; bodies: {', '.join(self.frame_names) or 'none'}")
        return self.rotations[..., self.frame_names.index(name), :, :]

    def names(self):
        return self.frame_names + self.point_names


def pose_layout(model):
    """(frame names, point names, lines, size) from the metadata, type-checked (once per model)."""
    cached = getattr(model, "_pose_layout", None)
    if cached is not None:
        return cached
    meta = model.metadata.get("poses")
    if "poses" not in model.functions or not isinstance(meta, dict):
        raise ModelError(f"model {model.name!r} was built without `poses` (its bodies' positions); "
                         f"rebuild it with the default functions or with functions including 'poses' "
                         f"(eomc build --outputs ...,poses)")
    frames, points, lines = meta.get("frames"), meta.get("points"), meta.get("lines", [])
    ok = (isinstance(frames, list) and isinstance(points, list) and isinstance(lines, list)
          and all(isinstance(n, str) for n in frames + points)
          and all(isinstance(pair, list) and len(pair) == 2 and all(isinstance(i, int) and 0 <= i < len(points)
                                                                   for i in pair) for pair in lines))
    if not ok:
        raise LoadError(f"{model.directory / (model.name + '.json')}: 'poses' must list frame and point "
                        f"names and point-index lines; rebuild the model (eomc build)")
    model._pose_layout = (tuple(frames), tuple(points), tuple(tuple(p) for p in lines),
                          12 * len(frames) + 3 * len(points))
    return model._pose_layout


def pose_kernel(model):
    """fn(t, x (float64 nx), p, r, out) -> status over ``NAME_poses``, its size checked once."""
    cached = getattr(model, "_pose_kernel", None)
    if cached is not None:
        return cached
    frames, points, _, size = pose_layout(model)
    import cffi
    ffi = cffi.FFI()
    ffi.cdef(f"int {model.name}_poses(double t, const double *x, const double *p, const double *r, "
             f"double *out, double *work);\nint {model.name}_pose_count(void);")
    try:
        lib = ffi.dlopen(str(model.library_path))
        fn, count = getattr(lib, f"{model.name}_poses"), getattr(lib, f"{model.name}_pose_count")
    except (OSError, AttributeError) as exc:
        raise LoadError(f"cannot find {model.name}_poses in {model.library_path}: {exc}; "
                        f"rebuild the model") from None
    if int(count()) != size:
        raise LoadError(f"{model.library_path}: {model.name}_poses writes {int(count())} numbers but "
                        f"{model.name}.json names {size}; rebuild the model")
    work = np.empty(max(model.work_size, 1))
    frombuf = ffi.from_buffer
    null = ffi.NULL
    work_ptr = frombuf("double[]", work)
    default_p = np.ascontiguousarray(model.param_defaults)
    default_p_ptr = frombuf("double[]", default_p) if default_p.size else null

    def kernel(t, x, p, r, out):
        pp = default_p_ptr if p is default_p else (null if p is None or p.size == 0 else frombuf("double[]", p))
        return fn(t, frombuf("double[]", x), pp, null if r is None or r.size == 0 else frombuf("double[]", r),
                  frombuf("double[]", out), work_ptr)
    kernel.default_p = default_p
    kernel.lib = lib   # keep the library open as long as the kernel lives

    many = getattr(getattr(model, "integrators", None), "eomc_mat_rows", None)
    failed = ffi.new("size_t *")

    def rows(t, X, p, r, out):
        """kernel along rows X (n, nx) into out (n, size) with one p and r, t (n,) float64: one C
        call (eomc_mat_rows of the integrator library, runtime/c/eomc_rows.c) calls NAME_poses row
        after row (the verdicts evaluate every output row of a run: runtime/pair_check.py,
        ground_check.py); the first failing row's index and status, or (-1, 0)."""
        pp = default_p_ptr if p is default_p else (null if p is None or p.size == 0 else frombuf("double[]", p))
        rp = null if r is None or r.size == 0 else frombuf("double[]", r)
        xp, op, nx = frombuf("double[]", X), frombuf("double[]", out), X.shape[1]
        if many is not None:
            status = many(fn, len(X), frombuf("double[]", t), xp, nx, pp, rp, op, size, work_ptr, failed)
            return (int(failed[0]), status) if status else (-1, 0)
        for i in range(len(X)):     # an integrator library older than eomc_mat_rows (rebuilt at install)
            status = fn(float(t[i]), xp + i * nx, pp, rp, op + i * size, work_ptr)
            if status:
                return i, status
        return -1, 0
    kernel.rows = rows
    kernel.rows_in_c = many is not None
    model._pose_kernel = kernel
    return kernel


def _split(flat, nf, npt):
    lead = flat.shape[:-1]
    frames = flat[..., :12 * nf].reshape(lead + (nf, 12))
    return (frames[..., :3], frames[..., 3:].reshape(lead + (nf, 3, 3)),
            flat[..., 12 * nf:].reshape(lead + (npt, 3)))


def _params(model, p):
    if p is None:
        return pose_kernel(model).default_p
    if isinstance(p, dict):
        return model._named(p, model.param_names, model.param_defaults, "parameter")
    return np.ascontiguousarray(model._array(p, (model.nparam,), "p (parameters)", model.param_names))


def _inputs(model, r):
    if model.ninput == 0 or r is None:
        if r is not None and np.size(r) != 0:
            raise ValueError(f"{model.name}: this model has no inputs, but r was given")
        return np.zeros(model.ninput)
    if isinstance(r, dict):
        return model._named(r, model.input_names, np.zeros(model.ninput), "input")
    return np.ascontiguousarray(model._array(r, (model.ninput,), "r (inputs)", model.input_names))


def evaluate_poses(model, t, X, p=None, r=None):
    """:class:`Poses` at time ``t`` and state ``X`` (nx,), or along (n_t,) times and (n_t, nx) states.

    ``r``: inputs, constant or (n_t, ninput) rows.
    """
    frames, points, lines, size = pose_layout(model)
    kernel = pose_kernel(model)
    t_arr = np.asarray(t, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    single = X.ndim == 1
    p0 = _params(model, p)
    if single:
        t0, x0 = model._time(t), model._state(X)
        r0 = _inputs(model, r)
        out = np.empty(size)
        status = kernel(t0, x0, p0, r0, out)
        if status:
            model._fail("poses", status, t0, x0, inputs=(p, r))
        pos, rot, pts = _split(out, len(frames), len(points))
        return Poses(float(t_arr), frames, points, pos, rot, pts, lines)
    if X.ndim != 2 or X.shape[1] != model.nx or t_arr.shape != (X.shape[0],):
        raise ValueError(f"poses along a trajectory need t of shape (n,) and x of shape (n, {model.nx}); "
                         f"got {t_arr.shape} and {X.shape}")
    R = None if r is None else np.asarray(r, dtype=np.float64)
    rows = R is not None and R.ndim == 2
    r0 = None if rows else _inputs(model, r)
    out = np.empty((len(X), size))
    if not rows and len(X):
        Xc = np.ascontiguousarray(X)
        i, status = kernel.rows(np.ascontiguousarray(t_arr), Xc, p0, r0, out)
        if status:
            model._fail("poses", status, float(t_arr[i]), Xc[i], inputs=(p, r))
    for i in range(len(X) if rows else 0):
        ri = _inputs(model, R[i]) if rows else r0
        xi = np.ascontiguousarray(X[i])
        status = kernel(float(t_arr[i]), xi, p0, ri, out[i])
        if status:
            model._fail("poses", status, float(t_arr[i]), xi, inputs=(p, r))
    pos, rot, pts = _split(out, len(frames), len(points))
    return Poses(t_arr, frames, points, pos, rot, pts, lines)
