"""Torsional and rolling friction (MJCF condim 4 and 6 against a plane; compiler/contact/law.spin_moment)
against closed forms, central differences and MuJoCo's mj_step on the same sphere."""
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

import eomc  # noqa: E402

R, M, G = 0.1, 1.0, 9.81
MUT, MUR = 0.02, 0.01
I = 0.4 * M * R * R
XML = """<mujoco><option timestep="0.001"/><worldbody><geom name="floor" type="plane" size="1 1 .1"/>
  <body name="b" pos="0 0 .1"><freejoint name="free"/>
    <geom name="ball" type="sphere" size="{r}" mass="{m}" condim="{c}" friction="1 {mut} {mur}"/></body>
</worldbody></mujoco>"""


def _xml(condim=6):
    return XML.format(r=R, m=M, c=condim, mut=MUT, mur=MUR)


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    path = tmp_path_factory.mktemp("spin") / "ball6.xml"
    path.write_text(_xml())
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # condim 6 against a plane: modelled, no warning
        model = eomc.compile(str(path), functions=("rhs", "jac_x", "outputs", "events"))
    p = np.array(model.param_defaults, dtype=float)
    return model, p, dict(zip(model.param_names, p))


def _resting(model, P, **speeds):
    """The ball at its resting depth (k δ^1.5 = m g: the normal force is m g) with ``speeds``."""
    x = np.zeros(len(model.state_names))
    x[list(model.quaternions)] = 1.0         # upright (the MJCF default: the quaternion's w)
    x[2] = R - (M * G / P["k_ball"]) ** (2 / 3)
    for name, value in speeds.items():
        x[model.state_names.index(f"u_free_{name}")] = value
    return x


def test_parameters_are_mujocos(ball):
    model, _, P = ball
    assert (P["mut_ball"], P["mur_ball"]) == (MUT, MUR)
    assert {"mut_ball", "mur_ball"} <= set(model.param_names)


def test_spin_decays_as_the_regularised_law_says(ball):
    """Spinning about the normal, the sphere carries m g on its axis: no slip, and
    I ω' = -μ_t m g ω/sqrt(ω² + ω_s²) (ω_s = v_s/r), whose exact integral is
    F(ω) = F(ω0) - a t, F(ω) = sqrt(ω² + ω_s²) - ω_s ln((ω_s + sqrt(ω² + ω_s²))/ω), a = μ_t m g/I:
    a linear decay at μ_t N/I (MuJoCo's rate: μ_t is a length) until the band ω ~ ω_s."""
    model, p, P = ball
    w0, a, ws = 10.0, MUT * M * G / I, P["vs_ball"] / R
    res = model.simulate(_resting(model, P, wz=w0), (0, 0.21), p=p, method="radau", rtol=1e-10, atol=1e-12,
                         n_points=22)
    w = res["u_free_wz"]

    def F(x):
        s = np.sqrt(x * x + ws * ws)
        return s - ws * np.log((ws + s) / x)
    assert w[-1] < 10 * ws                                   # it got to the band
    keep = w > ws / 10
    assert np.abs(F(w[keep]) - (F(w0) - a * res.t[keep])).max() < 1e-7
    mid = (w > 1) & (w < 9)                                  # Coulomb's linear decay above the band
    assert np.polyfit(res.t[mid], w[mid], 1)[0] == pytest.approx(-a, rel=2e-3)
    late = model.simulate(res.x[-1], (0, 0.2), p=p, method="radau", rtol=1e-8, atol=1e-12)
    assert abs(late["u_free_wz"][-1]) < 1e-4                # it stops, and does not turn back


def test_rolling_decelerates_as_the_law_says(ball):
    """Rolling without slip (the regularised sliding friction holds the contact point), the rolling
    moment μ_r m g decelerates the centre at (5/7) μ_r g / r; the ball comes to rest."""
    model, p, P = ball
    v0 = 1.0
    res = model.simulate(_resting(model, P, vx=v0, wy=v0 / R), (0, 1.7), p=p, method="radau", rtol=1e-10,
                         atol=1e-12, n_points=18)
    v = np.array([model.rhs(t, x, p)[0] for t, x in zip(res.t, res.x)])     # x' (world)
    mid = (res.t >= 0.1) & (res.t <= 0.9)
    assert -np.polyfit(res.t[mid], v[mid], 1)[0] == pytest.approx(5 / 7 * MUR * G / R, rel=1e-3)
    assert abs(v[-1]) < 1e-4
    without = p.copy()
    without[model.param_names.index("mur_ball")] = 0.0
    rolled = model.simulate(res.x[0], (0, 1.0), p=without, method="radau", rtol=1e-8, atol=1e-12)
    assert model.rhs(1.0, rolled.x[-1], without)[0] == pytest.approx(v0, rel=1e-3)   # mur = 0: rolls on


