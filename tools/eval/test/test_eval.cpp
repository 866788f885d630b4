// depowder-eval on short runs: the JSON's shape, CU-ICP's errors under generous bounds,
// determinism for a seed, the report's tables, and the command line.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "depowder/child_process.hpp"
#include "depowder/eval/experiment.hpp"
#include "depowder/eval/report.hpp"
#include "depowder/files.hpp"
#include "depowder/mesh.hpp"
#include "depowder/node/yaml.hpp"
#include "depowder/parts.hpp"
#include "depowder/stats.hpp"
#ifdef DEPOWDER_EVAL_MOVING
#include "depowder/sim/push.hpp"
#endif

using namespace depowder;
using namespace depowder::eval;

namespace {

// The default cell's two cameras (config/cell.yaml), built without YAML.
EvalCell testCell() {
  EvalCell cell;
  for (const double y : {-0.45, 0.45})
    cell.cameras.push_back(sim::CameraModel::fromFov(y < 0 ? "LEFT" : "RIGHT", 320, 240, 70, 55,
                                                     lookAt({0.0, y, 0.55}, {0.0, 0.0, 0.05})));
  return cell;
}

std::vector<tracker::Method> allMethods() {
  return {tracker::Method::kCu, tracker::Method::kContinuous, tracker::Method::kVanilla};
}

void expectNumber(const Json& row, const std::string& key) {
  ASSERT_TRUE(row.has(key)) << key;
  EXPECT_TRUE(row.at(key).isNumber()) << key;
  EXPECT_TRUE(std::isfinite(row.at(key).number())) << key;
}

const Json* findRow(const Json& doc, const std::string& method) {
  for (const Json& r : doc.at("rows").elements())
    if (r.at("method").string() == method) return &r;
  return nullptr;
}

}  // namespace

TEST(EvalJson, RoundTripAndErrors) {
  Json doc = Json::object();
  doc.set("experiment", "static");
  doc.set("nan", std::nan(""));
  Json rows = Json::array();
  Json r = Json::object();
  r.set("part", "cu\"p\n");
  r.set("v", 0.125);
  r.set("list", Json::arrayOf(std::vector<double>{1, 2.5}));
  rows.push(r);
  doc.set("rows", rows);
  const Json back = Json::parse(doc.dump());
  EXPECT_EQ(back.at("experiment").string(), "static");
  EXPECT_TRUE(back.at("nan").isNull());
  EXPECT_EQ(back.at("rows").at(0).at("part").string(), "cu\"p\n");
  EXPECT_DOUBLE_EQ(back.at("rows").at(0).at("v").number(), 0.125);
  EXPECT_DOUBLE_EQ(back.at("rows").at(0).at("list").at(1).number(), 2.5);
  // Numbers read back exactly, in their shortest form: two methods' figures that differ in the
  // 11th digit stay apart when a report is rendered again from the JSON.
  const std::vector<double> numbers{0.1, 0.1 + 0.2, 0.10311111111111, 0.10311111111112, 1e-300, -2.0 / 3.0};
  const Json exact = Json::parse(Json::arrayOf(numbers).dump());
  for (std::size_t i = 0; i < numbers.size(); ++i) EXPECT_EQ(exact.at(i).number(), numbers[i]) << i;
  EXPECT_EQ(Json(0.1).dump(), "0.1");
  EXPECT_THROW(Json::parse("{\"a\": }"), JsonError);
  EXPECT_THROW(Json::parse("[1, 2"), JsonError);
  EXPECT_EQ(Json::parse("\"\\u00e9\\u0041\"").string(),
            "\xc3\xa9"
            "A");
  EXPECT_THROW(Json::parse("\"\\u12g4\""), JsonError);  // a non-hex digit (std::stoul threw its own)
  EXPECT_EQ(Json::parse(std::string(200, '[') + std::string(200, ']')).size(), 1u);
  EXPECT_THROW(Json::parse(std::string(100000, '[')), JsonError);  // not a stack overflow
  EXPECT_THROW(back.at("missing"), JsonError);
}

TEST(EvalScene, ConversionKeepsTheFrame) {
  sim::DepthImage f;
  f.camera = "LEFT";
  f.time = 1.5;
  f.width = 4;
  f.height = 2;
  f.fx = 100;
  f.fy = 101;
  f.cx = 1.5;
  f.cy = 0.5;
  f.min_range = 0.25;
  f.max_range = 9;
  f.T_cell_camera.translation() << 0.1, 0.2, 0.3;
  f.depth = {1, 2, 3, 4, 5, 6, 7, 8};
  const ProxyInput in = toProxyInput(f);
  EXPECT_EQ(in.image.utime, 1500000);
  EXPECT_EQ(in.image.depth, f.depth);
  EXPECT_EQ(in.camera.name, "LEFT");
  EXPECT_DOUBLE_EQ(in.camera.fy, 101);
  EXPECT_DOUBLE_EQ(in.camera.max_range, 9);
  EXPECT_TRUE(in.camera.T_cell_camera.isApprox(f.T_cell_camera));
}

// --self-filter: the nozzle's pose goes to the camera proxy, which removes its points, as
// ROBOT_STATE has it do in the cell; the rest of the scan stays.
TEST(EvalScene, SelfFilterTakesTheNozzleOutOfTheScan) {
  const EvalCell cell = testCell();
  const Mesh cube = parts::byName("cube");
  sim::World world(cell.sim, cell.box, {{"cube", cube, placePart(cube, 0.3, {-0.06, 0.0}, 0.03), 1000}}, cell.cameras,
                   3);
  world.setPowderLevel(0.05);  // the cube half buried
  // Upright, tip 6 cm over the powder beside the cube (+z of the nozzle frame sprays down).
  Pose T_cell_nozzle = Pose::Identity();
  T_cell_nozzle.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T_cell_nozzle.translation() << 0.08, 0.03, 0.11;
  world.setNozzle(T_cell_nozzle, Tool::kOff);
  const Pose T_nozzle_cell = T_cell_nozzle.inverse(Eigen::Isometry);
  const double r = cell.sim.nozzle.radius;
  auto onNozzle = [&](const Cloud& scan, double grow) {
    int n = 0;
    for (const Point& p : scan) {
      const Point q = T_nozzle_cell * p;
      n += q.head<2>().norm() < r + grow && q.z() > -cell.sim.nozzle.length && q.z() < grow;
    }
    return n;
  };
  FrameSource plain(cell), filtered(cell);
  const Cloud with = plain.capture(world);
  const Cloud without = filtered.capture(world, &T_cell_nozzle);
  EXPECT_GT(onNozzle(with, 0.003), 30);    // the cameras see the nozzle's body...
  EXPECT_EQ(onNozzle(without, 0.003), 0);  // ...and the self-filter takes all of it out
  // Away from the nozzle (beyond its margin and a voxel) the scan is the same but for the noise.
  const double far = perception::SelfFilterConfig{}.margin + 0.01;
  const double kept = static_cast<double>(without.size() - onNozzle(without, far)),
               all = static_cast<double>(with.size() - onNozzle(with, far));
  EXPECT_NEAR(kept / all, 1.0, 0.02);
}

