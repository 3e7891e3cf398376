#!/usr/bin/env python3
"""Open3D 0.16 beside v2xloc-dataset dair-v2x-c on the same DAIR-V2X-C pairs and voxel.

FPFH + RANSAC (mutual filter on) + point-to-plane ICP at one voxel, seeded, from no prior; the
reference is the dataset's vehicle-from-roadside transform as DAIR-V2X's calib_i2v.py computes it
(cooperative/calib/lidar_i2v where present, else the per-frame calibrations with the
system_error_offset added to the roadside's world translation). Prints the same per-pair columns
as the C++ tool (t_err / r_err against the dataset's transform, fitness, CPU seconds) and the
count within the floor.

  /usr/bin/python3 tools/eval/dair_pairs_open3d.py ../shared/data/dair_v2x_c_example [--voxel 1.0] [--seed 1]
"""
import argparse
import json
import os
import sys
import time

import numpy as np
import open3d as o3d


def load_json(path):
    with open(path) as f:
        return json.load(f)


def calib(path):
    j = load_json(path)
    j = j.get("transform", j)
    t = np.eye(4)
    t[:3, :3] = np.array(j["rotation"], dtype=float)
    t[:3, 3] = np.array(j["translation"], dtype=float).reshape(3)
    return t


def frames(root, side, keys):
    info_path = os.path.join(root, side, "data_info.json")
    if not os.path.exists(info_path):
        return {}
    out = {}
    for e in load_json(info_path):
        fid = os.path.splitext(os.path.basename(e["pointcloud_path"]))[0]
        out[fid] = [os.path.join(root, side, e[k]) for k in keys]
    return out


def dataset_transform(root, entry, vehicle, roadside):
    vid = os.path.splitext(os.path.basename(entry["vehicle_pointcloud_path"]))[0]
    rid = os.path.splitext(os.path.basename(entry["infrastructure_pointcloud_path"]))[0]
    offset = entry.get("system_error_offset") or {"delta_x": 0.0, "delta_y": 0.0}
    dx, dy = float(offset["delta_x"]), float(offset["delta_y"])
    given = os.path.join(root, "cooperative/calib/lidar_i2v", vid + ".json")
    if os.path.exists(given):
        t = calib(given)
        t[0, 3] += dx
        t[1, 3] += dy
        return vid, rid, t
    world_novatel, novatel_lidar = (calib(p) for p in vehicle[vid])
    world_roadside = calib(roadside[rid][0])
    world_roadside[0, 3] += dx
    world_roadside[1, 3] += dy
    return vid, rid, np.linalg.inv(world_novatel @ novatel_lidar) @ world_roadside


def prepare(path, voxel):
    down = o3d.io.read_point_cloud(path).voxel_down_sample(voxel)
    down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    fpfh = o3d.pipelines.registration.compute_fpfh_feature(
        down, o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100))
    return down, fpfh


def register(source, target, voxel):
    reg = o3d.pipelines.registration
    src, src_f = prepare(source, voxel)
    tgt, tgt_f = prepare(target, voxel)
    coarse = reg.registration_ransac_based_on_feature_matching(
        src, tgt, src_f, tgt_f, True, 1.5 * voxel, reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9), reg.CorrespondenceCheckerBasedOnDistance(1.5 * voxel)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    fine = reg.registration_icp(src, tgt, voxel, coarse.transformation, reg.TransformationEstimationPointToPlane())
    return fine


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root")
    ap.add_argument("--voxel", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--success-translation", type=float, default=2.0)
    ap.add_argument("--success-rotation", type=float, default=2.0)
    args = ap.parse_args()
    o3d.utility.random.seed(args.seed)
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    vehicle = frames(args.root, "vehicle-side", ["calib_novatel_to_world_path", "calib_lidar_to_novatel_path"])
    roadside = frames(args.root, "infrastructure-side", ["calib_virtuallidar_to_world_path"])
    pairs = load_json(os.path.join(args.root, "cooperative/data_info.json"))
    print("%-8s %-8s %9s %9s %8s %9s" % ("vehicle", "infra", "t_err[m]", "r_err[deg]", "fitness", "s"))
    within, seconds = 0, []
    for entry in pairs:
        vid, rid, ref = dataset_transform(args.root, entry, vehicle, roadside)
        t0 = time.process_time()
        fine = register(os.path.join(args.root, entry["infrastructure_pointcloud_path"]),
                        os.path.join(args.root, entry["vehicle_pointcloud_path"]), args.voxel)
        seconds.append(time.process_time() - t0)
        est = fine.transformation
        t_err = float(np.linalg.norm(est[:3, 3] - ref[:3, 3]))
        cos = np.clip((np.trace(ref[:3, :3].T @ est[:3, :3]) - 1.0) / 2.0, -1.0, 1.0)
        r_err = float(np.degrees(np.arccos(cos)))
        ok = t_err <= args.success_translation and r_err <= args.success_rotation
        within += ok
        print("%-8s %-8s %9.3f %9.3f %8.3f %9.2f%s" % (vid, rid, t_err, r_err, fine.fitness, seconds[-1],
                                                       "  within floor" if ok else ""))
    if not pairs:
        print("no pairs in cooperative/data_info.json", file=sys.stderr)
        return 1
    print("Open3D %s, voxel %.2f m, seed %d: %d of %d within %.2f m / %.1f deg of the dataset's transform, "
          "%.2f s/pair mean (process CPU)" % (o3d.__version__, args.voxel, args.seed, within, len(pairs),
                                              args.success_translation, args.success_rotation, np.mean(seconds)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
