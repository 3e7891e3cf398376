#!/usr/bin/env python3
"""Where the IMU must matter, measured through the firmware with and without it.

Each scenario replays recordings through `v2xloc-firmware` (`v2xloc-eval REC --firmware FW --faults
SPEC --json --trace DIR`) twice: from the folder of recordings with an IMU stream and from the same
recordings without one (identical but for imu_reports.txt). Prints one Markdown table: live Fused
and Fused (valid) (metres, unaligned, every frame after the first map), the largest error once the
filter has started (the start-up frames output the GNSS fix), the poses published against the
recording's frames (a pose every frame: all of them, none held), and the scenario's own figure from
the per-frame trace against the truth.

  tools/eval/imu_scenarios.py --imu out/recordings_imu --no-imu out/recordings
  tools/eval/imu_scenarios.py --imu A --no-imu B --eval build/host/bin/v2xloc-eval \\
      --firmware build/host/bin/v2xloc-firmware --jobs 2 --json scenarios.json

Scenarios (the spells sit on Sim 3's left turn, 5.6-9.1 s, up to 36 deg/s at 6-7 m/s; Sim 0 drives
straight):
  lidar-blind        no ego scan reaches the firmware for 3 s from 6.0 s (18.5 m, 87 deg of the
                     turn; its period timer closes each period without a scan): the error of the
                     spell's last pose, the largest in the spell, and of the first pose after it
  lidar-blind-empty  the scans of the same spell arrive without points: the same figures
  gnss-outage        no GNSS from 2 s for 30 s (to the end of the 20-22 s recordings): the largest
                     error in the outage
  infra_0 refused    Sim 0 / 2_infra, infra_0 declares a pose shifted 3 m (signed, refused): the error
                     and the yaw error of the last frame (target: live Fused <= 0.02 m)
  imu-*              each IMU fault from 6.0 s: live Fused with the fault against the run without it
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import tempfile

from security_matrix import counters  # same directory

BLIND_AT, BLIND_S = 6.0, 3.0
GNSS_AT = 2.0
FAULT_AT = 6.0
TURN = ["sim3_2_infra", "sim3_4_infra"]
FAULT_ROWS = ["sim3_2_infra", "sim0_4_infra_2_agent"]


def trace_rows(path):
    """The per-frame trace of v2xloc-eval --trace as dicts keyed by its header's names."""
    with open(path) as f:
        names = f.readline().lstrip("#").split()
        return [dict(zip(names, map(float, line.split()))) for line in f if line.strip()]


def blind_spell(rows):
    """The spell's last pose and largest error (if it had poses), then the first pose after it."""
    spell = [r for r in rows if BLIND_AT - 1e-6 <= r["t"] < BLIND_AT + BLIND_S - 1e-6]
    after = [r for r in rows if r["t"] >= BLIND_AT + BLIND_S - 1e-6]
    parts = []
    if spell:
        last = spell[-1]
        worst = max(r["err_fused_3d"] for r in spell)
        parts.append(f"{last['err_fused_3d']:.3f} m at {last['t']:.1f} s (spell max {worst:.3f})")
    else:
        parts.append("no pose in the spell")
    if after:
        r = after[0]
        parts.append(f"after {r['err_fused_3d']:.3f} m, yaw {r['err_fused_yaw_deg']:+.2f} deg at {r['t']:.1f} s")
    return "; ".join(parts)


def worst_from(at):
    def figure(rows):
        tail = [r["err_fused_3d"] for r in rows if r["t"] >= at - 1e-6]
        return f"max {max(tail):.3f} m from {at:g} s" if tail else None
    return figure


def last_frame(rows):
    r = rows[-1]
    return f"last {r['err_fused_3d']:.3f} m, yaw {r['err_fused_yaw_deg']:+.2f} deg"


# (label, --faults spec, recordings, figure from the trace; None: the fault row's delta to "none")
SCENARIOS = [
    ("none", "none", TURN + ["sim0_2_infra", "sim0_4_infra_2_agent"], last_frame),
    ("LiDAR blind 3 s (no scans)", f"lidar-blind={BLIND_S:g},lidar-blind-at={BLIND_AT:g}", TURN, blind_spell),
    ("LiDAR blind 3 s (empty scans)", f"lidar-blind={BLIND_S:g},lidar-blind-at={BLIND_AT:g},lidar-blind-empty=1",
     TURN, blind_spell),
    ("GNSS outage 30 s", f"gnss-outage=30,gnss-outage-at={GNSS_AT:g}", ["sim0_2_infra", "sim3_2_infra"],
     worst_from(GNSS_AT)),
    ("infra_0 refused (declares 3 m off)", "rogue-shift=3", ["sim0_2_infra"], last_frame),
    ("IMU dropout 3 s", f"imu-dropout=3,imu-dropout-at={FAULT_AT:g}", FAULT_ROWS, None),
    ("IMU gyro z stuck", f"imu-stuck=gz,imu-stuck-at={FAULT_AT:g}", FAULT_ROWS, None),
    ("IMU gyro z bias step 2 deg/s", f"imu-bias-step=2,imu-bias-step-at={FAULT_AT:g}", FAULT_ROWS, None),
    ("IMU reports repeated 5 %", "imu-repeat=0.05", FAULT_ROWS, None),
    ("IMU reports reordered 5 %", "imu-reorder=0.05", FAULT_ROWS, None),
]


