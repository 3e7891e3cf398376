#!/usr/bin/env python3
"""How well the IMU's accelerometer alone tells the body's tilt, against a recording's truth.

Reads a recording's HID IMU reports (imu_reports.txt, hal/HID_IMU_REPORT.md: accelerometer at
1 mg, gyro at 0.01 deg/s) and its 100 Hz ground truth. Over sliding windows (--window seconds,
one every --every reports) the mean specific force, less the vehicle's own acceleration along
the body (forward: the speed's change over the window; lateral: speed x mean gyro z, the
centripetal term), is taken as the world's up axis in the body frame and compared with the
truth's. The speed comes from the ground truth (an ideal wheel speed: the result is a lower
bound on the error an ECU would see). Prints the error's median / p95 / max in degrees, with and
without the motion terms, and the true tilt's range.

  tools/eval/accel_tilt.py out/slope/sim0_2_infra
"""
import argparse
import bisect
import math
import sys


def rotation(qx, qy, qz, qw):
    return [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
            [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
            [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]


def read_truth(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            v = [float(x) for x in line.split()]
            if len(v) != 8 or not all(math.isfinite(x) for x in v):
                sys.exit(f"{path}: bad line: {line.strip()}")
            rows.append((v[0], v[1:4], rotation(*v[4:8])))
    if len(rows) < 3:
        sys.exit(f"{path}: fewer than 3 poses")
    return rows


def i16(b, o):
    v = b[o] | (b[o + 1] << 8)
    return v - 65536 if v > 32767 else v


def read_imu(path):
    samples = []
    try:
        f = open(path)
    except OSError as e:
        sys.exit(f"{path}: {e.strerror} (a recording made with --no-imu has no IMU stream)")
    with f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            parts = line.split()
            try:
                report = bytes(int(x, 16) for x in parts[1:])
                t = int(parts[0]) * 1e-9
            except ValueError:
                sys.exit(f"{path}: bad line: {line.strip()}")
            if len(report) != 22 or report[0] != 1:
                continue  # not an input report 1 (the codec rejects it too)
            gyro_z = i16(report, 12) * 0.01 * math.pi / 180.0
            accel = [i16(report, 14 + 2 * k) * 1e-3 * 9.80665 for k in range(3)]
            samples.append((t, gyro_z, accel))
    return samples


def angle_deg(a, b):
    na = math.sqrt(sum(x * x for x in a))
    nb = math.sqrt(sum(x * x for x in b))
    c = sum(x * y for x, y in zip(a, b)) / (na * nb)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recording")
    ap.add_argument("--window", type=float, default=0.5, help="seconds of reports averaged")
    ap.add_argument("--every", type=int, default=20, help="reports between windows")
    a = ap.parse_args()
    truth = read_truth(f"{a.recording}/ground_truth_100hz.tum")
    imu = read_imu(f"{a.recording}/imu_reports.txt")
    if len(imu) < 10:
        sys.exit(f"{a.recording}: no IMU reports (a recording made with --no-imu?)")
    stamps = [r[0] for r in truth]

    def at(t):
        i = min(max(bisect.bisect_left(stamps, t), 1), len(truth) - 2)
        return i

    def forward_speed(i):
        (t0, p0, _), (t1, p1, _) = truth[i - 1], truth[i + 1]
        r = truth[i][2]
        return sum(r[k][0] * (p1[k] - p0[k]) / (t1 - t0) for k in range(3))

    corrected, raw, tilt = [], [], []
    imu_stamps = [s[0] for s in imu]
    for k in range(0, len(imu), a.every):
        t1 = imu[k][0]
        first = bisect.bisect_left(imu_stamps, t1 - a.window)
        win = imu[first:k + 1]
        if len(win) < 10 or win[-1][0] - win[0][0] < 0.5 * a.window:
            continue
        t0 = win[0][0]
        f = [sum(s[2][c] for s in win) / len(win) for c in range(3)]
        wz = sum(s[1] for s in win) / len(win)
        v0, v1, vm = forward_speed(at(t0)), forward_speed(at(t1)), forward_speed(at(0.5 * (t0 + t1)))
        up_meas = [f[0] - (v1 - v0) / (t1 - t0), f[1] - vm * wz, f[2]]
        r = truth[at(0.5 * (t0 + t1))][2]
        up_true = [r[2][0], r[2][1], r[2][2]]  # world z in the body frame
        corrected.append(angle_deg(up_meas, up_true))
        raw.append(angle_deg(f, up_true))
        tilt.append(math.degrees(math.acos(max(-1.0, min(1.0, up_true[2])))))
    if not corrected:
        sys.exit("no window with enough reports")

    def stats(v):
        s = sorted(v)
        return f"median {s[len(s) // 2]:.3f}, p95 {s[int(0.95 * (len(s) - 1))]:.3f}, max {s[-1]:.3f} deg"

    print(f"{a.recording}: {len(corrected)} windows of {a.window} s, true tilt {min(tilt):.2f}-{max(tilt):.2f} deg")
    print(f"  accelerometer less the motion terms: {stats(corrected)}")
    print(f"  accelerometer as read:               {stats(raw)}")


if __name__ == "__main__":
    main()