@pytest.mark.parametrize("scale", [1.0, 0.05])
def test_jac_x_matches_central_differences(ball, scale):
    """Pressed, sliding, spinning and rolling at once (scale 1) and within the regularisation band
    (scale 0.05: ω ~ ω_s = 0.1 rad/s, slip ~ v_s)."""
    model, p, P = ball
    x = _resting(model, P, vx=0.3 * scale, vy=-0.2 * scale, vz=-0.05 * scale, wx=1.5 * scale, wy=-2 * scale,
                 wz=3 * scale)
    x[2] -= 1e-4
    x[3:6] = (0.2, -0.1, 0.3)
    J = model.jacobian(0.0, x, p)
    h = 1e-7
    fd = np.column_stack([(model.rhs(0, x + h * e, p) - model.rhs(0, x - h * e, p)) / (2 * h) for e in np.eye(len(x))])
    assert np.abs(J - fd).max() < 1e-5 * max(1.0, np.abs(fd).max())


def _mujoco_decay(cone, condim=6, **speeds):
    """MuJoCo's mj_step from the ball at its rest (2 s settled) with qvel ``speeds``: times, qvel rows."""
    m = mujoco.MjModel.from_xml_string(_xml(condim).replace('timestep="0.001"', f'timestep="0.001" cone="{cone}"'))
    d = mujoco.MjData(m)
    for _ in range(2000):
        mujoco.mj_step(m, d)
    d.qvel[:] = 0
    for k, v in speeds.items():
        d.qvel[("vx", "vy", "vz", "wx", "wy", "wz").index(k)] = v
    rows = []
    for _ in range(400):
        rows.append((d.time, *d.qvel))
        mujoco.mj_step(m, d)
    rows = np.array(rows)
    return rows[:, 0] - rows[0, 0], rows[:, 1:]


@pytest.mark.parametrize("cone", ["pyramidal", "elliptic"])
def test_spin_down_rate_is_mujocos(cone):
    """MuJoCo's soft torsional row on the same sphere (1 ms mj_step) spins down at the law's Coulomb rate
    μ_t m g / I above the band, to 0.5 % (measured -48.9 rad/s² against 49.05, both cones); below it
    MuJoCo's soft constraint and eomc's regularisation differ (not compared)."""
    t, qvel = _mujoco_decay(cone, wz=10.0)
    w = qvel[:, 5]
    mid = (w > 2) & (w < 8)
    assert np.polyfit(t[mid], w[mid], 1)[0] == pytest.approx(-MUT * M * G / I, rel=5e-3)


@pytest.mark.parametrize("cone, tol", [("elliptic", 1e-2), ("pyramidal", 0.1)])
def test_rolling_deceleration_is_mujocos(cone, tol):
    """MuJoCo's rolling rows on the ball rolling at 1 m/s: the centre decelerates at (5/7) μ_r g / r as
    this law's (measured 0.7006 m/s² elliptic, 0.666 pyramidal, whose cone edges n ± μ_k e_k mix the
    rolling rows with the sliding ones, against 0.7007)."""
    t, qvel = _mujoco_decay(cone, vx=1.0, wy=1.0 / R)
    v = qvel[:, 0]
    mid = (t > 0.1) & (t < 0.35)
    assert -np.polyfit(t[mid], v[mid], 1)[0] == pytest.approx(5 / 7 * MUR * G / R, rel=tol)


def test_condim_4_has_no_rolling_friction(tmp_path):
    """condim 4: torsional friction only (no mur_ parameter); condim 3: neither, and the C is what it was."""
    from eomc.compiler.mjcf.collision import ground_geoms
    for condim, keys in ((4, (MUT, None)), (3, (None, None)), (6, (MUT, MUR))):
        m = mujoco.MjModel.from_xml_string(_xml(condim))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            (g,) = ground_geoms(m)
        assert (g.mut, g.mur) == keys
        assert g.rho == (R if condim > 3 else None)


@pytest.mark.parametrize("condim", [2, 5])
def test_condims_mujoco_refuses_stay_refused(tmp_path, condim):
    from eomc.runtime.errors import ModelFileError
    path = tmp_path / "bad.xml"
    path.write_text(_xml(condim))
    with pytest.raises(ModelFileError, match=r"bad.xml:3: .*invalid condim in geom"):
        eomc.compile(str(path), functions=("rhs",), cache_dir=tmp_path / "cache")


