"""The generated code of solid pairs (box–box, sphere–cylinder): its outputs at random states are
the signed distance by hand (numpy; sphere–cylinder) and :func:`solid_contact` evaluated in Python
(box–box), so the lowering carries the narrow phase into C."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402
from eomc.compiler.contact.pairs import solid_contact  # noqa: E402
from eomc.compiler.mjcf.compare import prepared, to_mujoco, tree_of  # noqa: E402
from eomc.compiler.mjcf.model import MjcfModel, check_model, load_mjmodel  # noqa: E402
from eomc.runtime.errors import EomcWarning  # noqa: E402

XML = """<mujoco model="solids"><option gravity="0 0 0"/><worldbody>
<body name="A" pos="0 0 0.3"><freejoint/><geom name="ball" type="sphere" size="0.1" contype="1" conaffinity="2"/></body>
<body name="E" pos="0.2 0 0.3"><freejoint/><geom name="drum" type="cylinder" size="0.08 0.1" contype="2" conaffinity="1"/></body>
<body name="C" pos="0 0.3 0.3"><freejoint/><geom name="cube" type="box" size="0.1 0.08 0.06" contype="4" conaffinity="4"/></body>
<body name="D" pos="0.2 0.3 0.3"><freejoint/><geom name="slab" type="box" size="0.05 0.12 0.07" contype="4" conaffinity="4"/></body>
</worldbody></mujoco>"""


def _sdf(x, kind, centre, R, size):
    q = R.T @ (np.asarray(x) - centre)
    e = np.abs(q) - size if kind == "box" else np.array([np.hypot(q[0], q[1]) - size[0], abs(q[2]) - size[1]])
    return np.linalg.norm(np.maximum(e, 0)) + min(e.max(), 0.0)


def test_generated_depths_are_the_signed_distances(tmp_path):
    path = tmp_path / "solids.xml"
    path.write_text(XML)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        # orientation="euler": the states pose the bodies by body-XYZ angles (q[6 b + 3:6 b + 6])
        model = eomc.compile(MjcfModel(path, orientation="euler"), functions=["outputs"], cache_dir=tmp_path / "c",
                             progress=False)
    assert not [w for w in seen if "no contact" in str(w.message)]
    assert {f"depth_cube__slab_{i}" for i in range(16)} | {"depth_ball__drum"} <= set(model.output_names)
    m = prepared(load_mjmodel(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EomcWarning)
        built = tree_of(m, model, actuators=check_model(m, path))
    d = mujoco.MjData(m)
    rng = np.random.default_rng(2)
    g = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("ball", "drum", "cube", "slab")}
    pressed = 0
    for _ in range(10):
        q = np.zeros(model.nq)
        for body, centre in enumerate(([0, 0, 0.3], [0.15, 0, 0.3], [0, 0.3, 0.3], [0.12, 0.3, 0.3])):
            q[6 * body:6 * body + 3] = np.array(centre) + rng.uniform(-0.06, 0.06, 3)
            q[6 * body + 3:6 * body + 6] = rng.uniform(-1, 1, 3)
        u = np.zeros(model.nq)
        d.qpos[:], d.qvel[:] = to_mujoco(m, built, q, u)
        mujoco.mj_kinematics(m, d)
        out = model.outputs(0.0, np.concatenate([q, u]))
        frame = {n: (np.array(d.geom_xpos[i]), np.array(d.geom_xmat[i]).reshape(3, 3)) for n, i in g.items()}
        sd = _sdf(frame["ball"][0], "cylinder", *frame["drum"], m.geom_size[g["drum"]][:2]) - 0.1
        assert out["depth_ball__drum"] == pytest.approx(-sd, abs=1e-12)
        placed = {n: {"kind": "box", "centre": list(frame[n][0]), "axes": [list(frame[n][1][:, k]) for k in range(3)],
                      "size": [float(x) for x in m.geom_size[g[n]]]} for n in ("cube", "slab")}
        for i in range(16):            # the formula itself is test_solid_pairs' job: here C = the formula
            _, n, want = solid_contact(placed["cube"], placed["slab"], i)
            depth = out[f"depth_cube__slab_{i}"]
            assert depth == pytest.approx(float(want), abs=1e-12)
            pressed += depth > 0
            assert (out[f"Fn_cube__slab_{i}"] > 0) == (depth > 0)
    assert pressed >= 3
