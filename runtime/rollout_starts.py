"""Rollout rows started as ``simulate`` starts them: on the model's constraints.

Why: a model with configuration or velocity constraints (dm_control's manipulator, quadruped and
stacker: MJCF equality constraints and tendons) must start on them, and ``simulate`` completes a
start that is off them (its ``consistent=None`` default: runtime/simulate.checked_start).
``rollout`` promised each row equal to ``simulate`` of that start bit for bit, but ran every row as
given: a start with random joint speeds (what a Monte Carlo or RL reset makes) then followed the
wrong motion with status 0 and no warning (session 52's rollout sweep over the 31 MJCF files:
manipulator's rows ended up to 0.24 away from simulate's, quadruped's and stacker's too).  Here
every row goes through the same check; one warning for the rows that moved.

The check is one C pass over every row where all rows share their parameters and inputs (the
usual case: 10,000 rows in milliseconds), else a pass per row; only rows off the constraints (or
every row, with consistent=True) are completed, row by row, by simulate's own code.
"""
import warnings

import numpy as np

from .errors import ModelError
from .rollout_extras import _row_inputs, _row_r
from .simulate import _along, _user_level, checked_start


def _off_rows(model, X0, P, p_stride, controls, atol):
    """Indices of the rows whose start is off the constraints by more than simulate's limit, in one
    C pass when every row shares p and r (else None: the caller checks row by row)."""
    if p_stride != 0 or controls[3] != 0:
        return None
    n_r, r_t, r_v = _row_inputs(controls, 0, model.ninput)
    n = X0.shape[0]
    g = np.abs(_along(model, dict(p=np.ascontiguousarray(P[0]), n_r=n_r, r_t=r_t, r_v=r_v), 1,
                      np.zeros(n), X0))
    limit = max(1e-8, 10 * float(atol))
    return np.flatnonzero(~(g <= limit).all(axis=1))


def starts_on_constraints(model, X0, P, p_stride, controls, atol, consistent):
    """X0 with each row handled as ``simulate(x0=row, consistent=consistent)`` handles its start:
    consistent=None completes a row off the constraints (keeping the independent coordinates and
    speeds), True completes every row, False runs them as given; one ConstraintWarning for the
    rows that were off.  A row that cannot be completed raises ModelError naming it."""
    if model.nhol + model.nvel == 0 or model.c_model.constraints == model.ffi.NULL:
        return X0
    n = X0.shape[0]
    rows = range(n) if consistent else _off_rows(model, X0, P, p_stride, controls, atol)
    if rows is None:
        rows = range(n)
    out, seen = X0, []
    for i in rows:
        given = X0[i]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                x = checked_start(model, given, (0.0, 1.0), P[0 if p_stride == 0 else i, :-1],
                                  _row_r(controls, i, model.ninput), atol, consistent)
            except ModelError as error:
                raise ModelError(f"x0s row {i} of {n}: {error}") from None
        if caught:
            seen.append((i, caught[0]))
        if x is not given:
            if out is X0:
                out = X0.copy()
            out[i] = x
    if seen:
        first = seen[0][1]
        which = ", ".join(str(i) for i, _ in seen[:8]) + (", ..." if len(seen) > 8 else "")
        warnings.warn(first.category(f"{len(seen)} of {n} rows of x0s (rows {which}); row {seen[0][0]}: "
                                     f"{first.message}"), stacklevel=_user_level())
    return out
