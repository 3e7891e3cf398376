#!/usr/bin/python3
"""Plots of evaluated recordings from what v2xloc-eval writes with --plots DIR.

For every DIR/<name>_frames.csv (one row per frame: truth, GNSS fix, odometry, registration,
fused pose, gate decision and the per-frame error of each Table 1 column) this writes
  DIR/<name>_topview.png  the run over the reference map's points (DIR/<name>_map.csv)
  DIR/<name>_error.png    error over time per Table 1 column, log axis, gate-valid frames marked
  DIR/<name>_timing.png   per-frame processing time, from DIR/<name>_timing.csv or the evaluator's
                          trace (--trace TRACE_DIR), columns t and *_ms; skipped when neither has them

usage: plot_run.py DIR [--trace TRACE_DIR] [--only NAME]
Exit 0 on success, 2 on bad input, 3 when matplotlib is not installed.
"""
import argparse
import csv
import math
import os
import sys

try:
    import matplotlib
    matplotlib.use("Agg")  # files only, no display needed
    import matplotlib.pyplot as plt
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar
except ImportError as exc:  # the plots are optional; the evaluator's numbers are not
    print(f"plot_run.py: matplotlib is not available ({exc}); install python3-matplotlib", file=sys.stderr)
    sys.exit(3)

DPI = 110
# Table 1 columns as the evaluator names them in the frames file, with the label the paper uses.
ERROR_COLUMNS = [
    ("err_gps", "GPS (horizontal)", "tab:orange"),
    ("err_slam", "SLAM (odometry)", "tab:purple"),
    ("err_reg", "Reg. (registration ok)", "tab:green"),
    ("err_fused", "Fused (live)", "tab:blue"),
    ("err_fused_lag", "Fused (after backfill)", "tab:cyan"),
]


class InputError(Exception):
    pass


def read_table(path):
    """Whitespace- or comma-separated table with a header line (leading '#' allowed)."""
    with open(path, newline="") as f:
        lines = [ln for ln in f.read().splitlines() if ln.strip()]
    if not lines:
        raise InputError(f"{path}: empty file")
    sep = "," if "," in lines[0] else None
    header = lines[0].lstrip("#").strip().split(sep)
    header = [h.strip() for h in header]
    rows = []
    for n, ln in enumerate(lines[1:], start=2):
        cells = ln.split(sep)
        if len(cells) != len(header):
            raise InputError(f"{path}:{n}: {len(cells)} values, header has {len(header)}")
        try:
            rows.append([float(c) for c in cells])
        except ValueError as exc:
            raise InputError(f"{path}:{n}: {exc}") from None
    return {h: [r[i] for r in rows] for i, h in enumerate(header)}


def need(table, path, names):
    missing = [n for n in names if n not in table]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}")


def finite(values):
    return [v for v in values if not math.isnan(v)]