// One trial of 15 frames at 60 %, seed 7.
StaticOptions shortStatic() {
  StaticOptions o;
  o.visibilities = {0.6};
  o.trials = 1;
  o.duration = 0.5;  // 15 frames
  o.seed = 7;
  return o;
}

TEST(EvalStatic, ShortRunShapeBoundsAndDeterminism) {
  const EvalCell cell = testCell();
  const StaticOptions o = shortStatic();
  const std::vector<EvalPart> parts{defaultPart("cube")};
  const StaticResult r = runStatic(cell, parts, allMethods(), o);
  ASSERT_FALSE(r.interrupted);
  ASSERT_EQ(r.rows.size(), 3u);
  const Json doc = Json::parse(toJson(r, o).dump());
  EXPECT_EQ(doc.at("experiment").string(), "static");
  EXPECT_EQ(doc.at("seed").number(), 7);
  ASSERT_EQ(doc.at("rows").size(), 3u);
  for (const Json& row : doc.at("rows").elements()) {
    EXPECT_EQ(row.at("part").string(), "cube");
    EXPECT_DOUBLE_EQ(row.at("visibility").number(), 0.6);
    for (const char* key : {"rot_err_deg", "trans_err_cm", "final_rot_err_deg", "final_trans_err_cm", "true_eta",
                            "tracked_fraction", "track_ms"})
      expectNumber(row, key);
    EXPECT_EQ(row.at("trials").number(), 1);
    EXPECT_EQ(row.at("frames_per_trial").number(), 15);
    // The set visibility is the simulator's Eq. 2 eta.
    EXPECT_NEAR(row.at("true_eta").number(), 0.6, 0.02);
  }
  const Json* cu = findRow(doc, "cu");
  ASSERT_NE(cu, nullptr);
  // Generous bounds: the initial error is at most 3 deg / 0.5 cm; CU-ICP must not make it much worse.
  EXPECT_LT(cu->at("rot_err_deg").number(), 4.0);
  EXPECT_LT(cu->at("trans_err_cm").number(), 0.6);
  EXPECT_LT(cu->at("final_rot_err_deg").number(), 3.0);
  EXPECT_LT(cu->at("final_trans_err_cm").number(), 0.4);
  EXPECT_GT(cu->at("tracked_fraction").number(), 0.5);

  // Same seed, same figures (CU only: the methods do not influence each other).
  const StaticResult again = runStatic(cell, parts, {tracker::Method::kCu}, o);
  ASSERT_EQ(again.rows.size(), 1u);
  EXPECT_EQ(again.rows[0].rot_err_deg, r.rows[0].rot_err_deg);
  EXPECT_EQ(again.rows[0].trans_err_cm, r.rows[0].trans_err_cm);
}

// The paper's own pipe (the authors' P_cad made a closed mesh, depowder-make-parts --shell; skipped
// without ../shared/data) at 40 and 100 % visibility, 2 seconds of frames: CU-ICP within the
// issue's goal, 3 deg and 0.3 cm (measured: 0.26 deg / 0.051 cm at 40 %, 0.96 deg / 0.034 cm at 100 %).
TEST(EvalStatic, ThePapersOwnPipe) {
  const std::string path = std::string(DEPOWDER_SHARED_DATA) + "/parts/paper_pipe_cm.xyz";
  if (!std::ifstream(path)) GTEST_SKIP() << "the paper's pipe not found at " << path << " (not part of the project)";
  const EvalPart pipe{"paper_pipe", shellAround(readXyz(path, 0.01), 0.0015, 0.001), 0.008};
  StaticOptions o = shortStatic();
  o.visibilities = {0.4, 1.0};
  o.duration = 2.0;
  const StaticResult r = runStatic(testCell(), {pipe}, {tracker::Method::kCu}, o);
  ASSERT_EQ(r.rows.size(), 2u);
  for (const auto& row : r.rows) {
    std::printf("paper_pipe at %.0f %%: %.2f deg, %.3f cm\n", row.visibility * 100, row.rot_err_deg, row.trans_err_cm);
    EXPECT_LT(row.rot_err_deg, 3.0) << row.visibility;
    EXPECT_LT(row.trans_err_cm, 0.3) << row.visibility;
  }
}

// --trace: one row per tracked frame and method, its error the same as the tables' (the last
// frame's is the row's final error), the CSV line as wide as its header.
TEST(EvalStatic, TraceHasEveryFrameAndTheTablesErrors) {
  const EvalCell cell = testCell();
  const StaticOptions o = shortStatic();
  std::vector<TraceRow> rows;
  std::vector<tracker::TrackResult> results;
  RunControl control;
  control.trace = [&](const TraceRow& row) {
    rows.push_back(row);
    results.push_back(*row.result);
  };
  const StaticResult r = runStatic(cell, {defaultPart("cube")}, allMethods(), o, control);
  ASSERT_EQ(r.rows.size(), 3u);
  ASSERT_EQ(rows.size(), 15u * 3u);
  const auto commas = [](const std::string& line) { return std::count(line.begin(), line.end(), ','); };
  for (std::size_t k = 0; k < rows.size(); ++k) {
    EXPECT_EQ(rows[k].frame, static_cast<int>(k / 3));
    EXPECT_EQ(rows[k].method, tracker::toString(allMethods()[k % 3]));
    TraceRow row = rows[k];
    row.result = &results[k];
    const std::string line = traceLine(row);
    EXPECT_EQ(commas(line), commas(traceHeader()));
    EXPECT_NEAR(rows[k].eta_true, 0.6, 0.05);  // the true visibility, the last field (dug to 60 %)
    EXPECT_NEAR(std::stod(line.substr(line.rfind(',') + 1)), rows[k].eta_true, 1e-4);
  }
  for (std::size_t m = 0; m < 3; ++m) {
    const TraceRow& last = rows[rows.size() - 3 + m];
    const PoseError e = poseError(results[results.size() - 3 + m].T_cell_part, last.T_true);
    EXPECT_NEAR(e.rot_deg, r.rows[m].final_rot_err_deg, 1e-9) << last.method;
    EXPECT_NEAR(e.trans_cm, r.rows[m].final_trans_err_cm, 1e-9) << last.method;
    // The line's rotation error is that angle, to its 3 decimals.
    TraceRow row = last;
    row.result = &results[results.size() - 3 + m];
    const std::string line = traceLine(row);
    std::size_t field = 0, start = 0;
    for (; field < 5; ++field) start = line.find(',', start) + 1;
    EXPECT_NEAR(std::stod(line.substr(start)), e.rot_deg, 1e-3);
  }
}

