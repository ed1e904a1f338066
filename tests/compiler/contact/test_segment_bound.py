"""The primal pairs' loops skip a capsule's pair whose balls overlap but whose segments are apart
(compiler/contact/table.SEGMENT_BOUND): NAME_implicit's block and the rhs are those of the loop
without the bound, but for the depth and point slots of the pairs the bound skipped, which are 0
instead of the narrow phase's negative depth and its point.  Oracles: the same model built
without the bound (SEGMENT_BOUND = False) and the outputs function (full = 1, every pair's narrow
phase: the exact depths)."""
import warnings

import numpy as np
import pytest

import eomc
from eomc.compiler.contact import table

from .test_narrow import LIMBS

SPHERES = {"head", "hand", "ball"}       # LIMBS' sphere geoms; the others are capsules


@pytest.fixture(scope="module")
def limbs(tmp_path_factory):
    from eomc.compiler.mjcf.model import MjcfModel
    tmp = tmp_path_factory.mktemp("bound")
    path = tmp / "limbs.xml"
    path.write_text(LIMBS)
    built = {}
    mp = pytest.MonkeyPatch()
    try:
        for bound in (True, False):
            mp.setattr(table, "SEGMENT_BOUND", bound)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                built[bound] = eomc.compile(MjcfModel(path, pairs=True), "lbound", functions=("rhs", "outputs", "implicit"),
                                            cache_dir=tmp / str(bound), progress=False)
    finally:
        mp.undo()
    return built


def _implicit(m, x):
    size = m.metadata["implicit"]["layout"]["size"]
    out = np.full(size, np.nan)
    ffi = m.ffi
    fp = ffi.addressof(m.model_lib, f"{m.name}_implicit")
    status = fp(0.0, ffi.from_buffer("double[]", np.ascontiguousarray(x, dtype=float)), m._default_p,
                ffi.NULL, ffi.from_buffer("double[]", out), ffi.NULL)
    assert status == 0
    return out


def _kinds(name):
    a, b = name.split(":")[0].split("__")
    return ("sphere" if a in SPHERES else "capsule", "sphere" if b in SPHERES else "capsule")


def test_the_bound_skips_apart_pairs_and_changes_nothing_else(limbs):
    bound, plain = limbs[True], limbs[False]
    info = bound.metadata["implicit"]
    assert info == plain.metadata["implicit"]
    at = info["layout"]["contact"]
    pairs = [(c, item["name"]) for c, item in enumerate(info["contacts"]) if item.get("pair")]
    assert {_kinds(n) for _, n in pairs} >= {("capsule", "capsule"), ("capsule", "sphere")}
    names = list(bound.state_names)
    rng = np.random.default_rng(11)
    skipped = {"capsule": 0, "sphere": 0}
    ran_apart = {"capsule": 0, "sphere": 0}
    pressed = 0
    for _ in range(150):
        x = np.zeros(bound.nx)
        x[names.index("q_joint0_z")] = 0.3
        x[names.index("q_joint3_z")] = 0.3
        x[names.index("q_joint3_y")] = rng.uniform(-0.12, -0.02)
        x += rng.normal(0, 0.25 if rng.random() < 0.5 else 0.02, bound.nx)
        assert np.array_equal(bound.rhs(0.0, x), plain.rhs(0.0, x))
        a, b = _implicit(bound, x), _implicit(plain, x)
        o = dict(bound.outputs(0.0, x))
        differ = np.flatnonzero(a != b)
        allowed = set()
        for c, name in pairs:
            ea, eb = a[at + 25 * c:at + 25 * (c + 1)], b[at + 25 * c:at + 25 * (c + 1)]
            other = "capsule" if _kinds(name) == ("capsule", "capsule") else "sphere"
            if ea[0] == eb[0]:
                pressed += eb[0] > 0
                continue
            # the bound skipped a pair the ball test let through: apart past the pad, slots 0
            assert eb[0] == o[f"depth_{name}"] < -1e-6
            assert ea[0] == 0 and not ea[1:4].any() and not ea[7:].any() and not eb[7:].any()
            skipped[other] += 1
            allowed.update(at + 25 * c + k for k in range(4))
        for c, name in pairs:
            e = a[at + 25 * c:at + 25 * (c + 1)]
            other = "capsule" if _kinds(name) == ("capsule", "capsule") else "sphere"
            if e[0] < 0:
                ran_apart[other] += 1
                if other == "sphere":      # a sphere's distance to a segment is exact: never run apart
                    assert e[0] >= -2e-6, (name, e[0])
        assert set(differ.tolist()) <= allowed
    assert pressed > 0
    assert skipped["capsule"] > 0 and skipped["sphere"] > 0, skipped
