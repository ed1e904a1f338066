"""The lanes rollout's energy watch reads the energy from the fixed step's own terms.

Why: a fast-path rollout keeps each row's energy range over every step (eomc_options.watch_output)
for simulate's energy verdict, and called NAME_energy after every step: 19-20 % of G1's lanes
rollout (session 18).  A model built with implicit_batch has NAME_implicit's out[] end with the
energy (compiler/tree/lower.implicit_layout "energy"; a pairs' table's points' elastic energy summed
by its slopes loop: contact/table.Table.energy_at, session 32), and the step makes those terms at
every step's end anyway (eomc_fixedstep.c), so the watch reads the value there (eomc_integrators.c
fs_watch).

Oracles: the model's own energy output at random states, and the watch's ranges with the shortcut
turned off (the struct's ``energy`` flag cleared: every step calls NAME_energy, as before)."""
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import eomc
import eomc.runtime.rollout as rollout_module
from tests.compiler.contact.test_narrow import LIMBS
from tests.helpers.implicit_call import implicit_terms_at

WATCHED = ("rhs", "outputs", "energy", "implicit", "implicit_batch")


def _build(path, name, tmp, functions=WATCHED, pairs=None):
    from eomc.compiler.mjcf.model import MjcfModel
    with warnings.catch_warnings():      # the files' self-collision pairs, where left out, say so
        warnings.simplefilter("ignore")
        spec = MjcfModel(path) if pairs is None else MjcfModel(path, pairs=pairs)
        return eomc.compile(spec, name, functions=functions, cache_dir=tmp / "cache", progress=False)


@pytest.fixture(scope="module")
def hopper(tmp_path_factory):
    gymnasium = pytest.importorskip("gymnasium")
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    return _build(path, "ew_hopper", tmp_path_factory.mktemp("ewh"))


# test_narrow's limbs (capsules and spheres on a free trunk, and a free ball) on a floor
FLOORED = LIMBS.replace("<worldbody>", '<worldbody><geom name="floor" type="plane" size="5 5 0.1"/>', 1)


@pytest.fixture(scope="module")
def limbs(tmp_path_factory):
    """Body-body pairs through the pairs' table, and ground contacts: the slot holds the pairs'
    energy as the table's slopes loop sums it."""
    tmp = tmp_path_factory.mktemp("ewl")
    path = tmp / "limbs.xml"
    path.write_text(FLOORED)
    return _build(path, "ew_limbs", tmp, pairs=True)


def _energy(model, x):
    return float(model.outputs(0.0, x)["energy"])


def test_the_slot_is_the_energy_output(hopper):
    info = hopper.metadata["implicit"]
    assert info["layout"]["energy"] == info["layout"]["size"] - 1 and "energy_apart" not in info
    rng = np.random.default_rng(4)
    x0 = np.array(hopper.initial_state, dtype=float)
    for _ in range(40):
        x = x0 + rng.normal(scale=0.3, size=hopper.nx)
        x[1] = rng.uniform(0.9, 1.3)         # rootz: some states with the foot in the floor
        out, layout = implicit_terms_at(hopper, x)
        e = _energy(hopper, x)
        assert abs(out[layout["energy"]] - e) <= 1e-12 * (1 + abs(e))


def test_only_a_model_built_for_the_lanes_has_the_slot(hopper, tmp_path):
    gymnasium = pytest.importorskip("gymnasium")
    path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    plain = _build(path, "ew_plain", tmp_path, functions=("rhs", "outputs", "energy", "implicit"))
    layout = plain.metadata["implicit"]["layout"]
    assert "energy" not in layout and layout["size"] == hopper.metadata["implicit"]["layout"]["size"] - 1