// The simulator keeps the difficulties the paper describes; the shared ICP is what removes them
// (docs/results.md, "The paper's gaps"). With a data term like the authors' (point-to-point,
// template to scan only, no normal test, no powder tests, no filter), a cup at 20 % visibility
// pulls Vanilla ICP's buried CAD points onto the powder and Continuous ICP's template drifts,
// while CU-ICP's template, derived once near the truth, holds. Seeds 1 to 5 of this cell gave
// CU-ICP 2.8 to 4.9 deg against 31 to 48 (Continuous) and 43 to 53 deg (Vanilla); with the
// tracker's own settings all three end 1.5 deg / 0.19 cm off on the same frames (seed 1).
TEST(EvalStatic, AuthorsDataTermShowsThePapersGaps) {
  StaticOptions o;
  o.visibilities = {0.2};
  o.trials = 1;
  o.seed = 1;
  EvalCell authors = testCell();
  for (const auto& [key, value] : std::vector<std::pair<std::string, double>>{{"icp.tangent_weight", 1},
                                                                              {"icp.scan_weight", 0},
                                                                              {"icp.normal_min_cos", -1},
                                                                              {"icp.kernel_scale", 0},
                                                                              {"visibility.powder_radius", 0},
                                                                              {"visibility.cover", 0},
                                                                              {"visibility.powder_scan_margin", 0},
                                                                              {"filter.data_inflation", 0},
                                                                              {"refit_margin", 0}})
    tracker::setField(authors.tracker, key, value);
  const StaticResult gaps = runStatic(authors, {defaultPart("cup")}, allMethods(), o);
  ASSERT_EQ(gaps.rows.size(), 3u);
  const double cu = gaps.rows[0].rot_err_deg;
  EXPECT_LT(cu, 10.0);
  for (std::size_t m = 1; m < 3; ++m) {
    EXPECT_GT(gaps.rows[m].rot_err_deg, 20.0) << gaps.rows[m].method;
    EXPECT_GT(gaps.rows[m].rot_err_deg, 4 * cu) << gaps.rows[m].method;
    EXPECT_GT(gaps.rows[m].trans_err_cm, 1.5) << gaps.rows[m].method;
  }
  const StaticResult shared = runStatic(testCell(), {defaultPart("cup")}, allMethods(), o);
  ASSERT_EQ(shared.rows.size(), 3u);
  for (const StaticRow& row : shared.rows) {
    EXPECT_LT(row.rot_err_deg, 5.0) << row.method;
    EXPECT_LT(row.trans_err_cm, 0.5) << row.method;
  }
}

TEST(EvalStatic, StopsCleanlyWithPartialResults) {
  const EvalCell cell = testCell();
  StaticOptions o;
  o.visibilities = {0.8, 1.0};
  o.trials = 1;
  o.duration = 0.2;  // 6 frames per trial
  int frames = 0;
  RunControl control;
  control.stop = [&] { return frames >= 8; };  // during the second visibility
  control.progress = [&](double done, double total, const std::string&) {
    frames = static_cast<int>(done);
    EXPECT_LE(done, total);
  };
  const StaticResult r = runStatic(cell, {defaultPart("cube")}, {tracker::Method::kCu}, o, control);
  EXPECT_TRUE(r.interrupted);
  ASSERT_EQ(r.rows.size(), 1u);  // the finished visibility only
  EXPECT_DOUBLE_EQ(r.rows[0].visibility, 0.8);
  EXPECT_TRUE(Json::parse(toJson(r, o).dump()).at("interrupted").boolean());
}

TEST(EvalSpeed, ShortRunShapeAndBounds) {
  const EvalCell cell = testCell();
  SpeedOptions o;
  o.visibilities = {0.8};
  o.trials = 1;
  o.linear_travel = 0.02;  // 2 cm at 1 cm/s: 60 frames
  o.linear_factors = {2, 4};
  o.turntable_travel_deg = 12;  // 12 deg at 6 deg/s: 60 frames
  o.turntable_factors = {2, 4};
  o.seed = 3;
  const SpeedResult r = runSpeed(cell, {defaultPart("cube")}, allMethods(), o);
  ASSERT_FALSE(r.interrupted);
  ASSERT_EQ(r.rows.size(), 3u);
  const Json doc = Json::parse(toJson(r, o).dump());
  EXPECT_EQ(doc.at("experiment").string(), "speed");
  for (const Json& row : doc.at("rows").elements()) {
    for (const char* key : {"max_trans_speed_cm_s", "max_rot_speed_deg_s", "true_eta_start"}) expectNumber(row, key);
    EXPECT_GE(row.at("max_trans_speed_cm_s").number(), 0);
    EXPECT_LE(row.at("max_trans_speed_cm_s").number(), 4.0 + 1e-9);
    EXPECT_LE(row.at("max_rot_speed_deg_s").number(), 24.0 + 1e-9);
    EXPECT_NEAR(row.at("true_eta_start").number(), 0.8, 0.03);
  }
  const Json* cu = findRow(doc, "cu");
  ASSERT_NE(cu, nullptr);
  // 2 cm/s is 0.7 mm a frame and 12 deg/s 0.4 deg a frame: CU-ICP must follow both.
  EXPECT_GE(cu->at("max_trans_speed_cm_s").number(), 2.0);
  EXPECT_GE(cu->at("max_rot_speed_deg_s").number(), 12.0);
}

// A factor the travel has no frames for (here 61 of 60) would report a success at a speed never
// tracked; a list out of order would cut the highest speed short. Both are refused up front.
TEST(EvalSpeed, FactorsPastTheRunsFramesAreRefused) {
  const EvalCell cell = testCell();
  SpeedOptions o;
  o.visibilities = {0.8};
  o.trials = 1;
  o.linear_travel = 0.02;  // 60 frames
  o.turntable_travel_deg = 12;
  for (const std::vector<int>& bad : std::vector<std::vector<int>>{{2, 61}, {4, 2}, {0, 2}, {}}) {
    o.linear_factors = bad;
    o.turntable_factors = {2, 4};
    EXPECT_THROW(runSpeed(cell, {defaultPart("cube")}, {tracker::Method::kCu}, o), std::invalid_argument);
    o.linear_factors = {2, 4};
    o.turntable_factors = bad;
    EXPECT_THROW(runSpeed(cell, {defaultPart("cube")}, {tracker::Method::kCu}, o), std::invalid_argument);
  }
}

