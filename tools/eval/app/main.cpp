// depowder-eval: the paper's experiments (Sec. V) on the simulator, one command each.
//   depowder-eval static  [--part cube] ...   Table I
//   depowder-eval speed   [--part cube] ...   Fig. 10
//   depowder-eval report  [--out docs]        both for the five default parts, docs/results.md + plots
// The sim, perception, tracker and progress libraries run in process (no LCM); a seed fixes
// every random draw. Ctrl-C stops at the next frame and writes what finished.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "depowder/eval/experiment.hpp"
#include "depowder/eval/report.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/parts.hpp"
#include "depowder/stats.hpp"
#include "terminal.hpp"

using namespace depowder;
using namespace depowder::eval;

namespace {

const char* kUsage =
    "usage: depowder-eval static|speed|moving|report [options]\n"
    "  static   Table I: a still part at each visibility, the nozzle circling it; mean errors\n"
    "  speed    Fig. 10: linear actuator and turntable at increasing speed; highest speed tracked\n"
#ifdef DEPOWDER_EVAL_MOVING
    "  moving   Table II: the nozzle pushes the part to the box wall from seeded contact points\n"
    "  report   static + speed + moving for the five default parts and three methods\n"
    "           -> DIR/results.md + PNGs\n"
#else
    "  report   static + speed for the five default parts and three methods -> DIR/results.md + PNGs\n"
    "  (moving, Table II, needs the simulator's rigid-body physics, which this build does not have)\n"
#endif
    "options:\n"
    "  --part NAME[,NAME]     default parts (cube, cup, propeller, owl, pipe; default: all five)\n"
    "  --mesh FILE --xi M     any mesh (STL/OBJ/PLY) instead, with its template distance xi (m)\n"
    "  --mesh-scale S         multiplies the mesh's coordinates (0.001 for millimetres; default 1)\n"
    "  --methods LIST         cu,continuous,vanilla (default: all three)\n"
    "  --trials N             seeded trials per part and visibility (static 5, speed 2)\n"
    "  --speed-trials N       report: trials of the speed experiment (default 2)\n"
    "  --moving-trials N      report: pushes per part of the moving experiment (default 5)\n"
    "  --seed S               (default 1)\n"
    "  --visibilities LIST    e.g. 0.2,0.4,0.6,0.8,1.0 (the default)\n"
    "  --duration S           static: seconds of frames per trial (default 2.5)\n"
    "  --cell FILE            the cell file's box and cameras, and its sim, perception and tracker settings\n"
    "                         (default config/cell.yaml); the tracker's eta1 is 0 (ICP at every visibility)\n"
    "                         unless --set eta1=... changes it; the JSON records it (options.eta1)\n"
    "  --json FILE            write the results as JSON\n"
    "  --trace FILE           static, moving: every tracked frame of every method as CSV (error in the part frame)\n"
    "  --out DIR              report: where results.md and the PNGs go (default docs)\n"
    "  --from FILE            report: rebuild DIR/results.md from a JSON file that report --json wrote\n"
    "  --notes FILE           report: markdown appended verbatim (default tools/eval/report_notes.md)\n"
    "  --no-nozzle            static: no nozzle in the cell (what its occlusion and interference cost)\n"
    "  --self-filter          static, moving: the camera proxy removes the nozzle's points, as ROBOT_STATE has it\n"
    "                         do in the cell (default: the nozzle stays in the scan, the paper's interference)\n"
    "  --probe N              moving: every N frames, a tracker without the filter started at the true pose fits\n"
    "                         that frame's scan 4 times; how far it ends from the truth shows how well the scan\n"
    "                         alone pins the part (printed, and probe_* in the JSON)\n"
    "  --motion-oracle NAME   moving: a diagnostic no cell has (full, planar, tip, physics or physics-scan): each\n"
    "                         tracker is told the part's true motion since the last frame (planar: only its turn\n"
    "                         about the vertical and its slide; tip: only the rest, its tip and rise or sink),\n"
    "                         which bounds what a motion model could add; physics: the motion the world's own\n"
    "                         physics and powder give the tracker's last estimate under the frame's nozzle path;\n"
    "                         physics-scan: the same with the powder as the scans show it (median height per\n"
    "                         column, the part and the nozzle left out), not the world's\n"
    "  --oracle-fraction F    moving: the motion told is F x the oracle's (turn angle and slide; default 1)\n"
    "  --push-offset F        moving, report: the push line passes the part's centre sideways by up to F x its\n"
    "                         xy diagonal (seeded; default 0.25): larger turns the part more\n"
    "  --push-speed V         moving, report: the nozzle pushes at V m/s (default 0.02); the time limit grows so\n"
    "                         that it may travel as far as at the default\n"
    "  --set KEY=VALUE        a tracker setting for every method (e.g. filter.data_inflation=0); repeatable\n"
    "  --quiet                no progress bar\n";

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-eval: " << error << "\n";
  std::cerr << kUsage;
  return error.empty() ? 0 : 2;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

double number(const std::string& flag, const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  throw std::invalid_argument(flag + ": not a number: '" + text + "'");
}

struct Args {
  std::string command;
  std::vector<std::string> parts;
  std::string mesh, json, cell, out = "docs", from, notes, trace;
  double xi = 0, mesh_scale = 1;
  std::vector<tracker::Method> methods{tracker::Method::kCu, tracker::Method::kContinuous, tracker::Method::kVanilla};
  int trials = 0, speed_trials = 0, moving_trials = 0;
  std::uint32_t seed = 1;
  std::vector<double> visibilities;
  double duration = 0;
  bool quiet = false, no_nozzle = false, self_filter = false;
  int probe = 0;                                     ///< moving: --probe N
  std::string motion_oracle;                         ///< moving: --motion-oracle full|planar|tip|physics[-scan]
  double oracle_fraction = -1;                       ///< moving: --oracle-fraction F (< 0: not given)
  double push_offset = -1;                           ///< moving: --push-offset F (< 0: the default)
  double push_speed = -1;                            ///< moving: --push-speed V (< 0: the default)
  std::vector<std::pair<std::string, double>> sets;  ///< --set key=value
  std::string command_line;                          ///< as typed, for the report
};

Args parse(int argc, char** argv) {
  Args a;
  a.command = argv[1];
  a.command_line = "depowder-eval " + a.command;
  for (int i = 2; i < argc; ++i) {
    const std::string f = argv[i];
    a.command_line += " " + f;
    if (f == "--quiet") {
      a.quiet = true;
      continue;
    }
    if (f == "--no-nozzle") {
      a.no_nozzle = true;
      continue;
    }
    if (f == "--self-filter") {
      a.self_filter = true;
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument("missing value after " + f);
    const std::string v = argv[++i];
    a.command_line += " " + v;
    if (f == "--part") {
      for (const std::string& p : split(v)) a.parts.push_back(p);
    } else if (f == "--mesh") {
      a.mesh = v;
    } else if (f == "--xi") {
      a.xi = number(f, v);
      if (!(a.xi > 0 && a.xi < 0.1)) throw std::invalid_argument("--xi must be in (0, 0.1) m");
    } else if (f == "--mesh-scale") {
      a.mesh_scale = number(f, v);
      if (!(a.mesh_scale > 0)) throw std::invalid_argument("--mesh-scale must be > 0");
    } else if (f == "--methods") {
      a.methods.clear();
      for (const std::string& m : split(v)) {
        const auto method = tracker::methodFromString(m);
        if (!method) throw std::invalid_argument("--methods: unknown method '" + m + "' (cu, continuous, vanilla)");
        a.methods.push_back(*method);
      }
      if (a.methods.empty()) throw std::invalid_argument("--methods: empty list");
    } else if (f == "--trials" || f == "--speed-trials" || f == "--moving-trials") {
      const double n = number(f, v);
      if (!(n >= 1 && n <= 1000 && n == std::floor(n))) throw std::invalid_argument(f + " must be an integer 1..1000");
      (f == "--trials" ? a.trials : f == "--speed-trials" ? a.speed_trials : a.moving_trials) = static_cast<int>(n);
    } else if (f == "--probe") {
      const double n = number(f, v);
      if (!(n >= 1 && n <= 10000 && n == std::floor(n)))
        throw std::invalid_argument("--probe must be an integer 1..10000 (frames)");
      a.probe = static_cast<int>(n);
    } else if (f == "--motion-oracle") {
      motionPart(v);  // rejects a name it does not know
      a.motion_oracle = v;
    } else if (f == "--oracle-fraction") {
      a.oracle_fraction = number(f, v);
      if (!(a.oracle_fraction >= 0 && a.oracle_fraction <= 2))
        throw std::invalid_argument("--oracle-fraction must be in [0, 2]");
    } else if (f == "--push-offset") {
      a.push_offset = number(f, v);
      if (!(a.push_offset >= 0 && a.push_offset <= 0.5))
        throw std::invalid_argument("--push-offset must be in [0, 0.5] (a fraction of the part's xy diagonal)");
    } else if (f == "--push-speed") {
      a.push_speed = number(f, v);
      if (!(a.push_speed >= 0.002 && a.push_speed <= 0.2))
        throw std::invalid_argument("--push-speed must be in [0.002, 0.2] m/s");
    } else if (f == "--seed") {
      const double s = number(f, v);
      if (!(s >= 0 && s <= 4294967295.0 && s == std::floor(s)))
        throw std::invalid_argument("--seed must be an integer 0..4294967295");
      a.seed = static_cast<std::uint32_t>(s);
    } else if (f == "--visibilities") {
      for (const std::string& x : split(v)) {
        const double e = number(f, x);
        if (!(e >= 0 && e <= 1)) throw std::invalid_argument("--visibilities: each in [0, 1], got " + x);
        a.visibilities.push_back(e);
      }
    } else if (f == "--duration") {
      a.duration = number(f, v);
      if (!(a.duration > 0 && a.duration <= 600)) throw std::invalid_argument("--duration must be in (0, 600] s");
    } else if (f == "--set") {
      const std::size_t eq = v.find('=');
      if (eq == std::string::npos) throw std::invalid_argument("--set needs KEY=VALUE, got '" + v + "'");
      const std::string key = v.substr(0, eq);
      const double value = number("--set " + key, v.substr(eq + 1));
      tracker::TrackerConfig probe = baseTrackerConfig();
      tracker::setField(probe, key, value);  // rejects an unknown key or a bad value now
      a.sets.emplace_back(key, value);
    } else if (f == "--cell") {
      a.cell = v;
    } else if (f == "--json") {
      a.json = v;
    } else if (f == "--trace") {
      a.trace = v;
    } else if (f == "--out") {
      a.out = v;
    } else if (f == "--from") {
      a.from = v;
    } else if (f == "--notes") {
      a.notes = v;
    } else {
      throw std::invalid_argument("unknown option " + f);
    }
  }
  if (!a.mesh.empty() && !a.parts.empty()) throw std::invalid_argument("give --part or --mesh, not both");
  if (a.self_filter && a.command == "speed") throw std::invalid_argument("--self-filter: speed has no nozzle");
  if (a.probe > 0 && a.command != "moving") throw std::invalid_argument("--probe is for moving");
  if (!a.motion_oracle.empty() && a.command != "moving") throw std::invalid_argument("--motion-oracle is for moving");
  if (a.oracle_fraction >= 0 && a.motion_oracle.empty())
    throw std::invalid_argument("--oracle-fraction goes with --motion-oracle");
  if (a.push_offset >= 0 && a.command != "moving" && a.command != "report")
    throw std::invalid_argument("--push-offset is for moving and report");
  if (a.push_speed >= 0 && a.command != "moving" && a.command != "report")
    throw std::invalid_argument("--push-speed is for moving and report");
  if (a.self_filter && a.no_nozzle) throw std::invalid_argument("--self-filter needs the nozzle (not --no-nozzle)");
  if (!a.mesh.empty() && a.xi <= 0) throw std::invalid_argument("--mesh needs --xi (m)");
  if (a.mesh.empty() && a.xi > 0 && a.parts.empty()) throw std::invalid_argument("--xi goes with --mesh");
  return a;
}

std::vector<EvalPart> partsOf(const Args& a) {
  std::vector<EvalPart> out;
  if (!a.mesh.empty()) {
    std::string name = a.mesh.substr(a.mesh.find_last_of('/') + 1);
    name = name.substr(0, name.find_last_of('.'));
    out.push_back({name, loadMesh(a.mesh, a.mesh_scale), a.xi});
    return out;
  }
  for (const std::string& p : a.parts.empty() ? parts::names() : a.parts) {
    EvalPart part = defaultPart(p);  // throws naming the known parts
    if (a.xi > 0) part.xi = a.xi;
    out.push_back(std::move(part));
  }
  return out;
}

RunControl control(ProgressBar& bar, std::ofstream* trace = nullptr) {
  RunControl c;
  c.stop = [] { return node::shutdownRequested(); };
  c.progress = [&bar](double done, double total, const std::string& what) { bar.update(done, total, what); };
  if (trace != nullptr) c.trace = [trace](const TraceRow& row) { *trace << traceLine(row) << '\n'; };
  return c;
}

// --trace FILE, opened with its header; none without the flag.
std::unique_ptr<std::ofstream> openTrace(const Args& a) {
  if (a.trace.empty()) return nullptr;
  if (a.command != "static" && a.command != "moving")
    throw std::invalid_argument("--trace is for static and moving, not " + a.command);
  auto out = std::make_unique<std::ofstream>(a.trace);
  if (!*out) throw std::runtime_error("cannot write the trace file '" + a.trace + "'");
  *out << traceHeader() << '\n';
  return out;
}

StaticOptions staticOptions(const Args& a) {
  StaticOptions o;
  if (a.trials > 0) o.trials = a.trials;
  if (!a.visibilities.empty()) o.visibilities = a.visibilities;
  if (a.duration > 0) o.duration = a.duration;
  o.nozzle = !a.no_nozzle;
  o.self_filter = a.self_filter;
  o.seed = a.seed;
  return o;
}

SpeedOptions speedOptions(const Args& a, int trials) {
  SpeedOptions o;
  if (trials > 0) o.trials = trials;
  if (!a.visibilities.empty()) o.visibilities = a.visibilities;
  o.seed = a.seed;
  return o;
}

#ifdef DEPOWDER_EVAL_MOVING
MovingOptions movingOptions(const Args& a, int trials) {
  MovingOptions o;
  if (trials > 0) o.trials = trials;
  o.self_filter = a.self_filter;
  o.probe_every = a.probe;
  o.motion_oracle = a.motion_oracle;
  if (a.oracle_fraction >= 0) o.motion_oracle_fraction = a.oracle_fraction;
  if (a.push_offset >= 0) o.max_offset_fraction = a.push_offset;
  if (a.push_speed >= 0) {
    o.max_duration *= std::max(1.0, o.push_speed / a.push_speed);  // as far a travel as at the default
    o.push_speed = a.push_speed;
  }
  o.seed = a.seed;
  return o;
}

// The part column: as wide as the longest name (a user's mesh may have a long one), at least 10.
template <class Rows>
int partWidth(const Rows& rows) {
  std::size_t w = 10;
  for (const auto& row : rows) w = std::max(w, row.part.size());
  return static_cast<int>(w);
}

void printMoving(const MovingResult& r) {
  const int w = partWidth(r.rows);
  std::printf("%-*s %-11s %5s %8s %12s %12s %9s\n", w, "part", "method", "vis", "success", "final deg", "final cm",
              "moved cm");
  for (const MovingRow& row : r.rows)
    std::printf("%-*s %-11s %4.0f%% %7.0f%% %12.2f %12.3f %9.1f\n", w, row.part.c_str(), row.method.c_str(),
                row.visibility * 100, row.success * 100, row.final_rot_err_deg, row.final_trans_err_cm, row.moved_cm);
  // Overall per method, over all the pushes, with the rate's 95 % interval (5 pushes a part leave it wide).
  std::vector<std::string> methods;
  for (const MovingRow& row : r.rows)
    if (std::find(methods.begin(), methods.end(), row.method) == methods.end()) methods.push_back(row.method);
  for (const std::string& m : methods) {
    double successes = 0, pushes = 0;
    int flagged[2] = {0, 0};  // pushes the tracker no longer called tracking at the end: failed, followed
    for (const MovingRow& row : r.rows)
      if (row.method == m)
        for (std::size_t i = 0; i < row.trial_success.size(); ++i) {
          successes += row.trial_success[i];
          pushes += 1;
          flagged[row.trial_success[i] ? 1 : 0] += row.trial_final_status[i] != "tracking";
        }
    const auto [lo, hi] = wilsonInterval(successes, pushes);
    std::printf(
        "%-*s %-11s %.0f of %.0f pushes: %.0f %% (95 %% interval %.0f to %.0f %%); lost or degraded "
        "at the end: %d of the %.0f failed, %d of the %.0f followed\n",
        w, "overall", m.c_str(), successes, pushes, 100 * successes / pushes, 100 * lo, 100 * hi, flagged[0],
        pushes - successes, flagged[1], successes);
  }
  // Each failed push, numbered as --trace numbers its trials: how the push moved the part tells
  // why (a large turn or a tip), and the trace of that trial shows when the estimate left it.
  for (const MovingRow& row : r.rows)
    for (std::size_t i = 0; i < row.trial_success.size(); ++i)
      if (!row.trial_success[i])
        std::printf(
            "failed %s %s trial %zu: moved %.1f cm, turned %.0f deg, tipped %.0f deg (%s), visibility %.0f %% at "
            "its lowest; final %.1f deg / %.2f cm, reported %s\n",
            row.part.c_str(), row.method.c_str(), i, row.trial_moved_cm[i], row.trial_turned_deg[i],
            row.trial_tilt_deg[i], row.trial_outcome[i].c_str(), 100 * row.trial_min_visibility[i],
            row.trial_final_rot_err_deg[i], row.trial_final_trans_err_cm[i], row.trial_final_status[i].c_str());
  for (const MovingRow& row : r.rows)
    if (!row.probe_rot_err_deg.empty())
      std::printf("probe %-*s %-11s %4zu fits from the truth: %.2f deg (p90 %.2f), %.3f cm\n", w, row.part.c_str(),
                  row.method.c_str(), row.probe_rot_err_deg.size(), row.probe_rot_mean_deg, row.probe_rot_p90_deg,
                  row.probe_trans_mean_cm);
}
#endif

Json setsJson(const Args& a) {
  Json j = Json::object();
  for (const auto& [key, value] : a.sets) j.set(key, value);
  return j;
}

void save(const std::string& path, Json doc, const Args& a) {
  if (path.empty()) return;
  doc.set("tracker_set", setsJson(a));
  writeJsonFile(path, doc);
  std::cerr << "depowder-eval: wrote " << path << "\n";
}

const char* kMovingNote =
    "**Not reproduced yet.** Pushing a part through powder with the arm needs the simulator's rigid-body "
    "physics (contact, friction, the powder's support and drag: issue 4), which was not in the committed "
    "sim/ when this report was made. Scripted poses pretending to be a push would measure something else, "
    "so this table holds only the paper's figures until `depowder-eval moving` exists.";

std::string defaultNotesPath() {
#ifdef DEPOWDER_SOURCE_DIR
  return std::string(DEPOWDER_SOURCE_DIR) + "/tools/eval/report_notes.md";
#else
  return "tools/eval/report_notes.md";
#endif
}

std::string readText(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "r");
  if (!f) return "";
  std::string text;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) text.append(buf, n);
  std::fclose(f);
  return text;
}

