"""README.md and docs/ as a user meets them, from a clone: the quick start is the two commands
CI runs, every install line names extras pyproject.toml defines and installs from the clone
(eomc is not on a package index), every `eomc ...` command shown parses, every file a
command names exists, and every relative link resolves."""
import json
import os
import re
import shlex
import tomllib
from pathlib import Path

import pytest

from eomc.cli import SUBCOMMANDS, command_parser

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
PAGES = [README, *sorted((ROOT / "docs").glob("*.md"))]
EXTRAS = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])


def _shell_lines(path):
    """(line number, command) of every line of the page's ```bash blocks, comments dropped."""
    out, inside = [], False
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if line.startswith("```"):
            inside = line.strip() in ("```bash", "```sh", "```console")
            continue
        if inside and line.strip() and not line.lstrip().startswith("#"):
            out.append((number, re.sub(r"\s+#.*$", "", line.strip())))
    return out


def _commands(path):
    """Every simple command of the page's shell blocks, and the inline `pip install ...` spans."""
    for number, line in _shell_lines(path):
        for part in re.split(r"&&|\|\||;", line):
            if part.strip():
                yield number, shlex.split(part)
    for number, line in enumerate(path.read_text().splitlines(), 1):
        for span in re.findall(r"`(pip install [^`]+)`", line):
            yield number, shlex.split(span)


def _eomc_installs(path):
    for number, argv in _commands(path):
        if argv[:2] == ["pip", "install"]:
            specs = [a for a in argv[2:] if not a.startswith("-")]
            if any(s.startswith(".") or s.startswith("eomc") for s in specs):
                yield number, argv, specs


def test_quick_start_is_two_commands_and_ci_runs_both():
    text = README.read_text()
    section = text[text.index("## Quick start"):]
    block = section[section.index("```bash") + len("```bash"):]
    block = block[:block.index("```")].strip().splitlines()
    assert len(block) == 2, block
    assert block[0].startswith('pip install ".[plot]" && eomc simulate examples/')
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    for command in block:
        assert command in [line.strip() for line in ci], f"CI must run the README's command as written: {command}"


def test_readme_is_a_guide_of_at_most_250_lines():
    assert len(README.read_text().splitlines()) <= 250


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_install_lines_work_from_a_clone_with_extras_that_exist(page):
    for number, argv, specs in _eomc_installs(page):
        for spec in specs:
            match = re.fullmatch(r"\.(?:\[([\w,-]+)\])?", spec)
            assert match, f"{page.name}:{number}: {' '.join(argv)}: install eomc from the clone as " \
                          f"\".[EXTRA]\" (eomc is not on a package index)"
            for extra in (match.group(1) or "").split(","):
                assert not extra or extra in EXTRAS, f"{page.name}:{number}: no extra {extra!r} in pyproject.toml"


def test_every_extra_is_documented_in_readme():
    installs = {e for _, _, specs in _eomc_installs(README) for s in specs
                for e in re.findall(r"[\w-]+", s.partition("[")[2])}
    assert EXTRAS <= installs, f"extras README does not show: {sorted(EXTRAS - installs)}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_eomc_command_shown_parses_and_its_shipped_files_exist(page, capsys):
    for number, argv in _commands(page):
        if argv[0] != "eomc" or len(argv) < 2 or argv[1] not in SUBCOMMANDS:
            continue
        _, parser = command_parser(argv[1])
        try:
            parser.parse_args(argv[2:])
        except SystemExit:
            pytest.fail(f"{page.name}:{number}: {' '.join(argv)}: {capsys.readouterr().err.strip()}")
        for arg in argv[2:]:
            if arg.startswith(("examples/", "benchmarks/", "tests/")):
                assert (ROOT / arg).exists(), f"{page.name}:{number}: {arg} does not exist"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_relative_links_resolve(page):
    for target in re.findall(r"\]\(([^)\s#]+)(?:#[^)]*)?\)", page.read_text()):
        if "://" not in target:
            assert (page.parent / target).exists(), f"{page.name}: link to {target} does not resolve"


