"""A command repeated on an unchanged model file loads the model it built, without deriving it;
a robot file is read once per command (eomc.compiler.build.reuse, eomc.cli.common)."""
import warnings

import numpy as np
import pytest

from eomc.cli import main

PENDULUM = '''
import sympy as sm
from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
{extra}
q, u = dynamicsymbols("q u")
m, l, g = sm.symbols("m l g", positive=True)
N = ReferenceFrame("N")
A = N.orientnew("A", "Axis", [q, N.z])
A.set_ang_vel(N, u * N.z)
O = Point("O")
O.set_vel(N, 0)
P = O.locatenew("P", -l * A.y)
P.v2pt_theory(O, N, A)
system = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
system.kanes_equations([Particle("bob", P, m)], [(P, -m * g * N.y)])
parameters = {{m: 1.0, l: LENGTH, g: 9.81}}
initial_state = {{q: 1.0, u: 0.0}}
'''


@pytest.fixture
def counted(monkeypatch, tmp_path):
    """A fresh cache, and counters of what a command does: readings of a model (the start of
    every derivation), derivations, C compiles."""
    import eomc.compiler.build.builder as builder
    import eomc.compiler.driver as driver
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    counts = {"read": 0, "derive": 0, "compile C": 0}

    def counting(name, real):
        def wrapper(*args, **kwargs):
            counts[name] += 1
            return real(*args, **kwargs)
        return wrapper
    monkeypatch.setattr(driver, "read_model", counting("read", driver.read_model))
    monkeypatch.setattr(driver, "spec_of", counting("derive", driver.spec_of))
    monkeypatch.setattr(builder, "run_compiler", counting("compile C", builder.run_compiler))
    return counts


def _model_file(tmp_path, extra="", length="1.0"):
    (tmp_path / "lengths.py").write_text(f"LENGTH = {length}\n")
    path = tmp_path / "pendulum.py"
    path.write_text(PENDULUM.format(extra=extra or "from lengths import LENGTH"))
    return path


def _run(path, out, *argv):
    assert main(["simulate", str(path), "--t-final", "0.5", "-q", "-o", str(out), *argv]) == 0
    return np.genfromtxt(out, delimiter=",", names=True)


def test_the_second_run_derives_nothing(counted, tmp_path):
    path = _model_file(tmp_path)
    first = _run(path, tmp_path / "1.csv")
    assert counted["read"] == 1 and counted["derive"] >= 1 and counted["compile C"] == 1, counted
    counted.update({k: 0 for k in counted})
    second = _run(path, tmp_path / "2.csv")
    assert counted == {"read": 0, "derive": 0, "compile C": 0}, counted
    assert np.array_equal(first["q"], second["q"])


SECOND_RUN = """
import sys
from eomc.cli import main
code = main(["simulate", sys.argv[1], "--t-final", "0.5", "-q", "-o", sys.argv[2]])
print(code, 'sympy' in sys.modules)
"""


def test_the_second_run_imports_no_sympy(tmp_path):
    """The look-up of the model built before (its key, the cache) imports no SymPy: it cost each
    command ~0.7 s before it started (s27: eomc.compiler imported SymPy, and the key's generator
    switches imported the generator's modules)."""
    import os
    import subprocess
    import sys
    path = _model_file(tmp_path)
    env = {**os.environ, "EOMC_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", SECOND_RUN, str(path), str(tmp_path / f"{k}.csv")],
                           capture_output=True, text=True, env=env, timeout=300) for k in range(2)]
    assert [r.stdout.split()[-2:] for r in runs] == [["0", "True"], ["0", "False"]], [r.stderr for r in runs]


BUILD_RUN = """
import sys
from eomc.cli import main
code = main(["build", sys.argv[1], "-o", sys.argv[2]])     # no -q: the summary is read
print(code, 'sympy' in sys.modules)
"""


