#!/usr/bin/env python3
"""The security tables of docs/security.md, measured: attacks and faults replayed through the firmware.

Each row runs `v2xloc-eval REC --firmware FW --faults SPEC --json` (the demo's wire path: scans over
UDP, vehicle signals and GNSS over CAN, map shares signed and verified) and reports the fused error
over all frames, Fused (lag), Fused (valid), the first localized frame, that a pose came every
frame, and the firmware's counters that moved against the run without a fault (what recorded the
rejection or the loss). Prints Markdown tables, one column block per recording.

  tools/eval/security_matrix.py /work/recordings/sim0_2_infra /work/recordings/sim0_4_infra_2_agent
  tools/eval/security_matrix.py REC... --only faults --json matrix.json
"""
import argparse
import json
import re
import subprocess
import sys

ATTACKS = [
    ("none", ""),
    ("all infrastructure units re-sent shifted 3 m, unsigned", "rogue-source=all-infra,rogue-shift=3,rogue-signed=0"),
    ("infra_0 declares a pose shifted 0.25 m, signed", "rogue-shift=0.25"),
    ("infra_0 declares a pose shifted 3 m, signed", "rogue-shift=3"),
    ("infra_0 declares a pose shifted 200 m, signed", "rogue-shift=200"),
    ("infra_0's points shifted 0.25 m under its true pose, signed", "rogue-shift=0.25,rogue-points=1"),
    ("infra_0's points shifted 3 m under its true pose, signed", "rogue-shift=3,rogue-points=1"),
    ("infra_0's points shifted 200 m under its true pose, signed", "rogue-shift=200,rogue-points=1"),
    ("agent shifted 0.25 m, signed", "rogue-source=agent_0_lidar,rogue-shift=0.25"),
    ("agent shifted 3 m, signed", "rogue-source=agent_0_lidar,rogue-shift=3"),
    ("agent shifted 200 m, signed", "rogue-source=agent_0_lidar,rogue-shift=200"),
    ("copy of infra_0 dated 5 s ahead, unsigned", "rogue-future=5,rogue-signed=0"),
    ("copy of infra_0 dated 5 s ahead, signed", "rogue-future=5"),
    ("16 invented agent ids", "rogue-ids=16"),
    ("ego scan dated 1e18 ns at frame 10", "ego-time-jump=10"),
    ("burst of 200 corrupt CAN frames", "can-burst=200"),
]
FAULTS = [
    ("none", ""),
    ("UDP loss 30 %", "loss=0.3"),
    ("reordering 20 %", "reorder=0.2"),
    ("duplication 20 %", "dup=0.2"),
    ("V2X delay 500 ms", "delay=0.5"),
    ("GNSS outage 30 s from 1 s", "gnss-outage=30"),
    ("infrastructure dropout 2 s", "infra-dropout=2"),
    ("CAN corrupt burst (200 frames)", "can-burst=200"),
]


# Counters that record a refusal, a loss or an injected fault (the others move with any change).
EVIDENCE = re.compile(r"rejected|mismatch|missing|unknown|future|replay|stale|timed_out|evicted|bad_|inconsistent|"
                      r"held_back|no_slot|dropped|lost|delayed|corrupt|rogue|repeated|gaps|too_old|skew|queue|"
                      r"wrong_channel|malformed|truncated|duplicat|reordered|jumps|incomplete|invalid|off_background")


def counters(stderr):
    """Every 'name N' pair of the firmware's exit report and the fault injector's summary."""
    out = {}
    for line in stderr.splitlines():
        line = line.strip()
        if line.startswith("faults "):
            body = line.split(":", 1)[1] if ":" in line else ""
            for item in body.split(","):
                m = re.match(r"\s*([A-Za-z][A-Za-z_ ]*?) (\d+)\s*$", item)
                if m:
                    out["fault: " + m.group(1)] = int(m.group(2))
        elif line.startswith("v2xloc-firmware:"):
            # A name already seen on an earlier line (map fusion's and the search's "inconsistent",
            # map fusion's and reassembly's "stale") is kept apart under its line's first word.
            topic = line.split()[1].rstrip(":")
            for name, value in re.findall(r"([a-z][a-z_]*) (\d+)\b", line):
                out[name if name not in out else f"{topic}.{name}"] = int(value)
    return out


def run(ev, fw, rec, spec):
    cmd = [ev, rec, "--firmware", fw, "--json", "--faults", spec or "none"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    row = {"spec": spec, "rc": p.returncode}
    if p.returncode != 0:
        row["error"] = p.stderr.strip().splitlines()[-1:] or ["?"]
        return row
    r = json.loads(p.stdout)["rows"][0]
    u = r["unaligned"]
    row.update(fused=u["fused"], lag=u["fused_lag"], valid=u["fused_valid"], first=r["first_localized_frame"],
               frames=r["frames"], counters=counters(p.stderr))
    return row


def cell(row, base):
    if row.get("rc") != 0:
        return f"**failed** ({row.get('error')})"
    moved = {k: v for k, v in row["counters"].items()
             if EVIDENCE.search(k) and v != base.get("counters", {}).get(k) and v != 0}
    noted = ", ".join(f"`{k}` {v}" for k, v in sorted(moved.items()))
    return (f"{row['fused']:.3f} ({row['lag']:.3f}, {row['valid']:.3f}), first {row['first']}; "
            f"{row['frames']} poses" + (f"; {noted}" if noted else ""))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recordings", nargs="+")
    ap.add_argument("--eval", default="build/host/bin/v2xloc-eval")
    ap.add_argument("--firmware", default="build/host/bin/v2xloc-firmware")
    ap.add_argument("--only", choices=["attacks", "faults"])
    ap.add_argument("--json", help="write every run here")
    args = ap.parse_args()
    tables = [("attacks", ATTACKS), ("faults", FAULTS)]
    results = {}
    for name, rows in tables:
        if args.only and args.only != name:
            continue
        print(f"\n{name}: fused error over all frames (Fused (lag), Fused (valid)) [m], unaligned; counters that moved\n")
        print("| " + " | ".join(["case", "`--faults`"] + [r.rstrip("/").split("/")[-1] for r in args.recordings]) + " |")
        print("|" + "---|" * (2 + len(args.recordings)))
        base = {}
        for label, spec in rows:
            cells = []
            for rec in args.recordings:
                row = run(args.eval, args.firmware, rec, spec)
                results.setdefault(name, {}).setdefault(rec, []).append(dict(row, label=label))
                if not spec:
                    base[rec] = row
                cells.append(cell(row, base.get(rec, {})))
            print(f"| {label} | `{spec or '-'}` | " + " | ".join(cells) + " |", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