def test_the_slot_holds_the_tables_pairs_too(limbs):
    """The table's pairs' elastic energy is the loop's own sum (table.Table.energy_at), in its order:
    equal to the energy output's to rounding while two or more points touch (measured: 2 ulp of the
    energy on gymnasium's humanoid, 1823 random states with a pair in touch, session 32), to the bit
    with one or none (a + b is b + a).  The bound here: 4 ulp of the energy."""
    info = limbs.metadata["implicit"]
    pairs = [k for k, c in enumerate(info["contacts"]) if c.get("pair")]
    assert len(pairs) >= 8 and "energy_apart" not in info
    rng = np.random.default_rng(5)
    touching = several = apart = 0
    for _ in range(300):
        x = rng.normal(scale=0.6, size=limbs.nx)
        out, layout = implicit_terms_at(limbs, x)
        depth = np.array([out[layout["contact"] + 25 * k] for k in pairs])
        e = _energy(limbs, x)
        touching += (depth > 0).sum() == 1
        several += (depth > 0).sum() > 1
        apart += not (depth > 0).any()
        bound = 4 * np.spacing(abs(e)) if (depth > 0).sum() > 1 else 1e-12 * (1 + abs(e))
        assert abs(out[layout["energy"]] - e) <= bound
    assert touching >= 10 and several >= 3 and apart >= 10


def _ranges(model, X0, monkeypatch, shortcut, **kw):
    """(the rows' energy ranges (lo, hi) the rollout's watch kept, its result, how many times the
    watch called NAME_energy): the watch's function is counted through a callback."""
    seen = {"calls": 0}
    verdicts = rollout_module._energy_verdicts
    energy_fn = rollout_module._energy_fn

    def spy(*args, **kwargs):
        seen["ranges"] = np.array([(w["lo"], w["hi"]) for w in args[-1]])     # switching.watched_stats
        return verdicts(*args, **kwargs)

    def counted(m, ffi):
        real = energy_fn(m, ffi)

        @ffi.callback("int(double, const double *, const double *, const double *, double *, double *)")
        def call(t, x, p, r, out, work):
            seen["calls"] += 1
            return real(t, x, p, r, out, work)
        seen["keep"] = call
        return call
    monkeypatch.setattr(rollout_module, "_energy_verdicts", spy)
    monkeypatch.setattr(rollout_module, "_energy_fn", counted)
    if not shortcut:
        run = rollout_module.implicit_for_run

        def without(*args, **kwargs):
            st, keep = run(*args, **kwargs)
            st.energy = 0           # the watch calls NAME_energy at every step, as before
            return st, keep
        monkeypatch.setattr(rollout_module, "implicit_for_run", without)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = eomc.rollout(model, X0, method="implicitfast", raise_on_failure=False, threads=1, **kw)
    monkeypatch.undo()
    return seen["ranges"], res, seen["calls"]


@pytest.mark.parametrize("lanes", [False, True])
def test_the_watch_keeps_the_same_ranges(hopper, monkeypatch, lanes):
    X0 = np.tile(np.array(hopper.initial_state, dtype=float), (9, 1))
    X0[:, hopper.nq:] = np.random.default_rng(1).uniform(-0.5, 0.5, (9, hopper.nu))
    kw = dict(dt=0.008, steps=60, lanes=lanes)
    got, res, calls = _ranges(hopper, X0, monkeypatch, True, **kw)
    want, ref, plain = _ranges(hopper, X0, monkeypatch, False, **kw)
    assert plain == len(X0) * 61 and calls == len(X0)       # each row's start only
    assert np.array_equal(res.x, ref.x) and np.array_equal(res.status, ref.status)
    assert np.isfinite(want).all() and (want[:, 1] > want[:, 0]).all()
    assert np.allclose(got, want, rtol=1e-12, atol=0)


def test_the_watch_reads_the_slot_while_a_tables_pair_touches(limbs, monkeypatch):
    """The limbs' ball dropped onto the trunk lying on the floor: while their pair touches, the slot
    holds its elastic energy too, so the watch never calls NAME_energy past each row's start (until
    session 32 it did at every such step: 11-13 % of gymnasium's humanoid's lanes rollout); the
    ranges equal the plain watch's."""
    names = list(limbs.state_names)
    x0 = np.array(limbs.initial_state, dtype=float)
    x0[names.index("q_joint0_z")] = 0.05                 # the trunk on the floor
    x0[names.index("q_joint3_y")] -= 0.1                 # the ball above it
    x0[names.index("q_joint3_z")] = 0.25
    X0 = np.tile(x0, (3, 1))
    X0[:, names.index("q_joint3_z")] += [0.0, 0.02, 0.04]
    kw = dict(dt=0.002, steps=200)
    info = limbs.metadata["implicit"]
    pairs = sum(1 for c in info["contacts"] if c.get("pair"))
    pair_depths = [n for n in limbs.output_names if n.startswith("depth_")][-pairs:]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = limbs.simulate(X0[0], (0.0, 0.4), method="implicitfast", dt=0.002)
    assert max(run.outputs[n].max() for n in pair_depths) > 0       # a table's pair touched
    got, res, calls = _ranges(limbs, X0, monkeypatch, True, **kw)
    want, ref, plain = _ranges(limbs, X0, monkeypatch, False, **kw)
    assert plain == len(X0) * 201 and calls == len(X0)      # each row's start only
    assert np.array_equal(res.x, ref.x)
    assert np.allclose(got, want, rtol=1e-12, atol=0)


