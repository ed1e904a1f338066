"""Is the generated C of every known model unchanged?  sha256 of the C per model, against a baseline.

A refactoring of the compiler promises the same C for the same input (the project's rule:
"byte-identical unless the change is meant").  This script generates -- without compiling --
the C of every shipped example model file, the test models (tests/helpers zoo, the URDF arm
with and without frames, states and contacts), the example-robot-data robots the tests build
(Panda's default build with its limits on too)
and the gymnasium MJCF models, and records sha256 of NAME.c, NAME.h, the cffi cdef and the
metadata per model.

    python benchmarks/c_identity.py --baseline   # record benchmarks/results/c_identity.json
    python benchmarks/c_identity.py              # compare with it; exit status 1 on a difference
    python benchmarks/c_identity.py -k arm -k ur5   # only the cases whose name contains a word

A case that fails to generate is recorded with its error (type and first line), so a model that
starts or stops building shows as a difference too.
"""
import argparse
import hashlib
import json
import sys
import tempfile
import time
import traceback
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
BASELINE = ROOT / "benchmarks" / "results" / "c_identity.json"

EXAMPLES = ["biomechanical_arm", "cart_pole_system", "cartpole_lqr", "double_pendulum",
            "four_bar_system", "heavy_top", "identify_cartpole", "n_link_cart", "rolling_disc",
            "whipple_bicycle"]
ROBOTS = {"ur5": ("ur5", False), "panda": ("panda", False), "solo12": ("solo12", True),
          "hyq": ("hyq_description/robots/hyq_no_sensors.urdf", True),
          "allegro": ("allegro_hand_description/urdf/allegro_right_hand.urdf", False),
          "romeo": ("romeo_description/urdf/romeo.urdf", True)}
GYM = ["inverted_double_pendulum", "hopper", "walker2d", "half_cheetah", "ant", "humanoid"]
GYM_LIMITS = ["hopper", "ant", "humanoid"]
TOOL0 = """  <link name="tool0"/>
  <joint name="flange" type="fixed">
    <parent link="lower"/>
    <child link="tool0"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/>
  </joint>
</robot>"""


def _arm(directory, tool=True):
    from helpers.urdf_arm import ARM
    path = Path(directory) / ("arm_tool.urdf" if tool else "arm.urdf")
    path.write_text(ARM.replace("</robot>", TOOL0) if tool else ARM)
    return path


def _colliding_arm(directory):
    """The arm with a box and a sphere colliding on its welded tool0, touching the ground."""
    from eomc.compiler.urdf.model import UrdfModel
    path = Path(directory) / "arm_colliding.urdf"
    path.write_text(_arm(directory).read_text().replace(
        '<link name="tool0"/>', '<link name="tool0"><collision><origin xyz="0 0 0.3" rpy="0 0.2 0"/><geometry>'
        '<box size="0.05 0.05 0.1"/></geometry></collision><collision><origin xyz="0.01 0 0.3"/><geometry>'
        '<sphere radius="0.03"/></geometry></collision></link>'))
    return UrdfModel(path, ground=True)


def _ground_robot(rel):
    from eomc.compiler.urdf.model import UrdfModel
    from helpers.robots import robot_path
    return UrdfModel(robot_path(rel), floating_base=True, limits=False, ground=True)


def _test_attribute(relative, name):
    """A model text a test writes (tests/<relative>), taken from the test module itself."""
    import importlib.util
    spec = importlib.util.spec_from_file_location(f"_c_identity_{Path(relative).stem}", ROOT / "tests" / relative)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return getattr(module, name)


