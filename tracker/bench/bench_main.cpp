// depowder-bench: CU-ICP (and its two baselines) against the authors' PCL configuration on
// the same frames from the same initial poses: median time per frame per part on one core,
// rotation / translation error against ground truth, peak memory.
//
// Frames: the five default parts at 40..100 % visibility, static (the paper's Table I) or
// pushed (--motion), seen by the cell's two cameras, merged, cropped to the box and voxelled
// at 5 mm as the camera proxy publishes them. Source `sim` (default when sim/ is built): the
// simulator's world (powder height field dug to the visibility, camera noise, flying pixels,
// drop-outs). Source `synthetic`: a flat powder plane and z-buffered views (scene.hpp).
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "depowder/parts.hpp"
#include "depowder/stats.hpp"
#include "depowder/tracker/part_tracker.hpp"
#include "pcl_baseline.hpp"
#include "scene.hpp"
#ifdef DEPOWDER_BENCH_HAVE_SIM
#include "depowder/node/cell.hpp"
#include "sim_frames.hpp"
#endif

namespace {

using namespace depowder;
using namespace depowder::tracker;

struct Options {
  int frames = 20;  ///< per sequence
  std::vector<double> visibilities{0.4, 0.55, 0.7, 0.85, 1.0};
  std::vector<std::string> parts = parts::names();
  std::vector<std::string> methods{"cu", "continuous", "vanilla", "pcl"};
  std::string json;
  unsigned seed = 1;
  double noise = 0.0015;          ///< m
  std::vector<std::string> sets;  ///< "key=value" overrides of TrackerConfig
  bool cull = true;               ///< give the trackers the camera positions (back-face culling)
#ifdef DEPOWDER_BENCH_HAVE_SIM
  std::string source = "sim";
#else
  std::string source = "synthetic";
#endif
  std::string cell;       ///< cell YAML for the sim source ("" = the default cell)
  double init_deg = 2.0;  ///< initial pose error: rotation, deg...
  double init_mm = 3.0;   ///< ...and translation, mm (random directions, seeded)
  double motion_mm = 0;   ///< per frame: the part slides this far along x...
  double motion_deg = 0;  ///< ...and turns this much about z (0, 0: static, the paper's Table I)
};

// --set key=value: the TrackerConfig fields worth sweeping (how the defaults were chosen).
void applySet(TrackerConfig& c, const std::string& kv) {
  const std::size_t eq = kv.find('=');
  if (eq == std::string::npos) throw std::invalid_argument("--set needs key=value, got " + kv);
  const std::string key = kv.substr(0, eq);
  const double v = std::stod(kv.substr(eq + 1));
  setField(c, key, v);
}

const char* kUsage =
    "Usage: depowder-bench [--source sim|synthetic] [--cell FILE] [--frames N] [--parts a,b]\n"
    "                      [--methods cu,continuous,vanilla,pcl] [--visibilities 0.4,0.7,1.0]\n"
    "                      [--init-error DEG,MM] [--motion MM,DEG] [--no-cull] [--noise M] [--seed N]\n"
    "                      [--set key=value]... [--json FILE]\n"
    "Tracks frames of the default parts (buried in powder, two cameras, 5 mm voxels)\n"
    "with CU-ICP, its baselines and the authors' pcl::IterativeClosestPoint configuration, all\n"
    "from the same initial poses; prints the median time per frame per part (one core), the mean\n"
    "rotation / translation errors against ground truth and the peak memory.\n"
    "  --source S        sim: the simulator's frames (default when built with sim/); synthetic: a flat\n"
    "                    powder plane and z-buffered views (scene.hpp)\n"
    "  --cell FILE       cell YAML whose cameras and box the sim source uses (default: the default cell)\n"
    "  --frames N        frames per (part, visibility) sequence (default 20)\n"
    "  --parts LIST      parts to use (default: cube,cup,propeller,owl,pipe)\n"
    "  --methods LIST    trackers to run (default: cu,continuous,vanilla,pcl)\n"
    "  --visibilities L  visibility fractions (default: 0.4,0.55,0.7,0.85,1.0)\n"
    "  --noise M         range noise sigma of the synthetic source, metres (default 0.0015)\n"
    "  --init-error D,M  initial pose error, deg and mm, random directions (default 2,3)\n"
    "  --motion MM,DEG   per frame, the part slides MM along x and turns DEG about z (default 0,0:\n"
    "                    static parts as in the paper's Table I)\n"
    "  --seed N          random seed (default 1)\n"
    "  --set key=value   override a tracker config field for every method, e.g.\n"
    "                    --set icp.tangent_weight=0 (unknown keys list the known ones)\n"
    "  --no-cull         do not tell the trackers where the cameras are (no back-face culling)\n"
    "  --json FILE       also write the summary as JSON\n";

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    } else if (a == "--frames") {
      o.frames = std::stoi(value());
    } else if (a == "--parts") {
      o.parts = splitList(value());
    } else if (a == "--methods") {
      o.methods = splitList(value());
    } else if (a == "--visibilities") {
      o.visibilities.clear();
      for (const std::string& v : splitList(value())) o.visibilities.push_back(std::stod(v));
    } else if (a == "--noise") {
      o.noise = std::stod(value());
    } else if (a == "--seed") {
      o.seed = static_cast<unsigned>(std::stoul(value()));
    } else if (a == "--source") {
      o.source = value();
    } else if (a == "--cell") {
      o.cell = value();
    } else if (a == "--init-error") {
      const std::vector<std::string> v = splitList(value());
      if (v.size() != 2) throw std::invalid_argument("--init-error needs DEG,MM");
      o.init_deg = std::stod(v[0]);
      o.init_mm = std::stod(v[1]);
    } else if (a == "--motion") {
      const std::vector<std::string> v = splitList(value());
      if (v.size() != 2) throw std::invalid_argument("--motion needs MM,DEG");
      o.motion_mm = std::stod(v[0]);
      o.motion_deg = std::stod(v[1]);
    } else if (a == "--no-cull") {
      o.cull = false;
    } else if (a == "--set") {
      o.sets.push_back(value());
    } else if (a == "--json") {
      o.json = value();
    } else {
      throw std::invalid_argument("unknown argument " + a);
    }
  }
  if (o.frames < 1) throw std::invalid_argument("--frames must be >= 1");