def run(ev, fw, rec, spec, work):
    """One v2xloc-eval --firmware run: its JSON row, the firmware's counters, the trace."""
    trace_dir = tempfile.mkdtemp(dir=work)
    cmd = [ev, rec, "--firmware", fw, "--faults", spec, "--json", "--quiet", "--trace", trace_dir]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return {"error": (p.stderr.strip().splitlines() or ["?"])[-1], "spec": spec}
    row = json.loads(p.stdout)["rows"][0]
    with open(os.path.join(rec, "manifest.json")) as f:
        frame_count = json.load(f)["frame_count"]
    traces = [n for n in os.listdir(trace_dir) if n.endswith("_trace.txt")]
    rows = trace_rows(os.path.join(trace_dir, traces[0]))
    held = counters(p.stderr).get("ego_frames_held", 0)
    started = [k for k, r in enumerate(rows) if r["initialized"]]
    tracked = [r["err_fused_3d"] for r in rows[started[0]:]] if started else []
    return {"spec": spec, "fused": row["unaligned"]["fused"], "valid": row["unaligned"]["fused_valid"],
            "max": max(tracked) if tracked else None, "poses": len(rows), "frames": frame_count, "held": held,
            "trace": rows}


def fmt(v):
    return "n/a" if v is None or v < 0 else f"{v:.3f}"


def pair(a, b, key):
    return f"{fmt(a.get(key))} / {fmt(b.get(key)) if b else '-'}"


def poses(a, b):
    def one(r):
        if r is None:
            return "-"
        if "error" in r:
            return "failed"
        return str(r["poses"]) + (f" ({r['held']} held)" if r["held"] else "")
    return f"{one(a)} / {one(b)} of {a.get('frames', b.get('frames') if b else '?')}"


def figure_of(r, figure, base):
    if "error" in r:
        return f"**failed**: {r['error']}"
    if figure is not None:
        return figure(r["trace"]) or "-"
    d = r["fused"] - base["fused"] if base and "error" not in base else None
    return "-" if d is None else f"Fused {d * 1000:+.1f} mm vs no fault; " + worst_from(FAULT_AT)(r["trace"])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--imu", required=True, help="folder of the recordings with an IMU stream")
    ap.add_argument("--no-imu", required=True, help="folder of the same recordings without one")
    ap.add_argument("--eval", default="build/host/bin/v2xloc-eval")
    ap.add_argument("--firmware", default="build/host/bin/v2xloc-firmware")
    ap.add_argument("--jobs", type=int, default=2, help="replays run at once")
    ap.add_argument("--json", help="write every run (without the traces) here")
    ap.add_argument("--only", help="the scenarios whose label contains this text (and 'none')")
    args = ap.parse_args()
    for folder in (args.imu, args.no_imu):
        if not os.path.isdir(folder):
            sys.exit(f"imu_scenarios: no folder {folder}")
    fw = os.path.abspath(args.firmware)
    jobs = []  # (scenario index, recording name, with IMU)
    for k, (label, spec, recs, _) in enumerate(SCENARIOS):
        if args.only and k > 0 and args.only not in label:
            continue
        for name in recs:
            jobs.append((k, name, True))
            if not spec.startswith("imu-"):  # without an IMU an IMU fault has nothing to act on
                jobs.append((k, name, False))
    with tempfile.TemporaryDirectory(prefix="imu-scenarios-") as work, \
            concurrent.futures.ThreadPoolExecutor(max(1, args.jobs)) as pool:
        futures = {j: pool.submit(run, args.eval, fw, os.path.join(args.imu if j[2] else args.no_imu, j[1]),
                                  SCENARIOS[j[0]][1], work) for j in jobs}
        results = {j: f.result() for j, f in futures.items()}
    print_table(results, {k for k, _, _ in jobs})
    if args.json:
        with open(args.json, "w") as f:
            json.dump([{"scenario": SCENARIOS[k][0], "recording": n, "imu": i,
                        **{x: y for x, y in r.items() if x != "trace"}} for (k, n, i), r in results.items()], f, indent=1)
    failed = [r for r in results.values() if "error" in r]
    return 1 if failed else 0


def print_table(results, scenarios):
    print("Through the firmware; metres, unaligned, with the IMU / without it "
          "(an IMU fault row: the recording without an IMU is the 'none' row)\n")
    print("| scenario | recording | live Fused | Fused (valid) | max (started) | poses | figure (IMU) | figure (no IMU) |")
    print("|---|---|---|---|---|---|---|---|")
    for k, (label, spec, recs, figure) in enumerate(SCENARIOS):
        if k not in scenarios:
            continue
        for name in recs:
            a = results[(k, name, True)]
            b = results.get((k, name, False)) or results.get((0, name, False))
            base_a = results.get((0, name, True))
            fig_a = figure_of(a, figure, base_a)
            fig_b = figure_of(b, figure, None) if (k, name, False) in results else "-"
            print(f"| {label} | {name} | {pair(a, b, 'fused')} | {pair(a, b, 'valid')} | {pair(a, b, 'max')} | "
                  f"{poses(a, b)} | {fig_a} | {fig_b} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
