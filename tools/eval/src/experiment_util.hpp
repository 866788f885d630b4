// Helpers shared by the experiments (private to the library).
#pragma once

#include <functional>
#include <random>
#include <string>
#include <vector>

#include "depowder/eval/scene.hpp"

namespace depowder::eval {

/// FNV-1a of a part name: a trial's seed depends on the part's name, not its position in a list,
/// so `--part cube` gives the cube rows of a full report.
std::uint64_t nameHash(const std::string& name);

/// `T` with a random error: rotation about a random axis through the part origin by an angle
/// uniform in [0, max_rot], translation in a random direction by a length uniform in [0, max_trans].
Pose perturbed(const Pose& T, double max_trans, double max_rot, std::mt19937& rng);

/// The physics steps in one camera frame (step_hz / fps, at least 1) and their length (s).
int frameSteps(const EvalCell& cell);
double frameStep(const EvalCell& cell);
/// Advances the world by one camera frame in step_hz steps; `before_step(t)` is called with
/// the time each step ends at (scripted nozzle / part motion).
void advanceFrame(sim::World& world, const EvalCell& cell, const std::function<void(double t)>& before_step);

double mean(const std::vector<double>& v);
std::string percent(double fraction);  ///< "40%"

}  // namespace depowder::eval