TEST(EvalReport, TablesCarryOursAndThePapers) {
  Json s = Json::object();
  s.set("experiment", "static");
  s.set("interrupted", false);
  Json opt = Json::object();
  opt.set("trials", 2);
  opt.set("duration_s", 2.5);
  opt.set("max_offset_m", 0.02);
  opt.set("nozzle", true);
  opt.set("nozzle_standoff_m", 0.03);
  opt.set("nozzle_above_top_m", 0.01);
  opt.set("nozzle_tilt_deg", 15.0);
  opt.set("nozzle_period_s", 2.0);
  opt.set("init_trans_max_m", 0.005);
  opt.set("init_rot_max_deg", 3.0);
  s.set("options", opt);
  Json rows = Json::array();
  for (const char* m : {"cu", "continuous", "vanilla"}) {
    Json r = Json::object();
    r.set("part", "cube");
    r.set("method", m);
    r.set("visibility", 0.4);
    r.set("rot_err_deg", std::string(m) == "cu" ? 1.234 : 9.0);
    r.set("trans_err_cm", 0.111);
    for (const char* k : {"tilt_err_deg", "tracked_fraction", "lost_fraction", "template_updates", "template_size",
                          "track_ms", "init_rot_err_deg", "init_trans_err_cm"})
      r.set(k, 1.0);
    rows.push(r);
  }
  s.set("rows", rows);
  ReportInputs in{s, Json(), Json(), "not run", "depowder-eval report", "## Notes\n"};
  const std::string md = reportMarkdown(in, {});
  EXPECT_NE(md.find("**1.23** (1.69)"), std::string::npos) << md;  // ours, best, then the paper's cube 40 %
  EXPECT_NE(md.find("9.00 (3.76)"), std::string::npos) << md;      // Continuous ICP, paper 3.76
  EXPECT_NE(md.find("| CU-ICP (paper) | 100 | 80 | 100 | 100 | 80 | 92 |"), std::string::npos) << md;
  EXPECT_NE(md.find("## Notes"), std::string::npos);
  EXPECT_DOUBLE_EQ(paperRotErrDeg("cu", "overall", 0.2), 19.0);
  EXPECT_DOUBLE_EQ(paperTransErrCm("vanilla", "pipe", 1.0), 0.38);
  EXPECT_TRUE(std::isnan(paperRotErrDeg("cu", "cube", 0.5)));
}

// The paper's "overall" is the mean of its five parts: a run of two parts gets its own overall row
// without the paper's beside it (19.0 deg for CU-ICP at 20 %), each part row still with its own, and
// a run with eta1 set says so instead of "ICP runs at every visibility".
TEST(EvalReport, ASubsetsOverallIsNotComparedWithThePapers) {
  Json s = Json::object();
  s.set("experiment", "static");
  s.set("interrupted", false);
  Json opt = Json::object();
  for (const auto& [k, v] : std::vector<std::pair<const char*, double>>{{"trials", 1},
                                                                        {"duration_s", 1},
                                                                        {"max_offset_m", 0.02},
                                                                        {"init_trans_max_m", 0.005},
                                                                        {"init_rot_max_deg", 3},
                                                                        {"eta1", 0.5}})
    opt.set(k, v);
  opt.set("nozzle", false);
  s.set("options", opt);
  Json rows = Json::array();
  for (const char* part : {"cube", "cup"}) {
    Json r = Json::object();
    r.set("part", part);
    r.set("method", "cu");
    r.set("visibility", 0.2);
    r.set("rot_err_deg", std::string(part) == "cube" ? 1.0 : 3.0);
    r.set("trans_err_cm", 0.5);
    for (const char* k : {"tilt_err_deg", "tracked_fraction", "lost_fraction", "template_updates", "template_size",
                          "track_ms", "init_rot_err_deg", "init_trans_err_cm"})
      r.set(k, 1.0);
    rows.push(r);
  }
  s.set("rows", rows);
  const std::string md = reportMarkdown({s, Json(), Json(), "not run", "depowder-eval report", ""}, {});
  EXPECT_NE(md.find("| cube | 1.00 (16.8) | 0.50 (1.05) |"), std::string::npos) << md;  // the paper's cube
  EXPECT_NE(md.find("| overall | 2.00 | 0.50 |"), std::string::npos) << md;             // ours alone
  EXPECT_EQ(md.find("(19.0)"), std::string::npos) << md;
  EXPECT_NE(md.find("eta1 = 0.50 (set for this run)"), std::string::npos) << md;
  EXPECT_EQ(md.find("ICP runs at every visibility"), std::string::npos) << md;
}

// The report's "Reproduce with" line keeps what decides the figures, not where a run wrote them.
TEST(EvalReport, ReproduceCommandDropsOutputFlags) {
  EXPECT_EQ(
      reproduceCommand("depowder-eval report --trials 10 --json out/r.json --seed 1 --out out --notes n.md --quiet"),
      "depowder-eval report --trials 10 --seed 1");
  EXPECT_EQ(reproduceCommand("depowder-eval report --from r.json --out docs"), "depowder-eval report");
  EXPECT_EQ(reproduceCommand("depowder-eval moving --set filter.q_yaw_deg=1 --cell c.yaml"),
            "depowder-eval moving --set filter.q_yaw_deg=1 --cell c.yaml");
}

// Table II's overall cell: the mean of the parts and the Wilson interval over all pushes, checked
// against the interval computed by hand (20 of 25: centre 0.7600, half-width 0.1514).
TEST(EvalReport, TableTwoOverallCarriesTheRatesInterval) {
  const auto [lo, hi] = wilsonInterval(20, 25);
  EXPECT_NEAR(lo, 0.6087, 1e-4);
  EXPECT_NEAR(hi, 0.9114, 1e-4);
  EXPECT_NEAR(wilsonInterval(23, 25).first, 0.7503, 1e-4);  // the paper's 92 %
  EXPECT_DOUBLE_EQ(wilsonInterval(5, 5).second, 1.0);
  EXPECT_DOUBLE_EQ(wilsonInterval(0, 5).first, 0.0);
  EXPECT_TRUE(std::isnan(wilsonInterval(1, 0).first));
  EXPECT_TRUE(std::isnan(wilsonInterval(6, 5).second));

  Json doc = Json::object();
  doc.set("experiment", "moving");
  doc.set("interrupted", false);
  Json opt = Json::object();
  for (const auto& [k, v] : std::vector<std::pair<const char*, double>>{{"trials", 5},
                                                                        {"contact_band", 0.2},
                                                                        {"min_visibility", 0.4},
                                                                        {"max_visibility", 0.6},
                                                                        {"push_speed_m_s", 0.02},
                                                                        {"success_rot_deg", 15},
                                                                        {"success_trans_m", 0.015}})
    opt.set(k, v);
  doc.set("options", opt);
  Json rows = Json::array();
  const std::vector<std::pair<const char*, double>> rates{
      {"cube", 1.0}, {"cup", 1.0}, {"propeller", 0.2}, {"owl", 1.0}, {"pipe", 0.8}};
  for (const auto& [part, rate] : rates) {
    Json r = Json::object();
    r.set("part", part);
    r.set("method", "cu");
    r.set("visibility", 0.5);
    r.set("success", rate);
    r.set("trials", 5);
    for (const char* k : {"final_rot_err_deg", "final_trans_err_cm", "moved_cm", "turned_deg"}) r.set(k, 1.0);
    // Pushes 0 .. rate * 5 - 1 followed; the propeller's failures: two flagged lost, two still tracking.
    std::vector<int> ok;
    std::vector<std::string> status;
    for (int i = 0; i < 5; ++i) {
      ok.push_back(i < std::lround(rate * 5));
      status.push_back(ok.back() || std::string(part) == "pipe" || i >= 3 ? "tracking" : "lost");
    }
    r.set("trial_success", Json::arrayOf(ok));
    r.set("trial_final_status", Json::arrayOf(status));
    rows.push(r);
  }
  doc.set("rows", rows);
  const std::string md = reportMarkdown({Json(), Json(), doc, "", "depowder-eval report", ""}, {});
  EXPECT_NE(md.find("| 80 [61, 91] (92) |"), std::string::npos) << md;
  EXPECT_NE(md.find("LOST or DEGRADED at the last frame (the rest it reported as TRACKING): CU-ICP 2 of 5 failed and "
                    "0 of 20 followed."),
            std::string::npos)
      << md;
}

