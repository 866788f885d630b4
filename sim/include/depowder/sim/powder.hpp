// The powder: a height field over the build box interior that the tools change.
//
// Cell (i, j) has its centre at x = -Lx/2 + (i + 0.5) dx, y = -Ly/2 + (j + 0.5) dy (cell
// frame: origin at the floor centre). Each cell stores the powder surface height and a
// floor: the top of the topmost part over the cell centre, or 0 (the box floor). The
// surface never goes below the floor, so powder never stands inside a part; the powder
// over a part is the layer height - floor, and digging beside a part lowers the surface
// there and so exposes the part's side. Powder under a part's overhang is not modelled
// (it is hidden, and stays put while parts are static).
//
// The tools work per step on a disc under the nozzle tip (sim/README.md, "Powder"):
//   vacuum: the surface drops towards (tip z - standoff), but by at most layer_depth per
//           pass (a pass starts when a cell enters the disc), at sink_rate; over a part it
//           stops `residue` above the part's top (the vacuum cannot clean the top);
//   air:    over a part the residue is blown off down to the part's top; elsewhere at most
//           extra_depth per pass is blown away.
// Relaxation moves powder downhill wherever a neighbour is lower than the angle of repose
// allows, conserving volume (the floor is never eroded).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace depowder::sim {

struct PowderConfig {
  double cell_size = 0.003;        ///< m, side of a cell (rounded so whole cells tile the box interior)
  double cover = 0.01;             ///< m of powder above the highest part top at the start (paper Sec. IV)
  double level = -1;               ///< m, initial surface height if >= 0 (then `cover` is ignored)
  double repose_deg = 32;          ///< angle of repose (dry sand 30..35 deg)
  int relax_sweeps = 16;           ///< most relaxation sweeps per step (a sweep moves powder by one cell)
  double relax_tolerance = 1e-6;   ///< m of height above the repose slope that is left alone
  double bare_thickness = 0.0005;  ///< m; a surface within this of the floor is bare (not drawn)
};

struct VacuumConfig {
  double radius = 0.015;       ///< m, radius of the suction disc under the tip (nozzle 2.5 cm diameter)
  double standoff = 0.01;      ///< m below the tip that the suction reaches
  double layer_depth = 0.005;  ///< m, most the surface drops per pass
  double sink_rate = 0.1;      ///< m/s, how fast the surface drops within a pass
  double residue = 0.002;      ///< m of powder the vacuum leaves on a part's top (the air blast removes it)
};

struct AirConfig {
  double radius = 0.03;        ///< m, radius of the blast disc under the tip
  double reach = 0.15;         ///< m; the blast acts when the tip is at most this far above the surface
  double clear_rate = 0.05;    ///< m/s, how fast the residue on a part's top is blown off
  double extra_depth = 0.001;  ///< m, most blown away per pass beside parts
};

class PowderField {
 public:
  /// A flat, empty field over an interior of size_x by size_y (m).
  PowderField(double size_x, double size_y, double cell_size);

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  double dx() const { return dx_; }
  double dy() const { return dy_; }
  double cellArea() const { return dx_ * dy_; }
  std::size_t size() const { return h_.size(); }
  std::size_t index(int i, int j) const { return static_cast<std::size_t>(j) * nx_ + i; }
  Eigen::Vector2d centre(int i, int j) const { return {x0_ + (i + 0.5) * dx_, y0_ + (j + 0.5) * dy_}; }
  /// The cell holding xy; false outside the interior.
  bool cellOf(const Eigen::Vector2d& xy, int& i, int& j) const;

  double height(std::size_t c) const { return h_[c]; }
  double floor(std::size_t c) const { return floor_[c]; }
  bool overPart(std::size_t c) const { return over_part_[c] != 0; }
  const std::vector<double>& heights() const { return h_; }
  const std::vector<double>& floors() const { return floor_; }
  /// Surface height at xy, bilinear between cell centres (clamped at the walls), m.
  double surfaceAt(const Eigen::Vector2d& xy) const;

  /// Replaces the floors (per cell; `over_part` marks cells over a part). Where the surface is
  /// below its new floor it is raised to it (a moving part pushes powder up). Returns that volume, m^3.
  double setFloor(const std::vector<double>& floor, const std::vector<std::uint8_t>& over_part);
  /// Flat surface at `level` (m), never below the floors.
  void fill(double level);
  /// Sets one cell (clamped to its floor).
  void setHeight(std::size_t c, double h);
  /// Powder above the floors, m^3.
  double volume() const;
  /// Incremented whenever a height changes (render caches).
  std::uint64_t version() const { return version_; }

  /// Starts a new simulation step: a cell in a tool's disc this step and the last continues its pass.
  void beginStep() { ++stamp_; }
  /// Vacuum at `tip` (cell frame) for dt seconds. Returns the volume removed, m^3.
  double vacuum(const Eigen::Vector3d& tip, const VacuumConfig& config, double dt);
  /// Air blast from `tip` for dt seconds. Returns the volume blown away, m^3.
  double airBlast(const Eigen::Vector3d& tip, const AirConfig& config, double dt);

  /// Angle-of-repose relaxation: at most `max_sweeps` sweeps over the cells that changed (and
  /// their neighbours). Volume is conserved. Returns the sweeps that moved powder (0: at rest).
  int relax(double repose_deg, int max_sweeps, double tolerance);
  /// Largest height excess (m) of a cell over a neighbour beyond the repose slope (8-neighbours,
  /// slope measured between centres), counting only cells that have powder to give. 0 at rest.
  double maxSlopeExcess(double repose_deg) const;

 private:
  enum class PassTool : std::uint8_t { kNone, kVacuum, kAir };
  /// Calls fn(cell) for every cell whose centre is within r of xy.
  template <class Fn>
  void forDisc(const Eigen::Vector2d& xy, double r, Fn&& fn);
  /// The surface at the start of this cell's current pass of `tool`.
  double passStart(std::size_t c, PassTool tool);
  void markDirty(int i, int j);

  int nx_ = 0, ny_ = 0;
  double dx_ = 0, dy_ = 0, x0_ = 0, y0_ = 0;
  std::vector<double> h_, floor_;
  std::vector<std::uint8_t> over_part_;
  std::uint64_t version_ = 0;
  // Tool passes.
  std::int64_t stamp_ = 0;
  std::vector<std::int64_t> pass_stamp_;
  std::vector<PassTool> pass_tool_;
  std::vector<double> pass_start_;
  // Cells changed since relaxation last came to rest: [i0, i1] x [j0, j1], empty if i0 > i1.
  int di0_, di1_, dj0_, dj1_;
  std::vector<double> delta_;  ///< relaxation scratch
};

}  // namespace depowder::sim
