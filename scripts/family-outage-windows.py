#!/usr/bin/env python3
"""The 30 s outage drift of `terraslip-lab family --outages K --json FILE`
per withheld window, grouped by where the window lies against the changes
of ground: within 60 s after one, 60 s or more after, or with one inside.
Medians per estimator, and each one's median ratio to `oracle-prior` over
the same windows.

    target/release/terraslip-lab family --outages 5 --json fam.json
    python3 scripts/family-outage-windows.py fam.json
"""
import json
import statistics
import sys

ORACLE = "oracle-prior"


def group(w):
    if w["change_inside"]:
        return "a change of ground inside"
    if w["since_change_s"] < 60.0:
        return "within 60 s after a change"
    return "60 s or more after a change"


def main(paths):
    drift = {}
    for path in paths:
        for row in json.load(open(path)):
            for w in row["figures"]["outages"]:
                key = (path, row["world"], w["start_s"])
                drift.setdefault(key, {"group": group(w)})[row["estimator"]] = w["drift_pct"]
    names = sorted({e for v in drift.values() for e in v if e != "group"})
    groups = ["within 60 s after a change", "60 s or more after a change", "a change of ground inside"]
    print("windows | n | " + " | ".join(f"{e} median %" for e in names)
          + " | " + " | ".join(f"{e} / {ORACLE} (median)" for e in names if e != ORACLE))
    for g in groups + ["all"]:
        rows = [v for v in drift.values() if g in ("all", v["group"])]
        med = []
        for e in names:
            x = [v[e] for v in rows if e in v and v[e] == v[e]]
            med.append(f"{statistics.median(x):.2f}" if x else "-")
        ratio = []
        for e in names:
            if e == ORACLE:
                continue
            r = [v[e] / v[ORACLE] for v in rows if e in v and ORACLE in v and v[ORACLE] > 0 and v[e] == v[e]]
            ratio.append(f"{statistics.median(r):.2f}" if r else "-")
        print(f"{g} | {len(rows)} | " + " | ".join(med) + " | " + " | ".join(ratio))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