def cases(directory):
    """name -> function returning (model, keyword arguments of eomc.compiler.driver.generate)."""
    import eomc.mechanics as me
    from helpers import zoo
    out = {}
    for name in EXAMPLES:
        path = str(ROOT / "examples" / f"{name}.py")
        out[f"example:{name}"] = lambda path=path: (path, {})
    for form in ("kane", "recursive"):
        path = str(ROOT / "examples" / "cart_pole_system.py")
        out[f"example:cart_pole_system:{form}"] = lambda path=path, form=form: (path, {"formulation": form})
    out["example:cart_pole_system:frames"] = lambda: (str(ROOT / "examples" / "cart_pole_system.py"),
                                                      {"frames": ["com"]})

    def zoo_case(build, *args):
        def make():
            system, specified = build(*args, me)
            return system, {"inputs": specified}
        return make
    out["zoo:n_link_pendulum_on_cart3"] = zoo_case(zoo.n_link_pendulum_on_cart, 3)
    out["zoo:n_link_lagrange2"] = zoo_case(zoo.n_link_pendulum_on_cart_lagrange, 2)
    out["zoo:heavy_top"] = zoo_case(zoo.heavy_top)
    out["zoo:four_bar"] = zoo_case(zoo.four_bar)
    out["zoo:rolling_disc"] = lambda: (zoo.rolling_disc(me)[0], {})
    out["zoo:spring_damper_chain3"] = lambda: (zoo.spring_damper_chain(3, me)[0], {})

    arm = lambda tool=True: str(_arm(directory, tool))   # noqa: E731
    out["arm"] = lambda: (arm(False), {})
    out["arm:kane"] = lambda: (arm(False), {"formulation": "kane"})
    out["arm:recursive"] = lambda: (arm(False), {"formulation": "recursive"})
    out["arm_tool0:frames"] = lambda: (arm(), {"frames": ["tool0", "com"]})
    out["arm_tool0:frames:recursive"] = lambda: (arm(), {"frames": ["tool0"], "formulation": "recursive"})
    out["arm_tool0:contacts"] = lambda: (arm(), {"contacts": [dict(link="tool0", radius=0.02)],
                                                 "formulation": "recursive"})

    def arm_states(frames):
        def make():
            from sympy.physics.mechanics import dynamicsymbols
            i_m = dynamicsymbols("i_m")
            tau = dynamicsymbols("tau_elbow")
            kw = {"states": {i_m: -i_m + tau}, "formulation": "recursive"}
            if frames:
                kw["frames"] = ["tool0"]
            return arm(), kw
        return make
    out["arm_tool0:states"] = arm_states(False)
    out["arm_tool0:states:frames"] = arm_states(True)

    def robot(rel, floating, limits=False, **kw):
        def make():
            from eomc.compiler.urdf.model import UrdfModel
            from helpers.robots import robot_path
            return UrdfModel(robot_path(rel), floating_base=floating, limits=limits), kw
        return make
    for name, (rel, floating) in ROBOTS.items():
        out[f"robot:{name}"] = robot(rel, floating)
    out["robot:ur5:frames"] = robot("ur5", False, frames=["tool0"], formulation="recursive")
    # the default build of a robot (`eomc build panda.urdf`: the file's limits, damping and friction
    # on, with their default stiffness from the load each joint carries), which the robot cases
    # above leave out: a change to the URDF limit defaults or laws shows here
    out["robot:panda:limits"] = robot("panda", False, limits=True)
    out["robot:solo12:contacts"] = robot(
        "solo12", True, contacts=[dict(link=f"{leg}_FOOT", radius=0.016, vs=1e-4) for leg in ("FL", "FR", "HL", "HR")],
        formulation="recursive", functions=("rhs", "jac_x", "jac_r", "outputs", "events"))

    # the ground from the file's <collision> geometry (boxes, spheres, meshes; a welded link's too)
    out["arm_tool0:ground"] = lambda: (_colliding_arm(directory), {"frames": ["tool0"]})
    out["robot:solo12:ground"] = lambda: (_ground_robot("solo12"), {"functions": ("rhs", "outputs", "events")})

    # every row of the table of joint kinds (multibody/joint_kinds.py) from both readers: the
    # tests' small models (MJCF slide, hinges with ref and anchor, ball, free, a weld; URDF planar,
    # continuous, prismatic, revolute, fixed), body XYZ angles and quaternions
    def small_mjcf(orientation):
        def make():
            from eomc.compiler.mjcf.model import MjcfModel
            path = Path(directory) / "small.xml"
            path.write_text(_test_attribute("compiler/mjcf/test_mjcf.py", "SMALL"))
            return MjcfModel(path, **({"orientation": orientation} if orientation else {})), {}
        return make
    out["joints:mjcf_small"] = small_mjcf(None)          # the default: quaternions (session 30)
    out["joints:mjcf_small:euler"] = small_mjcf("euler")

    def urdf_zoo(**kw):
        def make():
            path = Path(directory) / "zoo.urdf"
            path.write_text(_test_attribute("compiler/urdf/test_joint_types.py", "ROBOT"))
            return str(path), kw
        return make
    out["joints:urdf_zoo"] = urdf_zoo()
    out["joints:urdf_zoo:recursive"] = urdf_zoo(formulation="recursive")
    out["robot:solo12:quaternion"] = robot("solo12", "quaternion")

    def gym(asset, ignore=("limits",), **kw):
        def make():
            import gymnasium
            from eomc.compiler.mjcf.model import MjcfModel
            path = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / f"{asset}.xml"
            return MjcfModel(path, ignore=ignore), kw
        return make
    for asset in GYM:
        out[f"gym:{asset}"] = gym(asset)
    # the default build (limits on: the MJCF limit law, its ramp and energy), which the cases above
    # leave out (session 22: a change to the limit law's lowering was checked by hand)
    for asset in GYM_LIMITS:
        out[f"gym:{asset}:limits"] = gym(asset, ignore=())
    # the fixed-step rollout's lanes (NAME_implicit_batch and its pairs' rows path, session 27's
    # 0441b173), which no default build emits
    from eomc.compiler.emit.signatures import FUNCTION_ORDER, ON_REQUEST
    lanes = tuple(f for f in FUNCTION_ORDER if f not in ON_REQUEST) + ("implicit_batch",)
    out["gym:humanoid:lanes"] = gym("humanoid", functions=lanes)
    return out