@pytest.fixture(scope="module")
def limbs_quaternion(tmp_path_factory):
    """The floored limbs with quaternions (two free joints and a ball joint: three quaternions) and
    its floor contacts only (pairs=False: no energy_apart), so the slot holds the whole energy."""
    from eomc.compiler.mjcf.model import MjcfModel
    tmp = tmp_path_factory.mktemp("ewq")
    path = tmp / "limbs.xml"
    path.write_text(FLOORED)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path, orientation="quaternion", pairs=False), "ew_limbs_quat", functions=WATCHED,
                            cache_dir=tmp / "cache", progress=False)


@pytest.mark.parametrize("lanes", [False, True])
def test_the_watch_reads_the_slot_with_quaternions(limbs_quaternion, monkeypatch, lanes):
    """A quaternion model's watch reads the energy from the step's terms too (session 28; before, it
    called NAME_energy at every step: the quaternion rollouts 5-12 % slower than the Euler ones).  The
    terms were made at the step's end before its quaternions were normalised; the energy does not see
    a quaternion's length (quaternion_rotation), so the ranges equal, to rounding, those of NAME_energy
    at the normalised states.  Rows start turned and spinning and land on the floor."""
    m = limbs_quaternion
    assert len(m.quaternions) == 3 and "energy_apart" not in m.metadata["implicit"]
    rng = np.random.default_rng(7)
    X0 = np.tile(np.array(m.initial_state, dtype=float), (6, 1))
    for i in m.quaternions:
        X0[:, i:i + 4] = rng.normal(size=(6, 4))
        X0[:, i:i + 4] /= np.linalg.norm(X0[:, i:i + 4], axis=1)[:, None]
    X0[:, m.nq:] = rng.uniform(-2.0, 2.0, (6, m.nu))
    kw = dict(dt=0.002, steps=150, lanes=lanes)
    got, res, calls = _ranges(m, X0, monkeypatch, True, **kw)
    want, ref, plain = _ranges(m, X0, monkeypatch, False, **kw)
    assert plain == len(X0) * 151 and calls == len(X0)       # each row's start only
    assert np.array_equal(res.x, ref.x) and np.array_equal(res.status, ref.status)
    assert (res.status == 0).all()
    names = list(m.output_names)
    touched = [max(m.outputs(0.0, x)[n] for n in names if n.startswith("depth_")) > 0 for x in res.x]
    assert any(touched)
    assert np.isfinite(want).all() and (want[:, 1] > want[:, 0]).all()
    assert np.allclose(got, want, rtol=1e-12, atol=0)


def _rise_rows(text):
    """The rows a rollout's energy warning names (its '(rows 1, 2, ...)'), as a set."""
    found = re.search(r"\(rows ([\d, ]+)(, \.\.\.)?\)", text)
    return {int(k) for k in found.group(1).split(", ")} if found else set()