#ifdef DEPOWDER_BENCH_HAVE_SIM
  if (o.source != "sim" && o.source != "synthetic") throw std::invalid_argument("--source must be sim or synthetic");
#else
  if (o.source != "synthetic") throw std::invalid_argument("--source sim needs sim/ in the build");
#endif
  for (const std::string& m : o.methods)
    if (m != "pcl" && !methodFromString(m)) throw std::invalid_argument("unknown method " + m);
  for (const std::string& p : o.parts) parts::byName(p);  // throws naming the known parts
  return true;
}

// The paper's xi (Sec. V-A): 1 cm for cube, cup, owl; 0.8 cm for propeller and pipe.
double xiFor(const std::string& part) { return part == "propeller" || part == "pipe" ? 0.008 : 0.01; }

struct Sample {
  double ms;           ///< wall time of the frame (the figure)
  double cpu_ms;       ///< CPU time of the tracking thread for the frame (less sensitive to a busy machine)
  double register_ms;  ///< wall time of the registration step alone: crop, search structure, ICP
  double own_cpu_ms;   ///< cpu_ms less the time of the Eq. 2 calls, which both trackers share
  TrackTiming steps;   ///< the tracker's own breakdown (zero for pcl)
  int iterations;      ///< ICP iterations (0 for pcl, which does not report them)
  bool checked;        ///< the disagreement check ran (FilterConfig::check_every)
  double rot_deg, trans_cm;
  double visibility;
  std::string part;
};

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? std::nan("") : s / v.size();
}

struct Summary {
  double ms_median, ms_p90, cpu_median, register_median, own_cpu_median, rot_mean, trans_mean, rot_median, trans_median;
  std::size_t frames;
};
Summary summarise(const std::vector<Sample>& s) {
  std::vector<double> ms, cpu, reg, own, rot, trans;
  for (const Sample& x : s) {
    ms.push_back(x.ms);
    own.push_back(x.own_cpu_ms);
    cpu.push_back(x.cpu_ms);
    reg.push_back(x.register_ms);
    rot.push_back(x.rot_deg);
    trans.push_back(x.trans_cm);
  }
  return {median(ms), percentile(ms, 0.9), median(cpu), median(reg),   median(own),
          mean(rot),  mean(trans),         median(rot), median(trans), s.size()};
}

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}
double wallMs() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  try {
    parse(argc, argv, opt);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depowder-bench: %s\n%s", e.what(), kUsage);
    return 2;
  }
  TrackerConfig base;  // the defaults of config/cell.yaml, with --set applied
  try {
    for (const std::string& kv : opt.sets) applySet(base, kv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "depowder-bench: %s\n", e.what());
    return 2;
  }
  std::map<std::string, std::vector<Sample>> samples;  // method -> per frame
  std::mt19937 rng(opt.seed);
  scene::SceneConfig scene_config;
  scene_config.noise_sigma = opt.noise;
