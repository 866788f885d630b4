// The whole pipeline on rendered frames of the default two-camera rig.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>

#include "depowder/clock.hpp"
#include "depowder/perception/camera_proxy.hpp"
#include "depowder/point_grid.hpp"
#include "depowder/stats.hpp"
#include "synthetic.hpp"

using namespace depowder;
using namespace depowder::perception;
using namespace depowder::perception::synthetic;

namespace {
constexpr std::int64_t kT0 = 1'700'000'000'000'000;
const Eigen::Vector3d kBox(0.4, 0.3, 0.2);

Scene scene() { return boxScene(kBox, 0.08, {Sphere{{0.02, 0.01, 0.09}, 0.04}}); }

/// The nozzle spraying down with its tip 1 cm into the sphere's top: the self-filter takes the
/// sphere's cap round it.
Pose nozzleInTheSphere() {
  Pose T_cell_nozzle = Pose::Identity();
  T_cell_nozzle.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T_cell_nozzle.translation() = Point(0.02, 0.01, 0.12);
  return T_cell_nozzle;
}

}  // namespace

TEST(CameraProxy, TwoCamerasMergeIntoOneCroppedDownsampledCloud) {
  const auto rig = defaultRig(320, 240);
  const Scene s = scene();
  PerceptionConfig cfg;
  cfg.outlier_min_neighbours = 0;  // compared with plain voxelDownsample below
  CameraProxy proxy(cfg, kBox, {"LEFT", "RIGHT"});
  const DepthImage left = render(s, rig[0], kT0), right = render(s, rig[1], kT0 + 2000);
  ASSERT_TRUE(proxy.addDepth(left, rig[0], kT0 + 1000).ok());
  ASSERT_TRUE(proxy.addDepth(right, rig[1], kT0 + 3000).ok());
  const auto out = proxy.poll(kT0 + 3000);
  ASSERT_EQ(out.size(), 1u);
  const CellCloud& c = out[0];
  EXPECT_EQ(c.utime, kT0 + 2000);
  EXPECT_EQ(c.sources, (std::vector<std::string>{"LEFT", "RIGHT"}));
  EXPECT_EQ(c.source_utimes, (std::vector<std::int64_t>{kT0, kT0 + 2000}));
  // Same as deprojecting, concatenating and running depowder::voxelDownsample by hand.
  Cloud all = deproject(left, rig[0], proxy.crop()).points;
  const Cloud r = deproject(right, rig[1], proxy.crop()).points;
  all.insert(all.end(), r.begin(), r.end());
  EXPECT_EQ(c.points_in, all.size());
  EXPECT_EQ(c.points.size(), voxelDownsample(all, cfg.voxel_leaf).size());
  // Powder surface visible: 40 x 30 cm at 5 mm is 4800 voxels, minus the sphere's footprint.
  EXPECT_GT(c.points.size(), 4000u);
  EXPECT_LT(c.points.size(), 15000u);
  // Every point finite, in the crop box, and on the scene's surface: a voxel centroid of a
  // plane lies on it; only voxels straddling an edge (wall / powder, sphere / powder) move off.
  std::vector<double> d;
  for (const auto& p : c.points) {
    ASSERT_TRUE(p.allFinite());
    ASSERT_TRUE(proxy.crop().contains(p));
    d.push_back(s.distance(p));
  }
  EXPECT_LT(percentile(d, 0.5), 0.0003);
  EXPECT_LT(percentile(d, 0.95), 0.0010);
  EXPECT_LT(percentile(d, 1.0), 0.5 * cfg.voxel_leaf * std::sqrt(3.0));
  EXPECT_EQ(proxy.counters().frames_in, 2);
  EXPECT_EQ(proxy.counters().frames_out, 1);
  EXPECT_EQ(proxy.counters().dropped(), 0);
}