def _python_block(path, heading):
    """The first ```python block under the page's ``heading``."""
    text = path.read_text().split(f"\n{heading}\n", 1)[1]
    return text.split("```python\n", 1)[1].split("```", 1)[0]


def test_the_derivatives_snippet_runs_as_written(monkeypatch):
    # the first-hour report (s20): it built without jac_r, so linearize's B refused
    import numpy as np
    monkeypatch.chdir(ROOT)                      # the snippet's paths are a clone's
    # only the x of README's Python section (first hour s28: the snippet's x0 was defined nowhere)
    namespace = {"np": np, "x": np.array([0.0, 0.2, 0.0, 0.0])}
    exec(compile("import eomc\n" + _python_block(README, "## Derivatives"), "README.md", "exec"), namespace)
    A, B, P = namespace["A"], namespace["B"], namespace["P"]
    assert A.shape == (4, 4) and B.shape[0] == 4 and P.shape[0] == 4
    assert namespace["res"].dx_dp.shape[1:] == (4, P.shape[1])


def test_bdf_rhs_calls_per_step_match_the_committed_measurement():
    """README said BDF "needs one or two rhs calls per step"; the no-flag runs measure 2.13-2.31
    (s29 firsthour11: 2.26 on the hopper and Solo12).  The range README and docs/contact.md give
    is the range of benchmarks/results/bdf_calls.md (per accepted and per attempted step)."""
    table = (ROOT / "benchmarks" / "results" / "bdf_calls.md").read_text()
    per_step = [float(x) for row in table.splitlines() if row.startswith("| ") and "| bdf |" in row
                for x in row.strip(" |").split(" | ")[-2:]]
    assert len(per_step) >= 8, table
    said = f"{min(per_step):.1f}-{max(per_step):.1f} rhs calls per"
    for page in (README, ROOT / "docs" / "contact.md"):
        text = " ".join(page.read_text().split())
        assert said in text and "one or two rhs calls" not in text, (page.name, said)


def _python_blocks(path):
    """Every ```python block of the page."""
    return [block.split("```", 1)[0] for block in path.read_text().split("```python\n")[1:]]


def test_the_python_blocks_of_readme_and_docs_python_run_as_written(tmp_path, monkeypatch):
    """The Python a SymPy user copies first (s30 first hour): README's "Import: Python" and "Many
    states" blocks and docs/python.md's, run verbatim in one namespace each, from a directory that
    holds what they name -- a clone's examples/, `out/` as `eomc build examples/double_pendulum.py
    -o out` writes it, and `ur5.urdf` (example-robot-data's UR5).  (README's "Derivatives" block
    has its own test above: it reads an `x` from the first block.)"""
    import numpy as np
    from eomc.cli import main
    from helpers.robots import robot_path       # example-robot-data, a test dependency: no skip
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    ur5 = robot_path("ur5")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    (tmp_path / "ur5.urdf").write_bytes(ur5.read_bytes())
    assert main(["build", "examples/double_pendulum.py", "-o", "out", "-q"]) == 0
    readme = {b.split("\n", 1)[0]: b for b in _python_blocks(README)}
    blocks = [("README.md, Import: Python", readme["import numpy as np"]),
              ("README.md, Many states", readme["import numpy as np, eomc"]),
              ("docs/python.md", _python_blocks(ROOT / "docs" / "python.md")[0])]
    ran = {}
    for where, block in blocks:
        ran[where] = namespace = {}
        exec(compile(block, where, "exec"), namespace)
    for where in ("README.md, Import: Python", "docs/python.md"):
        res, built = ran[where]["res"], ran[where]["built"]
        assert res.status == 0 and np.isfinite(res["q1"]).all() and built.state_names == ("q1", "q2", "u1", "u2")
    assert ran["docs/python.md"]["robot"].frame("tool0", 0.0, np.zeros(12)).p.shape == (3,)
    many = ran["README.md, Many states"]["res"]
    assert many.x.shape == (10_000, 4) and np.all(many.status == 0)


