#!/usr/bin/env python3
"""The 12 rows with and without the IMU over several noise seeds, through the firmware.

One recording set shares one noise realisation per sensor: a row's difference of a few tenths of
a millimetre between two configurations can be that realisation's. For each seed this renders the
12 recordings twice (`v2xloc-sim generate --all --seed S --no-stereo`, then the same with
`--no-imu`: every byte but the IMU's stream identical), replays both through `v2xloc-firmware`
(`v2xloc-eval REC --firmware FW --json`) and prints per row the live Fused and Fused (valid)
without / with the IMU (metres, unaligned), then the mean difference per scenario over the seeds
and how many rows got worse.

  tools/eval/imu_seed_study.py --seeds 1001 1002 --out out/seeds [--jobs 2] [--json F]

Rendering takes ~3 min per seed and variant on 2 cores, the replays ~1 min.
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys

from security_matrix import run  # same directory: one firmware replay's JSON row

WORSE_MM = 0.05  # a row counts as worse beyond this (the tables print 0.1 mm)


def render(sim, seed, folder, with_imu):
    if os.path.exists(os.path.join(folder, "sim3_4_infra_2_agent", "manifest.json")):
        return
    cmd = [sim, "generate", "--all", "--seed", str(seed), "--no-stereo", "--out", folder]
    if not with_imu:
        cmd.append("--no-imu")
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def replay(ev, fw, rec):
    row = run(ev, fw, rec, "none")
    if row["rc"] != 0:
        sys.exit(f"{rec}: {row['error']}")
    return row["fused"], row["valid"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", required=True)
    ap.add_argument("--out", default="out/seeds", help="recordings go to OUT/<seed>/{imu,no_imu}/")
    ap.add_argument("--sim", default="build/host/bin/v2xloc-sim")
    ap.add_argument("--eval", default="build/host/bin/v2xloc-eval")
    ap.add_argument("--firmware", default="build/host/bin/v2xloc-firmware")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", help="write every row's figures here")
    args = ap.parse_args()
    ev, fw = os.path.abspath(args.eval), os.path.abspath(args.firmware)
    results = {}  # (seed, row) -> {"no_imu": (live, valid), "imu": (live, valid)}
    for seed in args.seeds:
        folders = {v: os.path.join(args.out, str(seed), v) for v in ("imu", "no_imu")}
        for variant, folder in folders.items():
            render(args.sim, seed, folder, variant == "imu")
        rows = sorted(n for n in os.listdir(folders["imu"]) if n.startswith("sim"))
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            jobs = {(row, v): pool.submit(replay, ev, fw, os.path.join(folders[v], row)) for row in rows for v in folders}
            for (row, v), job in jobs.items():
                results.setdefault((seed, row), {})[v] = job.result()
    print("| seed | recording | live Fused, no IMU / IMU | Fused (valid), no IMU / IMU |")
    print("|---|---|---|---|")
    for (seed, row), r in sorted(results.items()):
        print(f"| {seed} | {row} | {r['no_imu'][0]:.4f} / {r['imu'][0]:.4f} | {r['no_imu'][1]:.4f} / {r['imu'][1]:.4f} |")
    print()
    print("| scenario | rows | live Fused, mean IMU - no IMU | worse | Fused (valid), mean | worse |")
    print("|---|---|---|---|---|---|")
    for sim in sorted({row[:4] for _, row in results}):
        diffs = [(r["imu"][0] - r["no_imu"][0], r["imu"][1] - r["no_imu"][1])
                 for (_, row), r in results.items() if row.startswith(sim)]
        n = len(diffs)
        live = [1000 * d[0] for d in diffs]
        valid = [1000 * d[1] for d in diffs]
        print(f"| Sim {sim[3]} | {n} | {sum(live) / n:+.2f} mm | {sum(x > WORSE_MM for x in live)} | "
              f"{sum(valid) / n:+.2f} mm | {sum(x > WORSE_MM for x in valid)} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump([{"seed": s, "row": row, **r} for (s, row), r in sorted(results.items())], f, indent=1)


if __name__ == "__main__":
    main()
