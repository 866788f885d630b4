// The viewer's scene model: messages in, scene out; newest message wins; garbage on
// the channels is counted, never fatal; when the snapshot modes write pictures.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/convert.hpp"
#include "depowder/nozzle_plan_t.hpp"
#include "depowder/part_pose_t.hpp"
#include "depowder/point_cloud_t.hpp"
#include "depowder/progress_t.hpp"
#include "depowder/robot_state_t.hpp"
#include "depowder/sim_truth_t.hpp"
#include "depowder/viewer/listen.hpp"
#include "depowder/viewer/scene.hpp"
#include "depowder/viewer/snapshots.hpp"

using namespace depowder;
using namespace depowder::viewer;

namespace {

part_pose_t makePose(const std::string& part, const Pose& T, std::int32_t template_version,
                     const std::vector<std::vector<std::int16_t>>& xyz, float resolution = 0.0005f) {
  part_pose_t m{};
  m.utime = 1000;
  m.part = part;
  m.method = "cu";
  m.status = part_pose_t::TRACKING;
  m.T_cell_part = node::toMsg(T);
  m.template_updated = true;
  m.template_version = template_version;
  m.template_resolution = resolution;
  m.template_xyz = xyz;
  m.template_size = static_cast<std::int32_t>(xyz.size());
  return m;
}

progress_t makeProgress(const std::string& part, std::int8_t phase, double eta) {
  progress_t m{};
  m.part = part;
  m.phase = phase;
  m.eta = eta;
  m.T_cell_part = node::toMsg(Pose::Identity());
  m.contour = {{0.1f, 0.0f, 0.05f}, {0.0f, 0.1f, 0.05f}, {-0.1f, 0.0f, 0.05f}};
  m.num_contour = 3;
  return m;
}

point_cloud_t makeCloud(std::int64_t seq, std::int64_t utime, int n = 10) {
  Cloud c;
  for (int i = 0; i < n; ++i) c.emplace_back(0.01 * i, -0.02 * i, 0.05);
  point_cloud_t m = node::encodeCloud(c, utime);
  m.seq = seq;
  return m;
}

}  // namespace

TEST(SceneModel, PartPoseGivesPoseTemplateInMetresAndStatus) {
  SceneModel model;
  const Pose T = makePoseRpy({0.05, -0.02, 0.06}, 0.1, 0.2, 0.3);
  model.onPartPose(makePose("pipe", T, 3, {{100, 0, -200}, {0, 40, 0}}, 0.0005f));
  const PartScene* p = model.scene().find("pipe");
  ASSERT_NE(p, nullptr);
  EXPECT_TRUE(p->has_estimate);
  EXPECT_LT(translationDistance(p->T_cell_part, T), 1e-9);
  EXPECT_LT(rotationAngle(p->T_cell_part.linear(), T.linear()), 1e-6);
  ASSERT_EQ(p->template_points.size(), 2u);
  EXPECT_NEAR(p->template_points[0].x(), 0.05, 1e-7);  // 100 counts * 0.5 mm
  EXPECT_NEAR(p->template_points[0].z(), -0.10, 1e-7);
  EXPECT_NEAR(p->template_points[1].y(), 0.02, 1e-7);
  EXPECT_EQ(p->template_version, 3);
  EXPECT_EQ(p->track_status, +part_pose_t::TRACKING);
  EXPECT_EQ(model.rejected().count, 0);

  // Same version, not updated: the template is kept (not re-decoded); a new version replaces it.
  part_pose_t same = makePose("pipe", T, 3, {{1, 1, 1}});
  same.template_updated = false;
  model.onPartPose(same);
  EXPECT_EQ(model.scene().find("pipe")->template_points.size(), 2u);
  model.onPartPose(makePose("pipe", T, 4, {{1, 1, 1}}));
  EXPECT_EQ(model.scene().find("pipe")->template_points.size(), 1u);
}