def test_rhs_call_ratios_match_derivative_calls_md():
    """README's derivative costs "in rhs calls ([derivative_calls.md], ...)" mixed two sessions'
    tables (s30: jac_r 4.8 and jac_p 58 were session 22's G1, superseded by the file's two current
    runs, 4.55 / 4.41 and 52 / 54; jvp and vjp 3.1 / 3.3 were below its 3.16 / 3.35).  Each range
    README and docs/derivatives.md state is the file's current tables' range (above its "Session 22"
    part), rounded half up to the digits stated."""
    from decimal import ROUND_HALF_UP, Decimal
    text = (ROOT / "benchmarks" / "results" / "derivative_calls.md").read_text().split("## Session 22", 1)[0]
    columns = {"jac_x": "jac_x/rhs", "jvp": "jvp/rhs", "vjp": "vjp/rhs", "jac_r": "jac_r/rhs", "jac_p": "jac_p/rhs"}
    values, head = {k: [] for k in columns}, None
    for row in text.splitlines():
        cells = [c.strip() for c in row.strip().strip("|").split("|")]
        if row.startswith("| model |"):
            head = cells
        elif head and row.startswith("| ") and len(cells) == len(head) and cells[0] != "model":
            for k, col in columns.items():
                values[k].append(Decimal(cells[head.index(col)]))
    assert all(len(v) >= 16 for v in values.values()), values       # two runs of 8 rows
    pages = {README: r"`(jac_x|jvp|vjp|jac_r|jac_p)` ([0-9.]+)-([0-9.]+)",
             ROOT / "docs" / "derivatives.md": r"\b(jac_x|jvp|vjp|jac_r|jac_p) ([0-9.]+)-([0-9.]+)"}
    for page, pattern in pages.items():
        sentence = " ".join(page.read_text().split()).split("derivative_calls.md", 1)[1][:500]
        said = {m.group(1): (m.group(2), m.group(3)) for m in re.finditer(pattern, sentence)}
        assert set(said) == set(columns), (page.name, said)
        for k, (lo, hi) in said.items():
            got = [min(values[k]), max(values[k])]
            rounded = [v.quantize(Decimal(s) if "." not in s else Decimal(1).scaleb(-len(s.split(".")[1])),
                                  rounding=ROUND_HALF_UP) for v, s in zip(got, (lo, hi))]
            assert [str(r) for r in rounded] == [lo, hi], (page.name, k, lo, hi, got)


def test_the_rollout_blocks_of_docs_sweeps_run_as_written(tmp_path):
    """docs/sweeps.md's rollout block, then its stopped rollout (s33 first hour: `partial_result`
    was in no page) with a Ctrl-C 0.5 s into the call (a million rows: minutes on 2 cores), verbatim in one namespace in a process of
    their own: the rows that ended are status 0, the others 9, and those never started NaN."""
    import subprocess
    import sys
    import textwrap
    blocks = [textwrap.dedent(b) for b in _python_blocks(ROOT / "docs" / "sweeps.md")]
    first = next(b for b in blocks if "eomc.rollout(model, X0, steps=1000" in b)
    stopped = next(b for b in blocks if "partial_result" in b)
    # the Ctrl-C 0.5 s after the C run is armed (a Timer started before the call fired while its Python
    # prepared a million rows, under CI's load: then no row had ended)
    ctrl_c = ("import os, signal, threading\nfrom eomc.runtime import native\n_arm = native._Interruptible._arm\n"
              "def _timed(self):\n    threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()\n"
              "    return _arm(self)\nnative._Interruptible._arm = _timed\n")
    check = ("import json\nprint(json.dumps([len(res.status), int(done.sum()), int(never.sum()),"
             " int((res.status == 9).sum()), bool((res.status[never] == 9).all())]))\n")
    script = first + stopped.replace("try:\n", ctrl_c + "try:\n", 1) + check
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    env = dict(os.environ, EOMC_CACHE_DIR=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    n, done, never, stopped_rows, never_are_9 = json.loads(out.stdout.strip().splitlines()[-1])
    assert n == 1_000_000 and done > 0 and never > 0 and never_are_9 and done + stopped_rows == n
