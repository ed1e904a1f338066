"""`eomc build`: the files it writes, the module it generates, and failures leaving DIR untouched."""
import subprocess
import sys

import numpy as np

from helpers import model_files
from eomc.cli import main


def test_build_writes_sources_library_metadata_and_module(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    out = tmp_path / "out"
    code = main(["build", str(model), "-o", str(out), "--name", "trolley", "--outputs", "rhs,jacobian",
                 "--cache-dir", str(tmp_path / "cache")])     # no -q: the summary is printed
    assert code == 0
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == sorted(
        ["trolley.c", "trolley.h", "libtrolley.so", "trolley.json", "trolley.py",
         "eomc_model.h", "eomc_integrators.h", "eomc_batch.h", "eomc_batch.c"])
    assert "built model 'trolley'" in capsys.readouterr().out
    script = ("import sys; sys.modules['sympy'] = None; sys.path.insert(0, sys.argv[1]); import trolley, json;"
              "print(json.dumps([list(trolley.rhs(0.0, [0.1, 0.4, 0.3, -0.2], r=[1.5])), list(trolley.model.functions)]))")
    run = subprocess.run([sys.executable, "-c", script, str(out)], capture_output=True, text=True, timeout=120,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    import json
    values, functions = json.loads(run.stdout)
    np.testing.assert_allclose(values, model_files.cart_rhs(np.array([0.1, 0.4, 0.3, -0.2]), 1.5), rtol=1e-12)
    assert set(functions) == {"rhs", "jac_x"}


def test_quiet_build_prints_nothing_and_errors_still_show(tmp_path, capsys):
    """-q: nothing on stdout or stderr on success (it printed the summary and the file list: quiet
    means quiet); a failure still says what failed (and warnings and the moved start's note still
    show: test_first_hour's test_build_says_the_moved_start_as_a_cli_note)."""
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    assert main(["build", str(model), "-o", str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c"), "-q"]) == 0
    printed = capsys.readouterr()
    assert (printed.out, printed.err) == ("", "")
    assert (tmp_path / "o" / "pend.json").is_file()
    assert main(["build", str(tmp_path / "nope.py"), "-o", str(tmp_path / "o2"), "-q"]) == 1
    printed = capsys.readouterr()
    assert printed.out == "" and "nope.py: cannot read model file" in printed.err


def test_header_declares_the_model_entry_point(tmp_path):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    assert main(["build", str(model), "-o", str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c"), "-q"]) == 0
    header = (tmp_path / "o" / "pend.h").read_text()
    assert "pend_model(void)" in header and '#include "eomc_model.h"' in header


def test_failed_build_leaves_output_dir_untouched(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    out = tmp_path / "o"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    code = main(["build", str(model), "-o", str(out), "--cache-dir", str(tmp_path / "c"), "-q",
                 "--cflags=-O2 -fPIC -std=c99 -DEOMC_X=1 -Wno-such-warning-flag-xyz -Werror=bogus-flag"])
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith("eomc build: error: the C compiler failed on ")
    assert "no-such-warning-flag-xyz" in err  # the compiler's own message
    assert [p.name for p in out.iterdir()] == ["keep.txt"]


def test_missing_model_file_and_missing_system(tmp_path, capsys):
    assert main(["build", str(tmp_path / "nope.py"), "-o", str(tmp_path / "o")]) == 1
    assert "nope.py: cannot read model file" in capsys.readouterr().err
    bad = model_files.write(tmp_path, "x = 1\n", "bad")
    assert main(["build", str(bad), "-o", str(tmp_path / "o")]) == 1
    assert f"{bad}: does not define `system`" in capsys.readouterr().err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_missing_compiler_message(tmp_path, capsys, monkeypatch):
    model = model_files.write(tmp_path, model_files.PENDULUM, "p")
    monkeypatch.setenv("CC", str(tmp_path / "no" / "cc"))
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert main(["build", str(model), "-o", str(tmp_path / "o"), "--cache-dir", str(tmp_path / "c"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "not an executable C compiler" in err and "install" in err


def test_unknown_function_is_named_and_fold_parameters_bakes_defaults(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    assert main(["build", str(model), "-o", str(tmp_path / "o"), "--outputs", "rhs,massmatrix", "-q"]) == 1
    assert "unknown function 'massmatrix' to generate; choose from rhs" in capsys.readouterr().err
    assert main(["build", str(model), "-o", str(tmp_path / "f"), "--fold-parameters", "-q",
                 "--cache-dir", str(tmp_path / "c")]) == 0
    import eomc
    folded = eomc.load(tmp_path / "f")
    assert folded.nparam == 0
    x = np.array([0.1, 0.4, 0.3, -0.2])
    np.testing.assert_allclose(folded.rhs(0.0, x, r=[1.0]), model_files.cart_rhs(x, 1.0), rtol=1e-12)


def test_build_target_f32_writes_float_c_with_its_stack_and_a_float_module(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    out = tmp_path / "out32"
    code = main(["build", str(model), "-o", str(out), "--name", "trolley32", "--target", "c99-f32",
                 "--cache-dir", str(tmp_path / "cache")])     # no -q: the summary (its stack line) is printed
    assert code == 0
    printed = capsys.readouterr().out
    assert "stack (bytes, worst case over the calls inside trolley32.c): " in printed and "rhs " in printed
    header = (out / "trolley32.h").read_text()
    assert "int trolley32_rhs(float t, const float *x" in header and "trolley32_step_rk4" in header
    assert "trolley32_model(void)" not in header
    script = ("import sys; sys.modules['sympy'] = None; sys.path.insert(0, sys.argv[1]); import trolley32, json;"
              "print(json.dumps([float(v) for v in trolley32.rhs(0.0, [0.1, 0.4, 0.3, -0.2], r=[1.5])]))")
    run = subprocess.run([sys.executable, "-c", script, str(out)], capture_output=True, text=True, timeout=120,
                         cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    import json
    np.testing.assert_allclose(json.loads(run.stdout), model_files.cart_rhs(np.array([0.1, 0.4, 0.3, -0.2]), 1.5),
                               rtol=1e-5, atol=1e-6)


def test_build_target_f32_without_rhs_has_no_step(tmp_path):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    out = tmp_path / "mm"
    assert main(["build", str(model), "-o", str(out), "--name", "mm32", "--target", "c99-f32", "--outputs",
                 "mass_matrix", "--cache-dir", str(tmp_path / "cache"), "-q"]) == 0
    assert "step_rk4" not in (out / "mm32.c").read_text()
    import eomc
    m = eomc.load(out)
    assert m.mass_matrix(0.0, [0.1, 0.4, 0.3, -0.2]).shape == (2, 2)
    import pytest
    with pytest.raises(eomc.runtime.errors.EomcError, match="mm32_step_rk4 was not generated"):
        m.step_rk4(0.0, 0.01, [0.1, 0.4, 0.3, -0.2])


def test_build_target_choices_are_listed(tmp_path, capsys):
    model = model_files.write(tmp_path, model_files.CART, "cart")
    import pytest
    with pytest.raises(SystemExit):
        main(["build", str(model), "-o", str(tmp_path / "x"), "--target", "c99-f16"])
    assert "invalid choice: 'c99-f16' (choose from 'c99-f64', 'c99-f32')" in capsys.readouterr().err