// The default cell's text with `from` replaced by `to` (each must occur once), its part mesh
// given by absolute path, written where a test may write.
std::string cellVariant(const std::string& name, const std::string& from, const std::string& to) {
  const std::string src = DEPOWDER_SOURCE_DIR;
  std::ifstream in(src + "/config/cell.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto replace = [&](const std::string& a, const std::string& b) {
    const std::size_t at = text.find(a);
    EXPECT_NE(at, std::string::npos) << a;
    EXPECT_EQ(text.find(a, at + 1), std::string::npos) << a;
    if (at != std::string::npos) text.replace(at, a.size(), b);
  };
  replace("mesh: parts/pipe.stl", "mesh: " + src + "/config/parts/pipe.stl");
  if (!from.empty()) replace(from, to);
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

TEST(EvalCell, TakesTheCellFilesSimPerceptionAndTrackerSections) {
  const EvalCell def = loadEvalCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/cell.yaml");
  ASSERT_EQ(def.cameras.size(), 2u);
  EXPECT_EQ(def.cameras[0].name, "LEFT");
  EXPECT_DOUBLE_EQ(def.box.size.x(), 0.40);
  EXPECT_DOUBLE_EQ(def.sim.nozzle.length, 0.25);  // the cell's tube (sim.nozzle), not the library's 13 cm
  EXPECT_FALSE(def.sim.physics.enabled);          // the cell's is on; moving turns it on itself
  EXPECT_DOUBLE_EQ(def.perception.voxel_leaf, perception::PerceptionConfig{}.voxel_leaf);
  EXPECT_EQ(def.tracker.eta1, 0.0);  // ICP at every visibility, as baseTrackerConfig
  EXPECT_DOUBLE_EQ(def.tracker.filter.data_inflation, tracker::TrackerConfig{}.filter.data_inflation);
  EXPECT_TRUE(def.tracker.viewpoints.empty());  // evalTrackerConfig sets the cameras

  const EvalCell leaf = loadEvalCell(cellVariant("eval_leaf.yaml", "  voxel_leaf: 0.005", "  voxel_leaf: 0.003"));
  EXPECT_DOUBLE_EQ(leaf.perception.voxel_leaf, 0.003);
  const EvalCell tangent =
      loadEvalCell(cellVariant("eval_tangent.yaml", "    tangent_weight: 0.3", "    tangent_weight: 0.5"));
  EXPECT_DOUBLE_EQ(tangent.tracker.icp.tangent_weight, 0.5);
  EXPECT_DOUBLE_EQ(evalTrackerConfig(tracker::Method::kCu, tangent).icp.tangent_weight, 0.5);
  const std::string tube = "    length: 0.25             # m, = robot.tool_offset z (the tube";
  const EvalCell longer = loadEvalCell(cellVariant("eval_tube.yaml", tube, "    length: 0.3 # (the tube"));
  EXPECT_DOUBLE_EQ(longer.sim.nozzle.length, 0.3);

  // A misspelt key is named, as the processes name it.
  try {
    loadEvalCell(cellVariant("eval_typo.yaml", "    tangent_weight: 0.3", "    tangent_wieght: 0.3"));
    ADD_FAILURE() << "a misspelt tracker key was accepted";
  } catch (const node::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("tangent_wieght"), std::string::npos) << e.what();
  }
}

// sim.camera_truth (config/scenarios/camera_off.yaml): LEFT renders from its true pose, and its
// frames are deprojected with the pose the cell claims, as the camera process would.
TEST(EvalCell, ACameraOffItsClaimedPoseIsDeprojectedWithTheClaim) {
  const EvalCell off = loadEvalCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/scenarios/camera_off.yaml");
  const Pose claimed = lookAt({0.0, -0.35, 0.75}, {0.0, 0.0, 0.05});
  ASSERT_EQ(off.cameras.at(0).name, "LEFT");
  ASSERT_TRUE(off.cameras.at(0).T_cell_camera_claimed.has_value());
  EXPECT_LT(translationDistance(*off.cameras.at(0).T_cell_camera_claimed, claimed), 1e-12);
  EXPECT_NEAR(off.cameras.at(0).T_cell_camera.translation().x(), 0.004, 1e-12);
  EXPECT_LT((viewpoints(off.cameras).at(0) - claimed.translation()).norm(), 1e-12);  // the tracker knows the claim

  // Over the middle of the box, the powder (flat, over a buried cube) as the scan has it: where
  // LEFT's surface and RIGHT's no longer coincide there are more 5 mm voxels (measured: 3857
  // against 3410) and their mean height moves (1.8 mm), with the same world and noise.
  EvalCell truth = off;
  for (sim::CameraModel& c : truth.cameras) c.T_cell_camera_claimed.reset();
  auto scan = [](const EvalCell& cell) {
    sim::World world(cell.sim, cell.box, {{"cube", parts::cube(), placePart(parts::cube(), 0, {0, 0}, 0.0), 1000}},
                     cell.cameras, 5);
    FrameSource source(cell);
    double n = 0, sum = 0;
    for (const Point& p : source.capture(world))
      if (std::abs(p.x()) < 0.12 && std::abs(p.y()) < 0.09) n += 1, sum += p.z();
    return std::make_pair(n, sum / n);
  };
  const auto [n_true, z_true] = scan(truth);
  const auto [n_off, z_off] = scan(off);
  EXPECT_GT(n_off, 1.08 * n_true) << n_off << " voxels against " << n_true;
  EXPECT_GT(std::abs(z_off - z_true), 0.001) << z_off << " m against " << z_true;
}