def test_a_rise_given_back_before_the_end_warns_in_every_record_as_in_simulate(tmp_path):
    """Issue 29 item 1 (session 23): the total energy's rise above its running minimum is kept by the
    C watch (eomc_stats.watch_rise ...), so a rollout row warns of a rise it gave back before the end
    with record="final" (scalar and lanes) as with record="steps", and as simulate does at every step
    and with t_eval at the start and the end only.  The thrown ball at 2 ms: some rows, sliding and
    spinning in contact, gain a little energy and lose it again to friction.  Oracles: the model's
    own energy output along the recorded steps (the test's running minimum: the rise, where it rose
    most in one step, and the end below the start's + tolerance, so start-and-end alone cannot see
    it) and the contact's depth there (the words name it).  Until session 23 record="final" and a
    sparse t_eval judged the start and the end only: silent on these rows."""
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    from eomc.runtime.switching import PhysicsWarning, energy_tolerance
    from tests.runtime.test_rollout import thrown_ball
    m, x0 = thrown_ball(tmp_path, "rw_ball",
                        functions=tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST) + ("implicit_batch",))
    kw = dict(dt=0.002, steps=300, method="implicitfast", threads=2, raise_on_failure=False)
    said = {}
    for name, extra in (("steps", dict(record="steps")), ("final", {}), ("lanes", dict(lanes=True))):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = eomc.rollout(m, x0, **extra, **kw)
        said[name] = " ".join(str(w.message) for w in caught if issubclass(w.category, PhysicsWarning)
                              and "above its lowest value" in str(w.message))
        if name == "steps":
            steps = res
    rows = _rise_rows(said["steps"])
    assert rows and _rise_rows(said["final"]) == rows == _rise_rows(said["lanes"]), said
    t = np.append(0.002 * np.arange(300), 0.6)
    given_back = 0
    for i in range(16):
        E = np.array([m.outputs(tk, x)["energy"] for tk, x in zip(t, steps.x[i])], dtype=float)
        low = np.minimum.accumulate(E)
        k1 = int(np.argmax(E - low))
        rise = float(E[k1] - low[k1])
        scale = max(abs(E[0]), float(np.max(np.abs(E - E[0]))))
        tol = energy_tolerance(1e-6, 1e-9) * scale
        words = {}
        for how, t_eval in (("every step", None), ("ends", [0.0, 0.6])):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                one = m.simulate(x0[i], (0.0, 0.6), method="implicitfast", dt=0.002, t_eval=t_eval)
            words[how] = [str(w.message) for w in caught if "above its lowest value" in str(w.message)]
        assert np.array_equal(one.x[-1], steps.x[i, -1])
        assert (i in rows) == (rise > tol) == bool(words["every step"]) == bool(words["ends"]), (i, rise, tol)
        if i not in rows:
            continue
        assert words["every step"] == words["ends"]
        assert f"rose by {rise:.3g} above its lowest value" in words["every step"][0]
        given_back += E[-1] - E[0] <= tol
        # the step where it rose most within the rise, and the ball in contact at its end
        k0 = int(np.argmin(E[:k1 + 1]))
        j = k0 + 1 + int(np.argmax(np.diff(E[k0:k1 + 1])))
        where = f"its largest one-step rise in the step to t = {t[j]:.6g} s"
        assert where in words["every step"][0], words
        touching = m.outputs(t[j], steps.x[i, j])["depth_ball"] > 0
        assert ("ball" in words["every step"][0].split(where)[1].split(")")[0]) == touching
    assert given_back >= 1          # the end below the start's + tolerance: start-and-end alone is silent


def test_the_rows_allowances_in_one_pass_are_each_rows_own(hopper):
    """rollout's energy verdict sizes the allowance of all its rows at once (switching.
    energy_allowances); each row's held energy and sprung flag must be bit for bit what
    energy_allowance gives that row alone: rows inside their range, past one limit or two, the
    same start twice, and starts in contact."""
    from eomc.runtime.switching import _bounds, _indices, energy_allowance, energy_allowances, find_switches
    sw = find_switches(hopper)
    p = np.append(np.asarray(hopper.param_defaults, dtype=float), 0.0)
    _, _, _, limit_at = _bounds(sw, p)
    ix = _indices(sw)
    assert len(limit_at) >= 2
    x0 = hopper.initial_state if hopper.initial_state is not None else np.zeros(hopper.nx)
    X0 = np.tile(x0, (6, 1))
    for row, (j, past) in enumerate([(0, 0.3), (1, 0.05), (0, 0.3), (0, -0.2)]):
        X0[row + 1, ix["state"][j]] = limit_at[j] + ix["sign"][j] * past
    X0[5] = X0[2]
    X0[5, ix["state"][0]] = limit_at[0] + ix["sign"][0] * 0.1
    touching = np.array([False, True, False, False, True, False])
    held, sprung = energy_allowances(hopper, p, X0, touching, sw)
    alone = [energy_allowance(hopper, p, X0[k], bool(touching[k]), sw) for k in range(len(X0))]
    assert np.array([a[0] for a in alone]).tobytes() == held.tobytes()
    assert [a[1] for a in alone] == sprung.tolist()
    assert np.count_nonzero(held) >= 3         # the starts past a limit hold spring energy