TEST(SceneModel, RejectsInvalidPosesAndKeepsThePreviousState) {
  SceneModel model;
  model.onPartPose(makePose("cube", Pose::Identity(), 1, {{1, 2, 3}}));
  part_pose_t nan = makePose("cube", Pose::Identity(), 2, {});
  nan.T_cell_part.position[0] = NAN;
  model.onPartPose(nan);
  part_pose_t skew = makePose("cube", Pose::Identity(), 2, {});
  skew.T_cell_part.orientation[0] = 2.0;  // |q| != 1
  model.onPartPose(skew);
  progress_t bad_eta = makeProgress("cube", 2, NAN);
  model.onProgress(bad_eta);
  EXPECT_EQ(model.rejected().count, 3);
  const PartScene* p = model.scene().find("cube");
  ASSERT_NE(p, nullptr);
  EXPECT_TRUE(p->T_cell_part.isApprox(Pose::Identity()));
  EXPECT_EQ(p->template_version, 1);
  EXPECT_FALSE(p->has_progress);
}

TEST(SceneModel, ProgressPlanRobotAndTruth) {
  SceneModel model;
  model.onProgress(makeProgress("cube", progress_t::PHASE_VACUUM_TRACKED, 0.43));
  nozzle_plan_t plan{};
  plan.plan_id = 7;
  plan.part = "cube";
  plan.reason = "contour";
  for (int i = 0; i < 4; ++i) {
    waypoint_t w{};
    w.T_cell_nozzle = node::toMsg(makePoseRpy({0.01 * i, 0, 0.2}, 0, 0, 0));
    plan.waypoints.push_back(w);
  }
  plan.num_waypoints = 4;
  model.onNozzlePlan(plan);
  sim_truth_t truth{};
  part_truth_t pt{};
  pt.part = "cube";
  pt.T_cell_part = node::toMsg(makePoseRpy({0.1, 0, 0}, 0, 0, 0));
  pt.eta = 0.45;
  truth.parts = {pt};
  truth.num_parts = 1;
  truth.T_cell_nozzle = node::toMsg(makePoseRpy({0, 0, 0.3}, 0, 0, 0));
  model.onSimTruth(truth);

  const Scene& s = model.scene();
  const PartScene* p = s.find("cube");
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->phase, +progress_t::PHASE_VACUUM_TRACKED);
  EXPECT_EQ(p->contour.size(), 3u);
  EXPECT_TRUE(p->has_truth);
  EXPECT_NEAR(p->T_cell_part_true.translation().x(), 0.1, 1e-12);
  ASSERT_EQ(s.plan.size(), 4u);
  EXPECT_NEAR(s.plan[3].x(), 0.03, 1e-12);
  // No ROBOT_STATE yet: the simulated nozzle is shown; then the driver's wins.
  EXPECT_TRUE(s.has_nozzle);
  EXPECT_NEAR(s.T_cell_nozzle.translation().z(), 0.3, 1e-12);
  robot_state_t rs{};
  // A driver not yet connected has not measured the nozzle (its pose was the cell's origin): the
  // simulated one stays.
  rs.mode = robot_state_t::MODE_DISCONNECTED;
  rs.T_cell_nozzle = node::toMsg(Pose::Identity());
  model.onRobotState(rs);
  model.onSimTruth(truth);
  EXPECT_NEAR(model.scene().T_cell_nozzle.translation().z(), 0.3, 1e-12);
  // Nor one the controller refused before it read the arm; the status line says so.
  rs.mode = robot_state_t::MODE_FAULT;
  model.onRobotState(rs);
  model.onSimTruth(truth);
  EXPECT_NEAR(model.scene().T_cell_nozzle.translation().z(), 0.3, 1e-12);
  EXPECT_NE(statusLines(model.scene()).back().find("(arm not read)"), std::string::npos);
  rs.mode = robot_state_t::MODE_FOLLOWING;
  rs.measured = true;
  rs.T_cell_nozzle = node::toMsg(makePoseRpy({0, 0, 0.25}, 0, 0, 0));
  model.onRobotState(rs);
  model.onSimTruth(truth);
  EXPECT_NEAR(model.scene().T_cell_nozzle.translation().z(), 0.25, 1e-12);

  const std::vector<std::string> lines = statusLines(model.scene());
  ASSERT_GE(lines.size(), 2u);
  EXPECT_NE(lines[0].find("cube"), std::string::npos);
  EXPECT_NE(lines[0].find("phase 2 vacuum (tracked)"), std::string::npos);
  EXPECT_NE(lines[0].find("eta 0.43"), std::string::npos);
  EXPECT_NE(lines[0].find("true eta 0.45"), std::string::npos);
  EXPECT_NE(lines[0].find("no pose"), std::string::npos);
  EXPECT_NE(lines[1].find("plan 7 (contour, cube, 4 waypoints)"), std::string::npos);
  EXPECT_NE(lines[1].find("robot following"), std::string::npos);
  EXPECT_EQ(lines[1].find("not read"), std::string::npos) << lines[1];
}