// The camera proxy's agreement check (perception::compareHeights) on the simulator's powder dug
// round a part (slopes at the angle of repose, each side seen better by one camera): cameras
// where they say must stay well inside its limits, and LEFT 7.2 mm and 1.46 deg off beyond them.
TEST(EvalCell, DugPowderKeepsCorrectCamerasInAgreement) {
  const EvalCell off = loadEvalCell(std::string(DEPOWDER_SOURCE_DIR) + "/config/scenarios/camera_off.yaml");
  const perception::AgreementConfig limits;
  for (double eta : {0.3, 0.8}) {
    sim::World world(off.sim, off.box,
                     {{"cube", parts::cube(), placePart(parts::cube(), 0.4, {0.03, 0.01}, 0.0), 1000}}, off.cameras, 9);
    world.digToVisibility(0, eta);
    auto cloud = [&](std::size_t c, bool claimed) {
      ProxyInput in = toProxyInput(world.render(c));  // the frame carries the claimed pose
      if (!claimed) in.camera.T_cell_camera = world.cameras()[c].T_cell_camera;
      return perception::deproject(in.image, in.camera, perception::cropBox(off.box.size, 0.005)).points;
    };
    const Cloud right = cloud(1, true);
    const perception::Agreement ok = perception::compareHeights(cloud(0, false), right, off.box.size, limits);
    const perception::Agreement bad = perception::compareHeights(cloud(0, true), right, off.box.size, limits);
    ASSERT_TRUE(ok.valid && bad.valid);
    EXPECT_LT(std::abs(ok.offset), 0.5 * limits.max_offset) << "eta " << eta << ": " << ok.offset;
    EXPECT_LT(ok.tilt_deg, 0.5 * limits.max_tilt_deg) << "eta " << eta;
    EXPECT_GT(bad.tilt_deg, 2 * limits.max_tilt_deg) << "eta " << eta;
  }
}

TEST(EvalCli, WritesJsonAndRejectsBadFlags) {
  const std::string bin = std::string(DEPOWDER_BIN_DIR) + "/depowder-eval";
  const std::string json = ::testing::TempDir() + "eval_cli.json";
  const std::string cmd = bin + " static --part cube --visibilities 1.0 --trials 1 --duration 0.2 --methods cu " +
                          "--seed 2 --set eta1=0.5 --quiet --json " + json + " > /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Json doc = readJsonFile(json);
  EXPECT_EQ(doc.at("experiment").string(), "static");
  EXPECT_EQ(doc.at("options").at("eta1").number(), 0.5);  // the eta1 the run used, not the default 0
  ASSERT_EQ(doc.at("rows").size(), 1u);
  EXPECT_EQ(doc.at("rows").at(0).at("method").string(), "cu");
  EXPECT_LT(doc.at("rows").at(0).at("trans_err_cm").number(), 0.6);
  std::remove(json.c_str());
  for (const std::string bad : {" static --methods icp",
                                " static --part teapot",
                                " static --trials 0",
                                " static --mesh x.stl",
                                " static --set icp.nothing=1",
                                " frobnicate",
                                " speed --trace /dev/null",
                                " speed --self-filter",
                                " static --no-nozzle --self-filter",
                                " static --probe 5",
                                " moving --probe 0",
                                " static --push-offset 0.1",
                                " moving --push-offset 0.9",
                                " static --cell no-such-cell.yaml",
                                " static --motion-oracle full",
                                " moving --motion-oracle exact",
                                " moving --motion-oracle tilt",
                                " moving --oracle-fraction 0.5",
                                " moving --motion-oracle full --oracle-fraction 3",
                                " static --push-speed 0.01",
                                " moving --push-speed 0",
                                " moving --push-speed 1"}) {
    EXPECT_EQ(testutil::shellExitStatus(bin + bad + " > /dev/null 2>&1"), 2) << bad;
  }
}

#ifdef DEPOWDER_EVAL_MOVING
// --motion-oracle's motion: all of it takes T_a to T_b; the planar part keeps T_a's height and
// tilt and turns it about the vertical by the motion's turn about z; the tip part is the rest; a
// fraction scales each.
TEST(EvalMoving, OracleMotionIsTheTrueMotionOrItsPlanarOrTipPart) {
  const Pose T_a = makePoseRpy({0.05, -0.02, 0.03}, 0.1, -0.05, 0.4);
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  Pose T_b = T_a;
  T_b.linear() = turn * T_a.linear();
  T_b.translation() += Eigen::Vector3d(0.01, 0.004, -0.003);
  const Pose full = oracleMotion(T_a, T_b, MotionPart::kFull, 1.0) * T_a;
  EXPECT_TRUE(full.isApprox(T_b, 1e-12));
  const Pose planar = oracleMotion(T_a, T_b, MotionPart::kPlanar, 1.0) * T_a;
  EXPECT_NEAR(planar.translation().x(), T_b.translation().x(), 1e-12);
  EXPECT_NEAR(planar.translation().y(), T_b.translation().y(), 1e-12);
  EXPECT_NEAR(planar.translation().z(), T_a.translation().z(), 1e-12);
  const Eigen::AngleAxisd planar_turn(planar.linear() * T_a.linear().transpose());
  EXPECT_NEAR(std::abs(planar_turn.axis().z()), 1.0, 1e-9);  // about the vertical only
  const Eigen::Matrix3d& R = turn;
  EXPECT_NEAR(planar_turn.angle(), std::abs(std::atan2(R(1, 0) - R(0, 1), R(0, 0) + R(1, 1))), 1e-9);
  const Pose half = oracleMotion(T_a, T_b, MotionPart::kFull, 0.5) * T_a;
  EXPECT_TRUE(half.translation().isApprox(0.5 * (T_a.translation() + T_b.translation()), 1e-12));
  EXPECT_NEAR(rotationAngle(half.linear(), T_a.linear()), 0.5 * rotationAngle(T_b.linear(), T_a.linear()), 1e-12);
  EXPECT_TRUE(oracleMotion(T_a, T_b, MotionPart::kFull, 0.0).isApprox(Pose::Identity(), 1e-12));
  // The tip after the planar part is the whole motion; alone it keeps the origin's xy and turns
  // the part 0.1 rad about a horizontal axis (x, turned with the motion's turn about z).
  const Pose planar_motion = oracleMotion(T_a, T_b, MotionPart::kPlanar, 1.0);
  const Pose tip_motion = oracleMotion(T_a, T_b, MotionPart::kTip, 1.0);
  EXPECT_TRUE((tip_motion * planar_motion * T_a).linear().isApprox(T_b.linear(), 1e-12));
  const Pose tip = tip_motion * T_a;
  EXPECT_NEAR(tip.translation().x(), T_a.translation().x(), 1e-12);
  EXPECT_NEAR(tip.translation().y(), T_a.translation().y(), 1e-12);
  EXPECT_NEAR(tip.translation().z(), T_b.translation().z(), 1e-12);
  const Eigen::AngleAxisd tip_turn(tip.linear() * T_a.linear().transpose());
  EXPECT_NEAR(tip_turn.angle(), 0.1, 1e-9);
  EXPECT_NEAR(tip_turn.axis().z(), 0.0, 1e-9);
  MovingOptions o;
  o.motion_oracle = "tilt";
  try {
    runMoving(testCell(), {defaultPart("cube")}, {tracker::Method::kCu}, o);
    ADD_FAILURE() << "an unknown motion_oracle ran";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'tilt'"), std::string::npos) << e.what();
  }
}

