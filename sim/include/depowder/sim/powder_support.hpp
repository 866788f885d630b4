// Powder as support and drag on a rigid part, without simulating grains (sim/README.md,
// "Physics"). The part's outer surface is sampled; a sample is buried when it lies below the
// powder surface beside it, at depth d, where the powder's pressure scale is sigma = rho g d.
//   - Lateral (at-rest) pressure: a buried side face is pushed back by K sigma per area
//     (horizontal part of its normal); the powder on an upward face weighs on it (sigma per
//     area). Buried evenly, these cancel; with the powder gone on one side, the other side's
//     pressure pushes the part over into the gap.
//   - Resistance (plastic, like friction): a buried face moving into the powder is resisted by
//     up to N sigma per area (N_q, bearing, under a footing; K_p, passive pressure, on a wall or
//     top; blended by the normal's downward part); sliding along the powder by up to mu times the normal
//     pressure on the face (the at-rest pressure plus the bearing pressure in use); both grow
//     with speed by (1 + |u| / drag_speed) (drag). Below these limits the powder holds the part
//     still: a deeply buried part does not move under gravity. A face moving away from the
//     powder is not held back (powder does not pull). A downward face (a footing) counts
//     `footing_depth` deeper: even level with the surface it bears some load (0.5 B N_gamma).
// The resistance is solved as velocity-level impulses with bounds (projected Gauss-Seidel,
// warm-started), so a held part stays exactly still at any step size.
// Which powder is "beside" a sample: for an upward face on top of its column, that column (the
// powder on the part); for a wall, the first cell off the part's footprint along its horizontal
// normal; for a downward face (the part's bottom, resting on the hidden powder under it), the
// surface where the nearest way out of the footprint leads (8 directions; the surcharge that
// gives a footing its bearing capacity) -- unless the powder under it has run out: it stands
// only as high as the angle of repose allows from the ways out, so a part perched on powder
// whose surroundings are dug away on one side loses its support on that side and tips over.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "depowder/geometry.hpp"
#include "depowder/mesh.hpp"
#include "depowder/sim/powder.hpp"
#include "depowder/sim/rigid_shape.hpp"

namespace depowder::sim {

struct PowderForceConfig {
  double density = 1500;       ///< kg/m^3, bulk density of the powder (play sand 1500..1600, as the paper used)
  double bearing_factor = 20;  ///< N_q: pressure a downward face (footing) pushing into the powder builds, per rho g d
  double passive_factor = 3;   ///< K_p: the same for a wall or an upward face (passive pressure, (1+sin32)/(1-sin32))
  double shear_factor = 0.6;   ///< mu: shear stress along a buried face, per rho g d (tan 31 deg)
  double lateral_pressure =
      0.4;  ///< K: at-rest horizontal pressure on a buried side face, per rho g d (1 - sin 32 deg ~ 0.47)
  double drag_speed = 0.05;       ///< m/s at which the resistance has doubled (drag grows with speed)
  double footing_depth = 0.01;    ///< m added to a downward face's depth (bearing of a footing at the surface)
  double sample_spacing = 0.006;  ///< m between the surface samples the powder acts on
  int iterations = 8;             ///< projected Gauss-Seidel sweeps per substep (warm-started)
  bool displace = true;           ///< parts the physics moves push the powder: it piles up in front, fills in behind
};

/// A point of the part's outer surface, part frame.
struct SurfaceSample {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();  ///< outward unit normal
  double area = 0;                               ///< m^2 the sample stands for
};

/// Area-weighted samples (about area / spacing^2, seeded) of the surface powder can touch: a sample
/// whose outside (1 mm out along its normal) is in the filled solid (a tube's bore, a cup's inside)
/// is dropped, since that powder moves with the part.
std::vector<SurfaceSample> outerSurfaceSamples(const Mesh& mesh, const FilledSolid& filled, double spacing,
                                               std::uint32_t seed = 11);

/// The powder surface beside each sample of a part posed at T_cell_part (see above). `covered(cell)`:
/// the cell is under this part; `repose_deg`: the powder's angle of repose. -inf where there is no
/// powder (outside the box; under a bottom face the powder has run out from under).
void powderLevels(const std::vector<SurfaceSample>& samples, const Pose& T_cell_part, const PowderField& powder,
                  const std::function<bool(std::size_t)>& covered, double repose_deg, std::vector<double>& levels);

class PowderSupport {
 public:
  PowderSupport() = default;
  /// `samples` in the part frame; the body: its frame (centre of mass, principal axes) T_body_part,
  /// mass (kg) and principal moments of inertia (kg m^2).
  PowderSupport(const PowderForceConfig& config, std::vector<SurfaceSample> samples, const Pose& T_body_part,
                double mass, const Eigen::Vector3d& inertia, double gravity);

  const std::vector<SurfaceSample>& samples() const { return samples_; }
  /// The powder levels beside the samples (powderLevels), set once per world step.
  std::vector<double>& levels() { return levels_; }
  const std::vector<double>& levels() const { return levels_; }

  struct Result {
    Eigen::Vector3d v = Eigen::Vector3d::Zero();  ///< m/s, new velocity of the centre of mass, without dv_free
    Eigen::Vector3d w = Eigen::Vector3d::Zero();  ///< rad/s
    int buried = 0;                               ///< samples below the powder surface
  };
  /// One substep of h seconds for the body posed at T_cell_body moving at v, w (cell frame): its
  /// velocity after the powder's impulses, given that the other forces (gravity) change it by dv_free
  /// this substep (the caller applies those itself).
  Result solve(const Pose& T_cell_body, const Eigen::Vector3d& v, const Eigen::Vector3d& w,
               const Eigen::Vector3d& dv_free, double h);
  /// Forgets the warm start (after a teleport).
  void reset();

 private:
  struct BodySample {                 ///< a sample in the body frame, with what the solve needs of it
    Eigen::Vector3d r, n, t1, t2;     ///< position from the centre of mass; normal and tangents
    Eigen::Vector3d an, at1, at2;     ///< I^-1 (r x direction)
    double mn = 0, mt1 = 0, mt2 = 0;  ///< effective masses along the directions, kg
  };
  struct Row {  ///< a buried sample this substep
    std::size_t k;
    double cap_n, cap_t0, mu;  ///< impulse bounds: normal; tangential = cap_t0 + mu |lambda_n|
  };
  PowderForceConfig config_;
  double gravity_ = 9.81;
  double inv_mass_ = 1;
  Eigen::Vector3d inv_inertia_ = Eigen::Vector3d::Ones();
  std::vector<SurfaceSample> samples_;
  std::vector<BodySample> body_;
  std::vector<double> levels_;
  std::vector<Eigen::Vector3d> lambda_;  ///< warm start: last impulses (normal, tangent 1, tangent 2)
  std::vector<Row> rows_;
};

}  // namespace depowder::sim