def test_a_build_served_by_what_simulate_built_imports_no_sympy(tmp_path):
    """`eomc build` after `eomc simulate` of the same file exports what simulate built: it derives
    nothing, and imports no SymPy either (s28: its formulation line's cost model, and the driver
    imported before the look-up, cost it ~0.7 s of its ~1.1 s CPU)."""
    import os
    import subprocess
    import sys
    path = _model_file(tmp_path)
    env = {**os.environ, "EOMC_CACHE_DIR": str(tmp_path / "cache")}
    first = subprocess.run([sys.executable, "-c", SECOND_RUN, str(path), str(tmp_path / "1.csv")],
                           capture_output=True, text=True, env=env, timeout=300)
    build = subprocess.run([sys.executable, "-c", BUILD_RUN, str(path), str(tmp_path / "out")],
                           capture_output=True, text=True, env=env, timeout=300)
    assert first.stdout.split()[-2:] == ["0", "True"], first.stderr
    assert build.stdout.split()[-2:] == ["0", "False"], build.stderr
    assert "formulation: " in build.stdout and (tmp_path / "out" / "pendulum.json").is_file()


def test_a_changed_file_or_option_is_derived_again(counted, tmp_path):
    """The file's bytes and the options are in the key: each change derives again."""
    path = _model_file(tmp_path, extra="LENGTH = 1.0")
    _run(path, tmp_path / "1.csv")
    counted.update({k: 0 for k in counted})
    _run(path, tmp_path / "2.csv", "--formulation", "kane")     # another option
    assert counted["read"] == 1, counted
    counted.update({k: 0 for k in counted})
    path.write_text(path.read_text().replace("LENGTH = 1.0", "LENGTH = 2.0"))     # the file itself
    _run(path, tmp_path / "3.csv")
    assert counted["read"] == 1 and counted["compile C"] == 1, counted


