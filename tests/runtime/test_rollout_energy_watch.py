"""The lanes rollout's energy watch reads the energy from the fixed step's own terms.

Why: a fast-path rollout keeps each row's energy range over every step (eomc_options.watch_output)
for simulate's energy verdict, and called NAME_energy after every step: 19-20 % of G1's lanes
rollout (session 18).  A model built with implicit_batch has NAME_implicit's out[] end with the
energy (compiler/tree/lower.implicit_layout "energy"; less a pairs' table's points, whose depths
the slopes loop writes only into the slope block: metadata "energy_apart"), and the step makes
those terms at every step's end anyway (eomc_fixedstep.c), so the watch reads the value there
(eomc_integrators.c fs_watch) and calls NAME_energy only while an "apart" point touches.

Oracles: the model's own energy output at random states, and the watch's ranges with the shortcut
turned off (the struct's ``energy`` flag cleared: every step calls NAME_energy, as before)."""
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
    """Body-body pairs through the pairs' table, and ground contacts: the slot leaves the pairs'
    energy out."""
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


def test_the_slot_leaves_the_tables_pairs_out_and_says_which(limbs):
    info = limbs.metadata["implicit"]
    pairs = [k for k, c in enumerate(info["contacts"]) if c.get("pair")]
    assert len(pairs) >= 8 and info["energy_apart"] == pairs
    rng = np.random.default_rng(5)
    touching = apart = 0
    for _ in range(300):
        x = rng.normal(scale=0.6, size=limbs.nx)
        out, layout = implicit_terms_at(limbs, x)
        depth = np.array([out[layout["contact"] + 25 * k] for k in info["energy_apart"]])
        e = _energy(limbs, x)
        if (depth > 0).any():   # the pairs' elastic energy is the difference
            touching += 1
            assert out[layout["energy"]] < e
        else:
            apart += 1
            assert abs(out[layout["energy"]] - e) <= 1e-12 * (1 + abs(e))
    assert touching >= 10 and apart >= 10


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


def test_the_watch_evaluates_the_energy_while_a_tables_pair_touches(limbs, monkeypatch):
    """The limbs' ball dropped onto the trunk lying on the floor: while their pair touches, the slot
    lacks its elastic energy, so the watch calls NAME_energy there; the ranges equal the plain
    watch's."""
    names = list(limbs.state_names)
    x0 = np.array(limbs.initial_state, dtype=float)
    x0[names.index("q_joint0_z")] = 0.05                 # the trunk on the floor
    x0[names.index("q_joint3_y")] -= 0.1                 # the ball above it
    x0[names.index("q_joint3_z")] = 0.25
    X0 = np.tile(x0, (3, 1))
    X0[:, names.index("q_joint3_z")] += [0.0, 0.02, 0.04]
    kw = dict(dt=0.002, steps=200)
    apart = limbs.metadata["implicit"]["energy_apart"]
    pair_depths = [n for n in limbs.output_names if n.startswith("depth_")][-len(apart):]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = limbs.simulate(X0[0], (0.0, 0.4), method="implicitfast", dt=0.002)
    assert max(run.outputs[n].max() for n in pair_depths) > 0       # a table's pair touched
    got, res, calls = _ranges(limbs, X0, monkeypatch, True, **kw)
    want, ref, plain = _ranges(limbs, X0, monkeypatch, False, **kw)
    assert plain == len(X0) * 201 and len(X0) < calls < plain      # the steps with the pair touching call it
    assert np.array_equal(res.x, ref.x)
    assert np.allclose(got, want, rtol=1e-12, atol=0)