TEST(CameraProxy, OutputDoesNotDependOnArrivalOrder) {
  const auto rig = defaultRig(160, 120);
  const Scene s = scene();
  const DepthImage left = render(s, rig[0], kT0), right = render(s, rig[1], kT0);
  CameraProxy a(PerceptionConfig{}, kBox), b(PerceptionConfig{}, kBox);
  a.addDepth(left, rig[0], kT0);
  a.addDepth(right, rig[1], kT0);
  b.addDepth(right, rig[1], kT0);
  b.addDepth(left, rig[0], kT0);
  const auto pa = a.poll(kT0), pb = b.poll(kT0);
  ASSERT_EQ(pa.size(), 1u);
  ASSERT_EQ(pb.size(), 1u);
  ASSERT_EQ(pa[0].points.size(), pb[0].points.size());
  for (std::size_t i = 0; i < pa[0].points.size(); ++i) ASSERT_EQ(pa[0].points[i], pb[0].points[i]);
}

TEST(CameraProxy, CorruptFramesAreCountedAndTheStreamGoesOn) {
  const auto rig = defaultRig(160, 120);
  const Scene s = scene();
  CameraProxy proxy(PerceptionConfig{}, kBox, {"LEFT", "RIGHT"});
  std::int64_t t = kT0;
  auto step = [&](bool corrupt_right, bool blind_left) {
    DepthImage l = render(s, rig[0], t), r = render(s, rig[1], t);
    if (corrupt_right) r.depth.resize(r.depth.size() - 10);
    if (blind_left) std::fill(l.depth.begin(), l.depth.end(), 0);
    const FrameError el = proxy.addDepth(l, rig[0], t), er = proxy.addDepth(r, rig[1], t);
    t += 33'333;
    return std::make_pair(el, er);
  };
  step(false, false);
  ASSERT_EQ(proxy.poll(t).size(), 1u);
  const auto [el, er] = step(true, false);
  EXPECT_TRUE(el.ok());
  EXPECT_EQ(er.status, FrameStatus::kSizeMismatch);
  // LEFT's frame goes out without RIGHT after max_wait.
  auto out = proxy.poll(t - 33'333 + 41'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].sources, std::vector<std::string>{"LEFT"});
  EXPECT_EQ(out[0].missing, std::vector<std::string>{"RIGHT"});
  const auto [el2, er2] = step(false, true);
  EXPECT_EQ(el2.status, FrameStatus::kNoValidReturns);
  EXPECT_TRUE(er2.ok());
  out = proxy.poll(t - 33'333 + 41'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].sources, std::vector<std::string>{"RIGHT"});
  step(false, false);
  out = proxy.poll(t);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].sources.size(), 2u);
  const ProxyCounters& c = proxy.counters();
  EXPECT_EQ(c.frames_in, 8);
  EXPECT_EQ(c.frames_out, 4);
  EXPECT_EQ(c.partial_out, 2);
  EXPECT_EQ(c.dropped(), 2);
  EXPECT_EQ(c.by_status[static_cast<int>(FrameStatus::kSizeMismatch)], 1);
  EXPECT_EQ(c.by_status[static_cast<int>(FrameStatus::kNoValidReturns)], 1);
  EXPECT_EQ(c.last_error.status, FrameStatus::kNoValidReturns);
}

