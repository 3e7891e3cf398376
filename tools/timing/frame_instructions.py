#!/usr/bin/env python3
"""Instructions per 100 ms period of the localizer, counted by callgrind.

Runs `v2xloc-eval RECORDING --frames N --callgrind-dumps` under `valgrind --tool=callgrind`; the
evaluator dumps the counters at every stage boundary of every period ("frame F stage", see
tools/eval/offline_run.cpp), so each period's instructions split by stage exactly (recording I/O
falls into "idle" dumps and is not counted). Prints per-period instructions median / p99 / max,
the worst period's stage breakdown and its most expensive functions (inclusive), and optionally
writes a JSON summary.

  tools/timing/frame_instructions.py /work/recordings/sim0_4_infra_2_agent --frames 20
  tools/timing/frame_instructions.py REC --frames 40 --json out.json --keep /tmp/cg

Budget: 100 M instructions per period (A53-class core at 10 Hz).
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

BUDGET = 100e6


def percentile(values, q):
    if not values:
        return 0
    v = sorted(values)
    k = max(1, math.ceil(q * len(v)))
    return v[min(len(v), k) - 1]


def parse_parts(path):
    """(label, instructions, part_text_start) per dump of a combined callgrind file."""
    parts = []
    label, total = None, None
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("desc: Trigger: Client Request: "):
                label = line[len("desc: Trigger: Client Request: "):].strip()
            elif line.startswith("desc: Trigger: "):
                label = line[len("desc: Trigger: "):].strip()
            elif line.startswith("summary:") or line.startswith("totals:"):
                if total is None:
                    total = int(line.split()[1])
            elif line.startswith("part:") or line.startswith("# callgrind format"):
                if label is not None:
                    parts.append((label, total or 0))
                label, total = None, None
    if label is not None:
        parts.append((label, total or 0))
    return parts


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recording")
    ap.add_argument("--frames", type=int, default=20, help="periods to run from the start (default 20)")
    ap.add_argument("--eval", default=None, help="v2xloc-eval binary (default build/host/bin/v2xloc-eval)")
    ap.add_argument("--json", default=None, help="write the summary here")
    ap.add_argument("--keep", default=None, help="keep the callgrind output in this directory")
    ap.add_argument("--top", type=int, default=12, help="functions listed for the worst period")
    ap.add_argument("--budget", type=float, default=BUDGET)
    args = ap.parse_args()

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    evaluator = args.eval or os.path.join(root, "build", "host", "bin", "v2xloc-eval")
    out_dir = args.keep or tempfile.mkdtemp(prefix="frame-instr-")
    os.makedirs(out_dir, exist_ok=True)
    out_file = os.path.join(out_dir, "callgrind.out")
    if os.path.exists(out_file):
        os.remove(out_file)
    cmd = ["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out_file, "--combine-dumps=yes",
           "--dump-instr=no", "--compress-pos=no", evaluator, args.recording, "--frames", str(args.frames),
           "--quiet", "--callgrind-dumps"]
    print("running:", " ".join(cmd), file=sys.stderr)
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.stderr.write(r.stderr[-4000:])
        sys.exit("valgrind/v2xloc-eval failed")

    periods = {}  # frame -> {stage: instructions}
    for label, instr in parse_parts(out_file):
        m = re.match(r"frame (-?\d+) (\w+)", label)
        if not m or m.group(2) == "idle" or int(m.group(1)) < 0:
            continue
        st = periods.setdefault(int(m.group(1)), {})
        st[m.group(2)] = st.get(m.group(2), 0) + instr
    if not periods:
        sys.exit("no per-stage dumps found (was v2xloc-eval built with valgrind/callgrind.h?)")
    totals = {f: sum(s.values()) for f, s in periods.items()}
    values = list(totals.values())
    worst = max(totals, key=lambda f: totals[f])
    summary = {
        "recording": args.recording,
        "frames": len(values),
        "instructions": {"median": percentile(values, 0.5), "p99": percentile(values, 0.99), "max": max(values)},
        "worst_frame": worst,
        "worst_stages": dict(sorted(periods[worst].items(), key=lambda kv: -kv[1])),
        "over_budget_frames": sorted(f for f, v in totals.items() if v > args.budget),
        "per_frame": {str(f): totals[f] for f in sorted(totals)},
        "per_frame_stages": {str(f): periods[f] for f in sorted(periods)},
    }
    M = 1e6
    print("%s: %d periods, instructions per period median %.1f M, p99 %.1f M, max %.1f M (frame %d); "
          "budget %.0f M: %d over" % (args.recording, len(values), summary["instructions"]["median"] / M,
                                      summary["instructions"]["p99"] / M, summary["instructions"]["max"] / M,
                                      worst, args.budget / M, len(summary["over_budget_frames"])))
    print("per frame (M):", " ".join("%d:%.0f" % (f, totals[f] / M) for f in sorted(totals)))
    stages = sorted({st for s in periods.values() for st in s})
    summary["median_stages"] = {st: percentile([periods[f].get(st, 0) for f in periods], 0.5) for st in stages}
    summary["max_stages"] = {st: max(periods[f].get(st, 0) for f in periods) for st in stages}
    print("%-14s %12s %12s %12s" % ("stage", "worst period", "median", "max"))
    for st in sorted(stages, key=lambda x: -summary["max_stages"][x]):
        print("  %-14s %10.1f M %10.1f M %10.1f M" % (st, periods[worst].get(st, 0) / M,
                                                    summary["median_stages"][st] / M, summary["max_stages"][st] / M))
    # The worst period's functions: annotate its biggest stage dump (inclusive).
    if args.top > 0 and shutil.which("callgrind_annotate"):
        big = max(periods[worst].items(), key=lambda kv: kv[1])[0]
        part_file = os.path.join(out_dir, "worst_part.out")
        if extract_part(out_file, "frame %d %s" % (worst, big), part_file):
            a = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=99", part_file],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            skip = ("PROGRAM TOTALS", "libc-start", "below main", "main.cpp:main", "offline_run.cpp",
                    "ld-linux", "libc_start_call_main")
            lines = [l for l in a.stdout.splitlines()
                     if re.match(r"\s*[\d,]+ \(", l) and not any(k in l for k in skip)]
            print("worst period, stage '%s', top functions (inclusive):" % big)
            for l in lines[: args.top]:
                print("  " + l.strip()[:160])
    if args.json:
        with open(args.json, "w") as f:
            json.dump(summary, f, indent=1)
    if not args.keep:
        shutil.rmtree(out_dir, ignore_errors=True)


def extract_part(path, label, out_path):
    """Writes the header plus the one part labelled `label` as a stand-alone callgrind file."""
    with open(path, errors="replace") as f:
        text = f.read()
    chunks = re.split(r"(?m)^(?=part: )", text)
    header = chunks[0]
    for c in chunks[1:]:
        if ("desc: Trigger: Client Request: " + label + "\n") in c:
            with open(out_path, "w") as o:
                o.write(header + c)
            return True
    return False


if __name__ == "__main__":
    main()