#ifdef DEPOWDER_BENCH_HAVE_SIM
  std::unique_ptr<bench::SimFrames> sim;
  if (opt.source == "sim") {
    try {
      sim = std::make_unique<bench::SimFrames>(opt.cell.empty() ? node::defaultCellPath() : opt.cell);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "depowder-bench: %s\n", e.what());
      return 2;
    }
  }
#endif
  if (opt.cull) {
#ifdef DEPOWDER_BENCH_HAVE_SIM
    if (sim) base.viewpoints = sim->viewpoints();
#endif
    if (base.viewpoints.empty())
      for (const scene::Camera& c : scene::defaultCameras()) base.viewpoints.push_back(c.T_cell_camera.translation());
  }

  char noise[64] = "";
  if (opt.source == "synthetic") std::snprintf(noise, sizeof noise, ", noise %.1f mm", opt.noise * 1000);
  std::printf(
      "depowder-bench: %zu parts x %zu visibilities x %d frames, %s frames%s, start %.1f deg / %.1f mm off, "
      "motion %.2f mm + %.2f deg a frame\n",
      opt.parts.size(), opt.visibilities.size(), opt.frames, opt.source.c_str(), noise, opt.init_deg, opt.init_mm,
      opt.motion_mm, opt.motion_deg);
  for (const std::string& name : opt.parts) {
    const Mesh mesh = parts::byName(name);
    const double xi = xiFor(name);
    for (const double vis : opt.visibilities) {
      // Ground truth: resting in the box at a random yaw; static, or pushed along x while turning.
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      const Pose T0 = scene::restingPose(mesh, 0.02 * u(rng), 0.02 * u(rng), 0, 0, M_PI * u(rng));
      const double powder_z = scene::powderHeightFor(mesh, T0, vis);
      std::vector<Pose> truth;
      std::vector<Cloud> frames;
      for (int k = 0; k < opt.frames; ++k) {
        Pose T = T0;
        T.translation().x() += 0.001 * opt.motion_mm * k;
        T.linear() = Eigen::AngleAxisd(opt.motion_deg * M_PI / 180 * k, Eigen::Vector3d::UnitZ()) * T0.linear();
        truth.push_back(T);
        if (opt.source == "synthetic") frames.push_back(scene::render({{&mesh, T}}, powder_z, scene_config, rng));
      }
#ifdef DEPOWDER_BENCH_HAVE_SIM
      if (sim) frames = sim->render(name, mesh, truth, vis, static_cast<std::uint32_t>(rng()));
#endif
      // The same initial pose for every tracker: truth perturbed by 3 mm and 2 deg (--init-error).
      const Eigen::Vector3d dir = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
      const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
      Pose T_init = truth[0];
      T_init.translation() += 0.001 * opt.init_mm * dir;
      T_init.linear() = Eigen::AngleAxisd(opt.init_deg * M_PI / 180, axis) * T_init.linear();

      for (const std::string& method : opt.methods) {
        auto record = [&](const Pose& estimate, double ms, double cpu_ms, double register_ms, double eq2_ms, int k,
                          const TrackTiming& steps, int iterations, bool checked) {
          samples[method].push_back({ms, cpu_ms, register_ms, std::max(0.0, cpu_ms - eq2_ms), steps, iterations,
                                     checked, rotationAngle(estimate.linear(), truth[k].linear()) * 180 / M_PI,
                                     translationDistance(estimate, truth[k]) * 100, vis, name});
        };
        TrackerConfig config = base;
        if (method != "pcl") config.method = *methodFromString(method);
        PartTracker tracker(name, mesh, T_init, xi, config);
        if (method == "pcl") {
          bench::PclTracker pcl(tracker.cad(), T_init, xi, config);
          for (int k = 0; k < opt.frames; ++k) {
            const double w0 = wallMs(), c0 = threadCpuMs();
            const bench::PclFrame f = pcl.track(frames[k]);
            const double c1 = threadCpuMs(), w1 = wallMs();
            record(f.T_cell_part, w1 - w0, c1 - c0, f.register_ms, f.progress_ms, k, TrackTiming{}, 0, false);
          }
        } else {
          for (int k = 0; k < opt.frames; ++k) {
            const double w0 = wallMs(), c0 = threadCpuMs();
            const TrackResult r = tracker.track(frames[k]);
            const double c1 = threadCpuMs(), w1 = wallMs();
            record(r.T_cell_part, w1 - w0, c1 - c0, r.timing.crop_ms + r.timing.icp_ms, r.timing.progress_ms, k,
                   r.timing, r.iterations, r.checked);
          }
        }
      }
    }
  }

  // Figures.
  std::printf("\nper frame per part, one core: wall ms (p50, p90), thread CPU ms (p50), registration step ms (p50)\n");
  std::printf("%-11s %8s %8s %8s %8s %7s | %9s %9s | %9s %9s\n", "method", "ms p50", "ms p90", "cpu p50", "reg p50",
              "frames", "rot mean", "t mean", "rot p50", "t p50");
  std::printf("%-11s %8s %8s %8s %8s %7s | %9s %9s | %9s %9s\n", "", "", "", "", "", "", "deg", "cm", "deg", "cm");
  std::map<std::string, Summary> sum;
  for (const std::string& m : opt.methods) {
    const Summary s = sum[m] = summarise(samples[m]);
    std::printf("%-11s %8.3f %8.3f %8.3f %8.3f %7zu | %9.2f %9.3f | %9.2f %9.3f\n", m.c_str(), s.ms_median, s.ms_p90,
                s.cpu_median, s.register_median, s.frames, s.rot_mean, s.trans_mean, s.rot_median, s.trans_median);
  }
  std::printf(
      "\nmean wall time per step (ms): crop+grid, ICP, disagreement check (its second ICP), lines of sight and\n"
      "refit, progress (Eq. 2), template (Alg. 2); ICP iterations; frames the check ran on:\n");
  for (const std::string& m : opt.methods) {
    if (m == "pcl") continue;
    TrackTiming t;
    double iterations = 0, checked = 0;
    for (const Sample& s : samples[m]) {
      const double n = static_cast<double>(samples[m].size());
      t.crop_ms += s.steps.crop_ms / n;
      t.icp_ms += s.steps.icp_ms / n;
      t.check_ms += s.steps.check_ms / n;
      t.sight_ms += s.steps.sight_ms / n;
      t.progress_ms += s.steps.progress_ms / n;
      t.template_ms += s.steps.template_ms / n;
      iterations += s.iterations / n;
      checked += (s.checked ? 100.0 : 0.0) / n;
    }
    std::printf("%-11s %8.3f %8.3f %8.3f %8.3f %8.3f %8.3f %8.1f %7.0f%%\n", m.c_str(), t.crop_ms, t.icp_ms, t.check_ms,
                t.sight_ms, t.progress_ms, t.template_ms, iterations, checked);
  }
  std::printf("\nmean rotation error (deg) / translation error (cm) by visibility:\n%-11s", "method");
  for (double v : opt.visibilities) std::printf("   %5.0f%%      ", v * 100);
  std::printf("\n");
  for (const std::string& m : opt.methods) {
    std::printf("%-11s", m.c_str());
    for (double v : opt.visibilities) {
      std::vector<Sample> sel;
      for (const Sample& s : samples[m])
        if (s.visibility == v) sel.push_back(s);
      const Summary s = summarise(sel);
      std::printf("  %5.2f / %5.3f", s.rot_mean, s.trans_mean);
    }
    std::printf("\n");
  }
  std::printf("\nmean rotation error (deg) / translation error (cm) by part:\n%-11s", "method");
  for (const std::string& p : opt.parts) std::printf("  %14s", p.c_str());
  std::printf("\n");
  for (const std::string& m : opt.methods) {
    std::printf("%-11s", m.c_str());
    for (const std::string& p : opt.parts) {
      std::vector<Sample> sel;
      for (const Sample& s : samples[m])
        if (s.part == p) sel.push_back(s);
      const Summary s = summarise(sel);
      std::printf("  %5.2f / %5.3f", s.rot_mean, s.trans_mean);
    }
    std::printf("\n");
  }
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  const double peak_mb = ru.ru_maxrss / 1024.0;
  const bool have_cu = sum.count("cu"), have_pcl = sum.count("pcl");
  auto ratio = [&](double Summary::*field) {
    return have_cu && have_pcl ? sum["pcl"].*field / sum["cu"].*field : std::nan("");
  };
  const double speedup = ratio(&Summary::ms_median);
  if (have_cu && have_pcl) {
    std::printf(
        "\nCU-ICP vs PCL, median per frame per part: wall %.3f vs %.3f ms (%.1fx), thread CPU %.3f vs %.3f ms "
        "(%.1fx),\n  registration step alone %.3f vs %.3f ms (%.1fx)\n",
        sum["cu"].ms_median, sum["pcl"].ms_median, speedup, sum["cu"].cpu_median, sum["pcl"].cpu_median,
        ratio(&Summary::cpu_median), sum["cu"].register_median, sum["pcl"].register_median,
        ratio(&Summary::register_median));
    std::printf("  thread CPU without the Eq. 2 call both make (progress library): %.3f vs %.3f ms (%.1fx)\n",
                sum["cu"].own_cpu_median, sum["pcl"].own_cpu_median, ratio(&Summary::own_cpu_median));
  }
  std::printf("peak memory (getrusage ru_maxrss): %.1f MB\n", peak_mb);

  if (!opt.json.empty()) {
    std::ofstream out(opt.json);
    if (!out) {
      std::fprintf(stderr, "depowder-bench: cannot write %s\n", opt.json.c_str());
      return 1;
    }
    auto num = [](double v) {
      if (!std::isfinite(v)) return std::string("null");
      char b[64];
      std::snprintf(b, sizeof b, "%.6g", v);
      return std::string(b);
    };
    out << "{\n  \"source\": \"" << opt.source << "\",\n  \"frames\": " << (have_cu ? sum["cu"].frames : 0) << ",\n";
    out << "  \"frames_per_sequence\": " << opt.frames << ",\n";
    out << "  \"init_error_deg_mm\": [" << num(opt.init_deg) << ", " << num(opt.init_mm) << "],\n";
    out << "  \"motion_mm_deg_per_frame\": [" << num(opt.motion_mm) << ", " << num(opt.motion_deg) << "],\n";
    out << "  \"cu_icp_ms_median\": " << num(have_cu ? sum["cu"].ms_median : NAN) << ",\n";
    out << "  \"pcl_icp_ms_median\": " << num(have_pcl ? sum["pcl"].ms_median : NAN) << ",\n";
    out << "  \"speedup\": " << num(speedup) << ",\n";
    out << "  \"cu_icp_cpu_ms_median\": " << num(have_cu ? sum["cu"].cpu_median : NAN) << ",\n";
    out << "  \"pcl_icp_cpu_ms_median\": " << num(have_pcl ? sum["pcl"].cpu_median : NAN) << ",\n";
    out << "  \"speedup_cpu\": " << num(ratio(&Summary::cpu_median)) << ",\n";
    out << "  \"cu_icp_register_ms_median\": " << num(have_cu ? sum["cu"].register_median : NAN) << ",\n";
    out << "  \"pcl_icp_register_ms_median\": " << num(have_pcl ? sum["pcl"].register_median : NAN) << ",\n";
    out << "  \"speedup_register\": " << num(ratio(&Summary::register_median)) << ",\n";
    out << "  \"cu_icp_cpu_ms_median_without_eq2\": " << num(have_cu ? sum["cu"].own_cpu_median : NAN) << ",\n";
    out << "  \"pcl_icp_cpu_ms_median_without_eq2\": " << num(have_pcl ? sum["pcl"].own_cpu_median : NAN) << ",\n";
    out << "  \"speedup_cpu_without_eq2\": " << num(ratio(&Summary::own_cpu_median)) << ",\n";
    out << "  \"cu_icp_rot_err_deg\": " << num(have_cu ? sum["cu"].rot_mean : NAN) << ",\n";
    out << "  \"cu_icp_trans_err_cm\": " << num(have_cu ? sum["cu"].trans_mean : NAN) << ",\n";
    out << "  \"pcl_icp_rot_err_deg\": " << num(have_pcl ? sum["pcl"].rot_mean : NAN) << ",\n";
    out << "  \"pcl_icp_trans_err_cm\": " << num(have_pcl ? sum["pcl"].trans_mean : NAN) << ",\n";
    out << "  \"peak_memory_mb\": " << num(peak_mb) << ",\n";
    out << "  \"methods\": {";
    bool first = true;
    for (const std::string& m : opt.methods) {
      const Summary& s = sum[m];
      out << (first ? "\n" : ",\n") << "    \"" << m << "\": {\"ms_median\": " << num(s.ms_median)
          << ", \"ms_p90\": " << num(s.ms_p90) << ", \"cpu_ms_median\": " << num(s.cpu_median)
          << ", \"register_ms_median\": " << num(s.register_median) << ", \"rot_err_deg\": " << num(s.rot_mean)
          << ", \"trans_err_cm\": " << num(s.trans_mean) << ", \"rot_err_deg_median\": " << num(s.rot_median)
          << ", \"trans_err_cm_median\": " << num(s.trans_median) << ", \"frames\": " << s.frames << "}";
      first = false;
    }
    out << "\n  }\n}\n";
    std::printf("wrote %s\n", opt.json.c_str());
  }
  return 0;
}