// Frames under ever new camera names (a mis-set name, garbage that decodes) are refused past
// kMaxCameras, naming the cameras taken, so the proxy's memory stays bounded; a frame without a
// name is refused too. The known cameras' frames go on as before.
TEST(CameraProxy, CameraNamesPastTheMostTakenAreRefused) {
  auto rig = defaultRig(80, 60);
  const Scene s = scene();
  CameraProxy proxy(PerceptionConfig{}, kBox, {"LEFT", "RIGHT"});
  std::int64_t t = kT0;
  PinholeCamera other = rig[0];
  for (std::size_t k = 2; k < CameraProxy::kMaxCameras; ++k, t += 1000) {
    other.name = "CAM" + std::to_string(k);
    ASSERT_TRUE(proxy.addDepth(render(s, other, t), other, t).ok()) << other.name;
  }
  other.name = "CAM99";
  const FrameError e = proxy.addDepth(render(s, other, t), other, t);
  EXPECT_EQ(e.status, FrameStatus::kBadHeader);
  EXPECT_NE(e.message.find("camera 'CAM99' would be camera 17, past the 16 taken (CAM10, CAM11"), std::string::npos)
      << e.message;
  EXPECT_NE(e.message.find("LEFT, RIGHT): a mis-set camera name?"), std::string::npos) << e.message;
  other.name = "";
  EXPECT_EQ(proxy.addDepth(render(s, other, t), other, t).message, "a frame without a camera name");
  EXPECT_EQ(proxy.health(t).size(), CameraProxy::kMaxCameras);
  EXPECT_TRUE(proxy.addDepth(render(s, rig[1], t), rig[1], t).ok());
  EXPECT_EQ(proxy.counters().by_status[static_cast<int>(FrameStatus::kBadHeader)], 2);
  EXPECT_EQ(proxy.deprojectionTables(), 15u);  // RIGHT and CAM2..CAM15; LEFT sent nothing
}

