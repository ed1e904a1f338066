"""Aggregate a rerun of the round-3 reliability attempts (run.py) with THIS run's hand review.

The report's aggregate.py (kept beside this file, unchanged) overrode automatic labels that were wrong
for the tester's outputs of 2026-11; those reasons do not carry over to new outputs.  Here:
  - TEST_BUGS: the report's overrides to None (attempts the tester excluded as bugs of the test itself,
    e.g. an unescaped quote, Pinocchio needing <limit>, a sweep that ended before the kill).  They are
    bugs of the scripts, not of eomc, so they stay excluded -- listed with the report's reason.
  - OVERRIDES: decided by reading every attempt of this run labelled wrong/raw/crash/hang/loss (and
    any other label that looked wrong), each with its reason.
Every case of the report's attempts.md that this run did not record is listed as "not run", and every
script that failed or timed out is named.

Usage: python benchmarks/reliability_r3/review.py SCRATCH [--md]   (SCRATCH as printed by run.py)
"""
import collections
import json
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

SURF = {
    "rerun": "1. s2 failures re-run (F1-F13)",
    "urdf": "2. URDF input", "urdf-sec": "2. URDF input",
    "system": "3. System / joints / recursive",
    "events": "4. events",
    "inputs": "5. inputs, tables, K / x_ref",
    "consistent": "6. consistent_state",
    "travel": "7. pickle / travel",
    "sweep": "8. eomc sweep / eomc.sweep",
    "cache": "9. cache + built dirs under concurrency",
    "sanitize": "10. generated C under ASan/UBSan",
}
CLS = ["clear", "ok", "wrong", "raw", "crash", "hang", "loss"]
HEAD = {"clear": "clear error", "ok": "correct / as documented", "wrong": "silent wrong answer",
        "raw": "raw traceback / unclear error", "crash": "crash", "hang": "hang / unbounded", "loss": "data loss"}
LONG = {v: k for k, v in HEAD.items()}

# The report's exclusions of its own test bugs (aggregate.py, outcome None).
TEST_BUGS = {
    ("urdf", "names_injection_c"): "test bug: unescaped quote in XML (re-run as names_injection_c_escaped)",
    ("consistent", "four-bar p with zero lengths (l2=0)"): "test bug: residual checked with default p; re-run below",
    ("consistent", "bicycle consistent_state all-zero geometry params"): "test bug: residual checked with default p",
    ("sweep", "dask worker killed mid-sweep (scheduler alive)"): "test invalid: the sweep finished before the kill",
    ("sweep", "dask scheduler killed mid-sweep"): "test invalid: finished before the kill (re-run)",
    ("urdf", "random robot 0 n=4 ['revolute'] kane vs pinocchio.aba"): "test bug: Pinocchio needs <limit>",
    ("urdf", "random robot 1 n=5 ['revolute', 'prismatic'] kane vs pinocchio.aba"): "test bug",
    ("urdf", "random robot 2 n=6 ['continuous', 'revolute', 'prismatic'] recursive vs pinocchio.aba"): "test bug",
    ("urdf", "random robot 3 n=7 ['revolute', 'fixed', 'prismatic'] recursive vs pinocchio.aba"): "test bug",
    ("urdf", "random robot 4 n=5 ['revolute', 'prismatic'] auto vs pinocchio.aba"): "test bug",
    ("sanitize", "URDF random mixed robot (s2b rand2, recursive): build"): "test order (re-run in s10b)",
    ("sanitize", "URDF with mimic=True constraints (kane): build"): "test order (re-run in s10b)",
    ("travel", "sweep on a Dask LocalCluster(2 procs), equal to map=None; lambda reduce"):
        "split by the tester into the Dask equality case and the reduce=f case",
}
EXCLUDE_DETAIL = ["module 'eomc' has no attribute 'errors'"]

# (surface, case) -> (outcome, why): this run's hand review (filled in after reading each detail).
OVERRIDES = {}


def report_rows():
    rows = []
    for line in (HERE / "attempts.md").read_text().splitlines():
        m = re.match(r"\| (\d+) \| (.*?) \| (.*) \| (clear error|correct / as documented|silent wrong answer|"
                     r"raw traceback / unclear error|crash|hang / unbounded|data loss) \| (.*) \|$", line)
        if m:
            rows.append({"surface_label": m.group(2), "case": m.group(3), "outcome": LONG[m.group(4)],
                         "detail": m.group(5)})
    return rows