def test_the_verdict_reads_each_rows_energy_by_name_energy_and_the_outputs_only_where_it_rose(hopper, monkeypatch):
    """Session 52: the verdict evaluated the whole outputs at every row's start and end for one
    number (gymnasium's humanoid: 2.6 ms of a 2.9 ms rollout of 64 rows x 1 step).  The energy now
    comes from NAME_energy -- the outputs' own expression, the same bits -- and the whole outputs
    only for the rows whose energy rose.  Oracles: the outputs' energy column; the statuses and
    messages of the unchecked step (split=0: rows that create energy) with the outputs forced."""
    X0 = np.tile(np.array(hopper.initial_state, dtype=float), (24, 1))
    X0[:, hopper.nq:] = np.random.default_rng(7).uniform(-0.5, 0.5, (24, hopper.nu))
    res = eomc.rollout(hopper, X0, dt=0.008, steps=40, method="implicitfast", split=0.0, raise_on_failure=False)
    P, p_stride = rollout_module._params(hopper, None, len(X0))
    t, X = np.array([0.0, 0.32]), np.stack([X0, res.x], axis=1)
    E = rollout_module._row_energies(hopper, np.arange(len(X0)), t, X, P, p_stride, (0, None, None, 0))
    np.testing.assert_array_equal(E, [[_energy(hopper, x) for x in pair] for pair in X])
    kw = dict(dt=0.008, steps=125, method="implicitfast", split=0.0, raise_on_failure=False)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        fast = eomc.rollout(hopper, X0, **kw)
    asked = []
    real = rollout_module._row_outputs
    monkeypatch.setattr(rollout_module, "_row_outputs", lambda *a: asked.append(len(a[2])) or real(*a))
    eomc.rollout(hopper, X0, **kw)
    assert 0 < sum(asked) < len(X0)           # only the rows whose energy rose
    monkeypatch.setattr(rollout_module, "_row_energies", lambda *a: None)     # the whole outputs, as before
    monkeypatch.setattr(rollout_module, "_screened", lambda *a: None)         # and the first look in numpy
    with warnings.catch_warnings(record=True) as before:
        warnings.simplefilter("always")
        old = eomc.rollout(hopper, X0, **kw)
    assert (fast.status == 20).any()           # the unchecked step created energy in some rows
    np.testing.assert_array_equal(fast.status, old.status)
    assert fast.messages == old.messages and [str(w.message) for w in seen] == [str(w.message) for w in before]


def _numpy_look(E, cols, rtol, known):
    """The verdict's first look as _energy_verdicts wrote it in numpy before eomc_energy_screen:
    which rows' energy rose beyond rtol of its scale, or whose total rose above its running minimum."""
    seen = np.concatenate([E[:, :1], cols["lo"][:, None], cols["hi"][:, None], E[:, 1:]], axis=1)
    with np.errstate(invalid="ignore"):
        scale = np.maximum(np.maximum(np.abs(seen[:, 0]), np.abs(seen - seen[:, :1]).max(axis=1)), 1e-300)
        gain, tol = seen.max(axis=1) - seen[:, 0], rtol * scale
        risen = np.zeros(len(E), dtype=bool)
        if known:
            T0 = cols["total0"]
            tscale = np.maximum.reduce([np.abs(T0), cols["total_hi"] - T0, T0 - cols["total_lo"],
                                        np.full(T0.shape, 1e-300)])
            risen = cols["rise"] > rtol * tscale
    return (gain > tol) | risen