// A camera whose frames come but are all refused before merging (here absurd intrinsics) is
// silent to the merger; its health says its frames are refused, and why. One that sends nothing
// is silent only.
TEST(CameraProxy, ACameraSendingOnlyRefusedFramesIsToldFromASilentOne) {
  auto rig = defaultRig(80, 60);
  const Scene s = scene();
  CameraProxy proxy(PerceptionConfig{}, kBox, {"LEFT", "RIGHT", "TOP"});
  PinholeCamera absurd = rig[1];
  absurd.fx = 1e-310;
  std::int64_t t = kT0;
  for (int k = 0; k < 60; ++k, t += 33'333) {
    ASSERT_TRUE(proxy.addDepth(render(s, rig[0], t), rig[0], t).ok());
    EXPECT_EQ(proxy.addDepth(render(s, absurd, t), absurd, t).status, FrameStatus::kBadHeader);
    proxy.poll(t + 50'000);
  }
  std::map<std::string, CameraHealth> health;
  for (const CameraHealth& h : proxy.health(t)) health[h.name] = h;
  EXPECT_FALSE(health["LEFT"].silent);
  EXPECT_EQ(health["LEFT"].refused, "");
  EXPECT_TRUE(health["RIGHT"].silent);
  EXPECT_NE(health["RIGHT"].refused.find("89.9 deg off the optical axis"), std::string::npos)
      << health["RIGHT"].refused;
  EXPECT_TRUE(health["TOP"].silent);
  EXPECT_EQ(health["TOP"].refused, "");
  // Once its refused frames stop too, it is silent only.
  for (const CameraHealth& h : proxy.health(t + 2'000'000)) EXPECT_EQ(h.refused, "") << h.name;
}

// Frames refused before the merger takes their camera (no valid return here) keep no tables under
// their names: such frames under ever new names once grew them by about 2.5 MB a 640x480 name.
TEST(CameraProxy, RefusedFramesOfNewNamesKeepNoTables) {
  auto rig = defaultRig(80, 60);
  const Scene s = scene();
  CameraProxy proxy(PerceptionConfig{}, kBox, {"LEFT", "RIGHT"});
  PinholeCamera other = rig[0];
  DepthImage blind = render(s, other, kT0);
  std::fill(blind.depth.begin(), blind.depth.end(), 0);
  for (int k = 0; k < 100; ++k) {
    other.name = "CAM" + std::to_string(k);
    EXPECT_EQ(proxy.addDepth(blind, other, kT0).status, FrameStatus::kNoValidReturns) << other.name;
  }
  EXPECT_EQ(proxy.deprojectionTables(), 0u);
  EXPECT_TRUE(proxy.addDepth(render(s, rig[0], kT0), rig[0], kT0).ok());
  EXPECT_EQ(proxy.deprojectionTables(), 1u);
}

// A frame stamped before 0 or past 2^53 us (a garbage message that decodes) is refused, saying
// its utime, and does not reach the merger; a nozzle pose stamped so is ignored, and does not
// keep the next poses out (one from the far future would, being newer than any). The next
// frames go on as before.
TEST(CameraProxy, FramesAndPosesStampedOutsideTheUtimesTakenAreRefused) {
  const auto rig = defaultRig(160, 120);
  const Scene s = scene();
  PerceptionConfig cfg;
  cfg.self_filter.margin = 0.005;
  CameraProxy proxy(cfg, kBox, {"LEFT"});
  const Pose T_cell_nozzle = nozzleInTheSphere();
  for (const std::int64_t utime : {std::int64_t{-1}, kMaxUtime + 1, INT64_MIN, INT64_MAX}) {
    const FrameError e = proxy.addDepth(render(s, rig[0], utime), rig[0], kT0);
    EXPECT_EQ(e.status, FrameStatus::kBadHeader);
    EXPECT_NE(e.message.find("utime " + std::to_string(utime)), std::string::npos) << e.message;
    proxy.addNozzlePose(utime, T_cell_nozzle);
  }
  EXPECT_TRUE(proxy.poll(kT0 + 100'000).empty());
  proxy.addNozzlePose(kT0, T_cell_nozzle);
  EXPECT_TRUE(proxy.addDepth(render(s, rig[0], kT0), rig[0], kT0).ok());
  const auto out = proxy.poll(kT0 + 100'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_GT(out[0].on_nozzle, 0u);  // the pose at kT0 was taken
  EXPECT_EQ(proxy.counters().by_status[static_cast<int>(FrameStatus::kBadHeader)], 4);
}

// A ROBOT_STATE stamped ahead of the others, by less than a clock jump (a bad stamp, a driver
// host whose clock ran ahead for a moment), keeps none of the poses after it out: the frame at
// kT0 is filtered with the pose of kT0 that came after it.
TEST(CameraProxy, ANozzlePoseStampedAheadKeepsNoneOfTheNextOut) {
  const auto rig = defaultRig(160, 120);
  const Scene s = scene();
  PerceptionConfig cfg;
  cfg.self_filter.margin = 0.005;
  CameraProxy proxy(cfg, kBox, {"LEFT"});
  const Pose T_cell_nozzle = nozzleInTheSphere();
  Pose elsewhere = T_cell_nozzle;
  elsewhere.translation().z() += 1.0;  // a metre up: filters nothing
  proxy.addNozzlePose(kT0 - 500'000, elsewhere);
  proxy.addNozzlePose(kT0 + 1'500'000, elsewhere);  // 1.5 s ahead
  proxy.addNozzlePose(kT0, T_cell_nozzle);
  ASSERT_TRUE(proxy.addDepth(render(s, rig[0], kT0), rig[0], kT0).ok());
  const auto out = proxy.poll(kT0 + 100'000);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_GT(out[0].on_nozzle, 0u);  // the pose at kT0 was taken
}

// A log played again: the cameras' frames and the robot's poses go back a year. When every
// camera's next frame is far behind, the time steps start over, and the nozzle poses likewise,
// rather than every frame after being refused as late. One frame is lost: the first camera's,
// while the other has not yet gone back. A lone frame a year ahead after that is refused and
// changes nothing.
TEST(CameraProxy, AClockGoingBackStartsOverAndAFrameFromTheFarFutureIsRefused) {
  const auto rig = defaultRig(160, 120);
  const Scene s = scene();
  PerceptionConfig cfg;
  cfg.self_filter.margin = 0.005;
  CameraProxy proxy(cfg, kBox, {"LEFT", "RIGHT"});
  constexpr std::int64_t kYear = 365LL * 24 * 3600 * 1'000'000, kFrame = 33'333;
  const Pose T_cell_nozzle = nozzleInTheSphere();
  auto step = [&](std::int64_t utime, std::int64_t now) {
    const FrameError left = proxy.addDepth(render(s, rig[0], utime), rig[0], now);  // LEFT first
    return std::make_pair(left, proxy.addDepth(render(s, rig[1], utime), rig[1], now));
  };
  proxy.addNozzlePose(kT0 + kYear, T_cell_nozzle);
  step(kT0 + kYear, kT0);
  auto out = proxy.poll(kT0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, kT0 + kYear);

  proxy.addNozzlePose(kT0 + 2 * kFrame, T_cell_nozzle);
  const auto [left, right] = step(kT0 + 2 * kFrame, kT0 + 2 * kFrame);
  EXPECT_EQ(left.status, FrameStatus::kLate);
  EXPECT_TRUE(right.ok()) << right.message;
  EXPECT_EQ(proxy.clockRestarts(), 1);
  out = proxy.poll(kT0 + 2 * kFrame + 41'000);  // RIGHT's alone, after max_wait
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, kT0 + 2 * kFrame);
  EXPECT_GT(out[0].on_nozzle, 0u);  // the pose of the clock gone back was taken
  const auto [left3, right3] = step(kT0 + 3 * kFrame, kT0 + 4 * kFrame);
  EXPECT_TRUE(left3.ok() && right3.ok());
  out = proxy.poll(kT0 + 4 * kFrame);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].sources.size(), 2u);

  EXPECT_EQ(proxy.addDepth(render(s, rig[0], kT0 + kYear), rig[0], kT0 + 5 * kFrame).status, FrameStatus::kAhead);
  const auto [left6, right6] = step(kT0 + 6 * kFrame, kT0 + 6 * kFrame);
  EXPECT_TRUE(left6.ok() && right6.ok());
  out = proxy.poll(kT0 + 6 * kFrame);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, kT0 + 6 * kFrame);
  EXPECT_EQ(proxy.clockRestarts(), 1);
  EXPECT_EQ(proxy.counters().dropped(), 2);
  EXPECT_EQ(proxy.counters().by_status[static_cast<int>(FrameStatus::kAhead)], 1);
}

// Flying pixels at depth edges (the sphere's silhouette against the powder) make isolated
// voxels; isolated-voxel removal takes most of them and almost none of the surface.
TEST(CameraProxy, IsolatedVoxelRemovalTakesFlyingPixels) {
  const auto rig = defaultRig(320, 240);
  const Scene s = boxScene(kBox, 0.04, {Sphere{{0.0, 0.0, 0.07}, 0.05}, Sphere{{0.1, 0.05, 0.05}, 0.03}});
  std::mt19937 rng(3);
  Noise noise;
  noise.sigma_base = 0;
  noise.sigma_per_m = 0;
  noise.flying_pixel_prob = 1.0;
  auto run = [&](int min_neighbours, std::size_t& far, std::size_t& total) {
    PerceptionConfig cfg;
    cfg.outlier_min_neighbours = min_neighbours;
    CameraProxy proxy(cfg, kBox);
    std::mt19937 local = rng;  // same noise for both runs
    for (const auto& cam : rig) proxy.addDepth(render(s, cam, kT0, 0.00025, &noise, &local), cam, kT0);
    const auto out = proxy.poll(kT0);
    EXPECT_EQ(out.size(), 1u);
    far = 0;
    for (const auto& p : out[0].points) far += s.distance(p) > 0.005;
    total = out[0].points.size();
  };
  std::size_t far0 = 0, total0 = 0, far1 = 0, total1 = 0;
  run(0, far0, total0);
  run(2, far1, total1);
  EXPECT_GT(far0, 50u);                            // flying pixels do reach the cloud
  EXPECT_LT(far1, far0 / 3);                       // most are removed
  EXPECT_GT(total1, total0 - far0 - total0 / 50);  // and at most 2 % of the surface with them
}

// The self-filter: with the nozzle's pose known (ROBOT_STATE), the points on it are removed and
// nothing else; a pose older than max_age, or a negative margin, filters nothing (the first
// says so: a cell's nozzle should have a pose).
TEST(CameraProxy, SelfFilterRemovesThePointsOnTheNozzleOnly) {
  const auto rig = defaultRig(320, 240);
  const Scene s = scene();  // the sphere stands in for the nozzle: a body over the powder
  PerceptionConfig cfg;
  cfg.self_filter.radius = 0.03;
  cfg.self_filter.length = 0.2;
  cfg.self_filter.effector.clear();  // the tube alone (the next test: the end effector)
  cfg.self_filter.margin = 0.005;
  const Pose T_cell_nozzle = nozzleInTheSphere();  // +z of the nozzle = -z
  const DepthImage left = render(s, rig[0], kT0), right = render(s, rig[1], kT0);
  auto run = [&](const PerceptionConfig& c, std::int64_t nozzle_utime) {
    CameraProxy proxy(c, kBox, {"LEFT", "RIGHT"});
    proxy.addNozzlePose(nozzle_utime, T_cell_nozzle);
    proxy.addDepth(left, rig[0], kT0);
    proxy.addDepth(right, rig[1], kT0);
    auto out = proxy.poll(kT0);
    EXPECT_EQ(out.size(), 1u);
    return out.empty() ? CellCloud{} : out[0];
  };
  PerceptionConfig off = cfg;
  off.self_filter.margin = -1;
  const CellCloud all = run(off, kT0), filtered = run(cfg, kT0 + 3000), stale = run(cfg, kT0 - 200000);
  const Pose T_nozzle_cell = T_cell_nozzle.inverse(Eigen::Isometry);
  const double r = cfg.self_filter.radius + cfg.self_filter.margin;
  // Inside the grown cylinder (tip at z = 0, body along -z of the nozzle): how far in, m (< 0: outside).
  auto depthInside = [&](const Point& p) {
    const Point q = T_nozzle_cell * p;
    return std::min({r - q.head<2>().norm(), cfg.self_filter.margin - q.z(),
                     q.z() + cfg.self_filter.length + cfg.self_filter.margin});
  };
  int inside_before = 0;
  for (const Point& p : all.points) inside_before += depthInside(p) > 0;
  EXPECT_GT(inside_before, 100);  // the sphere's cap is seen
  EXPECT_EQ(all.on_nozzle, 0u);
  EXPECT_GT(filtered.on_nozzle, 0u);
  for (const Point& p : filtered.points) ASSERT_LE(depthInside(p), cfg.voxel_leaf) << p.transpose();
  // Away from the cylinder (by more than a voxel) the cloud is untouched.
  const PointGrid kept(filtered.points, cfg.voxel_leaf);
  for (const Point& p : all.points) {
    if (depthInside(p) < -cfg.voxel_leaf) {
      ASSERT_TRUE(kept.nearest(p, 1e-9).found()) << p.transpose();
    }
  }
  EXPECT_EQ(stale.on_nozzle, 0u);
  EXPECT_EQ(stale.points.size(), all.points.size());
  // Only the stale pose's frame is said unfiltered (the filter on, no pose near it).
  EXPECT_TRUE(stale.unfiltered);
  EXPECT_FALSE(filtered.unfiltered);
  EXPECT_FALSE(all.unfiltered);
}

// The end effector's body (robot.effector) is filtered too, each of its cylinders where the
// planner places it: on the line from the flange to the tip (robot.tool_offset), which here is not
// the nozzle's axis. With a hair-thin tube tilted 29 deg off that line, a 1 cm plate on the flange
// and a 3 cm body below it, the sphere's cap inside either goes, and the rest stays (beside the
// plate as well).
TEST(CameraProxy, SelfFilterRemovesTheEndEffectorsBodyOnTheLineToTheFlange) {
  const auto rig = defaultRig(320, 240);
  const Scene s = scene();
  // The flange 1 cm over the sphere's top, the tip 20 cm straight below it: the plate from the
  // flange down to 11 cm, the body on to 5 cm. The nozzle sprays down, tilted about y.
  const Point flange(0.02, 0.01, 0.14);
  Pose T_cell_nozzle = Pose::Identity();
  T_cell_nozzle.linear() =
      (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  T_cell_nozzle.translation() = flange - Point(0, 0, 0.2);
  Pose T_cell_flange = Pose::Identity();
  T_cell_flange.translation() = flange;
  PerceptionConfig cfg;
  cfg.self_filter.radius = 0.001;
  cfg.self_filter.length = 0.2;
  cfg.self_filter.effector = {{0.01, 0.03}, {0.03, 0.06}};
  cfg.self_filter.T_flange_nozzle = T_cell_flange.inverse(Eigen::Isometry) * T_cell_nozzle;
  cfg.self_filter.margin = 0.005;
  CameraProxy proxy(cfg, kBox, {"LEFT", "RIGHT"});
  proxy.addNozzlePose(kT0, T_cell_nozzle);
  proxy.addDepth(render(s, rig[0], kT0), rig[0], kT0);
  proxy.addDepth(render(s, rig[1], kT0), rig[1], kT0);
  const auto out = proxy.poll(kT0);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_GT(out[0].on_nozzle, 100u);
  const double leaf = cfg.voxel_leaf;
  int beside_plate = 0;
  for (const Point& p : out[0].points) {
    const Point q = p - flange;  // the plate: z from 0 to -0.03; the body: on to -0.09
    const double r = q.head<2>().norm();
    const bool plate = q.z() < -leaf && q.z() > -0.03 + leaf;
    ASSERT_FALSE(plate && r < 0.015 - leaf) << p.transpose();
    ASSERT_FALSE(q.z() < -0.03 - leaf && q.z() > -0.09 + leaf && r < 0.035 - leaf) << p.transpose();
    beside_plate += plate && r > 0.015 + leaf;
  }
  EXPECT_GT(beside_plate, 10);  // within the body's radius but beside the plate: kept
}

// config.agreement: a camera whose frames claim a pose 1 deg off its true one is flagged after
// flag_after checks of period seconds each; the cameras where they say never are.
TEST(CameraProxy, ACameraThatMovedIsFlaggedAfterThreeChecks) {
  const auto rig = defaultRig(320, 240);
  const Scene s = scene();
  auto run = [&](double turn_deg) {
    PerceptionConfig cfg;  // period 1 s, flag_after 3
    CameraProxy proxy(cfg, kBox, {"LEFT", "RIGHT"});
    PinholeCamera claimed = rig[0];
    claimed.T_cell_camera.linear() =
        Eigen::AngleAxisd(turn_deg * M_PI / 180, Eigen::Vector3d::UnitX()).matrix() * rig[0].T_cell_camera.linear();
    const DepthImage left = render(s, rig[0], 0), right = render(s, rig[1], 0);
    std::vector<bool> flagged;
    for (int k = 0; k < 8; ++k) {  // one time step every 0.5 s: a check every other step
      const std::int64_t t = kT0 + k * 500'000;
      DepthImage l = left, r = right;
      l.utime = r.utime = t;
      proxy.addDepth(l, claimed, t);
      proxy.addDepth(r, rig[1], t);
      EXPECT_EQ(proxy.poll(t).size(), 1u);
      flagged.push_back(proxy.agreement().count("RIGHT") ? proxy.agreement().at("RIGHT").flagged : false);
    }
    return std::make_pair(flagged, proxy.agreement());
  };
  const auto [ok_flags, ok] = run(0.0);
  ASSERT_EQ(ok.size(), 1u);
  EXPECT_EQ(ok.begin()->first, "RIGHT");  // compared with LEFT, the first by name
  EXPECT_EQ(ok.at("RIGHT").reference, "LEFT");
  EXPECT_TRUE(ok.at("RIGHT").last.valid);
  EXPECT_LT(ok.at("RIGHT").last.tilt_deg, 0.1);  // measured 0.053 (the sphere's edge cells), the limit 0.25
  EXPECT_EQ(ok_flags, std::vector<bool>(8, false));
  const auto [off_flags, off] = run(1.0);
  EXPECT_NEAR(off.at("RIGHT").last.tilt_deg, 1.0, 0.1);
  // Checks at steps 0, 2, 4, 6: the third over the limit is step 4.
  EXPECT_EQ(off_flags, (std::vector<bool>{false, false, false, false, true, true, true, true}));
}
