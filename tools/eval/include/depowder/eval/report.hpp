// docs/results.md and its plots from the experiments' JSON documents: tables laid out like the
// paper's (Table I, Table II, Fig. 10) with the paper's own figures beside ours.
#pragma once

#include <string>
#include <vector>

#include "depowder/eval/json.hpp"

namespace depowder::eval {

struct ReportInputs {
  Json static_doc;          ///< toJson(StaticResult) (null: not run)
  Json speed_doc;           ///< toJson(SpeedResult) (null: not run)
  Json moving_doc;          ///< toJson(MovingResult) (null: not run)
  std::string moving_note;  ///< why Table II was not reproduced (empty: nothing said)
  std::string command;      ///< the command that produced the documents
  std::string notes;        ///< markdown appended verbatim (the analysis written by hand)
};

/// The paper's Table I: errors of `method` ("cu", "continuous", "vanilla") on `part` (or
/// "overall") at `visibility` (0.2..1.0). NaN where the paper has no figure.
double paperRotErrDeg(const std::string& method, const std::string& part, double visibility);
double paperTransErrCm(const std::string& method, const std::string& part, double visibility);
/// The paper's Table II success rate (%), NaN if unknown.
double paperSuccessPercent(const std::string& method, const std::string& part);

/// `command` without the flags that only say where output goes (--json, --out, --notes, --from
/// and their values, --quiet): what reproduces the figures, with the report written to docs/.
std::string reproduceCommand(const std::string& command);

/// The whole results.md text; `images` are the PNG names (relative to results.md) to show.
std::string reportMarkdown(const ReportInputs& in, const std::vector<std::string>& images);

/// Writes `dir`/results.md and the plots (eval_static.png, eval_speed.png) with gnuplot.
/// Returns the files written. A missing gnuplot leaves the plots out (said in the text) rather
/// than failing. Throws JsonError if a document lacks a field the tables need.
std::vector<std::string> writeReport(const ReportInputs& in, const std::string& dir);

}  // namespace depowder::eval
