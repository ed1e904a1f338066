"""eomc animate: a built directory to HTML, a trajectory CSV, a GIF, and one-line errors."""
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from eomc.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The double pendulum built into a directory once (`eomc build`, default functions)."""
    tmp = tmp_path_factory.mktemp("animate")
    out = tmp / "dp"
    env_cache = tmp / "cache"
    run = subprocess.run([sys.executable, "-m", "eomc", "build", str(EXAMPLES / "double_pendulum.py"),
                          "-o", str(out), "-q"], capture_output=True, text=True, timeout=300,
                         env={**__import__("os").environ, "EOMC_CACHE_DIR": str(env_cache)})
    assert run.returncode == 0, run.stderr
    return out


def _data(page):
    text = Path(page).read_text()
    return json.loads(re.search(r'id="eomc-data">(.*?)</script>', text, re.S).group(1))


def test_animate_a_built_directory(built, tmp_path, capsys):
    page = tmp_path / "dp.html"
    assert main(["animate", str(built), "--t-final", "2", "-o", str(page), "--fps", "30"]) == 0
    assert "wrote" in capsys.readouterr().out
    data = _data(page)
    t = np.frombuffer(__import__("base64").b64decode(data["t"]), "<f4")
    assert len(t) == 61 and t[-1] == pytest.approx(2.0)
    assert data["points"] == ["Bob1", "Bob2", "O"] and data["traces"][0]["name"] == "Bob2"


def test_animate_a_trajectory_csv_and_a_gif(built, tmp_path):
    traj = tmp_path / "traj.csv"
    assert main(["simulate", str(built), "--t-final", "1", "-o", str(traj), "--points", "11"]) == 0
    page, gif = tmp_path / "dp.html", tmp_path / "dp.gif"
    assert main(["animate", str(built), "--from", str(traj), "-o", str(page), "--gif", str(gif),
                 "--gif-fps", "5", "--trace", "Bob1"]) == 0
    data = _data(page)
    assert data["traces"][0]["name"] == "Bob1" and [o["name"] for o in data["outputs"]] == ["energy", "tip_x", "tip_y"]
    from PIL import Image
    with Image.open(gif) as im:
        assert im.n_frames == 6


def test_a_gif_is_reported_with_its_size_and_span(built, tmp_path, capsys):
    """As the HTML page's line (size, span): before, "wrote dp.gif" alone."""
    gif = tmp_path / "dp.gif"
    assert main(["animate", str(built), "--t-final", "1", "--gif", str(gif), "--gif-fps", "5", "-q"]) == 0
    size = gif.stat().st_size / 1e6
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote {gif} ({size:.2f} MB, 5 frames/s, t = [0, 1])"


def test_no_output_named_writes_the_models_page_and_never_over_a_users_file(built, tmp_path, monkeypatch, capsys):
    """No flags at all (issue 29's first run): the page is MODEL's name + .html in the current
    folder; a second run rewrites its own page; a file of that name eomc did not write stays."""
    monkeypatch.chdir(tmp_path)
    assert main(["animate", str(built), "--t-final", "0.5", "--fps", "10"]) == 0
    assert "wrote dp.html" in capsys.readouterr().out
    assert len(np.frombuffer(__import__("base64").b64decode(_data(tmp_path / "dp.html")["t"]), "<f4")) == 6
    assert main(["animate", str(built), "--t-final", "1", "--fps", "10"]) == 0      # its own page: rewritten
    assert len(np.frombuffer(__import__("base64").b64decode(_data(tmp_path / "dp.html")["t"]), "<f4")) == 11
    capsys.readouterr()
    mine = tmp_path / "dp.html"
    mine.write_text("<html>my notes</html>")
    assert main(["animate", str(built), "--t-final", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "dp.html exists and eomc did not write it" in err and len(err.strip().splitlines()) == 1, err
    assert mine.read_text() == "<html>my notes</html>"


@pytest.mark.parametrize("argv,match", [
    (["--t-final", "1", "-o", "x.png"], "expected a .html file"),
    (["--from", "{bad}", "-o", "x.html"], "no column q2, u2"),
    (["--t-final", "1", "-o", "x.html", "--trace", "Bob7"], "trace names 'Bob7'"),
])
def test_animate_errors_are_one_line(built, tmp_path, capsys, argv, match):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,q1,u1\n0,0.1,0\n0.1,0.2,0\n")
    argv = [a.replace("{bad}", str(bad)) for a in argv]
    argv = [str(tmp_path / a) if a.endswith((".html", ".png")) else a for a in argv]
    assert main(["animate", str(built), *argv]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err


def test_mp4_without_ffmpeg_is_one_line(built, tmp_path, monkeypatch, capsys):
    """No ffmpeg on PATH and no imageio-ffmpeg wheel: one line naming the extra to install
    from the clone, no traceback, status 2 -- before the model is loaded or run."""
    import eomc.cli.common as cli_common
    import eomc.runtime.animate as animate_module

    def refuse(*args, **kwargs):
        raise AssertionError("the model was loaded before the missing ffmpeg was reported")
    monkeypatch.setattr(cli_common, "load_model", refuse)
    monkeypatch.setattr(animate_module.shutil, "which", lambda name: None)
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    assert main(["animate", str(built), "--t-final", "0.5", "--mp4", str(tmp_path / "dp.mp4")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert 'writing .mp4 needs ffmpeg: install the video extra (pip install ".[video]"' in err, err


TILTED = '''
import sympy as sm
from eomc.mechanics import KanesMethod, Particle, Point, ReferenceFrame, dynamicsymbols
q, u = dynamicsymbols("q u")
m, l, g = sm.symbols("m l g", positive=True)
N = ReferenceFrame("N")
A = N.orientnew("A", "Axis", [q, N.x + N.y])
A.set_ang_vel(N, u * (N.x + N.y).normalize())
O = Point("O")
O.set_vel(N, 0)
P = O.locatenew("P", -l * A.z)
P.v2pt_theory(O, N, A)
system = KanesMethod(N, q_ind=[q], u_ind=[u], kd_eqs=[q.diff() - u])
system.kanes_equations([Particle("bob", P, m)], [(P, -m * g * N.z)])
parameters = {m: 1.0, l: 1.0, g: 9.81}
initial_state = {q: 1.0, u: 0.0}
'''


def test_a_gif_of_a_motion_out_of_plane_is_refused_before_the_run(tmp_path, monkeypatch, capsys):
    """First hour s28: an A1's --gif was refused ("not planar") only after its 11 s run.  A start
    that already leaves every coordinate plane is refused before the model is simulated."""
    import eomc.runtime.model as model_module
    monkeypatch.setenv("EOMC_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "tilted.py"
    path.write_text(TILTED)

    def refuse(*args, **kwargs):
        raise AssertionError("simulated before the --gif was refused")
    monkeypatch.setattr(model_module.Model, "simulate", refuse)
    assert main(["animate", str(path), "--t-final", "1", "-q", "--gif", str(tmp_path / "t.gif")]) == 2
    err = capsys.readouterr().err
    assert "tilted is not planar at its start" in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("flag", ["--gif", "--mp4"])
def test_a_bare_gif_flag_says_what_it_takes(built, tmp_path, capsys, flag):
    """First hour s28: `--gif -o a1.gif` gave argparse's bare "expected one argument"."""
    suffix = flag[2:]
    assert main(["animate", str(built), flag, "-o", str(tmp_path / f"a.{suffix}")]) == 2
    err = capsys.readouterr().err
    assert f"{flag} takes the {suffix.upper()} file to write, e.g. {flag} anim.{suffix}" in err, err