TEST(SceneModel, SceneFromCellLoadsMeshesAndBox) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "depowder_viewer_scene_cell";
  std::filesystem::create_directories(dir);
  Mesh tri;
  tri.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.triangles = {{0, 1, 2}};
  saveStl(tri, (dir / "tri.stl").string());
  std::ofstream(dir / "cell.yaml") << "box: {size: [0.5, 0.4, 0.3]}\n"
                                      "parts:\n  - name: tri\n    mesh: tri.stl\n    mesh_scale: 0.1\n";
  const Scene s = sceneFromCell(node::loadCell((dir / "cell.yaml").string()));
  EXPECT_TRUE(s.box_size.isApprox(Eigen::Vector3d(0.5, 0.4, 0.3)));
  ASSERT_EQ(s.parts.size(), 1u);
  ASSERT_TRUE(s.parts[0].mesh);
  EXPECT_NEAR(s.parts[0].mesh->vertices[1].x(), 0.1, 1e-6);
  EXPECT_FALSE(s.parts[0].has_estimate);  // nothing drawn red before the tracker speaks
  // No robot or planner section: the planner's 13 cm tube, and no end effector (the tool offset
  // puts the flange at the tip, as the planner and the driver take it).
  ASSERT_TRUE(s.tool_mesh);
  EXPECT_NEAR(bounds(*s.tool_mesh).min().z(), -0.13, 1e-9);
  EXPECT_NEAR(bounds(*s.tool_mesh).max().x(), 0.0125, 1e-9);

  std::ofstream(dir / "bad.yaml") << "parts:\n  - name: x\n    mesh: missing.stl\n";
  EXPECT_THROW(sceneFromCell(node::loadCell((dir / "bad.yaml").string())), MeshError);
  std::filesystem::remove_all(dir);
}

