import subprocess
import sys

import eomc
from eomc.cli import main


def test_version_flag_prints_package_version(capsys):
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    assert capsys.readouterr().out.strip() == f"eomc {eomc.__version__}"


def test_import_eomc_does_not_import_sympy():
    code = "import sys, eomc, eomc.runtime; print('sympy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