def plot_topview(name, frames, map_points, out_path):
    fig, ax = plt.subplots(figsize=(10, 8.5), dpi=DPI)
    if map_points is not None and map_points["x"]:
        sc = ax.scatter(map_points["x"], map_points["y"], c=map_points["z"], s=0.3, cmap="Greys",
                        vmin=-1.0, vmax=12.0, rasterized=True, label="reference map points (infra + agent clouds)")
        fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.01, label="map point height z [m]")
    gx = [x for x, v in zip(frames["gnss_x"], frames["gnss"]) if v > 0]
    gy = [y for y, v in zip(frames["gnss_y"], frames["gnss"]) if v > 0]
    ax.plot(gx, gy, "x", color="tab:orange", ms=4, label="GNSS fix (latest, lever arm removed)")
    ax.plot(frames["slam_x"], frames["slam_y"], "--", color="tab:purple", lw=1.2, label="odometry (anchored at frame 0)")
    ax.plot(frames["truth_x"], frames["truth_y"], "-", color="black", lw=2.5, label="ground truth")
    ax.plot(frames["fused_x"], frames["fused_y"], "-", color="tab:blue", lw=1.2, label="fused (live)")
    groups = {"valid": ([], []), "rejected": ([], []), "undecided": ([], [])}
    for i, ok in enumerate(frames["reg_ok"]):
        if ok <= 0:
            continue
        key = "undecided" if frames["gate_decided"][i] <= 0 else ("valid" if frames["gate_valid"][i] > 0 else "rejected")
        groups[key][0].append(frames["reg_x"][i])
        groups[key][1].append(frames["reg_y"][i])
    style = {"valid": ("o", "tab:green", "registration, gate: valid"),
             "rejected": ("s", "tab:red", "registration, gate: rejected"),
             "undecided": ("^", "0.5", "registration, gate: not yet decided")}
    for key, (xs, ys) in groups.items():
        if xs:
            marker, colour, label = style[key]
            ax.plot(xs, ys, marker, color=colour, ms=4, mfc="none", label=f"{label} ({len(xs)})")
    # Frame the drive, not the whole map: the truth and the fused pose with a margin.
    xs = finite(frames["truth_x"] + frames["fused_x"])
    ys = finite(frames["truth_y"] + frames["fused_y"])
    margin = 20.0
    x0, x1, y0, y1 = min(xs) - margin, max(xs) + margin, min(ys) - margin, max(ys) + margin
    # A straight drive would give a thin strip: widen the shorter side to 60 % of the longer one so
    # the map around the road stays visible.
    wx, wy = x1 - x0, y1 - y0
    if wy < 0.6 * wx:
        c = 0.5 * (y0 + y1)
        y0, y1 = c - 0.3 * wx, c + 0.3 * wx
    elif wx < 0.6 * wy:
        c = 0.5 * (x0 + x1)
        x0, x1 = c - 0.3 * wy, c + 0.3 * wy
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x east [m]")
    ax.set_ylabel("y north [m]")
    ax.set_title(f"{name}: top view (local ENU at the intersection centre)")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.add_artist(AnchoredSizeBar(ax.transData, 10.0, "10 m", loc="lower right", pad=0.6, frameon=True, size_vertical=0.4))
    # Below the axes: the legend must not hide the drive.
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=2, fontsize=8, framealpha=0.9, markerscale=1.5)
    fig.savefig(out_path, bbox_inches="tight")  # equal aspect leaves empty bands: crop them
    plt.close(fig)


def plot_errors(name, frames, out_path):
    fig, ax = plt.subplots(figsize=(10, 5), dpi=DPI)
    t = frames["t"]
    floor = 1e-4  # a zero error cannot be drawn on a log axis: shown at 0.1 mm
    plotted = 0
    for col, label, colour in ERROR_COLUMNS:
        if col not in frames:
            continue
        pts = [(ti, max(e, floor)) for ti, e in zip(t, frames[col]) if not math.isnan(e) and e >= 0]
        if not pts:
            continue
        mean = sum(e for _, e in pts) / len(pts)
        style = "o" if col == "err_reg" else "-"
        ax.plot([p[0] for p in pts], [p[1] for p in pts], style, color=colour, lw=1.3, ms=2.5,
                label=f"{label}: mean {mean:.3g} m over {len(pts)} frames")
        plotted += 1
    if plotted == 0:
        raise InputError(f"{name}: no error column has a value")
    ax.set_yscale("log")
    # Gate-valid frames as a green band at the bottom of the axis (axis-relative height).
    valid_t = [ti for ti, v in zip(t, frames["gate_valid"]) if v > 0]
    if valid_t:
        ax.plot(valid_t, [0.02] * len(valid_t), "|", color="tab:green", ms=10, mew=1.5,
                transform=ax.get_xaxis_transform(), label=f"gate: valid frame ({len(valid_t)} of {len(t)})")
    ax.axhline(0.015, color="0.4", ls=":", lw=1, label="1.5 cm")
    ax.set_xlabel("time since recording start [s]")
    ax.set_ylabel("position error [m] (log scale)")
    ax.set_title(f"{name}: error over time per Table 1 column (unaligned)")
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8, framealpha=0.9)
    fig.savefig(out_path, bbox_inches="tight")  # the legend sits below the axes: keep it in the file
    plt.close(fig)