// The tool drawn at the nozzle, from the default cell: the 25 cm tube to the flange and the
// authors' end effector below it (its plate and its body), in the nozzle frame.
TEST(SceneModel, ToolOfCellIsTheTubeAndTheEndEffector) {
  const Mesh tool = toolOfCell(node::loadCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml"));
  const Eigen::AlignedBox3d b = bounds(tool);
  EXPECT_NEAR(b.min().z(), -0.25, 1e-9);
  EXPECT_NEAR(b.max().z(), 0.0, 1e-9);
  EXPECT_NEAR(b.max().x(), 0.0445, 1e-9);
  // Three closed cylinders of 24 facets: their prisms' volumes add up.
  auto prism = [](double r, double l) { return 0.5 * 24 * r * r * std::sin(2 * M_PI / 24) * l; };
  EXPECT_NEAR(volume(tool), prism(0.0125, 0.25) + prism(0.0445, 0.008) + prism(0.0286, 0.121), 1e-9);
  EXPECT_EQ(closednessProblem(tool), "");
}

// A tool offset that tilts the nozzle 60 deg against the flange (33 deg off the line from the
// flange to the tip): the tube stays on the nozzle's axis, and the end effector is drawn where
// the planner places it, on that line (effectorBodies).
TEST(SceneModel, ToolOfCellPlacesTheEndEffectorOnTheLineToTheFlange) {
  const Mesh tool = toolOfCell(node::loadCellFromString(
      "robot: {tool_offset: {xyz: [0.1, 0, 0.2], rpy_deg: [0, 60, 0]}, effector: [{radius: 0.03, length: 0.05}]}\n"
      "planner: {nozzle: {radius: 0.01, length: 0.1}}\n"));
  const Pose T_flange_nozzle = makePoseRpy({0.1, 0, 0.2}, 0, 60 * M_PI / 180, 0);
  const Point flange = T_flange_nozzle.inverse(Eigen::Isometry).translation();  // in the nozzle frame
  const Point axis = -flange.normalized();                                      // towards the tip
  const double tube = std::hypot(0.1, 0.2);                                     // grown to the flange
  auto prism = [](double r, double l) { return 0.5 * 24 * r * r * std::sin(2 * M_PI / 24) * l; };
  EXPECT_NEAR(volume(tool), prism(0.01, tube) + prism(0.03, 0.05), 1e-9);
  int rim = 0, centre = 0;
  for (const Point& v : tool.vertices) {
    if (v.head<2>().norm() < 0.01 + 1e-9 && v.z() > -tube - 1e-9 && v.z() < 1e-9) continue;  // the tube's
    const double along = (v - flange).dot(axis), off = (v - flange - along * axis).norm();
    EXPECT_TRUE(std::abs(along) < 1e-9 || std::abs(along - 0.05) < 1e-9) << v.transpose();  // on its end discs
    rim += std::abs(off - 0.03) < 1e-9;
    centre += off < 1e-9;
  }
  EXPECT_EQ(rim, 2 * 24);
  EXPECT_EQ(centre, 2);
}

// Through a real (in-process) LCM bus: the newest message of each kind wins, so frames
// the viewer had no time to draw are dropped in the viewer.
TEST(Listen, KeepsOnlyTheNewestFrame) {
  node::Bus bus("memq://");
  SceneModel model;
  subscribe(bus, model);
  for (int seq = 0; seq < 5; ++seq) bus.publish("POINTS", makeCloud(seq, 1000 + seq, 3 + seq));
  bus.publish("PART_POSE", makePose("pipe", Pose::Identity(), 1, {{1, 1, 1}}));
  const int handled = drain(bus, 100);
  EXPECT_EQ(handled, 6);
  EXPECT_EQ(model.scene().cloud_seq, 4);
  EXPECT_EQ(model.scene().cloud.size(), 7u);
  EXPECT_NEAR(model.scene().cloud[6].x(), 0.06, 0.0005);
  ASSERT_NE(model.scene().find("pipe"), nullptr);
  EXPECT_EQ(bus.counters().decode_errors, 0);
}

TEST(Listen, SurvivesGarbageOnEveryChannel) {
  node::Bus bus("memq://", "T1_");  // a prefix, as two cells sharing a network would use
  SceneModel model;
  subscribe(bus, model);
  const std::vector<std::string> channels = {"POINTS",    "PART_POSE",   "PROGRESS",
                                             "SIM_TRUTH", "NOZZLE_PLAN", "ROBOT_STATE"};
  std::mt19937 rng(42);
  int garbage = 0;
  for (const std::string& ch : channels) {
    // Random bytes of several lengths (0 bytes included).
    for (int len : {0, 1, 7, 8, 64, 3000}) {
      std::vector<std::uint8_t> bytes(static_cast<std::size_t>(len));
      for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
      bus.publishRaw(ch, bytes.data(), len);
      ++garbage;
    }
    // A valid message of the wrong type.
    heartbeat_t hb{};
    hb.process = "impostor";
    bus.publish(ch, hb);
    ++garbage;
  }
  // A valid PART_POSE cut short.
  const part_pose_t good = makePose("cube", makePoseRpy({0.01, 0.02, 0.03}, 0, 0, 0.5), 1, {{1, 2, 3}, {4, 5, 6}});
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(good.getEncodedSize()));
  ASSERT_EQ(good.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  bus.publishRaw("PART_POSE", buf.data(), static_cast<int>(buf.size()) - 5);
  ++garbage;
  // Decodes, but the pose is NaN: taken off the wire, rejected by the model.
  part_pose_t nan = good;
  nan.T_cell_part.position[2] = NAN;
  bus.publish("PART_POSE", nan);
  bus.publishRaw("PART_POSE", buf.data(), static_cast<int>(buf.size()));  // the good one, once
  while (drain(bus, 0) > 0) {
  }
  EXPECT_EQ(bus.counters().decode_errors, garbage);
  EXPECT_EQ(bus.counters().handler_errors, 0);
  EXPECT_EQ(bus.counters().received, 2);
  EXPECT_EQ(model.rejected().count, 1);
  EXPECT_FALSE(bus.takeErrors().empty());

  // Still listening: the good message went through, and later ones do too.
  const PartScene* p = model.scene().find("cube");
  ASSERT_NE(p, nullptr);
  EXPECT_NEAR(p->T_cell_part.translation().y(), 0.02, 1e-9);
  EXPECT_EQ(p->template_points.size(), 2u);
  bus.publish("POINTS", makeCloud(9, 99));
  EXPECT_EQ(drain(bus, 100), 1);
  EXPECT_EQ(model.scene().cloud_seq, 9);
  EXPECT_EQ(model.scene().find("impostor"), nullptr);
}

TEST(Snapshots, EveryNthPointsFrameWaitsForThatFramesPoses) {
  SnapshotPolicy policy({/*every=*/5, /*on_phase=*/false, /*settle_s=*/0.5});
  SceneModel model;
  model.onPartPose(makePose("a", Pose::Identity(), 1, {}));  // utime 1000
  std::vector<std::string> written;
  auto step = [&](std::int64_t seq, double t, bool pose_arrives) {
    model.onPoints(makeCloud(seq, 1000 + seq));
    auto names = policy.due(model.scene(), t);
    if (pose_arrives) {
      part_pose_t m = makePose("a", Pose::Identity(), 1, {});
      m.utime = 1000 + seq;
      model.onPartPose(m);
      auto more = policy.due(model.scene(), t + 0.01);
      names.insert(names.end(), more.begin(), more.end());
    }
    written.insert(written.end(), names.begin(), names.end());
    return names;
  };
  EXPECT_EQ(step(0, 0.0, true), std::vector<std::string>{"points-000000.png"});
  for (int seq = 1; seq < 5; ++seq) EXPECT_TRUE(step(seq, 0.1 * seq, true).empty());
  // Frame 5 arrives; its PART_POSE is late: nothing until the pose comes or 0.5 s pass.
  EXPECT_TRUE(step(5, 1.0, false).empty());
  EXPECT_TRUE(policy.due(model.scene(), 1.2).empty());
  EXPECT_EQ(policy.due(model.scene(), 1.6), std::vector<std::string>{"points-000005.png"});
  // Frames 10..12 were dropped by the viewer: 13 is in the same bucket and is written instead.
  EXPECT_EQ(step(13, 2.0, true), std::vector<std::string>{"points-000013.png"});
  EXPECT_TRUE(step(14, 2.1, true).empty());
  EXPECT_EQ(written, (std::vector<std::string>{"points-000000.png", "points-000013.png"}));  // + 5 above
}

TEST(Snapshots, OnPhaseChangeNamedByPartAndPhase) {
  SnapshotPolicy policy({0, true, 0.5});
  SceneModel model;
  EXPECT_TRUE(policy.due(model.scene(), 0).empty());
  model.onProgress(makeProgress("pipe", progress_t::PHASE_VACUUM_BURIED, 0.1));
  EXPECT_EQ(policy.due(model.scene(), 1), std::vector<std::string>{"pipe-phase1-buried.png"});
  model.onProgress(makeProgress("pipe", progress_t::PHASE_VACUUM_BURIED, 0.2));
  EXPECT_TRUE(policy.due(model.scene(), 2).empty());
  model.onProgress(makeProgress("pipe", progress_t::PHASE_VACUUM_TRACKED, 0.3));
  model.onProgress(makeProgress("cup/2", progress_t::PHASE_VACUUM_BURIED, 0.0));
  EXPECT_EQ(policy.due(model.scene(), 3),
            (std::vector<std::string>{"pipe-phase2-tracked.png", "cup_2-phase1-buried.png"}));
  model.onProgress(makeProgress("pipe", progress_t::PHASE_AIR_BLAST, 0.9));
  model.onProgress(makeProgress("pipe", progress_t::PHASE_DONE, 1.0));
  EXPECT_EQ(policy.due(model.scene(), 4), std::vector<std::string>{"pipe-phase4-done.png"});
}