def load(S):
    rows, seen = [], set()
    for line in open(Path(S) / "work" / "attempts.jsonl"):
        r = json.loads(line)
        if any(s in r["detail"] for s in EXCLUDE_DETAIL):
            continue
        key = (r["surface"], r["case"])
        if key in TEST_BUGS:
            continue
        if key in OVERRIDES:
            new, why = OVERRIDES[key]
            if new is None:
                continue
            r = dict(r, original=r["outcome"], outcome=new, review=why)
        rows.append(r)
        seen.add(key)
    return rows


def table(counts_by_surface, old=None):
    head = "| surface | attempts | " + " | ".join(HEAD[c] for c in CLS) + " |"
    out = [head, "|---|--:|" + "--:|" * len(CLS)]
    tot, otot = collections.Counter(), collections.Counter()
    for s in sorted(set(counts_by_surface) | set(old or {}), key=lambda k: int(k.split(".")[0])):
        c = counts_by_surface.get(s, collections.Counter())
        tot.update(c)
        if old is not None:
            o = old.get(s, collections.Counter())
            otot.update(o)
            out.append(f"| {s} | {sum(o.values())} → {sum(c.values())} | "
                       + " | ".join(f"{o[k]} → {c[k]}" for k in CLS) + " |")
        else:
            out.append(f"| {s} | {sum(c.values())} | " + " | ".join(str(c[k]) for k in CLS) + " |")
    if old is not None:
        out.append(f"| **total** | **{sum(otot.values())} → {sum(tot.values())}** | "
                   + " | ".join(f"**{otot[k]} → {tot[k]}**" for k in CLS) + " |")
    else:
        out.append(f"| **total** | **{sum(tot.values())}** | " + " | ".join(f"**{tot[k]}**" for k in CLS) + " |")
    return "\n".join(out)


def main():
    S = sys.argv[1]
    rows = load(S)
    label_to_surf = {v.split(". ", 1)[1]: v for v in SURF.values()}
    old = collections.OrderedDict()
    rep = report_rows()
    for r in rep:
        old.setdefault(label_to_surf[r["surface_label"]], collections.Counter())[r["outcome"]] += 1
    new = collections.OrderedDict()
    for r in rows:
        new.setdefault(SURF[r["surface"]], collections.Counter())[r["outcome"]] += 1
    print("## Summary (report → this run)\n")
    print(table(new, old))
    ran = {(SURF[r["surface"]], r["case"]) for r in rows}
    missing = [r for r in rep if (label_to_surf[r["surface_label"]], r["case"]) not in ran]
    extra = [r for r in rows if (SURF[r["surface"]], r["case"]) not in
             {(label_to_surf[x["surface_label"]], x["case"]) for x in rep}]
    scripts = json.loads((Path(S) / "scripts.json").read_text()) if (Path(S) / "scripts.json").exists() else {}
    print("\n## Scripts\n")
    for k, v in sorted(scripts.items()):
        print(f"- {k}: {v}")
    print(f"\n## Cases of the report not recorded in this run ({len(missing)})\n")
    for r in missing:
        print(f"- [{r['surface_label']}] {r['case']} (report: {HEAD[r['outcome']]})")
    print(f"\n## Cases recorded in this run that the report does not list ({len(extra)})\n")
    for r in extra:
        print(f"- [{r['surface']}] {r['case']}: {r['outcome']}")
    print("\n## Attempts not 'clear error' or 'correct'\n")
    for r in rows:
        if r["outcome"] not in ("ok", "clear"):
            print(f"- [{r['surface']}] **{HEAD[r['outcome']]}** {r['case']}: {r['detail'][:400]}"
                  + (f" -- review: {r['review']}" if r.get("review") else ""))
    print("\n## Hand-review overrides of this run\n")
    for r in rows:
        if r.get("review"):
            print(f"- [{r['surface']}] {r['case']}: {r['original']} → {r['outcome']}: {r['review']}")


if __name__ == "__main__":
    main()
