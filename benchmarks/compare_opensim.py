"""One De Groote 2016 muscle lifting a mass: eomc against OpenSim's DeGrooteFregly2016Muscle
(issue 22, item 5).  Writes benchmarks/results/opensim.md.

The mechanism: a 5 kg block on a vertical slider hanging from the ground by one muscle
(elastic tendon, first-order activation, no pennation, no fibre damping), gravity 9.81.
The excitation is 0.3 from t = 0 (activation starts at 0.1); the muscle lifts the block.

- OpenSim 4.6 (the `opensim` wheel): DeGrooteFregly2016Muscle, explicit tendon-compliance
  mode (its state: the normalized tendon force), a PrescribedController, its Manager at
  integrator accuracy 1e-10.
- eomc: a model file with `states` = the activation (SymPy's FirstOrderActivationDeGroote2016
  rhs) and the normalized fibre length, whose rate comes from SymPy's inverse
  force-velocity curve; the muscle force acts along a LinearPathway (ForceActuator).  Both
  tools' curves are De Groote et al. 2016's; eomc is given OpenSim's constants (OpenSim
  takes them, to 16 digits, from the authors' code; SymPy's ``with_defaults`` has the
  paper's rounded ones) and OpenSim's passive curve, which is offset to vanish at a
  normalized fibre length of 0.2 (SymPy's vanishes at 1).  The curve table below checks
  each curve against OpenSim's own static functions.

    python3 benchmarks/compare_opensim.py
"""
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, fmt, format_table, peer_versions, write_results  # noqa: E402

MASS, G, FMAX, LOPT, LTS, VMAX = 5.0, 9.81, 500.0, 0.3, 0.25, 10.0
Q0, A0, E, FT0, T_END = 0.55, 0.1, 0.3, 0.2, 1.0
TAU_A, TAU_D = 0.015, 0.060
# OpenSim's DeGrooteFregly2016Muscle constants (DeGrooteFregly2016Muscle.h)
B = [(0.8150671134243542, 1.055033428970575, 0.162384573599574, 0.063303448465465),
     (0.433004984392647, 0.716775413397760, -0.029947116970696, 0.200356847296188),
     (0.1, 1.0, 0.353553390593274, 0.0)]
D = (-0.3211346127989808, -8.149, -0.374, 0.8825327733249912)
KPE, E0 = 4.0, 0.6
C1, C2, C3 = 0.2, 1.0, 0.2         # De Groote et al.'s are 0.2, 0.995, 0.25; OpenSim zeroes f(1)
KT = np.log((1.0 + C3) / C1) / (1.0 + 0.049 - C2)

MODEL = textwrap.dedent(f'''\
    """A block hanging from one De Groote muscle: OpenSim's DeGrooteFregly2016Muscle, in eomc."""
    import sympy as sm
    from eomc.mechanics import *
    from sympy.physics import biomechanics as bm

    q, u = dynamicsymbols("q u")                  # block's drop below the origin, its speed
    lM = dynamicsymbols("l_M_tilde")              # normalized fibre length
    ground = RigidBody("ground")
    block = RigidBody("block", mass={MASS})
    block.central_inertia = inertia(block.frame, 1, 1, 1)
    system = System.from_newtonian(ground)
    system.add_joints(PrismaticJoint("slider", ground, block, q, u, joint_axis=-ground.y))
    system.apply_uniform_gravity(-{G} * ground.y)
    path = LinearPathway(ground.masscenter, block.masscenter)

    act = bm.FirstOrderActivationDeGroote2016("m", {TAU_A}, {TAU_D}, sm.Symbol("b"))
    a, e = act.a, act.e
    lT = (path.length - {LOPT} * lM) / {LTS}          # normalized tendon length (no pennation)
    fT = bm.TendonForceLengthDeGroote2016(lT, {C1}, {C2}, {C3}, {float(KT)!r})
    fL = bm.FiberForceLengthActiveDeGroote2016(lM, *{[c for b in B for c in b]!r})
    # OpenSim's passive curve: zero at a normalized fibre length of 0.2 (SymPy's is zero at 1)
    off = sm.exp({KPE} * (0.2 - 1) / {E0})
    fP = (sm.exp({KPE} * (lM - 1) / {E0}) - off) / (sm.exp({KPE}) - off)
    fV = (fT - fP) / (a * fL)                     # fibre equilibrium, no damping
    vM = bm.FiberForceVelocityInverseDeGroote2016(fV, *{list(D)!r})
    system.add_actuators(ForceActuator(-{FMAX} * fT, path))

    name = "opensim_block"
    states = {{a: act.rhs()[0], lM: {VMAX} * vM}}    # v_max in optimal fibre lengths per second
    inputs = [e]
    parameters = {{sm.Symbol("b"): 0.1}}          # OpenSim's activation_dynamics_smoothing (SymPy's default: 10)
    outputs = {{"tendon_force": {FMAX} * fT, "fiber_length": {LOPT} * lM}}
    ''')