// --motion-oracle physics: the shadow world replays a frame from the part's pose at rest. From the
// true pose, before the first frame that moves a buried cube, it gives the world's own motion; with
// no nozzle in the frame, none.
TEST(EvalMoving, PhysicsMotionFromTheTruthIsTheWorldsOwn) {
  EvalCell cell = testCell();
  cell.sim.physics.enabled = true;
  const Mesh cube = defaultPart("cube").mesh;
  const Pose T0 = placePart(cube, 0.3, {0.0, 0.0}, 0.03);
  sim::World world(cell.sim, cell.box, {{"cube", cube, T0, 1000}}, cell.cameras, 3);
  world.digToVisibility(0, 0.5);
  sim::World shadow(cell.sim, cell.box, {{"cube", cube, T0, 1000}}, cell.cameras, 3);
  sim::PushScript push(world, sim::pushFrom(world, 0, 180, 0.5, 0.0));
  const double dt = 1.0 / 120;
  const std::vector<sim::ArmState> none(4);  // no nozzle in the cell
  const Pose still = physicsMotion(shadow, world.powder(), T0, none, dt);
  EXPECT_LT(still.translation().norm(), 1e-7);  // a buried part stays put
  EXPECT_LT(rotationAngle(still.linear(), Eigen::Matrix3d::Identity()), 1e-6);
  bool moved = false;
  for (int frame = 0; frame < 300 && !moved; ++frame) {
    const sim::PowderField powder = world.powder();
    const Pose T_before = world.partTruth(0).T_cell_part;
    std::vector<sim::ArmState> steps;
    for (int k = 0; k < 4; ++k) {
      steps.push_back(push.update(world.time() + dt));
      world.setArm(steps.back());
      world.step(dt);
    }
    const Pose T_after = world.partTruth(0).T_cell_part;
    moved = (T_after.translation() - T_before.translation()).norm() > 1e-5;
    if (!moved) continue;
    const Pose predicted = physicsMotion(shadow, powder, T_before, steps, dt) * T_before;
    std::printf("frame %d: moved %.3g m, predicted %.3g m off\n", frame,
                (T_after.translation() - T_before.translation()).norm(),
                (predicted.translation() - T_after.translation()).norm());
    EXPECT_LT((predicted.translation() - T_after.translation()).norm(), 1e-6)
        << "moved " << (T_after.translation() - T_before.translation()).norm() << " m";
    EXPECT_LT(rotationAngle(predicted.linear(), T_after.linear()), 1e-5);
  }
  EXPECT_TRUE(moved) << "the push never moved the cube";
}

// physics-scan's powder: a column with scan points takes their median height; the points on the
// part (within the margin of its box) and on the nozzle's body are not powder; the rest keep theirs.
TEST(EvalMoving, PowderFromScanTakesColumnMediansButNotThePartOrTheNozzle) {
  sim::PowderField powder(0.3, 0.3, 0.01);
  powder.fill(0.05);
  const Eigen::AlignedBox3d box(Eigen::Vector3d::Constant(-0.01), Eigen::Vector3d::Constant(0.01));
  const Pose T_part(Eigen::Translation3d(0.1, -0.1, 0.05));
  const Pose T_nozzle = sim::nozzlePose({-0.1, 0.1, 0.1}, {0, 0, -1});  // tip 10 cm up, body above it
  const Cloud scan = {{0.055, 0.055, 0.06},   {0.055, 0.055, 0.08}, {0.055, 0.055, 0.07},  // median 7 cm
                      {-0.095, -0.095, 0.02},                                              // one point: 2 cm
                      {0.1, -0.1, 0.06},      {0.118, -0.1, 0.04},                         // the part, its margin
                      {-0.095, 0.105, 0.15},  {-0.095, 0.105, 0.03}};                      // the nozzle, powder below
  powderFromScan(powder, scan, &T_nozzle, box, T_part, 0.01);
  auto at = [&](double x, double y) {
    int i = 0, j = 0;
    EXPECT_TRUE(powder.cellOf({x, y}, i, j));
    return powder.height(powder.index(i, j));
  };
  EXPECT_NEAR(at(0.055, 0.055), 0.07, 1e-12);
  EXPECT_NEAR(at(-0.095, -0.095), 0.02, 1e-12);
  EXPECT_NEAR(at(0.1, -0.1), 0.05, 1e-12);    // kept: the part's own point
  EXPECT_NEAR(at(0.118, -0.1), 0.05, 1e-12);  // kept: within the margin
  EXPECT_NEAR(at(-0.095, 0.105), 0.03, 1e-12);
  EXPECT_NEAR(at(0.0, 0.0), 0.05, 1e-12);                                      // no points: kept
  powderFromScan(powder, {{0.118, -0.1, 0.04}}, nullptr, box, T_part, 0.005);  // a thinner margin
  EXPECT_NEAR(at(0.118, -0.1), 0.04, 1e-12);
}

TEST(EvalMoving, ShortPushShapeAndBounds) {
  const EvalCell cell = testCell();
  MovingOptions o;
  o.trials = 1;
  o.seed = 5;
  o.max_duration = 12;
  o.probe_every = 30;
  const MovingResult r = runMoving(cell, {defaultPart("cube")}, allMethods(), o);
  ASSERT_FALSE(r.interrupted);
  ASSERT_EQ(r.rows.size(), 3u);
  const Json doc = Json::parse(toJson(r, o).dump());
  EXPECT_EQ(doc.at("experiment").string(), "moving");
  EXPECT_EQ(doc.at("options").at("max_offset_fraction").number(), o.max_offset_fraction);
  for (const Json& row : doc.at("rows").elements()) {
    for (const char* key : {"success", "final_rot_err_deg", "final_trans_err_cm", "visibility", "moved_cm"})
      expectNumber(row, key);
    EXPECT_GE(row.at("success").number(), 0.0);
    EXPECT_LE(row.at("success").number(), 1.0);
    EXPECT_GE(row.at("visibility").number(), 0.35);
    EXPECT_LE(row.at("visibility").number(), 0.65);
  }
  const Json* cu = findRow(doc, "cu");
  ASSERT_NE(cu, nullptr);
  EXPECT_GT(cu->at("moved_cm").number(), 1.0);  // the push moved the part
  // Every method saw the same push: the same part motion in every row.
  for (const Json& row : doc.at("rows").elements()) {
    EXPECT_DOUBLE_EQ(row.at("moved_cm").number(), cu->at("moved_cm").number());
    EXPECT_EQ(row.at("trial_outcome").at(0).string(), cu->at("trial_outcome").at(0).string());
  }
  // Pushed at about its centre of mass's height the cube slides: it does not tip over (before the
  // nozzle came down beside the part, it landed on the cube's top edge and tipped it over).
  EXPECT_LT(cu->at("trial_tilt_deg").at(0).number(), 5.0);
  // The lowest true visibility of the push: at most the initial one, and a fraction.
  EXPECT_GE(cu->at("trial_min_visibility").at(0).number(), 0.0);
  EXPECT_LE(cu->at("trial_min_visibility").at(0).number(), cu->at("trial_visibility").at(0).number());
  // The tracker's own status at the last frame: a followed cube push ends tracking.
  for (const Json& row : doc.at("rows").elements()) {
    const std::string status = row.at("trial_final_status").at(0).string();
    EXPECT_TRUE(status == "tracking" || status == "degraded" || status == "lost") << status;
    if (row.at("trial_success").at(0).number() != 0) {
      EXPECT_EQ(status, "tracking");
    }
  }
  // The probes (--probe): fits of the scan alone from the true pose, every 30 frames. Without the
  // filter they wander a few degrees (docs/results.md: 4.1 deg for the cube on seed 1), not tens.
  for (const Json& row : doc.at("rows").elements()) {
    EXPECT_GE(row.at("probes").number(), 6.0);
    expectNumber(row, "probe_rot_err_deg_mean");
    expectNumber(row, "probe_trans_err_cm_mean");
    EXPECT_LT(row.at("probe_rot_err_deg_mean").number(), 15.0);
    EXPECT_LE(row.at("probe_rot_err_deg_mean").number(), row.at("probe_rot_err_deg_p90").number());
    EXPECT_LT(row.at("probe_trans_err_cm_mean").number(), 1.0);
  }
  // No bound on CU-ICP's success here: one push per part is too few to bound a rate (docs/results.md,
  // Table II); the figure is measured, not asserted.
}

