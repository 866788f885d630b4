#include "depowder/eval/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "depowder/stats.hpp"

namespace depowder::eval {

namespace {

const std::vector<std::string> kMethods{"cu", "continuous", "vanilla"};
const std::vector<std::string> kPaperParts{"cube", "cup", "propeller", "owl", "pipe", "overall"};

// Whether a run had the camera proxy remove the nozzle's points (--self-filter; older runs: no).
bool selfFiltered(const Json& options) { return options.has("self_filter") && options.at("self_filter").boolean(); }

std::string methodTitle(const std::string& m) {
  if (m == "cu") return "CU-ICP";
  if (m == "continuous") return "Continuous ICP";
  if (m == "vanilla") return "Vanilla ICP";
  return m;
}

// Paper Table I, rows cube, cup, propeller, owl, pipe, overall; 20..100 %.
struct PaperRows {
  double rot[6][5];
  double trans[6][5];
};
const std::map<std::string, PaperRows> kTable1{{"cu",
                                                {{{16.8, 1.69, 0.73, 2.87, 4.29},
                                                  {3.85, 4.05, 3.76, 3.06, 5.03},
                                                  {6.60, 2.62, 2.12, 2.26, 2.45},
                                                  {47.9, 1.55, 12.4, 16.4, 5.85},
                                                  {19.6, 8.53, 6.74, 5.35, 3.93},
                                                  {19.0, 3.69, 5.15, 5.99, 4.31}},
                                                 {{1.05, 0.15, 0.19, 0.28, 0.35},
                                                  {0.94, 1.07, 0.68, 0.67, 0.60},
                                                  {0.83, 0.39, 0.36, 0.15, 0.19},
                                                  {2.20, 1.55, 0.66, 0.80, 0.40},
                                                  {1.17, 0.30, 0.38, 0.32, 0.34},
                                                  {1.24, 0.69, 0.45, 0.44, 0.38}}}},
                                               {"continuous",
                                                {{{16.8, 3.76, 1.80, 3.77, 4.46},
                                                  {50.3, 36.1, 34.3, 13.4, 5.66},
                                                  {11.1, 12.7, 4.04, 12.7, 10.8},
                                                  {74.0, 39.1, 12.3, 26.7, 7.01},
                                                  {55.5, 29.7, 18.5, 6.79, 4.16},
                                                  {41.5, 24.3, 14.2, 12.7, 6.42}},
                                                 {{1.38, 0.22, 0.24, 0.27, 0.35},
                                                  {6.54, 2.08, 1.13, 0.85, 0.79},
                                                  {4.14, 2.88, 1.70, 0.70, 0.49},
                                                  {4.79, 2.66, 0.79, 1.31, 0.42},
                                                  {2.32, 1.25, 1.38, 0.60, 0.38},
                                                  {3.83, 1.82, 1.05, 0.75, 0.49}}}},
                                               {"vanilla",
                                                {{{18.1, 3.52, 2.43, 3.49, 4.49},
                                                  {42.0, 36.3, 36.0, 13.3, 5.80},
                                                  {10.4, 7.61, 4.47, 16.9, 16.2},
                                                  {75.1, 69.9, 27.0, 28.9, 6.75},
                                                  {57.2, 30.0, 18.9, 6.86, 4.25},
                                                  {40.6, 29.5, 17.8, 13.9, 7.50}},
                                                 {{1.41, 0.23, 0.27, 0.30, 0.35},
                                                  {2.94, 2.04, 1.15, 0.91, 0.80},
                                                  {4.02, 2.85, 1.78, 0.62, 0.44},
                                                  {4.91, 4.64, 1.69, 1.40, 0.41},
                                                  {2.38, 1.30, 1.14, 0.61, 0.38},
                                                  {3.13, 2.21, 1.21, 0.77, 0.48}}}}};
// Paper Table II: cube, cup, propeller, owl, pipe, overall.
const std::map<std::string, std::vector<double>> kTable2{{"cu", {100, 80, 100, 100, 80, 92}},
                                                         {"continuous", {100, 0, 40, 100, 20, 52}},
                                                         {"vanilla", {60, 0, 0, 100, 0, 32}}};

/// The paper's "overall" is the mean of its five parts: a run's overall is compared with it only
/// when the run's parts are those five.
bool thePapersParts(std::vector<std::string> parts) {
  std::vector<std::string> paper(kPaperParts.begin(), kPaperParts.end() - 1);  // without "overall"
  std::sort(parts.begin(), parts.end());
  std::sort(paper.begin(), paper.end());
  return parts == paper;
}

int partIndex(const std::string& part) {
  const auto it = std::find(kPaperParts.begin(), kPaperParts.end(), part);
  return it == kPaperParts.end() ? -1 : static_cast<int>(it - kPaperParts.begin());
}
int visIndex(double v) {
  const double k = v * 5 - 1;
  const int i = static_cast<int>(std::lround(k));
  return std::abs(k - i) < 1e-6 && i >= 0 && i < 5 ? i : -1;
}

std::string fmt(double v, int decimals = 2) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  // Three significant figures as the paper prints them (19.0, 3.69, 0.45).
  if (decimals < 0) decimals = std::abs(v) >= 10 ? 1 : 2;
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
std::string pct(double v) { return std::to_string(static_cast<int>(std::lround(v * 100))) + " %"; }

/// Rows of a document, indexed by (part, method, visibility in permille).
using Key = std::tuple<std::string, std::string, long>;
std::map<Key, const Json*> indexRows(const Json& doc) {
  std::map<Key, const Json*> out;
  for (const Json& r : doc.at("rows").elements())
    out[{r.at("part").string(), r.at("method").string(), std::lround(r.at("visibility").number() * 1000)}] = &r;
  return out;
}
std::vector<std::string> partsOf(const Json& doc) {
  std::vector<std::string> out;
  for (const Json& r : doc.at("rows").elements())
    if (std::find(out.begin(), out.end(), r.at("part").string()) == out.end()) out.push_back(r.at("part").string());
  return out;
}
std::vector<std::string> methodsOf(const Json& doc) {
  std::set<std::string> seen;
  for (const Json& r : doc.at("rows").elements()) seen.insert(r.at("method").string());
  std::vector<std::string> out;
  for (const std::string& m : kMethods)
    if (seen.count(m)) out.push_back(m);
  for (const std::string& m : seen)
    if (std::find(out.begin(), out.end(), m) == out.end()) out.push_back(m);
  return out;
}
std::vector<double> visibilitiesOf(const Json& doc) {
  std::set<long> seen;
  for (const Json& r : doc.at("rows").elements()) seen.insert(std::lround(r.at("visibility").number() * 1000));
  std::vector<double> out;
  for (long v : seen) out.push_back(v / 1000.0);
  return out;
}

/// Mean of `field` over `parts` (NaN if any part lacks the row: an overall needs every part).
double overall(const std::map<Key, const Json*>& rows, const std::vector<std::string>& parts, const std::string& method,
               double vis, const std::string& field) {
  double sum = 0;
  for (const std::string& p : parts) {
    const auto it = rows.find({p, method, std::lround(vis * 1000)});
    if (it == rows.end()) return std::nan("");
    sum += it->second->at(field).number();
  }
  return parts.empty() ? std::nan("") : sum / parts.size();
}
double value(const std::map<Key, const Json*>& rows, const std::vector<std::string>& parts, const std::string& part,
             const std::string& method, double vis, const std::string& field) {
  if (part == "overall") return overall(rows, parts, method, vis, field);
  const auto it = rows.find({part, method, std::lround(vis * 1000)});
  return it == rows.end() ? std::nan("") : it->second->at(field).number();
}

/// The run's eta1 (Eq. 1), as the set-up text says it: 0 unless the run set another.
std::string eta1Text(const Json& opt) {
  const double eta1 = opt.has("eta1") ? opt.at("eta1").number() : 0.0;
  if (eta1 == 0) return "eta1 = 0: ICP runs at every visibility, since the paper reports errors at 20 % too";
  return "eta1 = " + fmt(eta1) + " (set for this run): below that visibility the tracker holds its pose without ICP";
}

std::string staticSection(const Json& doc) {
  std::ostringstream md;
  const auto rows = indexRows(doc);
  const std::vector<std::string> parts = partsOf(doc), methods = methodsOf(doc);
  const std::vector<double> vis = visibilitiesOf(doc);
  std::vector<std::string> row_parts = parts;
  if (parts.size() > 1) row_parts.push_back("overall");
  const bool papers_overall = thePapersParts(parts);
  const Json& opt = doc.at("options");

  md << "## Table I: pose tracking error of a static part at each surface visibility\n\n";
  md << "Each cell: **ours** (paper). Mean over every frame of every trial; " << opt.at("trials").number()
     << " seeded trials per part and visibility, " << fmt(opt.at("duration_s").number(), 1)
     << " s of 30 fps frames each. Bold: the best of the three methods in our run for that part and visibility. "
        "\"overall\" is the mean of the part rows, as in the paper.\n\n";
  md << "Set-up per trial: the part upright at a seeded yaw, within " << fmt(opt.at("max_offset_m").number() * 100, 0)
     << " cm of the box centre, the powder dug to the visibility (the simulator's Eq. 2 eta); "
     << (opt.at("nozzle").boolean()
             ? "the nozzle (tool off) circling it " + fmt(opt.at("nozzle_standoff_m").number() * 100, 0) +
                   " cm off its bounding box, tip " + fmt(opt.at("nozzle_above_top_m").number() * 100, 0) +
                   " cm above its top, leaning " + fmt(opt.at("nozzle_tilt_deg").number(), 0) + " deg, one lap per " +
                   fmt(opt.at("nozzle_period_s").number(), 1) + " s" +
                   (selfFiltered(opt) ? " (occlusion only: the camera proxy's self-filter removes its points); "
                                      : " (occlusion and interference, paper Fig. 7); ")
             : "no nozzle; ")
     << "the tracker starts from the true pose with a seeded error of up to "
     << fmt(opt.at("init_trans_max_m").number() * 1000, 0) << " mm and " << fmt(opt.at("init_rot_max_deg").number(), 0)
     << " deg (random direction and axis), the same for every method. The cell file's settings (--cell, "
        "default config/cell.yaml: its sim, perception and tracker sections) except "
     << eta1Text(opt) << ".\n\n";
  md << "| Method | Part |";
  for (double v : vis) md << " R " << pct(v) << " |";
  for (double v : vis) md << " t " << pct(v) << " |";
  md << "\n|---|---|";
  for (std::size_t i = 0; i < 2 * vis.size(); ++i) md << "---|";
  md << "\n";
  for (const std::string& m : methods) {
    for (const std::string& p : row_parts) {
      md << "| " << (p == row_parts.front() ? methodTitle(m) : "") << " | " << p << " |";
      for (const char* field : {"rot_err_deg", "trans_err_cm"}) {
        const bool rot = std::string(field) == "rot_err_deg";
        for (double v : vis) {
          const double ours = value(rows, parts, p, m, v, field);
          double best = INFINITY;
          for (const std::string& other : methods) best = std::min(best, value(rows, parts, p, other, v, field));
          const double paper = p == "overall" && !papers_overall ? std::nan("")
                               : rot                             ? paperRotErrDeg(m, p, v)
                                                                 : paperTransErrCm(m, p, v);
          const std::string o = fmt(ours, -1);
          md << " " << (methods.size() > 1 && ours <= best ? "**" + o + "**" : o);
          if (std::isfinite(paper)) md << " (" << fmt(paper, -1) << ")";
          md << " |";
        }
      }
      md << "\n";
    }
  }
  md << "\nR: rotation error (deg); t: translation error (cm).\n\n";

  // What else the trackers did, overall per method and visibility.
  md << "Per method, mean over parts: tilt error (the angle between the estimated and true part z axes, i.e. the "
        "rotation error without the spin about the part's own vertical axis, which a rotationally symmetric visible "
        "portion cannot show), fraction of frames TRACKING (the rest DEGRADED, or LOST: pose kept), "
        "template derivations per trial (Alg. 2, the first included), template size (CAD samples) and wall time "
        "of `track()` per frame (shared 2-core machine; a guide only):\n\n";
  md << "| Method | visibility | tilt error (deg) | tracked | lost | template updates / trial | template size | "
        "ms / frame | initial error (deg / cm) |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& m : methods)
    for (double v : vis)
      md << "| " << methodTitle(m) << " | " << pct(v) << " | " << fmt(overall(rows, parts, m, v, "tilt_err_deg"))
         << " | " << fmt(overall(rows, parts, m, v, "tracked_fraction")) << " | "
         << fmt(overall(rows, parts, m, v, "lost_fraction")) << " | "
         << fmt(overall(rows, parts, m, v, "template_updates"), 1) << " | "
         << fmt(overall(rows, parts, m, v, "template_size"), 0) << " | " << fmt(overall(rows, parts, m, v, "track_ms"))
         << " | " << fmt(overall(rows, parts, m, v, "init_rot_err_deg")) << " / "
         << fmt(overall(rows, parts, m, v, "init_trans_err_cm")) << " |\n";
  md << "\n";
  return md.str();
}

std::string speedSection(const Json& doc) {
  std::ostringstream md;
  const auto rows = indexRows(doc);
  const std::vector<std::string> parts = partsOf(doc), methods = methodsOf(doc);
  const std::vector<double> vis = visibilitiesOf(doc);
  const Json& opt = doc.at("options");
  auto list = [](const Json& a) {
    std::string s;
    for (const Json& v : a.elements()) s += (s.empty() ? "" : ", ") + fmt(v.number(), 0);
    return s;
  };
  md << "## Fig. 10: maximum trackable speed\n\n";
  md << "Highest speed of the increasing list still tracked (final error within "
     << fmt(opt.at("success_rot_deg").number(), 0) << " deg and " << fmt(opt.at("success_trans_m").number() * 1000, 0)
     << " mm, Table II's success), mean over " << opt.at("trials").number()
     << " seeded trials. Translation: linear actuator along x over " << fmt(opt.at("linear_travel_m").number() * 100, 0)
     << " cm, speeds " << list(opt.at("trans_speeds_cm_s")) << " cm/s; rotation: turntable about the part's vertical "
     << "axis over " << fmt(opt.at("turntable_travel_deg").number(), 0) << " deg, speeds "
     << list(opt.at("rot_speeds_deg_s"))
     << " deg/s. 0 means even the slowest was lost. The paper gives these only as a plot (its Fig. 10b), "
        "so no figures of its own stand beside ours.\n\n";
  md << "| Method | Part |";
  for (double v : vis) md << " v " << pct(v) << " (cm/s) |";
  for (double v : vis) md << " w " << pct(v) << " (deg/s) |";
  md << "\n|---|---|";
  for (std::size_t i = 0; i < 2 * vis.size(); ++i) md << "---|";
  md << "\n";
  std::vector<std::string> row_parts = parts;
  if (parts.size() > 1) row_parts.push_back("overall");
  for (const std::string& m : methods)
    for (const std::string& p : row_parts) {
      md << "| " << (p == row_parts.front() ? methodTitle(m) : "") << " | " << p << " |";
      for (const char* field : {"max_trans_speed_cm_s", "max_rot_speed_deg_s"})
        for (double v : vis) {
          const double ours = value(rows, parts, p, m, v, field);
          double best = -INFINITY;
          for (const std::string& other : methods) best = std::max(best, value(rows, parts, p, other, v, field));
          const std::string o = fmt(ours, 1);
          md << " " << (methods.size() > 1 && ours >= best ? "**" + o + "**" : o) << " |";
        }
      md << "\n";
    }
  md << "\nv: translation speed; w: rotation speed. Bold: the best of the three methods.\n\n";
  return md.str();
}

/// Cells where CU-ICP is not the best method (by more than a small margin), for the text.
std::string movingShortfalls(const Json& doc);

std::string shortfalls(const Json& static_doc, const Json& speed_doc, const Json& moving_doc) {
  std::ostringstream md;
  int n = 0;
  if (!moving_doc.isNull()) {
    const std::string m = movingShortfalls(moving_doc);
    md << m;
    n += static_cast<int>(std::count(m.begin(), m.end(), '\n'));
  }
  if (!static_doc.isNull()) {
    const auto rows = indexRows(static_doc);
    const std::vector<std::string> parts = partsOf(static_doc), methods = methodsOf(static_doc);
    for (const std::string& p : parts)
      for (double v : visibilitiesOf(static_doc))
        for (const auto& [field, unit, margin] :
             {std::tuple<std::string, std::string, double>{"rot_err_deg", "deg", 0.2}, {"trans_err_cm", "cm", 0.02}}) {
          const double cu = value(rows, parts, p, "cu", v, field);
          for (const std::string& m : methods) {
            if (m == "cu") continue;
            const double other = value(rows, parts, p, m, v, field);
            if (std::isfinite(cu) && std::isfinite(other) && cu > other * 1.1 && cu - other > margin) {
              md << "- static, " << p << " at " << pct(v) << ": " << methodTitle(m) << " " << fmt(other, -1) << " "
                 << unit << " vs CU-ICP " << fmt(cu, -1) << " " << unit << "\n";
              ++n;
            }
          }
        }
  }
  if (!speed_doc.isNull()) {
    const auto rows = indexRows(speed_doc);
    const std::vector<std::string> parts = partsOf(speed_doc), methods = methodsOf(speed_doc);
    for (const std::string& p : parts)
      for (double v : visibilitiesOf(speed_doc))
        for (const auto& [field, unit] :
             {std::pair<std::string, std::string>{"max_trans_speed_cm_s", "cm/s"}, {"max_rot_speed_deg_s", "deg/s"}}) {
          const double cu = value(rows, parts, p, "cu", v, field);
          for (const std::string& m : methods) {
            if (m == "cu") continue;
            const double other = value(rows, parts, p, m, v, field);
            if (std::isfinite(cu) && std::isfinite(other) && other > cu) {
              md << "- speed, " << p << " at " << pct(v) << ": " << methodTitle(m) << " " << fmt(other, 1) << " "
                 << unit << " vs CU-ICP " << fmt(cu, 1) << " " << unit << "\n";
              ++n;
            }
          }
        }
  }
  if (n == 0) return "None: CU-ICP is the best method (or within the margin) in every cell of this run.\n";
  return "Cells where a baseline beats CU-ICP (static: by more than 10 % and 0.2 deg / 0.02 cm; speed and moving: "
         "any):\n\n" +
         md.str();
}

std::string movingSection(const Json& doc, const std::string& note) {
  std::ostringstream md;
  md << "## Table II: success rate (%) of tracking parts pushed through powder\n\n";
  if (doc.isNull()) {
    md << "| Method | Cube | Cup | Propeller | Owl | Pipe | Overall |\n|---|---|---|---|---|---|---|\n";
    for (const std::string& m : kMethods) {
      md << "| " << methodTitle(m) << " (paper) |";
      for (const std::string& p : kPaperParts) md << " " << fmt(paperSuccessPercent(m, p), 0) << " |";
      md << "\n";
    }
    md << "\n" << (note.empty() ? "Not reproduced in this run." : note) << "\n\n";
    return md.str();
  }
  if (doc.at("interrupted").boolean()) md << "**This run was interrupted: the moving rows are partial.**\n\n";
  const auto rows = indexRows(doc);
  std::vector<std::string> parts = partsOf(doc);
  const std::vector<std::string> methods = methodsOf(doc);
  const Json& opt = doc.at("options");
  // Rows carry their mean initial visibility; look them up by part and method only.
  std::map<std::pair<std::string, std::string>, const Json*> by;
  for (const Json& r : doc.at("rows").elements()) by[{r.at("part").string(), r.at("method").string()}] = &r;
  const double push_cm_s = opt.at("push_speed_m_s").number() * 100;
  md << "Each cell: **ours** (paper). " << opt.at("trials").number()
     << " seeded pushes per part: a contact point on the part (azimuth, a height within "
     << fmt(50 * (opt.has("contact_band") ? opt.at("contact_band").number() : std::nan("")), 0)
     << " % of the part's height of its centre of mass's, sideways offset) and an initial visibility in ["
     << pct(opt.at("min_visibility").number()) << ", " << pct(opt.at("max_visibility").number())
     << "]; the nozzle pushes at " << fmt(push_cm_s, push_cm_s == std::round(push_cm_s) ? 0 : 1)
     << " cm/s until the part reaches the box wall (sim/push.hpp, rigid-body physics). Success: final error within "
     << fmt(opt.at("success_rot_deg").number(), 0) << " deg and " << fmt(opt.at("success_trans_m").number() * 1000, 0)
     << " mm. Overall: the mean of the parts, with in brackets the 95 % Wilson interval of the rate over all their"
        " pushes (the paper's 92 % is 23 of 25 pushes: [75, 98])."
     << (selfFiltered(opt)
             ? " The camera proxy's self-filter removes the nozzle's points, as in the cell."
             : " The pushing nozzle stays in the scan (the cell's camera proxy removes it: --self-filter).")
     << "\n\n";
  md << "| Method |";
  for (const std::string& p : parts) md << " " << p << " |";
  md << " Overall |\n|---|";
  for (std::size_t i = 0; i <= parts.size(); ++i) md << "---|";
  md << "\n";
  for (const std::string& m : methods) {
    md << "| " << methodTitle(m) << " |";
    double sum = 0, successes = 0, pushes = 0;
    for (const std::string& p : parts) {
      const auto it = by.find({p, m});
      const double ours = it == by.end() ? std::nan("") : 100 * it->second->at("success").number();
      sum += ours;
      if (it != by.end() && it->second->has("trials")) {
        const double n = it->second->at("trials").number();
        successes += it->second->at("success").number() * n;
        pushes += n;
      }
      const double paper = paperSuccessPercent(m, p);
      md << " " << fmt(ours, 0) << (std::isfinite(paper) ? " (" + fmt(paper, 0) + ")" : "") << " |";
    }
    const double paper_all = thePapersParts(parts) ? paperSuccessPercent(m, "overall") : std::nan("");
    const auto [lo, hi] = wilsonInterval(std::round(successes), pushes);
    md << " " << fmt(sum / parts.size(), 0) << " [" << fmt(100 * lo, 0) << ", " << fmt(100 * hi, 0) << "]"
       << (std::isfinite(paper_all) ? " (" + fmt(paper_all, 0) + ")" : "") << " |\n";
  }
  md << "\nMean final errors (deg / cm) and how far the pushes took the parts:\n\n| Method |";
  for (const std::string& p : parts) md << " " << p << " |";
  md << "\n|---|";
  for (std::size_t i = 0; i < parts.size(); ++i) md << "---|";
  md << "\n";
  for (const std::string& m : methods) {
    md << "| " << methodTitle(m) << " |";
    for (const std::string& p : parts) {
      const auto it = by.find({p, m});
      if (it == by.end()) {
        md << " - |";
        continue;
      }
      const Json& r = *it->second;
      md << " " << fmt(r.at("final_rot_err_deg").number(), -1) << " / " << fmt(r.at("final_trans_err_cm").number(), -1)
         << " |";
    }
    md << "\n";
  }
  md << "| (part moved cm / turned deg / tipped pushes) |";
  for (const std::string& p : parts) {
    const auto it = by.find({p, methods.front()});
    if (it == by.end()) {
      md << " - |";
      continue;
    }
    const Json& r = *it->second;
    int tipped = 0;  // pushes that tilted the part's vertical axis by more than 15 deg
    if (r.has("trial_tilt_deg"))
      for (const Json& t : r.at("trial_tilt_deg").elements()) tipped += t.number() > 15;
    md << " " << fmt(r.at("moved_cm").number(), 1) << " / " << fmt(r.at("turned_deg").number(), 1) << " / "
       << (r.has("trial_tilt_deg") ? std::to_string(tipped) + " of " + std::to_string(r.at("trial_tilt_deg").size())
                                   : std::string("-"))
       << " |";
  }
  md << "\n\n";
  // Whether the tracker knew: a failed push it still calls tracking is one the cell cannot tell
  // from a good track (runs before this field: nothing said).
  std::ostringstream known;
  for (const std::string& m : methods) {
    int flagged[2] = {0, 0}, count[2] = {0, 0};  // failed, followed
    for (const std::string& p : parts) {
      const auto it = by.find({p, m});
      if (it == by.end() || !it->second->has("trial_final_status")) continue;
      const Json& r = *it->second;
      for (std::size_t i = 0; i < r.at("trial_success").size(); ++i) {
        const int ok = r.at("trial_success").at(i).number() != 0;
        ++count[ok];
        flagged[ok] += r.at("trial_final_status").at(i).string() != "tracking";
      }
    }
    if (count[0] + count[1] == 0) continue;
    known << (known.tellp() > 0 ? "; " : "") << methodTitle(m) << " " << flagged[0] << " of " << count[0]
          << " failed and " << flagged[1] << " of " << count[1] << " followed";
  }
  if (known.tellp() > 0)
    md << "Pushes whose tracker said LOST or DEGRADED at the last frame (the rest it reported as TRACKING): "
       << known.str() << ".\n\n";
  return md.str();
}

std::string movingShortfalls(const Json& doc) {
  if (doc.isNull()) return "";
  std::ostringstream md;
  std::map<std::pair<std::string, std::string>, double> s;
  for (const Json& r : doc.at("rows").elements())
    s[{r.at("part").string(), r.at("method").string()}] = r.at("success").number();
  for (const auto& [key, rate] : s) {
    if (key.second == "cu") continue;
    const auto cu = s.find({key.first, "cu"});
    if (cu != s.end() && rate > cu->second)
      md << "- moving, " << key.first << ": " << methodTitle(key.second) << " " << fmt(100 * rate, 0) << " % vs CU-ICP "
         << fmt(100 * cu->second, 0) << " %\n";
  }
  return md.str();
}

// --- plots ---

bool haveGnuplot() { return std::system("command -v gnuplot > /dev/null 2>&1") == 0; }

/// Dash type and point type per method, so equal curves stay visible on top of each other.
std::string gnuplotStyle(const std::string& m) {
  if (m == "cu") return "lw 3 dt 1 pt 7 ps 1.2";
  if (m == "continuous") return "lw 2 dt 2 pt 5 ps 0.9";
  return "lw 1.5 dt 4 pt 9 ps 0.9";
}

std::string gnuplotColour(const std::string& m) {
  if (m == "cu") return "#c0392b";
  if (m == "continuous") return "#2471a3";
  return "#229954";
}

/// Writes the data and script into `dir`, runs gnuplot, removes the temporary files.
bool runGnuplot(const std::string& dir, const std::string& name, const std::string& data, const std::string& script) {
  const std::string dat = dir + "/." + name + ".dat", gp = dir + "/." + name + ".gp";
  {
    std::ofstream(dat) << data;
    std::ofstream(gp) << "datafile = '" << dat << "'\n" << script;
  }
  const bool ok = std::system(("gnuplot '" + gp + "' > /dev/null 2>&1").c_str()) == 0;
  std::remove(dat.c_str());
  std::remove(gp.c_str());
  return ok;
}

bool plotStatic(const Json& doc, const std::string& dir) {
  const auto rows = indexRows(doc);
  const std::vector<std::string> parts = partsOf(doc), methods = methodsOf(doc);
  const std::string over = parts.size() > 1 ? "overall" : parts.front();
  const bool compare = parts.size() == 1 || thePapersParts(parts);  // the paper's overall is its five parts'
  const double none = std::nan("");
  // Columns: visibility %, then per method ours rot, ours trans, paper rot, paper trans.
  std::ostringstream data;
  for (double v : visibilitiesOf(doc)) {
    data << v * 100;
    for (const std::string& m : methods)
      data << " " << fmt(value(rows, parts, over, m, v, "rot_err_deg"), 4) << " "
           << fmt(value(rows, parts, over, m, v, "trans_err_cm"), 4) << " "
           << fmt(compare ? paperRotErrDeg(m, over, v) : none, 4) << " "
           << fmt(compare ? paperTransErrCm(m, over, v) : none, 4);
    data << "\n";
  }
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1100,420 font 'sans,10'\nset output '" << dir << "/eval_static.png'\n"
     << "set datafile missing '-'\nset multiplot layout 1,2 title 'Table I (" << over
     << "): mean error vs surface visibility; solid: this simulation, dashed: paper'\n"
     << "set xlabel 'visibility (%)'\nset xrange [15:105]\nset xtics 20\nset grid\nset logscale y\n"
     << "set key top right\n";
  for (int panel = 0; panel < 2; ++panel) {
    gp << "set ylabel '" << (panel == 0 ? "rotation error (deg)" : "translation error (cm)") << "'\nplot ";
    for (std::size_t i = 0; i < methods.size(); ++i) {
      const int c = 2 + 4 * static_cast<int>(i) + panel;
      const std::string col = gnuplotColour(methods[i]);
      const std::string solid = methods[i] == "cu"           ? "lw 3 pt 7"
                                : methods[i] == "continuous" ? "lw 2 pt 5"
                                                             : "lw 1.5 pt 9";
      gp << (i ? ", " : "") << "datafile using 1:" << c << " with linespoints " << solid << " lc rgb '" << col
         << "' title '" << methodTitle(methods[i]) << "', datafile using 1:" << c + 2
         << " with linespoints dt 2 pt 6 lc rgb '" << col << "' title '" << methodTitle(methods[i]) << " (paper)'";
    }
    gp << "\n";
  }
  gp << "unset multiplot\n";
  return runGnuplot(dir, "eval_static", data.str(), gp.str());
}

bool plotSpeed(const Json& doc, const std::string& dir) {
  const auto rows = indexRows(doc);
  const std::vector<std::string> parts = partsOf(doc), methods = methodsOf(doc);
  std::ostringstream data;  // one block per part: visibility, then per method trans, rot
  for (const std::string& p : parts) {
    for (double v : visibilitiesOf(doc)) {
      data << v * 100;
      for (const std::string& m : methods)
        data << " " << fmt(value(rows, parts, p, m, v, "max_trans_speed_cm_s"), 3) << " "
             << fmt(value(rows, parts, p, m, v, "max_rot_speed_deg_s"), 3);
      data << "\n";
    }
    data << "\n\n";
  }
  std::ostringstream gp;
  gp << "set terminal pngcairo size " << 260 * parts.size() + 120 << ",620 font 'sans,9'\nset output '" << dir
     << "/eval_speed.png'\nset datafile missing '-'\nset multiplot layout 2," << parts.size()
     << " title 'Fig. 10: maximum trackable speed vs surface visibility'\n"
     << "set xrange [15:105]\nset xtics 20\nset grid\nset key top left\nset yrange [0:*]\n";
  for (int panel = 0; panel < 2; ++panel)
    for (std::size_t k = 0; k < parts.size(); ++k) {
      gp << "set title '" << parts[k] << (panel == 0 ? " translation" : " rotation") << "'\n"
         << "set xlabel 'visibility (%)'\nset ylabel '" << (panel == 0 ? "cm/s" : "deg/s") << "'\n";
      if (k == 0 && panel == 0)
        gp << "set key\n";
      else
        gp << "unset key\n";
      gp << "plot ";
      for (std::size_t i = 0; i < methods.size(); ++i)
        gp << (i ? ", " : "") << "datafile index " << k << " using 1:" << 2 + 2 * i + panel << " with linespoints "
           << gnuplotStyle(methods[i]) << " lc rgb '" << gnuplotColour(methods[i]) << "' title '"
           << methodTitle(methods[i]) << "'";
      gp << "\n";
    }
  gp << "unset multiplot\n";
  return runGnuplot(dir, "eval_speed", data.str(), gp.str());
}

}  // namespace

double paperRotErrDeg(const std::string& method, const std::string& part, double visibility) {
  const auto it = kTable1.find(method);
  const int p = partIndex(part), v = visIndex(visibility);
  return it == kTable1.end() || p < 0 || v < 0 ? std::nan("") : it->second.rot[p][v];
}

double paperTransErrCm(const std::string& method, const std::string& part, double visibility) {
  const auto it = kTable1.find(method);
  const int p = partIndex(part), v = visIndex(visibility);
  return it == kTable1.end() || p < 0 || v < 0 ? std::nan("") : it->second.trans[p][v];
}

double paperSuccessPercent(const std::string& method, const std::string& part) {
  const auto it = kTable2.find(method);
  const int p = partIndex(part);
  return it == kTable2.end() || p < 0 ? std::nan("") : it->second[static_cast<std::size_t>(p)];
}

std::string reproduceCommand(const std::string& command) {
  std::istringstream words(command);
  std::string out, w;
  while (words >> w) {
    if (w == "--quiet") continue;
    if (w == "--json" || w == "--out" || w == "--notes" || w == "--from") {
      words >> w;  // its value
      continue;
    }
    out += (out.empty() ? "" : " ") + w;
  }
  return out;
}

std::string reportMarkdown(const ReportInputs& in, const std::vector<std::string>& images) {
  std::ostringstream md;
  md << "# Evaluation: the paper's experiments in simulation\n\n"
     << "Generated by `depowder-eval report` (tools/eval): the simulator (sim/), the camera proxy (perception/), "
        "the tracker (tracker/) and Eq. 2 (progress/) driven in process, deterministic for the seed. "
        "Every method tracks the same frames in a trial. Reproduce with:\n\n```sh\n"
     << reproduceCommand(in.command) << "\n```\n\n";
  auto has = [&](const std::string& name) { return std::find(images.begin(), images.end(), name) != images.end(); };
  if (!in.static_doc.isNull()) {
    if (in.static_doc.at("interrupted").boolean())
      md << "**This run was interrupted: the static rows are partial.**\n\n";
    md << staticSection(in.static_doc);
    if (has("eval_static.png")) md << "![Table I as a plot](eval_static.png)\n\n";
  }
  md << movingSection(in.moving_doc, in.moving_note);
  if (!in.speed_doc.isNull()) {
    if (in.speed_doc.at("interrupted").boolean()) md << "**This run was interrupted: the speed rows are partial.**\n\n";
    md << speedSection(in.speed_doc);
    if (has("eval_speed.png")) md << "![Fig. 10 as a plot](eval_speed.png)\n\n";
  }
  md << "## Where CU-ICP does not beat the baselines\n\n"
     << shortfalls(in.static_doc, in.speed_doc, in.moving_doc) << "\n";
  if (!in.notes.empty()) md << in.notes << (in.notes.back() == '\n' ? "" : "\n");
  return md.str();
}

std::vector<std::string> writeReport(const ReportInputs& in, const std::string& dir) {
  std::vector<std::string> images, written;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);  // --out may name a directory not made yet
  if (ec) throw JsonError("cannot create the directory " + dir + ": " + ec.message());
  if (haveGnuplot()) {
    if (!in.static_doc.isNull() && in.static_doc.at("rows").size() > 0 && plotStatic(in.static_doc, dir))
      images.push_back("eval_static.png");
    if (!in.speed_doc.isNull() && in.speed_doc.at("rows").size() > 0 && plotSpeed(in.speed_doc, dir))
      images.push_back("eval_speed.png");
  }
  const std::string path = dir + "/results.md";
  std::ofstream out(path);
  if (!out) throw JsonError("cannot write " + path);
  out << reportMarkdown(in, images);
  if (!out) throw JsonError("error writing " + path);
  written.push_back(path);
  for (const std::string& i : images) written.push_back(dir + "/" + i);
  return written;
}

}  // namespace depowder::eval