def digest(text):
    return hashlib.sha256(text.encode()).hexdigest()


def _placeless(text, directory=""):
    """``text`` with the places that differ between machines and checkouts named instead: this run's
    temporary folder, the installed packages (example-robot-data's and gymnasium's files, quoted in
    warnings and metadata) and this checkout.  Why: the metadata and warning digests of 11 robot
    cases differed between two machines with the same C (session 36), the venv's path in them."""
    import sysconfig
    places = [(str(directory), "<tmp>")] if directory else []
    places += [(sysconfig.get_paths()["purelib"], "<site-packages>"), (sys.prefix, "<prefix>"), (str(ROOT), "<repo>")]
    for place, name in places:
        text = text.replace(place, name)
    return text


def run_case(make, directory=""):
    from eomc.compiler.driver import generate
    from eomc.runtime.errors import EomcWarning
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", EomcWarning)
        try:
            system, kw = make()
            _, generated = generate(system, use_cache=False, progress=False, **kw)
        except Exception as exc:   # a case that stops (or starts) building is a difference too
            first = _placeless((str(exc).splitlines() or [""])[0], directory)
            return {"error": f"{type(exc).__name__}: {first}"}
    metadata = _placeless(json.dumps(generated.metadata, sort_keys=True, default=str), directory)
    notes = sorted({_placeless(str(w.message), directory) for w in caught if issubclass(w.category, EomcWarning)})
    return {"c": digest(generated.c_source), "h": digest(generated.header), "cdef": digest(generated.cdef),
            "metadata": digest(metadata), "functions": sorted(generated.metadata.get("functions", [])),
            "warnings": [digest(n)[:16] for n in notes]}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", action="store_true", help="record the baseline instead of comparing")
    parser.add_argument("-k", action="append", default=[], help="only cases whose name contains this")
    parser.add_argument("--file", type=Path, default=BASELINE, help="the baseline JSON")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as directory:
        chosen = {n: m for n, m in cases(directory).items() if not args.k or any(k in n for k in args.k)}
        results = {}
        for name, make in chosen.items():
            start = time.perf_counter()
            try:
                results[name] = run_case(make, directory)
            except Exception:
                traceback.print_exc()
                results[name] = {"error": "the script failed"}
            print(f"{name:<40} {time.perf_counter() - start:6.1f} s  "
                  f"{results[name].get('error') or results[name]['c'][:12]}", flush=True)
    if args.baseline:
        old = json.loads(args.file.read_text()) if args.file.exists() and args.k else {}
        old.update(results)
        args.file.write_text(json.dumps(dict(sorted(old.items())), indent=1) + "\n")
        print(f"baseline of {len(results)} cases written to {args.file}")
        return 0
    base = json.loads(args.file.read_text())
    differ = 0
    for name, got in results.items():
        want = base.get(name)
        if want is None:
            print(f"NEW      {name}: not in the baseline")
            differ += 1
            continue
        changed = [key for key in sorted(set(want) | set(got)) if want.get(key) != got.get(key)]
        if changed:
            differ += 1
            print(f"DIFFERS  {name}: {', '.join(changed)}")
            for key in changed:
                print(f"           {key}: {want.get(key)!r} -> {got.get(key)!r}")
    print(f"{len(results) - differ} of {len(results)} cases identical to {args.file.name}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