# three balls on a table (a box in the world): 3 ball-table and 3 ball-ball pairs; ball "a" has condim 6
SCENE = """<mujoco><option timestep="0.001"/><worldbody>
  <geom name="table" type="box" size=".5 .5 .05" pos="0 0 -.05"/>
  <body name="a" pos="0 0 .1"><freejoint name="fa"/>
    <geom name="ga" type="sphere" size="{r}" mass="{m}" condim="6" friction="1 {mut} {mur}"/></body>
  <body name="b" pos=".25 0 .1"><freejoint name="fb"/><geom name="gb" type="sphere" size=".1" mass="1"/></body>
  <body name="c" pos="0 .25 .1"><freejoint name="fc"/><geom name="gc" type="sphere" size=".1" mass="1"/></body>
</worldbody></mujoco>"""


def _scene(tmp_path, table_from, monkeypatch, functions=("rhs", "jac_x", "vjp", "outputs", "events")):
    from eomc.compiler.contact import pairs
    monkeypatch.setattr(pairs, "TABLE_FROM", table_from)
    path = tmp_path / f"scene{table_from}.xml"
    path.write_text(SCENE.format(r=R, m=M, mut=MUT, mur=MUR))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return eomc.compile(str(path), functions=functions, cache_dir=tmp_path / "cache")


def _scene_states(model):
    """(x: the three balls resting on the table, a spinning at 10 rad/s; y: a pressed into b, a spinning
    and rolling, b turning the other way), the parameters and their dict."""
    p = np.array(model.param_defaults, dtype=float)
    P = dict(zip(model.param_names, p))
    S = list(model.state_names)
    x = np.zeros(len(S))
    x[list(model.quaternions)] = 1.0         # upright (the MJCF default: each quaternion's w)
    for body, xy in (("a", (0, 0)), ("b", (0.25, 0)), ("c", (0, 0.25))):
        x[S.index(f"q_f{body}_x")], x[S.index(f"q_f{body}_y")] = xy
        x[S.index(f"q_f{body}_z")] = R - (M * G / P[f"k_table__g{body}"]) ** (2 / 3)
    x[S.index("u_fa_wz")] = 10.0
    y = x.copy()
    y[S.index("q_fa_x")] += 0.05 + 1e-4
    for name, value in (("u_fa_wx", 1.0), ("u_fa_wy", -2.0), ("u_fa_wz", 3.0), ("u_fb_wz", -1.5), ("u_fb_wy", 0.5),
                        ("u_fa_vx", 0.1), ("u_fb_vy", -0.2)):
        y[S.index(name)] = value
    return x, y, p, P


def test_body_body_pair_spins_down_in_the_table_as_inlined(tmp_path, monkeypatch):
    """Ball a (condim 6) on the table (a box: a body-body pair, not a plane) spins down at μ_t m g/I as
    on the plane.  With TABLE_FROM = 2 its three pairs go through the pair table with b's and c's
    (whose law is then the spinning law routine, 0 torsion and rolling for the others): rhs, jac_x
    (the analytic kernel's pair path) and vjp equal those of the all-inlined build (1e-12), and
    jac_x matches central differences with a and b pressed together, turning against each other."""
    table = _scene(tmp_path, 2, monkeypatch)
    inline = _scene(tmp_path, 100, monkeypatch)
    c_table, c_inline = (m.source_path.read_text() for m in (table, inline))
    assert "eomc_pair_law_spin(" in c_table and "eomc_pairs(" in c_table
    assert "eomc_pairs(" not in c_inline and "eomc_pair_law_spin" not in c_inline
    x, y, p, P = _scene_states(table)
    assert {"mut_table__ga", "mur_table__ga", "mut_ga__gb", "mur_ga__gb"} <= set(P)
    assert not any(n.startswith("mut_") and "ga" not in n for n in P)
    res = table.simulate(x, (0, 0.15), p=p, method="radau", rtol=1e-10, atol=1e-12, n_points=16)
    w = res["u_fa_wz"]
    mid = (w > 2) & (w < 8)
    assert np.polyfit(res.t[mid], w[mid], 1)[0] == pytest.approx(-MUT * M * G / I, rel=2e-3)
    lam = np.random.default_rng(3).standard_normal(table.nx)
    for state in (x, y):
        fm, fi = table.rhs(0, state, p), inline.rhs(0, state, p)
        assert np.abs(fm - fi).max() <= 1e-12 * max(1.0, np.abs(fi).max())
        Jm, Ji = table.jacobian(0, state, p), inline.jacobian(0, state, p)
        assert np.abs(Jm - Ji).max() <= 1e-12 * max(1.0, np.abs(Ji).max())
        (_, gm, pm), (_, gi, pi) = table.vjp(0, state, lam, p), inline.vjp(0, state, lam, p)
        assert np.abs(gm - gi).max() <= 1e-12 * max(1.0, np.abs(gi).max())
        assert np.abs(pm - pi).max() <= 1e-12 * max(1.0, np.abs(pi).max())
    h = 1e-7
    fd = np.column_stack([(table.rhs(0, y + h * e, p) - table.rhs(0, y - h * e, p)) / (2 * h) for e in np.eye(len(y))])
    J = table.jacobian(0, y, p)
    assert np.abs(J - fd).max() < 1e-5 * max(1.0, np.abs(fd).max())