def _screen(model, X0, Xl, P, p_stride, status, stats, rtol, known):
    """(E, flags, count): eomc_energy_screen called directly, its total_known given."""
    ffi, n = model.ffi, len(X0)
    fn, zeros = rollout_module._energy_rows_fn(model)
    E, flag, work = np.empty((n, 2)), np.empty(n, dtype=np.uint8), np.empty(max(int(model.work_size), 1))
    Pc, buf = np.ascontiguousarray(P), ffi.from_buffer
    count = model.integrators.eomc_energy_screen(
        fn, n, 0.5, buf("double[]", np.ascontiguousarray(X0)), buf("double[]", np.ascontiguousarray(Xl)), model.nx,
        buf("double[]", Pc), Pc.shape[1] if p_stride else 0, buf("double[]", zeros), 0, buf("int[]", status), stats,
        int(known), rtol, buf("double[]", E), buf("unsigned char[]", flag), buf("double[]", work))
    return E, flag.astype(bool), int(count)


def _edge(E0, rtol):
    """(the largest watch_hi numpy's look does not flag, the next double, which it does) for a row
    whose start and end energies are both E0 and lowest value E0 (scale |E0|)."""
    tol = rtol * max(abs(E0), 1e-300)
    hi = E0 + tol
    while hi - E0 > tol:
        hi = np.nextafter(hi, -np.inf)
    while not hi - E0 > tol:
        hi = np.nextafter(hi, np.inf)
    return np.nextafter(hi, -np.inf), hi


@pytest.mark.parametrize("known", [True, False])
def test_the_first_look_in_c_is_numpys(hopper, known):
    """eomc_energy_screen (runtime/c/eomc_rows.c) flags the rows numpy's look flagged, NaN and the
    tolerance's edge included, and gives NAME_energy's start and end values (NaN for a row not run).
    Why: a rollout with nothing flagged returns without any more of the verdict (~45 of a one-row
    Rollout call's ~75 us were that numpy), so a row it missed would keep status 0 on created energy."""
    from eomc.runtime.rollout_result import _rollout_ffi
    rng = np.random.default_rng(11)
    n, rtol = 400, 1e-4
    x0 = np.array(hopper.initial_state, dtype=float)
    X0 = x0 + rng.normal(scale=0.2, size=(n, hopper.nx))
    Xl = x0 + rng.normal(scale=0.2, size=(n, hopper.nx))
    Xl[:2] = X0[:2]                                     # rows 0 and 1: the tolerance's edge, below
    P, p_stride = rollout_module._params(hopper, None, n)
    E_ref = np.array([[_energy(hopper, a), _energy(hopper, b)] for a, b in zip(X0, Xl)])
    status = np.zeros(n, dtype=np.intc)
    status[3::37] = 20                                  # rows not run to the end: not looked at
    E0, span = E_ref[:, 0], np.abs(E_ref[:, 0]) + 1.0
    cols = {"lo": E0 - rng.uniform(0, 1, n) * span, "total0": E0.copy(), "total_lo": E0 - span, "total_hi": E0 + span,
            "hi": E0 + rng.choice([0.0, 1e-7, 1e-5, 1e-3], n) * span, "rise": rng.choice([0.0, 1e-7, 1e-5, 1e-3], n) * span}
    cols["lo"][:2], cols["rise"][:2] = E0[:2], 0.0
    cols["hi"][0], cols["hi"][1] = _edge(E0[0], rtol)
    for k, name in zip((5, 6, 7, 8, 9), ("lo", "hi", "total0", "rise", "total_hi")):
        cols[name][k] = np.nan                          # NaN anywhere: not flagged (numpy's maximum carries it)
    cols["hi"][5], cols["rise"][5] = 1e3 * span[5], 0.0     # (row 5: flagged but for its NaN lowest value)
    stats = _rollout_ffi(hopper.ffi)[0].new("eomc_stats[]", n)
    for i in range(n):
        for name, values in cols.items():
            setattr(stats[i], f"watch_{name}", float(values[i]))
    E, flags, count = _screen(hopper, X0, Xl, P, p_stride, status, stats, rtol, known)
    ran = status == 0
    np.testing.assert_array_equal(E[ran], E_ref[ran])
    assert np.isnan(E[~ran]).all()
    want = _numpy_look(E_ref, cols, rtol, known) & ran
    assert 0 < want.sum() < ran.sum() and count == int(want.sum())
    np.testing.assert_array_equal(flags, want)
    assert not flags[0] and flags[1] and not flags[5]
    # the rollout's own call of it (rollout._screened) asks the same, with the model's total_known
    if known == rollout_module.total_known(hopper, rollout_module.find_switches(hopper)):
        got, got_count = rollout_module._screened(hopper, rollout_module.find_switches(hopper), X0, Xl, P, p_stride,
                                                  (0, None, None, 0), 0.5, status, stats, rtol)
        np.testing.assert_array_equal(got, E)
        assert got_count == count


