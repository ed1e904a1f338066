"""Libraries built for this machine's CPU (compiler/build/toolchain.MACHINE_FLAGS, runtime/cpu.py).

The default double build adds ``-mavx2 -ffp-contract=off`` on an x86-64 CPU with AVX2: the
same result bits as the portable -O2 build (checked here byte for byte on a floating-base
robot's rhs and jac_x; a build that may fuse multiply-adds differs, so the check can fail),
``portable=True`` / $EOMC_PORTABLE keep the portable flags, and a library whose flags this
CPU cannot run is refused by the loader with a message instead of dying of SIGILL.
"""
import platform

import numpy as np
import pytest

from helpers import osc_model
from helpers.robots import robot_path
from eomc.compiler.build import DEFAULT_CFLAGS, build, find_compiler
from eomc.compiler.build.toolchain import GCC_MACHINE_FLAGS, MACHINE_FLAGS, machine_flags
from eomc.runtime.metadata import LoadError
from eomc.runtime import cpu
from eomc.runtime.loader import load

X86 = platform.machine().lower() in ("x86_64", "amd64")
AVX2 = X86 and "avx2" in (cpu.cpu_features() or ())


def test_machine_flags_follow_the_cpu():
    tc = find_compiler()
    own = MACHINE_FLAGS if tc.is_clang else MACHINE_FLAGS + GCC_MACHINE_FLAGS   # clang rejects -fno-ipa-ra
    assert machine_flags(tc) == (own if AVX2 else ())
    assert "-mfma" not in MACHINE_FLAGS and "-march=native" not in MACHINE_FLAGS


def test_default_portable_and_env(tmp_path, monkeypatch):
    gen = osc_model.oscillator()
    own = build(gen, cache_dir=tmp_path)
    portable = build(gen, cache_dir=tmp_path, portable=True)
    assert load(own.directory).metadata["build"]["cflags"] == [*DEFAULT_CFLAGS, *machine_flags(find_compiler())]
    assert load(portable.directory).metadata["build"]["cflags"] == list(DEFAULT_CFLAGS)
    assert (own.key != portable.key) == AVX2          # a shared cache never serves one for the other
    monkeypatch.setenv("EOMC_PORTABLE", "1")
    assert build(gen, cache_dir=tmp_path).key == portable.key
    assert build(gen, cache_dir=tmp_path, cflags="-O1 -std=c99").key != portable.key   # the user's flags rule


@pytest.mark.skipif(not AVX2, reason="the machine flags are added on x86-64 CPUs with AVX2 only")
def test_machine_build_gives_the_portable_bits(tmp_path):
    from eomc.compiler.driver import generate
    from eomc.compiler.urdf.model import UrdfModel
    model = UrdfModel(robot_path("solo12"), floating_base="quaternion", limits=False)
    _, gen = generate(model, "solo_bits", functions=["rhs", "jac_x"], cache_dir=tmp_path, progress=False)
    builds = {"own": {}, "portable": dict(portable=True),
              "fused": dict(cflags="-O2 -std=c99 -mavx2 -mfma -ffp-contract=fast")}
    models = {k: load(build(gen, cache_dir=tmp_path, **kw).directory) for k, kw in builds.items()}
    own = models["own"]
    assert "-mavx2" in own.metadata["build"]["cflags"]
    rng = np.random.default_rng(6)
    X = rng.uniform(-1.0, 1.0, (60, own.nx)) * rng.choice([0.5, 1.0, 3.0], (60, own.nx))
    out = {k: [np.concatenate([m.rhs(0.0, x), m.jac_x(0.0, x).ravel()]) for x in X]
           for k, m in models.items()}
    assert np.array_equal(np.array(out["own"]).view(np.uint64), np.array(out["portable"]).view(np.uint64))
    assert not np.array_equal(np.array(out["own"]), np.array(out["fused"]))   # the check sees one rounding


