"""compiler/tree/zero_guards.py: a joint limit's side is skipped while its joint is inside the
range, and NAME_implicit gives the numbers of the straight-line build at every state, in the range
or past either side of it.

Why (issues 29, 31): the limits' laws and their slopes were 15 % of gymnasium humanoid's and 17 %
of the ant's NAME_implicit call, computed at every call though a joint is almost always inside
its range, where all of it is zero."""
import warnings

import numpy as np
import sympy as sm

import eomc
import eomc.compiler.tree.emit as tree_emit
from eomc.compiler.contact.law import step
from eomc.compiler.ir import Program
from eomc.compiler.mjcf.model import MjcfModel
from eomc.compiler.tree.joint_laws import ramp
from eomc.compiler.tree.zero_guards import with_threshold_guards

LEG = """<mujoco model="leg">
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="thigh" pos="0 0 1.2">
      <joint name="rootz" type="slide" axis="0 0 1"/>
      <joint name="hip" type="hinge" axis="0 1 0" range="-60 30" damping="0.5"/>
      <geom name="thigh" type="capsule" fromto="0 0 0 0 0 -0.45" size="0.05"/>
      <body name="shin" pos="0 0 -0.45">
        <joint name="knee" type="hinge" axis="0 1 0" range="-150 0"/>
        <geom name="shin" type="capsule" fromto="0 0 0 0 0 -0.45" size="0.04"/>
        <body name="foot" pos="0 0 -0.45">
          <joint name="ankle" type="hinge" axis="0 1 0" range="-45 45"/>
          <geom name="foot" type="capsule" fromto="-0.05 0 0 0.15 0 0" size="0.04"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="hip" gear="50" ctrlrange="-1 1"/><motor joint="knee" gear="50" ctrlrange="-1 1"/></actuator>
</mujoco>
"""


def _symbols():
    q, u, hi, e, b = sm.symbols("q u hi e b", real=True)
    return q, u, hi, e, b, sm.symbols("_t0:6", real=True)


def test_a_limits_term_is_named_and_guarded_by_how_far_past_it_is():
    """tau = -b u + (a side's law, zero while q <= hi): the side's term becomes a temporary (the
    guard's export) and the sum reads it; the clearance is hi - q."""
    q, u, hi, e, b, t = _symbols()
    r = ramp(q - hi)
    program = Program(inputs=(q, u, hi, e, b), ntemp=6, assignments=((t[0], r), (t[1], t[0] + e)),
                      results=((("imp", 0), -b * u + t[0] ** 3 / t[1] ** 2 * (1 + u) * sm.sqrt(u ** 2 + e) * sm.sin(u)),
                               (("imp", 1), 3 * step(q - hi) * t[0] ** 2 / t[1] ** 2)))
    new, guards = with_threshold_guards(program, ())
    assert len(guards) == 1
    clearance, exports, inner = guards[0]
    assert clearance == hi - q and inner == ()
    assert len(set(t for t, _ in new.assignments)) == len(new.assignments)      # no name reused
    res = dict(new.results)
    assert res[("imp", 0)].free_symbols & set(exports)       # the sum reads the named term
    assert not (res[("imp", 0)] - (-b * u)).free_symbols - set(exports)
    # the numbers are the program's, inside the range and past it
    for point in ({q: 0.2, hi: 0.5}, {q: 0.9, hi: 0.5}):
        point.update({u: -0.3, e: 0.01, b: 2.0})
        for key in (("imp", 0), ("imp", 1)):
            assert abs(_value(new, key, point) - _value(program, key, point)) < 1e-12


def _value(program, key, point):
    values = dict(point)
    for t, e in program.assignments:
        values[t] = sm.sympify(e.xreplace(values)).evalf()
    return float(dict(program.results)[key].xreplace(values).evalf())


def test_no_guard_where_the_term_can_be_infinite_or_is_not_zero():
    """A product with a division by the ramp (infinite where the ramp is 0) is not zero there; a
    sum with a term the threshold does not make zero is not either; a cheap term is not worth
    a branch."""
    q, u, hi, e, b, t = _symbols()
    r = ramp(q - hi)
    def one(value):
        return Program(inputs=(q, u, hi, e, b), ntemp=6, assignments=((t[0], r), (t[1], value)),
                       results=((("imp", 0), t[1] + b),))

    term = sm.sin(u) * t[0] ** 2 * u ** 3 * e * sm.sqrt(u ** 2 + e)
    assert len(with_threshold_guards(one(term / (1 + e ** 2)), ())[1]) == 1   # the control: guarded
    assert with_threshold_guards(one(term / step(q - hi)), ())[1] == []       # 0/0 there: not zero
    assert with_threshold_guards(one(term / t[0] ** 2 * sm.cos(t[0])), ())[1] == []   # cos(0) = 1
    cheap = Program(inputs=(q, u, hi, e, b), ntemp=6, assignments=((t[0], r),), results=((("imp", 0), t[0] * u + b),))
    assert with_threshold_guards(cheap, ())[1] == []


