"""A big translation unit compiled on several cores (compiler/build/toolchain.parallel_flags).

gcc's link-time optimiser splits the back end's work into partitions run as parallel jobs; the
library must compute exactly what the one-unit build computes (checked byte for byte here on a
floating-base robot's functions at random states), keep its measured stacks, and be used only where
it can run in parallel: gcc with make on PATH and more than one job.
"""
import os
import shutil

import numpy as np
import pytest

from helpers.robots import robot_path
from eomc.compiler.build import build, find_compiler
from eomc.compiler.build import toolchain
from eomc.compiler.build.toolchain import Toolchain, build_jobs, parallel_flags
from eomc.runtime.loader import load

GCC = not find_compiler().is_clang and shutil.which("make") is not None


@pytest.mark.skipif(not GCC, reason="the parallel build is gcc's -flto with make")
def test_the_parallel_build_gives_the_one_unit_bits_and_its_stacks(tmp_path, monkeypatch):
    from eomc.compiler.driver import generate
    from eomc.compiler.urdf.model import UrdfModel
    model = UrdfModel(robot_path("solo12"), floating_base="quaternion", limits=False)
    _, gen = generate(model, "solo_jobs", functions=["rhs", "jac_x", "outputs", "mass_matrix"],
                      cache_dir=tmp_path / "gen", progress=False)
    monkeypatch.setattr(toolchain, "PARALLEL_FROM", 0)      # this C is small: take the path anyway
    monkeypatch.setenv("EOMC_BUILD_JOBS", "2")
    parallel = build(gen, cache_dir=tmp_path / "parallel")
    monkeypatch.setenv("EOMC_BUILD_JOBS", "1")
    one = build(gen, cache_dir=tmp_path / "one")
    assert parallel.key == one.key                           # the same library, compiled another way
    a, b = load(parallel.directory), load(one.directory)
    assert a.metadata["build"]["parallel"] == ["-flto=2"]
    assert "parallel" not in b.metadata["build"]
    assert a.metadata["build"]["cflags"] == b.metadata["build"]["cflags"]
    assert sorted(os.listdir(parallel.directory)) == sorted(os.listdir(one.directory))   # no partition files left
    if b.metadata.get("stack"):
        assert set(a.metadata["stack"]) == set(b.metadata["stack"])
        assert all(a.metadata["stack"][f]["bytes"] for f in ("rhs", "jac_x"))
    rng = np.random.default_rng(44)
    X = rng.uniform(-1.0, 1.0, (40, a.nx)) * rng.choice([0.5, 1.0, 3.0], (40, a.nx))
    for x in X:
        for m0, m1 in ((a.rhs, b.rhs), (a.jac_x, b.jac_x), (a.mass_matrix, b.mass_matrix)):
            assert np.array_equal(np.asarray(m0(0.0, x)).view(np.uint64), np.asarray(m1(0.0, x)).view(np.uint64))
        oa, ob = a.outputs(0.0, x), b.outputs(0.0, x)
        assert all(np.array_equal(np.asarray(oa[k]).view(np.uint64), np.asarray(ob[k]).view(np.uint64)) for k in ob)


def test_parallel_flags_only_where_they_run_in_parallel(monkeypatch, tmp_path):
    gcc = Toolchain(("/usr/bin/gcc",), "/usr/bin/gcc", "gcc (Debian 12.2.0-14) 12.2.0")
    clang = Toolchain(("/usr/bin/clang",), "/usr/bin/clang", "Debian clang version 14.0.6")
    big = toolchain.PARALLEL_FROM
    make_dir = tmp_path / "bin"
    make_dir.mkdir()
    (make_dir / "make").write_text("#!/bin/sh\n")
    (make_dir / "make").chmod(0o755)
    with_make = {"PATH": str(make_dir), "EOMC_BUILD_JOBS": "4"}
    assert parallel_flags(gcc, big, with_make) == ("-flto=4",)
    assert parallel_flags(gcc, big - 1, with_make) == ()                                 # small: one unit
    assert parallel_flags(clang, big, with_make) == ()
    assert parallel_flags(gcc, big, {**with_make, "PATH": str(tmp_path)}) == ()           # no make: serial LTO
    assert parallel_flags(gcc, big, {**with_make, "EOMC_BUILD_JOBS": "1"}) == ()
    assert 1 <= build_jobs({}) <= 8


@pytest.mark.parametrize("value", ["0", "-2", "two", "1.5"])
def test_a_bad_job_count_is_named(value):
    with pytest.raises(ValueError, match="EOMC_BUILD_JOBS"):
        build_jobs({"EOMC_BUILD_JOBS": value})


@pytest.mark.skipif(not GCC, reason="the parallel build is gcc's -flto with make")
def test_the_progress_line_is_told_the_jobs_build_runs(monkeypatch):
    from helpers import osc_model
    from eomc.compiler.build import compile_jobs
    gen = osc_model.oscillator()
    monkeypatch.setenv("EOMC_BUILD_JOBS", "3")
    assert compile_jobs(gen) == 1                            # small C: one process
    monkeypatch.setattr(toolchain, "PARALLEL_FROM", 0)
    assert compile_jobs(gen) == 3
    assert compile_jobs(gen, cflags="-O1") == 1              # the user's flags: theirs alone
