"""eomc.compile end to end: model file or object -> loaded model, against closed forms."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from helpers import model_files
import eomc
from eomc.compiler.build import build
from eomc.compiler.build.cache import CacheWarning
from eomc.compiler.driver import Progress, generate
from eomc.errors import ModelError

RNG = np.random.default_rng(11)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    return {"cart": model_files.write(d, model_files.CART, "cart"),
            "pend": model_files.write(d, model_files.PENDULUM, "pendulum")}


def test_model_file_matches_closed_form(files, cache):
    model = eomc.compile(files["cart"], cache_dir=cache, progress=False)
    assert model.name == "cart" and model.input_names == ("F",)
    assert model.state_names == ("x", "th", "v", "w")
    assert model.initial_state.tolist() == [0.0, 0.4, 0.0, 0.0]
    for _ in range(25):
        x, F = RNG.normal(size=4), RNG.normal()
        np.testing.assert_allclose(model.rhs(0.0, x, r=[F]), model_files.cart_rhs(x, F), rtol=1e-12, atol=1e-13)


def test_system_object_with_keyword_arguments(files, cache):
    namespace = {}
    exec(compile(files["pend"].read_text(), str(files["pend"]), "exec"), namespace)
    m, l, g = (namespace[k] for k in ("m", "l", "g"))
    model = eomc.compile(namespace["kane"], "pendobj", parameters={m: 1.0, l: 2.0, g: 3.0},
                         outputs={"height": l * namespace["sm"].sin(namespace["q"])},
                         cache_dir=cache, progress=False)
    assert model.name == "pendobj" and dict(zip(model.param_names, model.param_defaults)) == {"m": 1.0, "l": 2.0, "g": 3.0}
    x = np.array([0.7, -0.1])
    np.testing.assert_allclose(model.rhs(0, x), model_files.pendulum_rhs(x, 1.0, 2.0, 3.0), rtol=1e-12)
    assert model.outputs(0, x) == pytest.approx({"height": 2.0 * np.sin(0.7)}, rel=1e-12)


def test_functions_subset_and_unknown_names(files, cache):
    model = eomc.compile(files["pend"], functions="rhs,mass_matrix", cache_dir=cache, progress=False)
    assert set(model.functions) == {"rhs", "mass_matrix"}
    with pytest.raises(ModelError, match="built without `jac_x`"):
        model.jacobian(0.0, [0.1, 0.2])
    with pytest.raises(ModelError, match="unknown function 'rhss'"):
        eomc.compile(files["pend"], functions=["rhss"], cache_dir=cache)
    with pytest.raises(ModelError, match="unknown parameter `mass`"):
        eomc.compile(files["pend"], parameters={"mass": 1.0}, cache_dir=cache)


def test_progress_reports_stage_timings(files, cache, capsys):
    eomc.compile(files["pend"], cache_dir=cache, progress=True)
    err = capsys.readouterr().err
    for stage in ("derive", "generate", "compile", "load"):
        assert f"eomc: {stage}" in err
    eomc.compile(files["pend"], cache_dir=cache, progress=False)
    assert capsys.readouterr().err == ""
    progress = Progress(False)
    eomc.compile(files["pend"], cache_dir=cache, progress=progress)  # a plain flag, not reused


def test_warm_cache_reuses_the_library(files, cache):
    first = eomc.compile(files["pend"], cache_dir=cache, progress=False)
    second = eomc.compile(files["pend"], cache_dir=cache, progress=False)
    assert first.library_path == second.library_path


def test_library_that_does_not_load_is_rebuilt(files, tmp_path):
    # build without loading: a library already loaded in this process cannot be replaced in it
    spec, generated = generate(files["pend"], progress=False)
    # the metadata compile() adds (its cache key reads it): the start, and the bodies' mass parameters
    from eomc.compiler.driver import _body_parameters
    bodies = _body_parameters(spec)
    extra = {"initial_state": spec.initial_state, **({"body_parameters": bodies} if bodies else {})}
    library = build(generated, cache_dir=tmp_path, extra_metadata=extra).library
    library.write_bytes(b"\0" * library.stat().st_size)  # same size: the manifest check passes, dlopen fails
    with pytest.warns(CacheWarning, match="was damaged .*rebuilding it"):
        second = eomc.compile(files["pend"], cache_dir=tmp_path, progress=False)
    assert second.library_path == library
    assert second.rhs(0, [0.3, 0.0])[1] == pytest.approx(model_files.pendulum_rhs([0.3, 0.0])[1], rel=1e-12)


def test_output_dir_gives_an_importable_module_without_sympy(files, cache, tmp_path):
    out = tmp_path / "built"
    model = eomc.compile(files["pend"], cache_dir=cache, output_dir=out, progress=False)
    assert model.library_path == out / "libpend.so"
    assert {p.name for p in out.iterdir()} >= {"pend.c", "pend.h", "libpend.so", "pend.json", "pend.py",
                                                "eomc_model.h", "eomc_integrators.h"}
    code = textwrap.dedent(f"""
        import sys
        sys.modules["sympy"] = None
        sys.path.insert(0, {str(out)!r})
        import pend
        print(pend.rhs(0.0, [0.3, 0.0])[1], pend.model.name)
        """)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    value, name = run.stdout.split()
    assert name == "pend" and float(value) == pytest.approx(model_files.pendulum_rhs([0.3, 0.0])[1], rel=1e-12)


def test_cython_backend_agrees_with_cffi(files, cache):
    cy = eomc.compile(files["cart"], backend="cython", cache_dir=cache, progress=False)
    ff = eomc.compile(files["cart"], cache_dir=cache, progress=False)
    assert cy.backend == "cython" and ff.backend == "cffi"
    X = RNG.normal(size=(10, 4))
    np.testing.assert_array_equal(cy.rhs_many(0.0, X, r=[0.5]), ff.rhs_many(0.0, X, r=[0.5]))
    np.testing.assert_array_equal(cy.jacobian(0.0, X[0]), ff.jacobian(0.0, X[0]))


def test_progress_lists_long_compiler_passes_in_plain_words(files, tmp_path, capsys, monkeypatch):
    """Passes that take long enough are listed under 'generate', named for people."""
    monkeypatch.setattr(Progress, "PASS_SHOWN", 0.0)     # the pendulum's passes are quick
    eomc.compile(files["pend"], cache_dir=tmp_path, progress=True)
    lines = capsys.readouterr().err.splitlines()
    start = lines.index("eomc: generate ...")
    # a log's "still running" lines (a loaded machine) are not the stage's end nor a pass
    end = next(i for i, line in enumerate(lines) if i > start and line.startswith("eomc: generate ")
               and "still running" not in line)
    passes = [line for line in lines[start + 1:end] if "still running" not in line]
    assert any(line.startswith("eomc:   common subexpressions ") for line in passes)
    assert passes and all(line.endswith(" s") and "_" not in line for line in passes)
    quiet = Progress(True)
    quiet.PASS_SHOWN = 1.0
    quiet.pass_done("cse", 0.5)                           # shorter than the threshold: silent
    assert capsys.readouterr().err == ""


def test_contact_laws_and_jacobian_plans_are_listed_like_passes(tmp_path, capsys, monkeypatch):
    """The contact laws' lowering and a recursive Jacobian's plan are not program passes, but on
    a contact-rich model they are most of 'generate' (dm_control's quadruped: ~24 of its ~29 s
    listed no step before session 22): they are listed under it, named for people."""
    path = tmp_path / "twolegs.xml"
    path.write_text(model_files.TWO_LEGS)
    monkeypatch.setattr(Progress, "PASS_SHOWN", 0.0)
    eomc.compile(str(path), cache_dir=tmp_path / "cache", progress=True)
    lines = capsys.readouterr().err.splitlines()
    start = lines.index("eomc: generate ...")
    # a log's "still running" lines (a loaded machine) are not the stage's end nor a pass
    end = next(i for i, line in enumerate(lines) if i > start and line.startswith("eomc: generate ")
               and "still running" not in line)
    steps = [line for line in lines[start + 1:end] if "still running" not in line]
    assert any(line.startswith("eomc:   contact laws ") for line in steps), steps
    assert any(line.startswith("eomc:   Jacobians (plan) ") for line in steps), steps


def test_auto_lists_forming_kanes_equations_under_generate(tmp_path, capsys, monkeypatch):
    """auto forms Kane's equations of a URDF robot inside 'generate' to compare both forms; that
    was most of so101's generate and no listed step (firsthour5: 76 s wall, ~7 s listed)."""
    path = tmp_path / "arm.urdf"
    path.write_text(_ARM_URDF)
    monkeypatch.setattr(Progress, "PASS_SHOWN", 0.0)
    eomc.compile(str(path), cache_dir=tmp_path / "cache", progress=True)
    lines = capsys.readouterr().err.splitlines()
    start = lines.index("eomc: generate ...")
    assert any(line.startswith("eomc:   Kane's equations (auto) ") and line.endswith(" s")
               for line in lines[start:]), lines