void printStatic(const StaticResult& r) {
  const int w = partWidth(r.rows);
  std::printf("%-*s %-11s %5s %9s %9s %9s %8s %8s %7s\n", w, "part", "method", "vis", "R_err deg", "tilt deg",
              "t_err cm", "tracked", "updates", "ms");
  for (const StaticRow& row : r.rows)
    std::printf("%-*s %-11s %4.0f%% %9.2f %9.2f %9.3f %8.2f %8.1f %7.2f\n", w, row.part.c_str(), row.method.c_str(),
                row.visibility * 100, row.rot_err_deg, row.tilt_err_deg, row.trans_err_cm, row.tracked_fraction,
                row.template_updates, row.track_ms);
}

void printSpeed(const SpeedResult& r) {
  const int w = partWidth(r.rows);
  std::printf("%-*s %-11s %5s %14s %14s\n", w, "part", "method", "vis", "max cm/s", "max deg/s");
  for (const SpeedRow& row : r.rows)
    std::printf("%-*s %-11s %4.0f%% %14.1f %14.1f\n", w, row.part.c_str(), row.method.c_str(), row.visibility * 100,
                row.max_trans_speed_cm_s, row.max_rot_speed_deg_s);
}

int run(const Args& a) {
  node::installShutdownHandlers();
  if (a.command == "report" && !a.from.empty()) {
    const Json doc = readJsonFile(a.from);
    ReportInputs in{doc.at("static"),
                    doc.at("speed"),
                    doc.has("moving") ? doc.at("moving") : Json(),
                    kMovingNote,
                    doc.at("command").string(),
                    readText(a.notes.empty() ? defaultNotesPath() : a.notes)};
    for (const std::string& f : writeReport(in, a.out)) std::cerr << "depowder-eval: wrote " << f << "\n";
    return 0;
  }
  EvalCell cell = loadEvalCell(a.cell);
  for (const auto& [key, value] : a.sets) tracker::setField(cell.tracker, key, value);
  const std::vector<EvalPart> parts = partsOf(a);
  const std::unique_ptr<std::ofstream> trace = openTrace(a);
  bool interrupted = false;
  if (a.command == "static") {
    ProgressBar bar("static", !a.quiet);
    const StaticOptions o = staticOptions(a);
    const StaticResult r = runStatic(cell, parts, a.methods, o, control(bar, trace.get()));
    bar.finish();
    printStatic(r);
    save(a.json, toJson(r, o), a);
    interrupted = r.interrupted;
  } else if (a.command == "speed") {
    ProgressBar bar("speed", !a.quiet);
    const SpeedOptions o = speedOptions(a, a.trials);
    const SpeedResult r = runSpeed(cell, parts, a.methods, o, control(bar));
    bar.finish();
    printSpeed(r);
    save(a.json, toJson(r, o), a);
    interrupted = r.interrupted;
#ifdef DEPOWDER_EVAL_MOVING
  } else if (a.command == "moving") {
    ProgressBar bar("moving", !a.quiet);
    const MovingOptions o = movingOptions(a, a.trials);
    const MovingResult r = runMoving(cell, parts, a.methods, o, control(bar, trace.get()));
    bar.finish();
    printMoving(r);
    save(a.json, toJson(r, o), a);
    interrupted = r.interrupted;
#endif
  } else if (a.command == "report") {
    const StaticOptions so = staticOptions(a);
    const SpeedOptions po = speedOptions(a, a.speed_trials);
    StaticResult sr;
    SpeedResult pr;
#ifdef DEPOWDER_EVAL_MOVING
    const std::string of = "/3 ";
#else
    const std::string of = "/2 ";
#endif
    {
      ProgressBar bar("report 1" + of + "static", !a.quiet);
      sr = runStatic(cell, parts, a.methods, so, control(bar));
    }
    printStatic(sr);
    if (!sr.interrupted) {
      ProgressBar bar("report 2" + of + "speed", !a.quiet);
      pr = runSpeed(cell, parts, a.methods, po, control(bar));
    }
    printSpeed(pr);
    interrupted = sr.interrupted || pr.interrupted;
    Json moving_doc;
#ifdef DEPOWDER_EVAL_MOVING
    const MovingOptions mo = movingOptions(a, a.moving_trials);
    MovingResult mr;
    if (!interrupted) {
      ProgressBar bar("report 3" + of + "moving", !a.quiet);
      mr = runMoving(cell, parts, a.methods, mo, control(bar));
      printMoving(mr);
      interrupted = mr.interrupted;
      moving_doc = toJson(mr, mo);
    }
#endif
    const Json static_doc = toJson(sr, so);
    const Json speed_doc = (sr.interrupted && pr.rows.empty()) ? Json() : toJson(pr, po);
    Json doc = Json::object();
    doc.set("experiment", "report");
    doc.set("seed", a.seed);
    doc.set("command", a.command_line);
    doc.set("interrupted", interrupted);
    doc.set("static", static_doc);
    doc.set("speed", speed_doc);
    doc.set("moving", moving_doc);
    save(a.json, doc, a);
    ReportInputs in{static_doc,  speed_doc,      moving_doc,
                    kMovingNote, a.command_line, readText(a.notes.empty() ? defaultNotesPath() : a.notes)};
    for (const std::string& f : writeReport(in, a.out)) std::cerr << "depowder-eval: wrote " << f << "\n";
  } else {
    return usage("unknown command '" + a.command + "'");
  }
  if (interrupted) {
    std::cerr << "depowder-eval: interrupted; the results above (and in the JSON) cover the finished trials\n";
    return 130;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage("missing command");
  const std::string cmd = argv[1];
  if (cmd == "--help" || cmd == "-h" || cmd == "help") return usage();
#ifndef DEPOWDER_EVAL_MOVING
  if (cmd == "moving")
    return usage(
        "moving (Table II) needs the simulator's rigid-body physics (pushing through powder), which this build of "
        "sim/ does not have");
#endif
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::cerr << "depowder-eval: " << e.what() << "\n";
    return 2;
  }
}