def test_a_condim_4_pair_in_the_table_has_torsion_alone(tmp_path, monkeypatch):
    """Ball b with condim 4 (torsion, no rolling: its pairs' μ_r is 0 in the table's spinning
    parameters) beside ball a's condim 6: the table build equals the all-inlined build in rhs and
    jac_x, and b's pairs have a torsion parameter and no rolling one."""
    scene = SCENE.replace('<geom name="gb" type="sphere" size=".1" mass="1"/>',
                          f'<geom name="gb" type="sphere" size=".1" mass="1" condim="4" friction="1 {MUT} 0"/>')
    built = []
    for table_from in (2, 100):
        from eomc.compiler.contact import pairs
        monkeypatch.setattr(pairs, "TABLE_FROM", table_from)
        path = tmp_path / f"four{table_from}.xml"
        path.write_text(scene.format(r=R, m=M, mut=MUT, mur=MUR))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            built.append(eomc.compile(str(path), functions=("rhs", "jac_x"), cache_dir=tmp_path / "cache"))
    table, inline = built
    _, y, p, P = _scene_states(table)
    assert "mut_table__gb" in P and "mur_table__gb" not in P
    y[table.state_names.index("u_fb_wx")] = 2.0          # b rolls too: no moment from it
    fm, fi = table.rhs(0, y, p), inline.rhs(0, y, p)
    assert np.abs(fm - fi).max() <= 1e-12 * max(1.0, np.abs(fi).max())
    Jm, Ji = table.jacobian(0, y, p), inline.jacobian(0, y, p)
    assert np.abs(Jm - Ji).max() <= 1e-12 * max(1.0, np.abs(Ji).max())


def test_second_order_functions_take_a_spinning_pair_through_the_table(tmp_path, monkeypatch):
    """hvp differentiates the pairs twice through the table (every pair, whatever their number), whose
    spinning law routine has its reverse sweep's tangent: hvp equals central differences of jac_x
    with a and b pressed together and turning, and the spin moment is in it (the torsion's
    parameter has a gradient).  Inlined pairs (no table) still refuse it, naming the pair."""
    from eomc.compiler.contact import pairs
    from eomc.runtime.errors import ModelError
    model = _scene(tmp_path, 100, monkeypatch, functions=("rhs", "jac_x", "vjp", "hvp"))
    _, y, p, P = _scene_states(model)
    rng = np.random.default_rng(5)
    lam, v = rng.standard_normal(model.nx), rng.standard_normal(model.nx)
    hv = model.hvp(0.0, y, lam, v, p=p)

    def central(step):
        return (model.jacobian(0, y + step * v, p) - model.jacobian(0, y - step * v, p)) / (2 * step)
    fd = ((4 * central(5e-7) - central(1e-6)) / 3).T @ lam     # steps well inside the 1e-4 m overlaps
    assert np.isfinite(hv).all() and np.abs(hv - fd).max() <= 1e-6 * np.abs(fd).max()
    gp = dict(zip(model.param_names, model.vjp(0.0, y, lam, p=p)[2]))
    assert gp["mut_ga__gb"] != 0.0 and gp["mur_ga__gb"] != 0.0
    monkeypatch.setattr(pairs, "PAIR_TABLE", False)
    path = tmp_path / "one.xml"
    path.write_text(SCENE.format(r=R, m=M, mut=MUT, mur=MUR))
    with pytest.raises(ModelError, match="the contact table__ga: torsional and rolling friction between two bodies"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            eomc.compile(str(path), functions=("rhs", "hvp"), cache_dir=tmp_path / "cache2")
