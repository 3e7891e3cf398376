#include "dataset_fixtures.hpp"

#include "host_sim/cloud_io/cloud_io.hpp"
#include "host_sim/common/rng.hpp"
#include "host_sim/scenario/scenario.hpp"
#include "host_sim/scenario/trajectory.hpp"
#include "host_sim/sensors/lidar.hpp"
#include "host_sim/world/intersection_world.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

namespace v2xloc::testing {
namespace {

namespace fs = std::filesystem;

const sim::IntersectionWorld& world() {
  static const std::unique_ptr<sim::IntersectionWorld> w = [] {
    auto out = std::make_unique<sim::IntersectionWorld>();
    sim::WorldConfig config;
    config.seed = 7;
    sim::build_intersection_world(config, *out);
    return out;
  }();
  return *w;
}

Mat4d to_mat(const Eigen::Isometry3d& iso) { return iso.matrix(); }

cloud_io::PointCloud to_cloud(const sim::LidarScan& scan) {
  cloud_io::PointCloud c;
  for (const sim::LidarPoint& p : scan.points) {
    c.points.push_back(p.p);
    c.intensity.push_back(p.intensity);
  }
  return c;
}

bool write_text(const std::string& path, const std::string& text, std::string& error) {
  std::ofstream out(path);
  out << text;
  if (!out) {
    error = "cannot write " + path;
    return false;
  }
  return true;
}

std::string row_major_3x4(const Mat4d& m) {
  std::string s;
  char buf[40];
  for (int i = 0; i < 12; ++i) {
    std::snprintf(buf, sizeof(buf), i ? " %.12e" : "%.12e", m(i / 4, i % 4));
    s += buf;
  }
  return s;
}

std::string id6(int v) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "%06d", v);
  return buf;
}

}  // namespace

bool write_kitti_fixture(const std::string& seq_dir, int frames, KittiFixtureInfo& info, std::string& error) {
  fs::create_directories(seq_dir + "/velodyne");
  // Northbound in the inner lane, then a 10 m radius left turn into the westbound lane.
  const double lane = sim::IntersectionLayout::kInnerLane;
  const sim::Trajectory drive(std::move(sim::Path({lane, -25.0, M_PI / 2}).straight(25.0 - 8.25).arc(10.0, M_PI / 2).straight(50.0)),
                              0.0, 8.0);
  // KITTI-like sensor, halved resolution (32 beams, 1024 columns): small files, fast tests.
  sim::LidarConfig lidar = sim::ego_lidar_config(false);
  lidar.beams = 32;
  lidar.elevation_max_deg = 2.0;
  lidar.elevation_min_deg = -24.8;
  // Velodyne -> cam0 (x right, y down, z forward), the structure of KITTI's Tr.
  Mat4d tr = Mat4d::Zero();
  tr.topLeftCorner<3, 3>() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  tr.topRightCorner<3, 1>() = Vec3d(-0.004, -0.076, -0.272);
  tr(3, 3) = 1.0;
  Mat4d tr_inv = Mat4d::Identity();
  tr_inv.topLeftCorner<3, 3>() = tr.topLeftCorner<3, 3>().transpose();
  tr_inv.topRightCorner<3, 1>() = -tr.topLeftCorner<3, 3>().transpose() * tr.topRightCorner<3, 1>();

  const sim::BodyPoseFn body = [&drive](double t) { return drive.body_to_enu(t); };
  std::string times, poses;
  Mat4d first_inv = Mat4d::Identity();
  info = KittiFixtureInfo{};
  sim::LidarScan scan;
  for (int k = 0; k < frames; ++k) {
    const double t0 = 0.1 * k;
    sim::Rng rng(sim::derive_seed(11, {static_cast<std::uint64_t>(k)}));
    sim::render_lidar_sweep(world().world, lidar, body, t0, -1, rng, scan);
    if (!cloud_io::write_kitti_bin(seq_dir + "/velodyne/" + id6(k) + ".bin", to_cloud(scan), error)) return false;
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.6e\n", t0);
    times += buf;
    // Ground truth at mid-sweep: column 0 fires backwards, the sensor faces forward half a
    // sweep later (KITTI triggers its cameras then).
    const Mat4d velo = to_mat(drive.body_to_enu(t0 + 0.05) * lidar.mount);
    if (k == 0) {
      first_inv.topLeftCorner<3, 3>() = velo.topLeftCorner<3, 3>().transpose();
      first_inv.topRightCorner<3, 1>() = -velo.topLeftCorner<3, 3>().transpose() * velo.topRightCorner<3, 1>();
    }
    const Mat4d cam = tr * first_inv * velo * tr_inv;
    if (k > 0)
      info.path_length_m += (cam.topRightCorner<3, 1>() - info.cam_poses.back().topRightCorner<3, 1>()).norm();
    info.cam_poses.push_back(cam);
    poses += row_major_3x4(cam) + "\n";
  }
  const std::string p = "7.188560e+02 0 6.071928e+02 0 0 7.188560e+02 1.852157e+02 0 0 0 1 0";
  const std::string calib = "P0: " + p + "\nP1: " + p + "\nP2: " + p + "\nP3: " + p + "\nTr: " + row_major_3x4(tr) + "\n";
  return write_text(seq_dir + "/times.txt", times, error) && write_text(seq_dir + "/calib.txt", calib, error) &&
         write_text(seq_dir + "/poses.txt", poses, error);
}