def test_a_threshold_inside_another_guard_is_left_to_it():
    q, u, hi, e, b, t = _symbols()
    r = ramp(q - hi)
    program = Program(inputs=(q, u, hi, e, b), ntemp=6,
                      assignments=((t[0], r), (t[1], sm.tanh(t[0]) * sm.sqrt(u ** 2 + e) * b * u ** 3)),
                      results=((("imp", 0), t[1] + b),))
    assert len(with_threshold_guards(program, ())[1]) == 1
    assert with_threshold_guards(program, [(e - 1, (t[1],), ())])[1] == [(e - 1, (t[1],), ())]
    # and one whose temporary an export reads (a pair's choice of its nearest points, a step()
    # inside the pair's block): two guards over one temporary would print it after its reader
    read = Program(inputs=(q, u, hi, e, b), ntemp=6,
                   assignments=((t[0], r), (t[1], sm.tanh(t[0]) * sm.sqrt(u ** 2 + e) * b * u ** 3),
                                (t[2], t[1] * e + u)),
                   results=((("imp", 0), t[2] + b),))
    assert len(with_threshold_guards(read, ())[1]) == 1
    assert with_threshold_guards(read, [(e - 1, (t[2],), ())])[1] == [(e - 1, (t[2],), ())]


def _build(path, cache, guarded):
    shipped = tree_emit.with_threshold_guards
    if not guarded:
        tree_emit.with_threshold_guards = lambda program, guards: (program, list(guards))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return eomc.compile(MjcfModel(path), name="leg", functions=("rhs", "implicit"), cache_dir=cache,
                                progress=False)
    finally:
        tree_emit.with_threshold_guards = shipped


def _implicit(model, X, r):
    ffi = model.ffi
    fp = ffi.addressof(model.model_lib, f"{model.name}_implicit")
    out = np.zeros((len(X), model.metadata["implicit"]["layout"]["size"]))
    for k, x in enumerate(np.ascontiguousarray(X)):
        assert fp(0.0, ffi.from_buffer("double[]", x), model._default_p, ffi.from_buffer("double[]", r),
                  ffi.from_buffer("double[]", out[k]), ffi.NULL) == 0
    return out


def test_the_guarded_implicit_is_the_straight_one_in_and_past_the_range(tmp_path):
    """The leg's NAME_implicit and rhs with its limits' sides guarded against the build without: the same
    outputs (to the order of a sum's terms) at random states inside the range and past either side
    of each limit, and the guards are there (one per side and use)."""
    path = tmp_path / "leg.xml"
    path.write_text(LEG)
    guarded = _build(path, tmp_path / "g", True)
    straight = _build(path, tmp_path / "s", False)
    text = next((tmp_path / "g").rglob("leg.c")).read_text()
    plain = next((tmp_path / "s").rglob("leg.c")).read_text()
    assert text.count("if (!(") >= plain.count("if (!(") + 12      # 3 joints x 2 sides, in both functions
    names = list(guarded.state_names)
    rng = np.random.default_rng(3)
    lo = np.radians([-60.0, -150.0, -45.0])
    hi = np.radians([30.0, 0.0, 45.0])
    X = []
    for k in range(60):
        x = 0.3 * rng.standard_normal(guarded.nx)
        where = k % 3          # inside, past the lower and past the upper bound
        for j, name in enumerate(("hip", "knee", "ankle")):
            i = names.index(f"q_{name}")
            x[i] = (rng.uniform(lo[j], hi[j]) if where == 0 else lo[j] - rng.uniform(0, 0.05) if where == 1
                    else hi[j] + rng.uniform(0, 0.05))
        X.append(x)
    X = np.array(X)
    r = np.array([0.3, -0.7])
    a, b = _implicit(guarded, X, r), _implicit(straight, X, r)
    scale = np.maximum(np.abs(b), 1.0)
    assert np.max(np.abs(a - b) / scale) < 1e-13
    # the rhs's torques too (its guards are among the text's above)
    f, g = guarded.rhs_many(0.0, X, r=r), straight.rhs_many(0.0, X, r=r)
    assert np.max(np.abs(f - g) / np.maximum(np.abs(g), 1.0)) < 1e-13
    past = np.array([k % 3 != 0 for k in range(60)])
    joint = guarded.metadata["implicit"]["layout"]["joint"]
    dq = [joint + 2 * names.index(f"q_{n}") + 1 for n in ("hip", "knee", "ankle")]   # -d(tau)/dq
    assert np.all(a[past][:, dq] != 0.0)        # past a bound: the limit's spring has a slope
    assert np.all(a[~past][:, dq] == 0.0)       # inside: none, the blocks skipped
