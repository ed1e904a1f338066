"""How big is a fresh virtual environment for the README's quick start?

For each git revision given (default: HEAD), clone the repository, make a fresh venv
(``python3 -m venv``, with its own pip and setuptools) and run the quick start's install,
``pip install '.[plot]'``, and the base install, ``pip install .``, each in its own venv.
Reported: the venv's size on disk (``du``), and the installed size of each distribution
(its RECORD files), largest first, so the table shows where the megabytes go.  Comparing two
revisions in one run keeps the package index and the pip version the same for both.

    python3 benchmarks/bench_install_size.py [--rev main~1,HEAD] [--no-write]
"""
import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import environment_header, format_table, write_results  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
INSTALLS = (("quick start", ".[plot]"), ("base", "."))

_SIZES = """
import importlib.metadata as md, json, os
out = {}
for d in md.distributions():
    total = 0
    for f in d.files or []:
        try:
            total += os.path.getsize(d.locate_file(f))
        except OSError:
            pass
    out[d.metadata["Name"]] = total
print(json.dumps(out))
"""


def _du_mb(path):
    return int(subprocess.run(["du", "-sm", str(path)], capture_output=True, text=True, check=True)
               .stdout.split()[0])


def measure(rev, spec, work):
    src = work / f"src-{rev.replace('/', '_').replace('~', '_')}"
    if not src.exists():
        subprocess.run(["git", "clone", "-q", str(REPO), str(src)], check=True)
        subprocess.run(["git", "-C", str(src), "checkout", "-q", rev], check=True)
    venv = work / f"venv-{src.name}-{spec.strip('.[]') or 'base'}"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    subprocess.run([str(venv / "bin" / "pip"), "install", "-q", spec], cwd=src, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    sizes = json.loads(subprocess.run([str(venv / "bin" / "python"), "-c", _SIZES], capture_output=True,
                                      text=True, check=True).stdout)
    commit = subprocess.run(["git", "-C", str(src), "log", "-1", "--format=%h %s"], capture_output=True,
                            text=True, check=True).stdout.strip()
    return {"rev": rev, "commit": commit, "spec": spec, "du_mb": _du_mb(venv), "sizes": sizes}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rev", default="HEAD", help="comma-separated git revisions (default HEAD)")
    parser.add_argument("--no-write", action="store_true")
    args = parser.parse_args(argv)
    revs = [r for r in args.rev.split(",") if r]
    # resolve names here: inside the clone, HEAD and branch names mean the clone's
    revs = [subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", r], capture_output=True,
                           text=True, check=True).stdout.strip() for r in revs]
    with tempfile.TemporaryDirectory(prefix="eomc-install-") as tmp:
        runs = [measure(rev, spec, Path(tmp)) for rev in revs for _, spec in INSTALLS]
    rows = [[r["commit"][:60], f"pip install '{r['spec']}'", r["du_mb"],
             f"{sum(r['sizes'].values()) / 1e6:.0f}", len(r["sizes"])] for r in runs]
    text = environment_header("Size of a fresh venv for the quick start", args, notes=[
        "each install in its own fresh `python3 -m venv` (its pip and setuptools count), from a clone",
        "venv MB: `du -sm` of the venv; dists MB: the sum of every distribution's RECORD files",
    ])
    text += "\n" + format_table(["revision", "install", "venv MB (du)", "dists MB", "distributions"], rows)
    names = sorted({n for r in runs for n in r["sizes"]},
                   key=lambda n: -max(r["sizes"].get(n, 0) for r in runs))
    text += "\n\n## Where the megabytes go (installed size per distribution, MB)\n\n"
    text += format_table(["distribution"] + [f"{r['rev']} {r['spec']}" for r in runs],
                         [[n] + [f"{r['sizes'][n] / 1e6:.1f}" if n in r["sizes"] else "-" for r in runs]
                          for n in names if max(r["sizes"].get(n, 0) for r in runs) >= 0.5e6])
    print(text)
    if not args.no_write:
        for path in write_results("install_size", text):
            print("wrote", path)


if __name__ == "__main__":
    main()
