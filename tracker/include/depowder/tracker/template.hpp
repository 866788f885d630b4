// The template P_tmpl (Alg. 2) and the per-frame scan crop. A template is a list of
// indices into the part's CAD samples, so it lives in the part frame and keeps the
// CAD normals that point-to-plane ICP uses.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/tracker/scan_index.hpp"

namespace depowder::tracker {

using Indices = std::vector<std::uint32_t>;

/// Alg. 2: the CAD samples (part frame) whose nearest scan point is closer than `xi` (m)
/// when the CAD model is at `T_cell_part` (lines 3-6), the scan indexed in `scan`.
Indices deriveTemplate(const Cloud& cad_points, const Pose& T_cell_part, const ScanIndex& scan, double xi);

/// One index per occupied `leaf` voxel (part frame): the first of `indices` in that voxel,
/// ordered by voxel (z, y, x) for locality. leaf <= 0 returns `indices` unchanged.
Indices thinned(const Cloud& cad_points, const Indices& indices, double leaf);

/// All indices 0..n-1 (Vanilla ICP's template: the whole CAD model, Strategy 1).
Indices allIndices(std::size_t n);

/// The finite points of `scan` that lie in `box_part` (a part-frame box) grown by `margin`
/// (m) when the part is at `T_cell_part`. Appends to `out` (cleared first). Returns the
/// number of non-finite points met.
std::size_t cropToPart(const Cloud& scan, const Pose& T_cell_part, const Eigen::AlignedBox3d& box_part, double margin,
                       Cloud& out);

/// A normal (cell frame) facing up within 45 deg: the faces and scan points the powder tests treat
/// as horizontal (the cover test below, the tracker's powder points).
inline bool facesUp(const Eigen::Vector3d& n) { return n.z() >= M_SQRT1_2; }

/// The powder's height around a part, from the powder points of Eq. 2's contour band (cell
/// frame): at an xy, the median height of the band points within `radius` (2-D), or the band's
/// mean height where fewer than 3 are that near.
class PowderHeights {
 public:
  PowderHeights() = default;
  PowderHeights(const Cloud& band, double mean_height, double radius);
  bool empty() const { return heights_.empty(); }
  double at(const Eigen::Vector2d& xy) const;

 private:
  ScanIndex flat_;               ///< the band points at z = 0
  std::vector<double> heights_;  ///< their heights, in the index's order
  double mean_ = 0, radius_ = 0;
  mutable std::vector<double> z_;
};

/// The template points ICP can use this frame (part frame, with normals): those facing at least one
/// of `viewpoints` (back-face culling; none: no culling) and, if `powder` is not empty, not below
/// the powder around them by more than `margin` (m) at pose T_cell_part, and, if `scan` is given
/// and `cover` > 0, not facing up (within 45 deg) with a scan point straight above them (within 4
/// mm in plan) `cover` to `cover` + 12 mm higher: a face under that much powder. Clears the
/// outputs first.
void visibleTemplate(const Cloud& points, const Cloud& normals, const Pose& T_cell_part,
                     const std::vector<Point>& viewpoints, const PowderHeights& powder, double margin,
                     const ScanIndex* scan, double cover, Cloud& out_points, Cloud& out_normals);

/// Gathers points[indices].
Cloud gather(const Cloud& points, const Indices& indices);

}  // namespace depowder::tracker