def plot_timing(name, trace, trace_path, out_path):
    cols = [c for c in trace if c.endswith("_ms")]
    if not cols:
        return False
    need(trace, trace_path, ["t"])
    fig, ax = plt.subplots(figsize=(10, 4.5), dpi=DPI)
    for c in cols:
        vals = trace[c]
        ax.plot(trace["t"], vals, "-", lw=1.1, label=f"{c[:-3]}: max {max(vals):.1f} ms")
    ax.axhline(100.0, color="tab:red", ls="--", lw=1, label="frame period (10 Hz) = 100 ms")
    ax.set_xlabel("time since recording start [s]")
    ax.set_ylabel("processing time per frame [ms]")
    ax.set_title(f"{name}: per-frame timing")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.9)
    fig.tight_layout()
    fig.savefig(out_path)
    plt.close(fig)
    return True


FRAME_COLUMNS = ["t", "truth_x", "truth_y", "gnss", "gnss_x", "gnss_y", "slam_x", "slam_y", "reg_ok", "reg_x",
                 "reg_y", "gate_decided", "gate_valid", "fused_x", "fused_y"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir", help="the directory v2xloc-eval --plots wrote")
    ap.add_argument("--trace", help="v2xloc-eval --trace directory (per-frame timing columns *_ms)")
    ap.add_argument("--only", help="plot only this recording name (e.g. sim0_4_infra_2_agent)")
    args = ap.parse_args()
    if not os.path.isdir(args.dir):
        print(f"plot_run.py: {args.dir}: not a directory", file=sys.stderr)
        return 2
    names = sorted(f[: -len("_frames.csv")] for f in os.listdir(args.dir) if f.endswith("_frames.csv"))
    if args.only:
        names = [n for n in names if n == args.only]
    if not names:
        print(f"plot_run.py: {args.dir}: no *_frames.csv (run v2xloc-eval --plots {args.dir} first)", file=sys.stderr)
        return 2
    try:
        for name in names:
            frames_path = os.path.join(args.dir, f"{name}_frames.csv")
            frames = read_table(frames_path)
            need(frames, frames_path, FRAME_COLUMNS)
            map_path = os.path.join(args.dir, f"{name}_map.csv")
            map_points = None
            if os.path.exists(map_path):
                map_points = read_table(map_path)
                need(map_points, map_path, ["x", "y", "z"])
            written = [f"{name}_topview.png", f"{name}_error.png"]
            plot_topview(name, frames, map_points, os.path.join(args.dir, written[0]))
            plot_errors(name, frames, os.path.join(args.dir, written[1]))
            timing_note = "no trace given: timing plot skipped"
            timing_path = os.path.join(args.dir, f"{name}_timing.csv")  # per-frame stage times, if written
            if os.path.exists(timing_path):
                if plot_timing(name, read_table(timing_path), timing_path, os.path.join(args.dir, f"{name}_timing.png")):
                    written.append(f"{name}_timing.png")
                    timing_note = ""
                else:
                    timing_note = f"{timing_path} has no *_ms column: timing plot skipped"
            elif args.trace:
                trace_path = os.path.join(args.trace, f"{name}_trace.txt")
                if not os.path.exists(trace_path):
                    timing_note = f"no {trace_path}: timing plot skipped"
                elif plot_timing(name, read_table(trace_path), trace_path, os.path.join(args.dir, f"{name}_timing.png")):
                    written.append(f"{name}_timing.png")
                    timing_note = ""
                else:
                    timing_note = "the trace has no per-frame timing (*_ms columns): timing plot skipped"
            print(f"plots: {args.dir}/{{{','.join(written)}}}" + (f" ({timing_note})" if timing_note else ""))
    except InputError as exc:
        print(f"plot_run.py: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
