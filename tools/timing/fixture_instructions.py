#!/usr/bin/env python3
"""x86-64 instructions per period and per stage of a target fixture, beside the Cortex-R52's.

Plays a fixture (`v2xloc-fixture record`, docs/target.md) into the host build of the same profile
under `valgrind --tool=callgrind --collect-atstart=no`: `v2xloc-fixture play --callgrind` collects
only inside the localizer calls, as the target's PMU counts them, and dumps at every change of
bucket (firmware/fixture/period_buckets.hpp: the calls by kind, the ego scan by the Localizer's
stage marks). With the target run's lines (`target.txt`, run_target.py's working folder, which
carry the same buckets) it prints both counts per period and, over the whole run, per stage with
their ratio (R52 / x86).

  tools/timing/fixture_instructions.py build/host-embedded/bin/v2xloc-fixture WORKDIR/inputs.fix \\
      --target WORKDIR/target.txt [--json WORKDIR/instructions.json]
"""
import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile


def percentile(values, q):
    v = sorted(values)
    return v[min(len(v), max(1, math.ceil(q * len(v)))) - 1]


def dumps(path):
    """{period: {bucket: instructions}} from the 'period N BUCKET' dumps of a combined callgrind file."""
    out, key = {}, None
    with open(path, errors="replace") as f:
        for line in f:
            m = re.match(r"desc: Trigger: Client Request: period (\d+) (\w+)", line)
            if m:
                key = (int(m.group(1)), m.group(2))
            elif (line.startswith("summary:") or line.startswith("totals:")) and key is not None:
                buckets = out.setdefault(key[0], {})
                buckets[key[1]] = buckets.get(key[1], 0) + int(line.split()[1])
                key = None
    return [out[k] for k in sorted(out)]


def target_buckets(path):
    """[{bucket: instructions}] per period line of target.txt ('... instr N cycles C stages NAME N ...')."""
    periods = []
    for line in open(path):
        if line.startswith("#"):
            continue
        f = line.split()
        if "stages" not in f:
            sys.exit(f"fixture_instructions: {path}: a period line without per-stage counts")
        pairs = f[f.index("stages") + 1:]
        buckets = {pairs[i]: int(pairs[i + 1]) for i in range(0, len(pairs), 2)}
        total = int(f[f.index("instr") + 1])
        if sum(buckets.values()) != total:
            sys.exit(f"fixture_instructions: {path}: period {f[0]}: stages sum to {sum(buckets.values())}, "
                     f"instr {total}")
        periods.append(buckets)
    return periods


def stats(name, values):
    return (f"{name}: median {statistics.median(values) / 1e6:6.1f} M  p99 {percentile(values, 0.99) / 1e6:6.1f} M"
            f"  max {max(values) / 1e6:6.1f} M")


def run_callgrind(fixture_tool, fixture):
    with tempfile.TemporaryDirectory(prefix="fixture-instr-") as tmp:
        out_file = os.path.join(tmp, "callgrind.out")
        cmd = ["valgrind", "--tool=callgrind", "--collect-atstart=no", "--combine-dumps=yes", "--dump-instr=no",
               "--compress-pos=no", "--callgrind-out-file=" + out_file, fixture_tool, "play", fixture,
               os.path.join(tmp, "host.txt"), "--callgrind"]
        if subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode != 0:
            sys.exit("fixture_instructions: valgrind / v2xloc-fixture play failed")
        return dumps(out_file)


def stage_totals(periods):
    totals = {}
    for p in periods:
        for b, n in p.items():
            totals[b] = totals.get(b, 0) + n
    return totals


def print_stage_table(r52, x86):
    """Whole-run instructions per stage, both ISAs, in the target line's bucket order."""
    t, h = stage_totals(r52), stage_totals(x86)
    all_t, all_h = sum(t.values()), sum(h.values())
    print(f"{'stage':14s} {'R52':>14s} {'x86-64':>14s} {'R52/x86':>8s} {'share':>6s}")
    for b in list(r52[0].keys()):
        tb, hb = t.get(b, 0), h.get(b, 0)
        ratio = f"{tb / hb:8.3f}" if hb > 0 else f"{'-':>8s}"
        print(f"{b:14s} {tb:14,d} {hb:14,d} {ratio} {100.0 * tb / all_t:5.1f}%")
    print(f"{'total':14s} {all_t:14,d} {all_h:14,d} {all_t / all_h:8.3f} 100.0%")
    return {"r52": t, "x86": h}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("fixture_tool")
    ap.add_argument("fixture")
    ap.add_argument("--target", help="the target run's period lines (target.txt)")
    ap.add_argument("--json", help="write the per-period totals and the per-stage sums here")
    a = ap.parse_args()
    x86 = run_callgrind(a.fixture_tool, a.fixture)
    if not x86:
        sys.exit("fixture_instructions: no per-period dumps (v2xloc-fixture built without valgrind/callgrind.h?)")
    x86_totals = [sum(p.values()) for p in x86]
    print(stats(f"x86-64 ({len(x86)} periods)", x86_totals))
    summary = {"fixture": a.fixture, "x86_per_period": x86_totals}
    if a.target:
        r52 = target_buckets(a.target)
        if len(r52) != len(x86):
            sys.exit(f"fixture_instructions: {len(r52)} target periods, {len(x86)} host periods")
        r52_totals = [sum(p.values()) for p in r52]
        print(stats(f"R52    ({len(r52)} periods)", r52_totals))
        ratios = [t / h for t, h in zip(r52_totals, x86_totals) if h > 0]
        print(f"ratio R52/x86: total {sum(r52_totals) / sum(x86_totals):.2f}, per period median "
              f"{statistics.median(ratios):.2f} min {min(ratios):.2f} max {max(ratios):.2f}")
        summary["r52_per_period"] = r52_totals
        summary["stages"] = print_stage_table(r52, x86)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(summary, f, indent=1)


if __name__ == "__main__":
    main()
