// Every algo registration call, run with the allocation counter armed: 0 heap allocations.
#include <gtest/gtest.h>

#include <vector>

#include "firmware/app/alloc_counter.hpp"
#include "registration_test_support.hpp"
#include "v2xloc/algo/registration/kabsch.hpp"
#include "v2xloc/algo/registration/register_clouds.hpp"

namespace v2xloc {
namespace {

RegistrationWorkspace g_workspace;  // static storage, as firmware declares it

testing::CloudPair make_pair() {
  testing::UrbanSceneOptions o;
  o.sensor_range = 12.0;
  o.sensor_separation = 4.0;
  o.ground_density = 2.0;
  o.structure_density = 5.0;
  return testing::make_urban_pair(51, 52, testing::rotation_zyx(0.8, 0.0, 0.0, Vec3d(2, 1, 0)), o);
}

TEST(AllocFree, CounterSeesHeapAllocations) {
  // The counter itself works (otherwise 0 below would prove nothing).
  firmware::alloc_counter::Scope scope;
  std::vector<int>* v = new std::vector<int>(100);
  delete v;
  EXPECT_GE(scope.allocations(), 2u);
}

TEST(AllocFree, WholePipelineAndEveryStageAllocateNothing) {
  const testing::CloudPair pair = make_pair();  // set-up: heap allowed here
  RegisterCloudsParams params;
  params.voxel_size = 0.4f;
  RegisterCloudsResult global, icp_only;
  {
    firmware::alloc_counter::Scope scope;
    global = register_clouds(pair.source, pair.target, params, Mat4d::Identity(), g_workspace);
    EXPECT_EQ(scope.allocations(), 0u) << "global pipeline";
  }
  ASSERT_EQ(global.registration.status, RegistrationStatus::kOk);
  ASSERT_GT(global.stats.correspondences, 0u);
  {
    firmware::alloc_counter::Scope scope;
    params.mode = RegistrationMode::kIcpOnly;
    icp_only = register_clouds(pair.source, pair.target, params, global.registration.transform,
                               g_workspace);
    EXPECT_EQ(scope.allocations(), 0u) << "icp-only pipeline";
  }
  EXPECT_EQ(icp_only.registration.status, RegistrationStatus::kOk);

  // The stages one by one on the workspace contents (clouds, trees, normals, features).
  RegistrationWorkspace& ws = g_workspace;
  const std::span<const Vec3f> src = ws.source_down.span();
  const std::span<const Vec3f> tgt = ws.target_down.span();
  firmware::alloc_counter::Scope scope;
  FixedVector<Vec3f, 4096> small_out;
  static VoxelDownsampleStorage<1u << 14, 4096> voxel;
  // At most 3000 points of the source (the scene may hold fewer: ASan caught a read past it).
  const std::size_t n_voxel_input = pair.source.size() < 3000 ? pair.source.size() : 3000;
  voxel.run(std::span<const Vec3f>(pair.source.data(), n_voxel_input), 0.5f, small_out);
  ws.source_tree.build(src);
  ws.target_tree.build(tgt);
  NormalParams np;
  np.radius = 0.8f;
  estimate_normals(ws.target_tree.tree, np, std::span<Vec3f>(ws.target_normals, tgt.size()));
  estimate_normals(ws.source_tree.tree, np, std::span<Vec3f>(ws.source_normals, src.size()));
  FpfhParams fp;
  fp.radius = 2.0f;
  compute_fpfh(ws.source_tree.tree, std::span<const Vec3f>(ws.source_normals, src.size()), fp,
               std::span<Feature33>(ws.spfh_scratch, src.size()),
               std::span<Feature33>(ws.source_features, src.size()));
  compute_fpfh(ws.target_tree.tree, std::span<const Vec3f>(ws.target_normals, tgt.size()), fp,
               std::span<Feature33>(ws.spfh_scratch, tgt.size()),
               std::span<Feature33>(ws.target_features, tgt.size()));
  ws.source_feature_tree.build(std::span<const Feature33>(ws.source_features, src.size()));
  ws.target_feature_tree.build(std::span<const Feature33>(ws.target_features, tgt.size()));
  CorrespondenceParams cp;
  cp.mutual_filter = true;
  match_features(std::span<const Feature33>(ws.source_features, src.size()),
                 ws.target_feature_tree.tree, cp, ws.correspondences, &ws.source_feature_tree.tree,
                 std::span<std::uint32_t>(ws.mutual_scratch, RegistrationWorkspace::kMaxPoints));
  RansacParams rp;
  rp.max_correspondence_distance = 0.6;
  const RansacResult rr = ransac(src, tgt, ws.correspondences.span(), ws.target_tree.tree, rp);
  IcpTarget view;
  view.points = tgt;
  view.normals = std::span<const Vec3f>(ws.target_normals, tgt.size());
  view.tree = &ws.target_tree.tree;
  IcpParams ip;
  ip.max_correspondence_distance = 0.4;
  ip.kernel.type = RobustKernelType::kTukey;
  const RegistrationResult fine = icp(src, view, rr.registration.transform, ip);
  ip.method = IcpMethod::kPointToPoint;
  icp(src, view, rr.registration.transform, ip);
  evaluate_registration(src, view, fine.transform, 0.4);
  Mat4d k;
  kabsch_fit(src.first(10), tgt.first(10), {}, k);
  EXPECT_EQ(scope.allocations(), 0u) << "individual stages";
  EXPECT_EQ(rr.registration.status, RegistrationStatus::kOk) << to_string(rr.registration.status);
  if (!firmware::alloc_counter::malloc_is_counted()) {
    std::printf("note: malloc not interposed in this build (sanitizer); operator new counted\n");
  }
}

}  // namespace
}  // namespace v2xloc
