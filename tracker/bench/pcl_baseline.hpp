// The authors' tracker, as REFERENCE.md describes their released implementation, for the
// benchmark: point-to-point pcl::IterativeClosestPoint (30 iterations, max correspondence
// distance xi, epsilons 5e-5 in their centimetre units), the scan cropped to +-12 cm around
// the current pose, the template derived and conditionally updated exactly as ours (the
// tracker library's Alg. 2, Eq. 1 and Eq. 2 code), ICP only once eta > eta1.
// PCL stays in pcl_baseline.cpp; this header has none.
#pragma once

#include <memory>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/tracker/config.hpp"

namespace depowder::tracker::bench {

struct PclFrame {
  Pose T_cell_part = Pose::Identity();
  bool converged = false;
  int iterations = 0;      ///< not exposed by pcl::IterativeClosestPoint: 0
  double ms = 0;           ///< wall time of the whole frame
  double register_ms = 0;  ///< wall time of the registration step: crop, conversion, kd-tree and ICP
  double progress_ms = 0;  ///< wall time of the Eq. 2 calls (the same library call as CU-ICP's)
};

class PclTracker {
 public:
  /// `cad` as PartTracker samples it (same spacing, same seed), so both use the same P_cad.
  PclTracker(const SurfaceSamples& cad, const Pose& T_cell_part_init, double xi, const TrackerConfig& config);
  ~PclTracker();
  PclFrame track(const Cloud& scan);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace depowder::tracker::bench
