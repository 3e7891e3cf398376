#!/usr/bin/env python3
"""Runs the worst-case localizer test binary under callgrind and checks every adversarial
period against the instruction budget (100 M per 100 ms period, A53-class core at 10 Hz).

The binary (tests/worst_case/localizer) dumps each counted period stage by stage, labelled
"CASE period N STAGE"; set-up work is dumped as "setup" and ignored. Prints one row per case
(max instructions per period, periods, the worst period's largest stages) and fails when any
period exceeds the budget or the gtest itself fails.

  tools/timing/worst_case_instructions.py build/host/bin/test_worst_case_localizer [--filter X]
      [--known-over CASE=CEILING,...]

--known-over names cases still over the budget (a known, reported gap): they fail only above
their ceiling (instructions), so the check guards them against getting worse while every other
case must fit the budget. Exit 77 (ctest: skipped) when valgrind is not installed.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from frame_instructions import parse_parts  # noqa: E402

BUDGET = 100e6


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("--filter", default="WorstCase.*", help="gtest filter")
    ap.add_argument("--budget", type=float, default=BUDGET)
    ap.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    ap.add_argument("--known-over", default="", help="CASE=CEILING,... allowed over the budget up to CEILING")
    args = ap.parse_args()
    known = {}
    for item in filter(None, args.known_over.split(",")):
        name, _, ceiling = item.partition("=")
        known[name] = float(ceiling)
    if shutil.which("valgrind") is None:
        print("SKIP: valgrind is not installed (the instruction counts need callgrind)")
        return 77
    with tempfile.TemporaryDirectory(prefix="worst-case-") as d:
        out = os.path.join(d, "callgrind.out")
        cmd = ["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out, "--combine-dumps=yes",
               "--dump-instr=no", "--compress-pos=no", args.binary, "--gtest_filter=" + args.filter]
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        sys.stdout.write(r.stdout[-3000:])
        if r.returncode != 0:
            sys.stderr.write(r.stderr[-3000:])
            print("FAIL: the worst-case test binary failed under callgrind")
            return 1
        cases = {}  # case -> {period: {stage: instructions}}
        for label, instr in parse_parts(out):
            m = re.match(r"(\S+) period (\d+)(?: (\S+))?$", label)
            if m:
                stages = cases.setdefault(m.group(1), {}).setdefault(int(m.group(2)), {})
                stage = m.group(3) or "all"
                stages[stage] = stages.get(stage, 0) + instr
    if not cases:
        print("FAIL: no counted periods found")
        return 1
    over = 0
    if args.markdown:
        print("| adversarial input | periods | max instructions per period | largest stages of that period (M) | budget |")
        print("|---|---|---|---|---|")
    for name, periods in cases.items():
        totals = {p: sum(st.values()) for p, st in periods.items()}
        worst_period = max(totals, key=lambda p: totals[p])
        worst = totals[worst_period]
        ceiling = known.get(name)
        ok = worst <= args.budget or (ceiling is not None and worst <= ceiling)
        over += 0 if ok else 1
        verdict = ("ok" if worst <= args.budget else "known over (ceiling %.0f M)" % (ceiling / 1e6)) if ok else "OVER"
        top = sorted(periods[worst_period].items(), key=lambda kv: -kv[1])[:3]
        stages = ", ".join("%s %.1f" % (k, v / 1e6) for k, v in top)
        if args.markdown:
            print("| %s | %d | %.1f M | %s | %s |" % (name, len(totals), worst / 1e6, stages, verdict))
        else:
            print("%-28s periods %3d  max %8.1f M (period %d: %s)  %s" % (
                name, len(totals), worst / 1e6, worst_period, stages, verdict))
    missing = sorted(set(known) - set(cases))
    if missing:
        print("FAIL: known-over case(s) not run: %s" % ", ".join(missing))
        return 1
    if over:
        print("FAIL: %d case(s) over %.0f M instructions per period (or over their known ceiling)" % (over, args.budget / 1e6))
        return 1
    print("all periods within %.0f M instructions%s" % (args.budget / 1e6, " except the known-over cases, within their ceilings" if known else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
