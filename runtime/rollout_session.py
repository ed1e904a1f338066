"""``eomc.Rollout``: a rollout set up once and run again and again (reinforcement learning, MPC).

Why: an environment steps its model a few steps at a time (gymnasium's frame_skip: 1-5 steps a
call), thousands of times an episode.  ``eomc.rollout`` checks its arguments, resolves its method,
prepares simulate's options and the fast path's C set-up on every call: ~170-270 us a call on
the hopper, ant and humanoid, against ~20 us for ``mujoco.rollout``'s persistent ``Rollout``
(benchmarks/results/rollout_latency.md, session 52).  A Rollout makes that plan once per span
and row count (runtime/rollout._Plan) and each call runs it: the rows' own checks (finite,
quaternions, constraints, inputs), the C loop, and simulate's verdicts on every row.

A call equals ``eomc.rollout(model, x0s, **options, steps=..., r=...)`` with the options given at
construction, bit for bit, with the same statuses, messages and warnings (tests/runtime/
test_rollout_session.py), except that method=None is resolved on the first call's rows and then
kept (rollout resolves it on each call's: RK4, or implicitfast where RK4 would diverge).
"""
from collections import OrderedDict

import numpy as np

from .events import DEFAULT_MAX_EVENTS
from .rollout import _controls, _params, _Plan, _x0s
from .simulate import IMPLICITFAST_SPLIT

__all__ = ["Rollout"]

PLANS_KEPT = 8      # plans kept per Rollout (one per span and row count; an episode uses one or two)


class Rollout:
    """Integrate many rows of one model with the same options, call after call.

    ``ro = eomc.Rollout(model, dt=0.003)`` takes rollout's options (method, p, threads, record,
    lanes, split, rtol, atol, max_steps, K, x_ref, events, max_events, consistent,
    raise_on_failure); ``ro(x0s, steps=5, r=actions)`` (or ``t_final=``) integrates the rows of
    x0s ((n, nx)) from t = 0 with inputs r as ``rollout`` takes them, and returns a
    RolloutResult.  ``ro.method`` is the method the rows run (None before the first call when
    method=None: it is chosen on the first call's rows, and again after ``set_params``).

    Parameters are set at construction, or by ``ro.set_params(p)`` (domain randomisation: new
    parameters each episode; the plans are made again on the next call, as they hold the fast
    path's depth limits and the energy watch's springs); p with one row per trajectory fixes the
    row count.  Nothing here holds state between calls but the plans: a call's rows start from its
    x0s, at t = 0.
    """

    def __init__(self, model, *, dt=None, method=None, p=None, threads=None, record="final", lanes=False,
                 split=IMPLICITFAST_SPLIT, rtol=1e-6, atol=1e-9, max_steps=100000, K=None, x_ref=None,
                 events=None, max_events=DEFAULT_MAX_EVENTS, consistent=None, raise_on_failure=True):
        # what can be checked without rows: the method, step and record (a span of one step, or of
        # 1 s for an adaptive method, stands for the calls' spans), and the parameters
        stepped = dt is not None
        _Plan.arguments(model, dt, None if stepped else 1.0, 1 if stepped else None, method, record, lanes, rtol)
        self.model, self._method = model, method
        self.set_params(p)
        self._options = dict(dt=dt, threads=threads, record=record, lanes=lanes, split=split, rtol=rtol,
                             atol=atol, max_steps=max_steps, K=K, x_ref=x_ref, events=events,
                             max_events=max_events)
        self.consistent, self.raise_on_failure = consistent, raise_on_failure

    def set_params(self, p):
        """The parameters of the calls from now on: None (the model's defaults), (nparam,) for every
        row or (n, nparam), one row per trajectory (checked now, as rollout checks them).  With
        method=None the method is chosen again on the next call's rows (stiffness is the
        parameters')."""
        rows = np.shape(p)[0] if p is not None and np.ndim(p) == 2 else 1
        self._params = {rows: _params(self.model, p, rows)}      # n -> (P, p_stride)
        self._p = None if p is None else np.array(p, dtype=np.float64)     # a copy: the caller's may change
        self._plans = OrderedDict()     # (n, steps, t_final) -> _Plan
        self.method = self._method

    def __call__(self, x0s, *, steps=None, t_final=None, r=None):
        """The rows of x0s integrated over ``steps`` steps (or to ``t_final``) with inputs r: a
        RolloutResult, as ``eomc.rollout`` returns it."""
        model = self.model
        X0 = _x0s(model, x0s)
        n = X0.shape[0]
        key = (n, steps, t_final)
        plan = self._plans.get(key)
        if plan is None:
            plan = self._plan(X0, n, steps, t_final)
        return plan.run(X0, _controls(model, r, n), r, self.consistent, self.raise_on_failure)

    def _plan(self, X0, n, steps, t_final):
        # one parameter row serves any row count; one per trajectory, only theirs (_params says so)
        params = self._params.get(n) or self._params.get(1) or _params(self.model, self._p, n)
        P, p_stride = params
        plan = _Plan(self.model, X0, P, p_stride, steps=steps, t_final=t_final, method=self.method,
                     **self._options)
        if self.method is None:     # chosen on these rows; kept, so every call runs the same method
            # (without dt, "auto" itself: it picks per row as simulate does, switching stiff rows to Radau)
            self.method = "auto" if plan.auto else plan.method
        self._plans[(n, steps, t_final)] = plan
        while len(self._plans) > PLANS_KEPT:
            self._plans.popitem(last=False)
        return plan

    def __getstate__(self):
        """Pickled without its plans (C structs; made again on the next call): a Rollout travels to a
        worker process with its model (which pickles by content) and its options."""
        state = dict(self.__dict__)
        state["_plans"] = OrderedDict()
        state["method"] = self._method
        return state

    def __repr__(self):
        return (f"<eomc.Rollout of {self.model.name}: method {self.method or 'chosen on the first call'}, "
                f"dt {self._options['dt']}>")