def test_a_changed_module_beside_the_file_is_derived_again(tmp_path):
    """A module the model file imports is a dependency of the build: changed, the model is
    derived again (fresh processes, as the command line runs: a module imported once stays
    imported in a process)."""
    import os
    import subprocess
    import sys
    path = _model_file(tmp_path)
    env = {**os.environ, "EOMC_CACHE_DIR": str(tmp_path / "cache")}

    def run(out):
        done = subprocess.run([sys.executable, "-m", "eomc", "simulate", str(path), "--t-final", "0.5", "-q",
                               "-o", str(out)], capture_output=True, text=True, env=env, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        return np.genfromtxt(out, delimiter=",", names=True)["q"]
    first, again = run(tmp_path / "1.csv"), run(tmp_path / "2.csv")
    assert np.array_equal(first, again)
    _model_file(tmp_path, length="2.0")
    assert not np.allclose(first, run(tmp_path / "3.csv"))      # the longer pendulum swings slower


def test_a_reused_build_warns_again_and_checks_the_options(counted, tmp_path, capsys):
    """What the build said is said again on a reuse; a misspelt --param is still one line."""
    path = _model_file(tmp_path, extra='import warnings\nwarnings.warn("lengths are in metres")\nLENGTH = 1.0')
    with pytest.warns(UserWarning, match="lengths are in metres"):
        _run(path, tmp_path / "1.csv")
    counted.update({k: 0 for k in counted})
    with pytest.warns(UserWarning, match="lengths are in metres"):
        _run(path, tmp_path / "2.csv")
    assert counted["read"] == 0, counted
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        capsys.readouterr()
        assert main(["simulate", str(path), "--t-final", "0.5", "-q", "--param", "lenght=2"]) == 2
    err = capsys.readouterr().err
    assert "unknown parameter lenght in --param" in err and err.count("\n") == 1, err
    assert counted["read"] == 0, counted


def test_a_reused_build_does_not_say_its_build_notes_again(counted, tmp_path):
    """ANYmal's, Allegro's and HyQ's kept link inertias (the dynamics are fine) were said on
    every simulate/check/animate that reused the build (first hour s26): a BuildNote is said
    when the model is built and not again on a reuse, while its other warnings still are."""
    from eomc.errors import BuildNote
    extra = ('import warnings\nfrom eomc.errors import BuildNote\n'
             'warnings.warn("inertias kept as given", BuildNote)\n'
             'warnings.warn("lengths are in metres")\nLENGTH = 1.0')
    path = _model_file(tmp_path, extra=extra)
    with warnings.catch_warnings(record=True) as first:
        warnings.simplefilter("always")
        _run(path, tmp_path / "1.csv")
    assert [str(w.message) for w in first if w.category is BuildNote] == ["inertias kept as given"]
    counted.update({k: 0 for k in counted})
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        _run(path, tmp_path / "2.csv")
    assert counted["read"] == 0, counted                    # reused
    said = [str(w.message) for w in again]
    assert "lengths are in metres" in said and "inertias kept as given" not in said, said


def test_a_robot_is_read_once_per_command(monkeypatch, tmp_path, capsys):
    """--x0, --input, --frame and --param are checked on the build's own reading of the URDF."""
    import eomc.compiler.urdf as urdf
    import eomc.compiler.urdf.reader as reader
    from helpers.urdf_arm import ARM
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "arm.urdf"
    path.write_text(ARM)
    reads = []
    real = reader.read_urdf

    def counting(*args, **kwargs):
        reads.append(args[0] if args else kwargs)
        return real(*args, **kwargs)
    monkeypatch.setattr(reader, "read_urdf", counting)
    monkeypatch.setattr(urdf, "read_urdf", counting)
    assert main(["simulate", str(path), "--t-final", "0.1", "-q", "--x0", "q_shoulder=0.3", "--input",
                 "tau_elbow=0.1", "--frame", "lower", "--param", "m_lower=2"]) == 0, capsys.readouterr().err
    assert len(reads) == 1, reads
    reads.clear()       # a typo: one reading, one line, nothing derived
    assert main(["simulate", str(path), "--t-final", "0.1", "-q", "--x0", "q_shouldr=0.3"]) == 2
    assert len(reads) == 1 and "did you mean q_shoulder" in capsys.readouterr().err


def test_a_model_files_param_is_checked_once_it_has_run(monkeypatch, tmp_path, capsys):
    """A .py model's parameters are known when the file has run: a misspelt --param is
    refused then, before its equations are derived or any C is generated."""
    import eomc.compiler.driver as driver
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))

    def refuse(*args, **kwargs):
        raise AssertionError("the model was derived or compiled")
    monkeypatch.setattr(driver, "spec_of", refuse)
    monkeypatch.setattr(driver, "build_and_load", refuse)
    path = _model_file(tmp_path)
    for command in (["simulate", "--t-final", "1"], ["check", "--t-final", "1"]):
        assert main([command[0], str(path), *command[1:], "-q", "--param", "ln=2"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "unknown parameter ln in --param (did you mean l?)" in err, err


def _arm(tmp_path):
    from helpers.urdf_arm import ARM
    path = tmp_path / "arm.urdf"
    path.write_text(ARM)
    return path


def _built(counted, tmp_path, argv, out):
    """Run ``eomc simulate`` on the arm and return (the model the command ran, what it did)."""
    import eomc.runtime.simulate as simulate_module
    seen = []
    real = simulate_module.simulate

    def spy(model, *args, **kwargs):
        seen.append(model)
        return real(model, *args, **kwargs)
    counted.update({k: 0 for k in counted})
    import unittest.mock
    with unittest.mock.patch.object(simulate_module, "simulate", spy):
        assert main(["simulate", str(argv[0]), "--t-final", "0.2", "-q", "-o", str(out), *argv[1:]]) == 0
    return seen[0], dict(counted)


def test_a_run_that_reads_no_implicit_terms_builds_none_and_implicitfast_gets_them(counted, tmp_path):
    """NAME_implicit (a quarter of a ground robot's build) is built only for a command that runs
    implicitfast; a build with it serves every later command, one without it never serves
    implicitfast (cli.common.load_model's methods)."""
    arm = _arm(tmp_path)
    contact = ["--contact", "lower:0,0,0.3:0.05"]
    model, did = _built(counted, tmp_path, [arm, *contact], tmp_path / "1.csv")
    assert "implicit" not in model.functions and did["compile C"] == 1, (model.functions, did)
    model, did = _built(counted, tmp_path, [arm, *contact, "--method", "bdf"], tmp_path / "2.csv")
    assert did == {"read": 0, "derive": 0, "compile C": 0}, did
    model, did = _built(counted, tmp_path, [arm, *contact, "--method", "implicitfast", "--dt", "0.002"],
                        tmp_path / "3.csv")
    assert "implicit" in model.functions and did["compile C"] == 1, (model.functions, did)
    model, did = _built(counted, tmp_path, [arm, *contact], tmp_path / "4.csv")     # the full build serves
    assert "implicit" in model.functions and did == {"read": 0, "derive": 0, "compile C": 0}, did
    first, last = (np.genfromtxt(tmp_path / f"{i}.csv", delimiter=",", names=True) for i in (1, 4))
    assert np.array_equal(first["q_shoulder"], last["q_shoulder"])


def test_a_model_without_contacts_built_for_auto_serves_implicitfast(counted, tmp_path):
    """Without contacts the default build has no NAME_implicit either: the build for auto is
    recorded as the default build too, so implicitfast does not build the model again."""
    arm = _arm(tmp_path)
    model, did = _built(counted, tmp_path, [arm], tmp_path / "1.csv")
    assert did["compile C"] == 1, did
    model, did = _built(counted, tmp_path, [arm, "--method", "implicitfast", "--dt", "0.002"], tmp_path / "2.csv")
    assert did == {"read": 0, "derive": 0, "compile C": 0}, did


def test_eomc_build_serves_the_commands_that_follow(counted, tmp_path, capsys):
    """Sweep s27: after `eomc build hopper.xml -o out`, `eomc simulate hopper.xml` derived,
    generated and compiled the model again (4.5 s CPU; dm_control's humanoid_CMU 41 s, 10x its
    11-29 figure): the command looks for the default set without NAME_implicit, which no build had
    recorded.  The build records itself under the key the commands look up (with its warnings, said
    again on reuse), so simulate and implicitfast after it read and build nothing."""
    arm = _arm(tmp_path)
    contact = ["--contact", "lower:0,0,0.3:0.05"]
    assert main(["build", str(arm), *contact, "-q", "-o", str(tmp_path / "out")]) == 0
    assert counted["compile C"] == 1, counted
    model, did = _built(counted, tmp_path, [arm, *contact], tmp_path / "1.csv")
    assert "implicit" in model.functions and did == {"read": 0, "derive": 0, "compile C": 0}, did
    model, did = _built(counted, tmp_path, [arm, *contact, "--method", "implicitfast", "--dt", "0.002"],
                        tmp_path / "2.csv")
    assert did == {"read": 0, "derive": 0, "compile C": 0}, did
    # a build other commands would not make (its own name) is not recorded for them
    assert main(["build", str(arm), *contact, "-q", "--name", "other", "-o", str(tmp_path / "o2")]) == 0
    model, did = _built(counted, tmp_path, [arm, *contact], tmp_path / "3.csv")
    assert model.name == "arm" and did == {"read": 0, "derive": 0, "compile C": 0}, did


def test_eomc_build_after_simulate_reuses_what_simulate_built(counted, tmp_path, capsys):
    """First hour s28: `eomc build a1.urdf --floating-base --ground -o DIR` after `eomc simulate` of
    the same robot derived, generated (and compiled) it again.  The build now looks up what the
    commands recorded under its key first: a model without contacts (simulate's build holds every
    default function: NAME_implicit is built for contacts only) and one simulated with
    implicitfast are written into DIR without deriving anything.  With contacts and the default
    method simulate built no NAME_implicit, which `eomc build` writes: it builds, and says why."""
    arm = _arm(tmp_path)
    for extra in ([], ["--frame", "lower"]):
        _built(counted, tmp_path, [arm, *extra], tmp_path / "1.csv")
        counted.update({k: 0 for k in counted})
        out = tmp_path / ("plain" + "".join(extra))
        assert main(["build", str(arm), *extra, "-o", str(out)]) == 0     # no -q: the summary is read
        assert counted == {"read": 0, "derive": 0, "compile C": 0}, (extra, counted)
        assert (out / "arm.json").is_file() and (out / "arm.py").is_file()
        assert "built model 'arm'" in capsys.readouterr().out
    contact = ["--contact", "lower:0,0,0.3:0.05"]
    _built(counted, tmp_path, [arm, *contact, "--method", "implicitfast", "--dt", "0.002"], tmp_path / "2.csv")
    counted.update({k: 0 for k in counted})
    assert main(["build", str(arm), *contact, "-q", "-o", str(tmp_path / "c1")]) == 0
    assert counted == {"read": 0, "derive": 0, "compile C": 0}, counted
    capsys.readouterr()
    contact = ["--contact", "lower:0,0,0.2:0.05"]
    _built(counted, tmp_path, [arm, *contact], tmp_path / "3.csv")
    counted.update({k: 0 for k in counted})
    assert main(["build", str(arm), *contact, "-o", str(tmp_path / "c2")]) == 0
    assert counted["derive"] >= 1, counted
    assert "NAME_implicit" in capsys.readouterr().err
