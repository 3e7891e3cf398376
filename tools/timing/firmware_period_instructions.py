#!/usr/bin/env python3
"""Instructions per 100 ms period of the whole firmware (localizer + V2X trust + decoding), by callgrind.

Replays RECORDING through `v2xloc-firmware` (`v2xloc-eval REC --firmware ...`, the demo's path) with
the firmware under `valgrind --tool=callgrind --dump-before=PeriodDriver::close_with_scan` (and
`close_without_scan`, the period timer's): an ego scan closes a period, so each dump holds one
period's work: the shares verified at its boundary, map
fusion, the localizer's frame, and the datagrams (fragment CRC, reassembly, share hashing) and CAN
frames that arrive until the next scan. A recording with an IMU stream (imu_reports.txt) is replayed
with it: the firmware reads every HID report from its emulated device at the full rate, decodes it
and hands the samples to the localizer at the period boundary. The dump before the first scan is
start-up (trust list, backgrounds, the first shares' fragments) and is reported apart. Prints
per-period median / p99 / max, the periods over 80 M with their split (localizer, ECDSA, SHA-256,
IMU reading and decoding, the rest), with --split-all the median split over every period, and
optionally writes a JSON summary.

  tools/timing/firmware_period_instructions.py /work/recordings/sim0_4_infra_2_agent --frames 60
  tools/timing/firmware_period_instructions.py REC --eval build/host/bin/v2xloc-eval \
      --firmware build/host/bin/v2xloc-firmware --faults loss=0.3 --json out.json

Budget: 100 M instructions per period (A53-class core at 10 Hz).
"""
import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

from frame_instructions import BUDGET, percentile  # same directory
# Inclusive cost of these functions splits a period (names as callgrind_annotate prints them).
GROUPS = {
    "localizer": re.compile(r"v2xloc::Localizer::(on_ego_scan|on_map_cloud|on_vehicle|on_gnss|on_imu)\("),
    "ecdsa": re.compile(r"mbedtls_ecdsa_verify\b"),
    "sha256": re.compile(r"v2xloc::trust::fragment_digest\("),
    "imu_read": re.compile(r"v2xloc::firmware::FirmwareApp::drain_imu\("),  # HID reads and report decoding
}
SPLIT_NAMES = {"localizer": "localizer", "ecdsa": "ECDSA", "sha256": "SHA-256", "imu_read": "IMU read"}


def total_of(path):
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("summary:") or line.startswith("totals:"):
                return int(line.split()[1])
    return 0


def split_of(path):
    out = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--auto=no", "--threshold=100", path],
                         capture_output=True, text=True).stdout
    split = {k: 0 for k in GROUPS}
    for line in out.splitlines():
        m = re.match(r"\s*([\d,]+)\s", line)
        if not m or not line.rstrip().endswith("]"):  # each function once: the line naming its object file
            continue
        for key, pattern in GROUPS.items():
            if pattern.search(line):
                split[key] += int(m.group(1).replace(",", ""))
    return split


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recording")
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--eval", default="build/host/bin/v2xloc-eval")
    ap.add_argument("--firmware", default="build/host/bin/v2xloc-firmware")
    ap.add_argument("--faults", default="", help="passed to v2xloc-eval --faults")
    ap.add_argument("--json", help="write the per-period counts here")
    ap.add_argument("--keep", help="keep the callgrind dumps in this directory")
    ap.add_argument("--split-all", action="store_true", help="split every period (one callgrind_annotate each)")
    args = ap.parse_args()
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        sys.exit("needs valgrind (callgrind) and callgrind_annotate")
    firmware = os.path.abspath(args.firmware)
    work = args.keep or tempfile.mkdtemp(prefix="fw-period-")
    os.makedirs(work, exist_ok=True)
    for old in glob.glob(os.path.join(work, "cg.*")):
        os.remove(old)
    wrapper = os.path.join(work, "firmware-under-callgrind.sh")
    with open(wrapper, "w") as f:
        f.write("#!/bin/sh\nexec valgrind --tool=callgrind "
                "'--dump-before=v2xloc::firmware::PeriodDriver::close_with_scan*' "
                "'--dump-before=v2xloc::firmware::PeriodDriver::close_without_scan*' "
                f"--callgrind-out-file={work}/cg.%p {firmware} \"$@\" 2>{work}/valgrind.err\n")
    os.chmod(wrapper, 0o755)
    cmd = [args.eval, args.recording, "--firmware", wrapper, "--frames", str(args.frames), "--json"]
    if args.faults:
        cmd += ["--faults", args.faults]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"v2xloc-eval failed ({run.returncode}):\n{run.stderr[-2000:]}")
    dumps = glob.glob(os.path.join(work, "cg.*.*"))
    if not dumps:
        sys.exit("no callgrind dumps written (see %s/valgrind.err)" % work)
    dumps.sort(key=lambda p: int(p.rsplit(".", 1)[1]))
    # Dump k (1-based) ends where period k-1 begins: dump 1 is start-up, dump k >= 2 is period k-2;
    # the last period (after the last scan) is in the final file without a number.
    finals = [p for p in glob.glob(os.path.join(work, "cg.*")) if re.search(r"cg\.\d+$", p)]
    files = dumps[1:] + finals
    startup = total_of(dumps[0])
    periods = []
    for i, path in enumerate(files):
        total = total_of(path)
        wanted = args.split_all or total > 0.8 * BUDGET
        periods.append({"period": i, "instructions": total, "split": split_of(path) if wanted else None})
    counts = [p["instructions"] for p in periods]
    over = [p for p in periods if p["instructions"] > BUDGET]
    print(f"{args.recording} ({len(periods)} periods{', faults ' + args.faults if args.faults else ''})")
    print(f"  start-up before the first scan: {startup / 1e6:.1f} M")
    print(f"  per period: median {percentile(counts, 0.5) / 1e6:.1f} M, p99 {percentile(counts, 0.99) / 1e6:.1f} M,"
          f" max {max(counts) / 1e6:.1f} M (period {counts.index(max(counts))}), over 100 M: {len(over)}")
    if args.split_all:
        medians = {k: percentile([p["split"][k] for p in periods], 0.5) for k in GROUPS}
        print("  median split: " + ", ".join(f"{SPLIT_NAMES[k]} {v / 1e6:.2f} M" for k, v in medians.items()))
    for p in periods:
        if p["split"] is None or p["instructions"] <= 0.8 * BUDGET:
            continue
        s = p["split"]
        rest = p["instructions"] - sum(s.values())
        parts = " + ".join(f"{SPLIT_NAMES[k]} {s[k] / 1e6:.1f}" for k in GROUPS)
        print(f"  period {p['period']:4d}: {p['instructions'] / 1e6:6.1f} M = {parts} + rest {rest / 1e6:.1f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"recording": args.recording, "faults": args.faults, "startup": startup,
                       "periods": periods}, f, indent=1)
    if not args.keep:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