def opensim_run(dt=0.01):
    import opensim as osim
    osim.Logger.removeFileSink()        # OpenSim would write opensim.log into the working directory
    model = osim.Model()
    model.setGravity(osim.Vec3(0, -G, 0))
    ground = model.getGround()
    block = osim.Body("block", MASS, osim.Vec3(0), osim.Inertia(1, 1, 1))
    model.addBody(block)
    rot = osim.Vec3(0, 0, -np.pi / 2)          # the slider's x axis along -y: q = drop
    joint = osim.SliderJoint("slider", ground, osim.Vec3(0), rot, block, osim.Vec3(0), rot)
    model.addJoint(joint)
    m = osim.DeGrooteFregly2016Muscle()
    m.setName("muscle")
    m.set_max_isometric_force(FMAX)
    m.set_optimal_fiber_length(LOPT)
    m.set_tendon_slack_length(LTS)
    m.set_max_contraction_velocity(VMAX)
    m.set_pennation_angle_at_optimal(0.0)
    m.set_fiber_damping(0.0)
    m.set_ignore_tendon_compliance(False)
    m.set_ignore_activation_dynamics(False)
    m.set_tendon_compliance_dynamics_mode("explicit")
    m.set_default_activation(A0)
    m.set_default_normalized_tendon_force(FT0)
    m.addNewPathPoint("origin", ground, osim.Vec3(0))
    m.addNewPathPoint("insertion", block, osim.Vec3(0))
    model.addForce(m)
    ctrl = osim.PrescribedController()
    ctrl.addActuator(m)
    ctrl.prescribeControlForActuator("muscle", osim.Constant(E))
    model.addController(ctrl)
    state = model.initSystem()
    coord = joint.getCoordinate()
    coord.setValue(state, Q0)
    coord.setSpeedValue(state, 0.0)
    manager = osim.Manager(model)
    manager.setIntegratorAccuracy(1e-10)
    state.setTime(0.0)
    manager.initialize(state)
    out = {"t": [], "q": [], "activation": [], "tendon_force": [], "fiber_length": []}
    t0 = time.process_time()
    for k in range(int(round(T_END / dt)) + 1):
        t = k * dt
        if k:
            state = manager.integrate(t)
        model.realizeDynamics(state)
        out["t"].append(t)
        out["q"].append(coord.getValue(state))
        out["activation"].append(m.getActivation(state))
        out["tendon_force"].append(m.getTendonForce(state))
        out["fiber_length"].append(m.getFiberLength(state))
    cpu = time.process_time() - t0
    curves = {"active force-length": [m.calcActiveForceLengthMultiplier(x) for x in LM_POINTS],
              "passive force-length": [m.calcPassiveForceMultiplier(x) for x in LM_POINTS],
              "force-velocity": [m.calcForceVelocityMultiplier(x) for x in V_POINTS],
              "tendon force-length": [m.calcTendonForceMultiplier(x) for x in LT_POINTS]}
    return {k: np.array(v) for k, v in out.items()}, cpu, curves, osim.__version__


LM_POINTS = np.linspace(0.4, 1.6, 13)
V_POINTS = np.linspace(-1.0, 1.0, 11)
LT_POINTS = np.linspace(0.99, 1.05, 7)


def sympy_curves(defaults):
    """SymPy's curve classes at the table points: with OpenSim's constants, or SymPy's
    ``with_defaults`` (the paper's rounded constants)."""
    import sympy as sm
    from sympy.physics import biomechanics as bm
    x = sm.Symbol("x")
    if defaults:
        fl = bm.FiberForceLengthActiveDeGroote2016.with_defaults(x)
        fp = bm.FiberForceLengthPassiveDeGroote2016.with_defaults(x)
        fv = bm.FiberForceVelocityDeGroote2016.with_defaults(x)
        ft = bm.TendonForceLengthDeGroote2016.with_defaults(x)
    else:
        fl = bm.FiberForceLengthActiveDeGroote2016(x, *[c for b in B for c in b])
        off = sm.exp(KPE * (0.2 - 1) / E0)
        fp = (sm.exp(KPE * (x - 1) / E0) - off) / (sm.exp(KPE) - off)
        fv = bm.FiberForceVelocityDeGroote2016(x, *D)
        ft = bm.TendonForceLengthDeGroote2016(x, C1, C2, C3, KT)
    ev = lambda f, pts: np.array([float(sm.sympify(f).doit().subs(x, p)) for p in pts])
    return {"active force-length": ev(fl, LM_POINTS), "passive force-length": ev(fp, LM_POINTS),
            "force-velocity": ev(fv, V_POINTS), "tendon force-length": ev(ft, LT_POINTS)}