bool write_dair_fixture(const std::string& root, int pairs, DairFixtureInfo& info, std::string& error) {
  for (const char* d : {"/cooperative/calib/lidar_i2v", "/vehicle-side/velodyne", "/infrastructure-side/velodyne"})
    fs::create_directories(root + d);
  const double lane = sim::IntersectionLayout::kInnerLane;
  struct PairSpec {
    sim::PlanarPose vehicle;
    int site;              // corner unit
    double dx, dy;         // system_error_offset
  };
  const PairSpec specs[3] = {{{-22.0, -lane, 0.0}, 2, 0.0, 0.0},
                             {{4.0, -lane, 0.0}, 0, 0.35, -0.2},
                             {{lane, -18.0, M_PI / 2}, 3, -0.15, 0.1}};
  const std::vector<sim::InfraSite> sites = sim::infra_sites(sim::Permutation::k4Infra);
  sim::LidarConfig vehicle_lidar = sim::ego_lidar_config(false);
  vehicle_lidar.beams = 40;  // the vehicle LiDAR of DAIR-V2X is a 40-beam unit
  sim::LidarConfig infra_lidar = sim::infra_lidar_config(false);
  std::string data_info = "[\n";
  info = DairFixtureInfo{};
  sim::LidarScan scan;
  for (int i = 0; i < pairs && i < 3; ++i) {
    const PairSpec& s = specs[i];
    const std::string vid = id6(17314 + i), iid = id6(1366 + 2 * i);
    const Eigen::Isometry3d body = sim::Trajectory::stationary(s.vehicle).body_to_enu(0.0);
    sim::Rng rng(sim::derive_seed(23, {static_cast<std::uint64_t>(i), 0}));
    sim::render_lidar_sweep(world().world, vehicle_lidar, [&body](double) { return body; }, 0.0, -1, rng, scan);
    if (!cloud_io::write_pcd(root + "/vehicle-side/velodyne/" + vid + ".pcd", to_cloud(scan),
                             cloud_io::PcdEncoding::kBinaryCompressed, error))
      return false;
    infra_lidar.mount = sites[static_cast<std::size_t>(s.site)].sensor_to_enu;
    rng.reseed(sim::derive_seed(23, {static_cast<std::uint64_t>(i), 1}));
    sim::render_lidar_sweep(world().world, infra_lidar,
                            [](double) { return Eigen::Isometry3d::Identity(); }, 0.0, -1, rng, scan);
    if (!cloud_io::write_pcd(root + "/infrastructure-side/velodyne/" + iid + ".pcd", to_cloud(scan),
                             cloud_io::PcdEncoding::kBinary, error))
      return false;
    const Mat4d truth = to_mat((body * vehicle_lidar.mount).inverse() * infra_lidar.mount);
    Mat4d given = truth;
    given(0, 3) -= s.dx;
    given(1, 3) -= s.dy;
    char buf[512];
    std::snprintf(buf, sizeof(buf),
                  "{\"rotation\": [[%.12f, %.12f, %.12f], [%.12f, %.12f, %.12f], [%.12f, %.12f, %.12f]], "
                  "\"translation\": [[%.12f], [%.12f], [%.12f]]}\n",
                  given(0, 0), given(0, 1), given(0, 2), given(1, 0), given(1, 1), given(1, 2), given(2, 0),
                  given(2, 1), given(2, 2), given(0, 3), given(1, 3), given(2, 3));
    if (!write_text(root + "/cooperative/calib/lidar_i2v/" + vid + ".json", buf, error)) return false;
    std::snprintf(buf, sizeof(buf),
                  "  {\"infrastructure_image_path\": \"infrastructure-side/image/%s.jpg\", "
                  "\"infrastructure_pointcloud_path\": \"infrastructure-side/velodyne/%s.pcd\", "
                  "\"vehicle_image_path\": \"vehicle-side/image/%s.jpg\", "
                  "\"vehicle_pointcloud_path\": \"vehicle-side/velodyne/%s.pcd\", "
                  "\"cooperative_label_path\": \"cooperative/label_world/%s.json\", "
                  "\"system_error_offset\": {\"delta_x\": %.3f, \"delta_y\": %.3f}},\n",
                  iid.c_str(), iid.c_str(), vid.c_str(), vid.c_str(), vid.c_str(), s.dx, s.dy);
    data_info += buf;
    info.vehicle_ids.push_back(vid);
    info.truth.push_back(truth);
    info.offsets.emplace_back(s.dx, s.dy, 0.0);
  }
  // A pair of the full release whose clouds this folder does not hold.
  data_info += "  {\"infrastructure_pointcloud_path\": \"infrastructure-side/velodyne/009999.pcd\", "
               "\"vehicle_pointcloud_path\": \"vehicle-side/velodyne/019999.pcd\", "
               "\"system_error_offset\": {\"delta_x\": 0.0, \"delta_y\": 0.0}}\n]\n";
  return write_text(root + "/cooperative/data_info.json", data_info, error);
}

}  // namespace v2xloc::testing