_ARM_URDF = """<robot name="arm">
  <link name="base"><inertial><mass value="2"/><origin xyz="0 0 0.05"/>
    <inertia ixx="0.02" iyy="0.03" izz="0.04" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="upper"><inertial><mass value="1"/><origin xyz="0 0 0.2"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10" velocity="5"/></joint>
</robot>"""


def test_compile_takes_floating_base_for_a_urdf_path(tmp_path, cache):
    """eomc.compile("robot.urdf", floating_base=True) as the command line's --floating-base
    (firsthour, session 20: it raised TypeError; the way in was UrdfModel, in docs/urdf.md only):
    the same model as UrdfModel(path, floating_base=True), six more coordinates than fixed."""
    from eomc.compiler.urdf.model import UrdfModel
    path = tmp_path / "arm.urdf"
    path.write_text(_ARM_URDF)
    kw = dict(functions=("rhs",), cache_dir=cache, progress=False)
    fixed = eomc.compile(str(path), **kw)
    floating = eomc.compile(str(path), floating_base=True, **kw)
    explicit = eomc.compile(UrdfModel(path, floating_base=True), **kw)
    assert floating.nq == fixed.nq + 6 == explicit.nq
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.5, 0.5, floating.nx)
    assert np.array_equal(floating.rhs(0.0, x), explicit.rhs(0.0, x))
    script = tmp_path / "m.py"
    script.write_text("")
    with pytest.raises(ModelError, match="floating_base= applies to URDF robots"):
        eomc.compile(str(script), floating_base=True, **kw)
