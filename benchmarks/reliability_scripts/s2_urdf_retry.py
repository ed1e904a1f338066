"""Run again only the named cases of s2_urdf.py (REL_ONLY_CASES, comma-separated; argv[1:] also works).

Written for the rerun (not one of the tester's scripts): three s2_urdf attempts of the 2026-11-26 rerun
failed with rc=127 because the driver's scratch venv link was being rebuilt while they ran; this
re-executes s2_urdf.py's own build() for those cases only, without wiping its folder."""
import os
import sys

ONLY = set(filter(None, os.environ.get("REL_ONLY_CASES", "").split(","))) | set(sys.argv[1:])
src = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "s2_urdf.py")).read()
src = src.replace("shutil.rmtree(D, ignore_errors=True)", "pass").replace("D.mkdir()", "D.mkdir(exist_ok=True)", 1)
src = src.replace('    fname = fname or f"{case}.urdf"\n',
                  '    if case not in ONLY:\n        return 0, "", "", D / "__skipped__"\n    fname = fname or f"{case}.urdf"\n', 1)
src = src.replace('    record("urdf-sec",', '    ONLY or record("urdf-sec",')
assert src.count("__skipped__") == 1 and "ONLY or record" in src
exec(compile(src, "s2_urdf.py", "exec"), {"__name__": "__main__", "ONLY": ONLY})