def test_the_first_look_flags_only_beyond_the_tolerance(hopper):
    """A gain or a rise of exactly the tolerance is not flagged, the next double is (numpy's
    ``gain > tol``): one row, its energy's start and end the same, its rtol found so that
    rtol * scale is the gain to the last bit."""
    from eomc.runtime.rollout_result import _rollout_ffi
    x0 = np.array(hopper.initial_state, dtype=float)[None, :]
    P, p_stride = rollout_module._params(hopper, None, 1)
    E0 = _energy(hopper, x0[0])
    rtol = 0.01
    for _ in range(4096):               # an rtol whose tolerance rtol * |E0| is a gain hi - E0 exactly
        if (E0 + rtol * abs(E0)) - E0 == rtol * abs(E0):
            break
        rtol = np.nextafter(rtol, 1.0)
    hi = E0 + rtol * abs(E0)
    assert hi - E0 == rtol * abs(E0)
    stats = _rollout_ffi(hopper.ffi)[0].new("eomc_stats[]", 1)
    status = np.zeros(1, dtype=np.intc)
    T0, span = E0, abs(E0)
    for top, rise, want in ((hi, 0.0, False), (np.nextafter(hi, np.inf), 0.0, True)):
        cols = {"lo": E0, "hi": top, "total0": T0, "total_lo": T0 - span, "total_hi": T0 + span, "rise": rise}
        for name, value in cols.items():
            setattr(stats[0], f"watch_{name}", float(value))
        _, flags, _ = _screen(hopper, x0, x0, P, p_stride, status, stats, rtol, False)
        assert flags[0] == want == _numpy_look(np.array([[E0, E0]]), {k: np.array([v]) for k, v in cols.items()},
                                               rtol, False)[0]
    tscale = max(abs(T0), span)         # the total's scale: |T0|, hi - T0, T0 - lo
    for rise, want in ((rtol * tscale, False), (np.nextafter(rtol * tscale, np.inf), True)):
        cols = {"lo": E0, "hi": E0, "total0": T0, "total_lo": T0 - span, "total_hi": T0 + span, "rise": rise}
        for name, value in cols.items():
            setattr(stats[0], f"watch_{name}", float(value))
        _, flags, _ = _screen(hopper, x0, x0, P, p_stride, status, stats, rtol, True)
        assert flags[0] == want


@pytest.mark.parametrize("fields", [None, ("rejected", "watch_lo", "watch_rise")])
def test_the_stats_columns_are_the_structs_fields(hopper, fields):
    """rollout._stats_columns reads eomc_stats[n] through one copy of its memory (8-byte fields as
    strided words, else numpy's structured view): every field of every row as cffi reads it."""
    from eomc.runtime.rollout_result import _rollout_ffi
    ffi = _rollout_ffi(hopper.ffi)[0]
    rng, n = np.random.default_rng(3), 5
    stats = ffi.new("eomc_stats[]", n)
    each = ffi.typeof("eomc_stats").fields
    for i in range(n):
        for name, f in each:
            integer = f.type.cname in ("long", "int")
            setattr(stats[i], name, int(rng.integers(-2**30, 2**30)) if integer else float(rng.normal()))
    cols = rollout_module._stats_columns(ffi, stats, n, fields)
    assert set(cols) == {name for name, _ in each} if fields is None else set(fields)
    for name, values in cols.items():
        np.testing.assert_array_equal(values, [getattr(stats[i], name) for i in range(n)])
        assert values.dtype.kind == ("i" if dict(each)[name].type.cname in ("long", "int") else "f")
