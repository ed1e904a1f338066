"""URDF chain build time vs n and axis pattern (recursive, rhs only)."""
import os, subprocess, sys, time
from pathlib import Path
sys.path.insert(0, "$SCRATCH/work")
from h import record, env, VENV
import s2_urdf_lib as L
D = Path("$SCRATCH/work/urdf4"); D.mkdir(exist_ok=True)
E = env(EOMC_CACHE_DIR="$SCRATCH/cache_urdf4")
def chain(n, planar):
    body = ""
    for i in range(n):
        ax = "0 1 0" if planar or i % 2 else "1 0 0"
        body += L.link(f"l{i}", com="0 0 0.1") + L.joint(f"j{i}", "base" if i == 0 else f"l{i-1}", f"l{i}", xyz="0 0 0.2", axis=ax)
    return L.robot(body)
for n, planar in [(8, False), (16, False), (24, False), (40, True)]:
    p = D / f"c{n}{'p' if planar else 'a'}.urdf"; p.write_text(chain(n, planar))
    t = time.time()
    q = subprocess.run(["/usr/bin/time", "-v", "timeout", os.environ.get("REL_SCALE_TIMEOUT", "600"), "nice", "-n", "5", f"{VENV}/eomc", "build", "-q", str(p), "-o", str(D / f"o{p.stem}"),
                        "--formulation", "recursive", "--outputs", "rhs"], capture_output=True, text=True, env=E)
    cpu = sum(float(l.split(":")[-1]) for l in q.stderr.splitlines() if "User time" in l or "System time" in l)
    rss = [l.split(":")[-1].strip() for l in q.stderr.splitlines() if "Maximum resident" in l]
    record("urdf", f"{n}-link URDF chain, {'planar (all y axes)' if planar else 'alternating x/y axes'}, recursive rhs (scaling)",
           "ok" if q.returncode == 0 else ("hang" if q.returncode == 124 else "raw"),
           f"rc={q.returncode} wall {time.time()-t:.0f}s CPU {cpu:.1f}s peak RSS {int(rss[0])//1024 if rss else '?'} MB")
