#!/usr/bin/env python3
"""x86-64 instructions per period of a target fixture, beside the Cortex-R52's.

Plays a fixture (`v2xloc-fixture record`, docs/target.md) into the host build of the same profile
under `valgrind --tool=callgrind --collect-atstart=no`: `v2xloc-fixture play --callgrind` collects
only inside the localizer calls, as the target's PMU counts them, and dumps once per period. With
the target run's lines (`target.txt`, run_target.py's working folder) it prints both counts per
recording and their ratio (R52 / x86).

  tools/timing/fixture_instructions.py build/host-embedded/bin/v2xloc-fixture WORKDIR/inputs.fix \\
      --target WORKDIR/target.txt
"""
import argparse
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
    """Instructions of each 'period N' dump of a combined callgrind file, in period order."""
    out, label = {}, None
    with open(path, errors="replace") as f:
        for line in f:
            m = re.match(r"desc: Trigger: Client Request: period (\d+)", line)
            if m:
                label = int(m.group(1))
            elif (line.startswith("summary:") or line.startswith("totals:")) and label is not None:
                out[label] = int(line.split()[1])
                label = None
    return [out[k] for k in sorted(out)]


def target_counts(path):
    counts = []
    for line in open(path):
        if line.startswith("#"):
            continue
        f = line.split()
        counts.append(int(f[f.index("instr") + 1]))
    return counts


def stats(name, values):
    return (f"{name}: median {statistics.median(values) / 1e6:6.1f} M  p99 {percentile(values, 0.99) / 1e6:6.1f} M"
            f"  max {max(values) / 1e6:6.1f} M")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("fixture_tool")
    ap.add_argument("fixture")
    ap.add_argument("--target", help="the target run's period lines (target.txt)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="fixture-instr-") as tmp:
        out_file = os.path.join(tmp, "callgrind.out")
        cmd = ["valgrind", "--tool=callgrind", "--collect-atstart=no", "--combine-dumps=yes",
               "--callgrind-out-file=" + out_file, a.fixture_tool, "play", a.fixture, os.path.join(tmp, "host.txt"),
               "--callgrind"]
        if subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode != 0:
            sys.exit("fixture_instructions: valgrind / v2xloc-fixture play failed")
        x86 = dumps(out_file)
    if not x86:
        sys.exit("fixture_instructions: no per-period dumps (v2xloc-fixture built without valgrind/callgrind.h?)")
    print(stats(f"x86-64 ({len(x86)} periods)", x86))
    if a.target:
        r52 = target_counts(a.target)
        if len(r52) != len(x86):
            sys.exit(f"fixture_instructions: {len(r52)} target periods, {len(x86)} host periods")
        print(stats(f"R52    ({len(r52)} periods)", r52))
        ratios = [t / h for t, h in zip(r52, x86) if h > 0]
        print(f"ratio R52/x86: total {sum(r52) / sum(x86):.2f}, per period median {statistics.median(ratios):.2f}"
              f" min {min(ratios):.2f} max {max(ratios):.2f}")


if __name__ == "__main__":
    main()