// Table II, seed 2: at the end of the cube's fifth push, against the box wall, the fits without
// the filter disagreed with it while matching fewer template points, and the disagreement
// check's restart lost the cube (18 deg off at the end). The check now restarts only when the
// free fits matched at least as many points (tracker/README.md, the filter, 4). In this test
// cell the same seed's pushes end within 1.9 deg / 0.53 cm (without the inlier test the fifth
// ends 4.8 deg / 1.16 cm off after such a restart).
// The fourth push ends mostly buried against the wall too (eta 0.05-0.14), where free fits are
// 20 deg off in tilt every frame: with a still part's turn noise of 0.0025 rather than 0.01 the
// check restarted 16 times and the push ended 5.6 deg / 2.65 cm off, and at 0.001, 0.005, 0.0075
// and 0.04 it failed as well. It now restarts only when the move asked explains most of the
// difference (filter.reset_unexplained): no restart at either turn noise, both within the bounds.
TEST(EvalMoving, CubeAtTheWallIsNotLostToARestart) {
  for (const double still_turn : {0.01, 0.0025}) {
    EvalCell cell = testCell();
    cell.tracker.filter.still_turn = still_turn;
    MovingOptions o;
    o.trials = 5;
    o.seed = 2;
    const MovingResult r = runMoving(cell, {defaultPart("cube")}, {tracker::Method::kCu}, o);
    ASSERT_FALSE(r.interrupted);
    ASSERT_EQ(r.rows.size(), 1u);
    EXPECT_EQ(r.rows[0].success, 1.0) << "still_turn " << still_turn;
    for (std::size_t t = 0; t < r.rows[0].trial_final_rot_err_deg.size(); ++t) {
      std::printf("still_turn %.4f, cube push %zu: %.2f deg / %.2f cm\n", still_turn, t + 1,
                  r.rows[0].trial_final_rot_err_deg[t], r.rows[0].trial_final_trans_err_cm[t]);
      EXPECT_LT(r.rows[0].trial_final_rot_err_deg[t], 3.0) << "still_turn " << still_turn << ", push " << t + 1;
      EXPECT_LT(r.rows[0].trial_final_trans_err_cm[t], 0.8) << "still_turn " << still_turn << ", push " << t + 1;
    }
  }
}

// The command line lists each failed push under the table, numbered as the JSON and --trace
// number trials, and no push that succeeded. The propeller's first push on seed 1 (turned 64 deg,
// tipped 8 deg) fails at the time of writing; the test holds either way.
TEST(EvalCli, MovingListsEachFailedPush) {
  const std::string bin = std::string(DEPOWDER_BIN_DIR) + "/depowder-eval";
  const std::string json = ::testing::TempDir() + "eval_moving_cli.json";
  const std::string out = ::testing::TempDir() + "eval_moving_cli.txt";
  const std::string cmd =
      bin + " moving --part propeller --methods cu --trials 1 --seed 1 --quiet --json " + json + " > " + out;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Json row = readJsonFile(json).at("rows").at(0);
  std::ifstream in(out);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const bool failed = row.at("trial_success").at(0).number() == 0;
  const std::string line = "failed propeller cu trial 0: moved ";
  EXPECT_EQ(text.find(line) != std::string::npos, failed) << text;
  if (failed) {
    char final_error[64];
    std::snprintf(final_error, sizeof final_error, "final %.1f deg / %.2f cm, reported %s\n",
                  row.at("trial_final_rot_err_deg").at(0).number(), row.at("trial_final_trans_err_cm").at(0).number(),
                  row.at("trial_final_status").at(0).string().c_str());
    EXPECT_NE(text.find(final_error), std::string::npos) << text;
  }
  // One push: 1 of 1 has the interval [21, 100] %, 0 of 1 [0, 79] %; then whether the tracker knew.
  const bool flagged = row.at("trial_final_status").at(0).string() != "tracking";
  const std::string overall =
      failed ? "overall    cu          0 of 1 pushes: 0 % (95 % interval 0 to 79 %); lost or degraded at the end: " +
                   std::to_string(flagged) + " of the 1 failed, 0 of the 0 followed\n"
             : "overall    cu          1 of 1 pushes: 100 % (95 % interval 21 to 100 %); lost or degraded at the end: "
               "0 of the 0 failed, " +
                   std::to_string(flagged) + " of the 1 followed\n";
  EXPECT_NE(text.find(overall), std::string::npos) << text;
  std::remove(json.c_str());
  std::remove(out.c_str());
}
#endif

TEST(EvalTrackerSet, KnownKeysOnlyAndValidated) {
  tracker::TrackerConfig c = baseTrackerConfig();
  EXPECT_EQ(c.eta1, 0.0);  // ICP at every visibility in the experiments
  tracker::setField(c, "icp.tangent_weight", 0.0);
  EXPECT_EQ(c.icp.tangent_weight, 0.0);
  tracker::setField(c, "filter.data_inflation", 0.0);
  EXPECT_EQ(c.filter.data_inflation, 0.0);
  tracker::setField(c, "icp.max_iterations", 12);
  EXPECT_EQ(c.icp.max_iterations, 12);
  EXPECT_THROW(tracker::setField(c, "icp.teleport", 1.0), std::invalid_argument);
  EXPECT_THROW(tracker::setField(c, "delta3", 2.0), std::invalid_argument);  // out of (0, 1]
  EXPECT_EQ(c.delta3, baseTrackerConfig().delta3);
  // A whole-number key takes whole numbers only (a cast of NaN or 1e20 to int is undefined), and
  // no key takes NaN; the config is left as it was.
  for (const double bad : {std::nan(""), 1e20, 2.5, -1e10})
    EXPECT_THROW(tracker::setField(c, "icp.max_iterations", bad), std::invalid_argument) << bad;
  EXPECT_THROW(tracker::setField(c, "visibility.powder_margin", std::nan("")), std::invalid_argument);
  EXPECT_EQ(c.icp.max_iterations, 12);
}
