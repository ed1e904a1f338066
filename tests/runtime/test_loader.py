"""eomc.runtime.loader: finding a build, refusing stale ones, and never importing SymPy."""
import json
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from helpers import osc_model
from eomc.compiler.build import build
from eomc.runtime.loader import LoadError, load


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return build(osc_model.oscillator(), cache_dir=tmp_path_factory.mktemp("cache"))


@pytest.fixture
def copy(built, tmp_path):
    target = tmp_path / "model"
    shutil.copytree(built.directory, target)
    return target


def test_load_by_directory_json_or_library(copy):
    for where in (copy, copy / "osc.json", copy / "libosc.so"):
        model = load(where)
        assert model.name == "osc" and model.library_path == copy / "libosc.so"
    assert load(copy, "osc").nx == 2


def test_wrong_name_or_empty_directory(copy, tmp_path):
    with pytest.raises(LoadError, match="no model named 'nope'"):
        load(copy, "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(LoadError, match="expected one built model, found none"):
        load(tmp_path / "empty")
    with pytest.raises(LoadError, match="no such model directory"):
        load(tmp_path / "missing")


def test_metadata_that_disagrees_with_the_library_is_refused(copy):
    data = json.loads((copy / "osc.json").read_text())
    data["nx"] = 5
    (copy / "osc.json").write_text(json.dumps(data))
    with pytest.raises(LoadError, match="nx is 2 in the library but 5 in its metadata"):
        load(copy)


def test_other_abi_version_is_refused(copy):
    data = json.loads((copy / "osc.json").read_text())
    data["abi_version"] = 99
    (copy / "osc.json").write_text(json.dumps(data))
    with pytest.raises(LoadError, match="ABI 99"):
        load(copy)


def test_unloadable_library_is_a_load_error(copy):
    (copy / "libosc.so").write_bytes(b"not a library")
    with pytest.raises(LoadError, match="cannot load model 'osc'"):
        load(copy)


def test_cdef_is_rebuilt_from_function_list_when_absent(copy):
    data = json.loads((copy / "osc.json").read_text())
    del data["cdef"]
    (copy / "osc.json").write_text(json.dumps(data))
    model = load(copy)
    assert model.inverse_dynamics(0.0, [0.0, 0.0], [1.0]).tolist() == [2.0]


def test_loading_needs_no_sympy(copy):
    code = textwrap.dedent(f"""
        import sys
        sys.modules["sympy"] = None  # any import of sympy now fails
        import numpy as np
        import eomc
        model = eomc.load({str(copy)!r})
        print(model.rhs(0.0, np.array([0.3, -0.2]))[1])
        print(sorted(m for m, v in sys.modules.items() if v is not None and m.startswith(("sympy", "eomc.compiler"))))
        """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    value, modules = out.stdout.splitlines()
    assert float(value) == pytest.approx(osc_model.oscillator_rhs(0, [0.3, -0.2])[1], rel=1e-14)
    assert modules == "[]"
    np.testing.assert_allclose(load(copy).rhs(0.0, [0.3, -0.2]), osc_model.oscillator_rhs(0, [0.3, -0.2]))


def test_two_libraries_with_the_same_model_name_stay_apart(built, tmp_path):
    """Same NAME, different code, one process: each Model calls its own library's functions."""
    doubled = osc_model.SOURCE.format(n="osc", N="OSC").replace("xdot[0] = x[1];", "xdot[0] = 2.0 * x[1];")
    other = build(osc_model.oscillator(c_source=doubled), cache_dir=tmp_path)
    first, second = load(built.directory), load(other.directory)
    x = np.array([0.3, -0.2])
    assert first.rhs(0.0, x)[0] == -0.2 and second.rhs(0.0, x)[0] == -0.4
    assert first.rhs_many(0.0, x[None, :])[0, 0] == -0.2 and second.rhs_many(0.0, x[None, :])[0, 0] == -0.4
    assert first.rhs(0.0, x)[0] == -0.2  # loading the second did not rebind the first


# ---- trust at load (reliability report 2026-11, F10) --------------------------------------------

_EVIL = """
#include <stdio.h>
__attribute__((constructor)) static void evil(void) { FILE *f = fopen("%s", "w"); if (f) fclose(f); }
"""


def _edit(copy, **changes):
    path = copy / "osc.json"
    data = json.loads(path.read_text())
    for key, value in changes.items():
        target = data
        *parents, last = key.split("__")
        for parent in parents:
            target = target[parent]
        target[last] = value
    path.write_text(json.dumps(data))


@pytest.mark.parametrize("where", ["relative", "absolute"])
def test_library_outside_the_directory_is_never_opened(copy, tmp_path, where):
    from eomc.compiler.build import find_compiler
    marker = tmp_path / "PWNED"
    (tmp_path / "evil").mkdir()
    (tmp_path / "evil" / "evil.c").write_text(_EVIL % marker)
    evil = tmp_path / "evil" / "libevil.so"
    subprocess.run([*find_compiler().argv, "-shared", "-fPIC", "-o", str(evil), str(tmp_path / "evil" / "evil.c")],
                   check=True)
    _edit(copy, build__library="../evil/libevil.so" if where == "relative" else str(evil))
    with pytest.raises(LoadError, match="build.library must be a file name inside the model's directory"):
        load(copy)
    assert not marker.exists()          # its constructor never ran


@pytest.mark.parametrize("changes, message", [
    ({"build__extension": "../x/osc_cy.so"}, "build.extension must be a file name inside"),
    ({"param_names": ["m", "c"]}, r"param_names is \['m', 'c', 'k'\] in the library but \['m', 'c'\]"),
    ({"state_names": ["a", "b"]}, "state_names is"),
    ({"param_defaults": [2.0, 0.5, 1.0]}, r"param_defaults is \[2.0, 0.5, 8.0\] in the library"),
    ({"op_counts": {"rhs": {"adds": "x"}}}, "op_counts must map each function to integer"),
    ({"cdef": "int osc_rhs(double t;;"}, r"C declarations \(cdef\) do not match"),
    ({"cdef": "int system(const char *);\n"}, r"C declarations \(cdef\) do not match"),
    ({"nx": "2"}, "nx must be a non-negative integer, not '2'"),
    ({"name": "osc; rm"}, "the model name must be a C identifier"),
    ({"functions": ["rhs", "launch"]}, "functions must be a list of"),
    ({"initial_state": [1.0, "x"]}, "initial_state must be a list of 2 numbers"),
    ({"initial_state": [1.0]}, "initial_state must be a list of 2 numbers"),
])
def test_inconsistent_metadata_is_a_load_error_that_says_rebuild(copy, changes, message):
    _edit(copy, **changes)
    with pytest.raises(LoadError, match=message) as info:
        load(copy)
    assert "rebuild the model" in str(info.value)


def test_names_and_defaults_come_from_the_library(copy):
    model = load(copy)
    assert model.param_names == ("m", "c", "k") and list(model.param_defaults) == [2.0, 0.5, 8.0]
    assert model.state_names == ("q", "u") and model.output_names == ("energy",)


def test_refused_loads_do_not_poison_later_loads(copy, tmp_path):
    """Reliability rerun: after two loads refused by the library-vs-JSON check (and a garbage
    collection), every later load in the process -- of a good directory too -- failed with
    cffi's "cdata 'eomc_model *' points to an opaque type".  A fresh process, because the
    bug needs loads that fail before any successful one."""
    bad = tmp_path / "bad"
    shutil.copytree(copy, bad)
    data = json.loads((bad / "osc.json").read_text())
    data["param_defaults"] = [v + 1.0 for v in data["param_defaults"]]
    (bad / "osc.json").write_text(json.dumps(data))
    code = textwrap.dedent(f"""
        import gc
        import eomc
        from eomc.runtime.loader import LoadError
        for _ in range(3):
            try:
                eomc.load({str(bad)!r})
            except LoadError as exc:
                assert "param_defaults" in str(exc), exc
            else:
                raise SystemExit("the edited directory loaded")
            gc.collect()
        print(eomc.load({str(copy)!r}).rhs(0.0, [0.3, -0.2])[1])
        """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert float(out.stdout) == pytest.approx(osc_model.oscillator_rhs(0, [0.3, -0.2])[1], rel=1e-14)