@pytest.mark.skipif(not AVX2, reason="the machine flags are added on x86-64 CPUs with AVX2 only")
def test_machine_build_of_a_contact_model_gives_the_portable_bits(tmp_path):
    """The ground law's sqrt (depth^1.5, the slip's norm) and NAME_implicit's contact slopes, in
    and out of touch: gcc's -fno-math-errno drops only errno (sqrt is the bare instruction),
    -mmemset-strategy only changes how zeros are stored, so the bits are the portable build's."""
    gymnasium = pytest.importorskip("gymnasium")
    from pathlib import Path
    from eomc.compiler.driver import generate
    from eomc.compiler.mjcf.model import MjcfModel
    xml = Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / "hopper.xml"
    _, gen = generate(MjcfModel(xml), "hop_bits", functions=["rhs", "jac_x", "outputs", "implicit"], cache_dir=tmp_path,
                      progress=False)
    own = load(build(gen, cache_dir=tmp_path).directory)
    portable = load(build(gen, cache_dir=tmp_path, portable=True).directory)
    if not find_compiler().is_clang:
        assert "-fno-math-errno" in own.metadata["build"]["cflags"]
    rng = np.random.default_rng(29)
    X = rng.uniform(-1.0, 1.0, (80, own.nx)) * rng.choice([0.1, 0.5, 1.0, 3.0], (80, own.nx))
    depths = np.array([[v for k, v in own.outputs(0.0, x).items() if k.startswith("depth_")] for x in X])
    assert (depths > 0).any() and (depths <= 0).any()     # points in touch and out of it

    def run(m, x):
        out = np.full(1 << 14, 7.25)      # past the end of NAME_implicit's output: untouched on both
        work = np.zeros(1 << 16)
        rc = m.model_lib.hop_bits_implicit(0.0, m.ffi.from_buffer("double[]", x),
                                           m.ffi.from_buffer("double[]", np.asarray(m.param_defaults, float)),
                                           m.ffi.from_buffer("double[]", np.zeros(max(m.ninput, 1))),
                                           m.ffi.from_buffer("double[]", out), m.ffi.from_buffer("double[]", work))
        return np.concatenate([[rc], m.rhs(0.0, x), m.jac_x(0.0, x).ravel(), out])

    a = np.array([run(own, x) for x in X])
    b = np.array([run(portable, x) for x in X])
    assert np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.mark.skipif(not X86, reason="-mavx2 is an x86 flag")
def test_loader_refuses_a_library_this_cpu_cannot_run(tmp_path, monkeypatch):
    built = build(osc_model.oscillator(), cache_dir=tmp_path, cflags="-O2 -std=c99 -mavx2")
    monkeypatch.setattr(cpu, "cpu_features", lambda: frozenset({"sse2"}))
    with pytest.raises(LoadError, match=r"built for a CPU with AVX2 .*--portable"):
        load(built.directory)
    monkeypatch.setattr(cpu, "cpu_features", lambda: None)    # features unknown: nothing refused
    assert load(built.directory).rhs(0.0, [0.3, -0.2]) is not None


def test_a_huge_translation_unit_is_built_without_the_errno_free_pair(monkeypatch):
    """Above ERRNO_FREE_UP_TO bytes of C the library is built without -fno-math-errno and its memset
    strategy (gcc 12 took 3.3x the CPU on dm_control's 8 MB quadruped with them); below, with them."""
    import types
    from eomc.compiler.build import builder, toolchain
    tc = toolchain.find_compiler()
    if not set(toolchain.ERRNO_FREE_FLAGS) <= set(toolchain.machine_flags(tc)):
        pytest.skip("this compiler or CPU takes no errno-free pair (clang, or no AVX2)")
    seen = []

    def fake_run(link, tmp, name, key, root):
        seen.append(list(link))
        raise RuntimeError("stop after the command line")
    monkeypatch.setattr(builder, "run_compiler", fake_run)
    for size in (1000, toolchain.ERRNO_FREE_UP_TO + 1):
        generated = types.SimpleNamespace(name="big", c_source="/* x */\n" + " " * size, header="",
                                          metadata={"functions": ["rhs"]}, cdef="")
        with pytest.raises(Exception):
            builder.build(generated, force=True)
    small, big = seen
    assert set(toolchain.ERRNO_FREE_FLAGS) <= set(small)
    assert not set(toolchain.ERRNO_FREE_FLAGS) & set(big) and "-fno-ipa-ra" in big