def eomc_run(tmp):
    import eomc
    path = Path(tmp) / "opensim_block.py"
    path.write_text(MODEL)
    model = eomc.compile(path, cache_dir=Path(tmp) / "cache")
    lT0 = C2 + np.log((FT0 + C3) / C1) / KT       # the tendon OpenSim starts with
    lM0 = (Q0 - LTS * lT0) / LOPT
    x0 = np.array([Q0, 0.0, A0, lM0])             # states: q, u, then a, l_M_tilde as declared
    assert model.state_names == ("q", "u", "a_m", "l_M_tilde"), model.state_names
    t_eval = np.linspace(0.0, T_END, int(round(T_END / 0.01)) + 1)
    t0 = time.process_time()
    res = model.simulate(x0, (0.0, T_END), r=[E], method="dop853", rtol=1e-11, atol=1e-11, t_eval=t_eval)
    cpu = time.process_time() - t0
    return {"t": res.t, "q": res["q"], "activation": res["a_m"],
            "tendon_force": res.outputs["tendon_force"], "fiber_length": res.outputs["fiber_length"]}, cpu


def main():
    with tempfile.TemporaryDirectory() as tmp:
        ours, our_cpu = eomc_run(tmp)
        (theirs, their_cpu, osim_curves, version) = opensim_run()
    ours_c, rounded = sympy_curves(False), sympy_curves(True)
    curve_rows = [[name, len(osim_curves[name]),
                   fmt(float(np.max(np.abs(ours_c[name] - osim_curves[name])))),
                   fmt(float(np.max(np.abs(rounded[name] - osim_curves[name]))))] for name in osim_curves]
    hist_rows = []
    for key, unit in (("activation", ""), ("tendon_force", "N"), ("fiber_length", "m"), ("q", "m")):
        diff = np.abs(ours[key] - theirs[key])
        scale = np.max(np.abs(theirs[key]))
        hist_rows.append([key + (f" [{unit}]" if unit else ""), fmt(float(theirs[key][0])),
                          fmt(float(theirs[key][-1])), fmt(float(ours[key][-1])), fmt(float(diff.max())),
                          fmt(float(diff.max() / scale))])
    text = environment_header(
        "One De Groote 2016 muscle lifting a block: eomc vs OpenSim's DeGrooteFregly2016Muscle (issue 22)",
        notes=[f"peers: opensim {version} (pip wheel), {', '.join(peer_versions(['sympy']))}",
               f"block {MASS} kg, g {G}; muscle F_max {FMAX} N, l_opt {LOPT} m, l_slack {LTS} m, v_max "
               f"{VMAX} l_opt/s, no pennation, fibre damping 0; activation 0.1 -> excitation {E}; "
               f"start q = {Q0} m at rest, normalized tendon force {FT0}",
               "OpenSim: explicit tendon-compliance mode (state: normalized tendon force), Manager, "
               "integrator accuracy 1e-10, states read every 0.01 s; eomc: state the normalized fibre "
               "length, DOP853 rtol=atol=1e-11 on the same grid",
               f"CPU for the 1 s run (0.01 s output grid): eomc simulate {our_cpu * 1e3:.3g} ms, OpenSim "
               f"Manager {their_cpu * 1e3:.3g} ms (one run each; not a benchmark)",
               "curves: max |SymPy curve - OpenSim's static curve function| over the table points "
               "(fibre lengths 0.4..1.6, velocities -1..1 v_max, tendon lengths 0.99..1.05); 'eomc "
               "model' = SymPy's curve classes with OpenSim's constants and OpenSim's offset passive "
               "curve, as the eomc model uses them; 'SymPy with_defaults' = the paper's rounded "
               "constants and SymPy's passive curve (zero at l = 1)"])
    text += "\n## Histories (t = 0 .. 1 s, 101 points)\n\n"
    text += format_table(["quantity", "OpenSim t=0", "OpenSim t=1 s", "eomc t=1 s", "max |diff|",
                          "max |diff| / max |OpenSim|"], hist_rows)
    text += "\n\n## Curves against OpenSim's own functions\n\n"
    text += format_table(["curve", "points", "eomc model", "SymPy with_defaults"], curve_rows)
    print(text)
    if "--no-write" not in sys.argv:
        print("wrote", write_results("opensim", text)[0])


if __name__ == "__main__":
    main()
