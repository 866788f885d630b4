#include "depowder/progress/phase.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "depowder/clock.hpp"

namespace depowder::progress {

const char* toString(EtaFilterMode m) {
  switch (m) {
    case EtaFilterMode::kMedian:
      return "median";
    case EtaFilterMode::kRunningMax:
      return "running_max";
    case EtaFilterMode::kRunningMaxReset:
      return "running_max_reset";
    case EtaFilterMode::kNone:
      return "none";
  }
  return "unknown";
}

bool parseEtaFilterMode(const std::string& name, EtaFilterMode& mode) {
  for (EtaFilterMode m :
       {EtaFilterMode::kMedian, EtaFilterMode::kRunningMax, EtaFilterMode::kRunningMaxReset, EtaFilterMode::kNone})
    if (name == toString(m)) {
      mode = m;
      return true;
    }
  return false;
}

void EtaFilter::reset() {
  window_.clear();
  has_value_ = false;
  value_ = 0;
  jump_pending_ = false;
}

bool EtaFilter::farFrom(const Pose& a, const Pose& b) const {
  return rotationAngle(a.rotation(), b.rotation()) * 180 / M_PI > config_.reset_rotation_deg ||
         translationDistance(a, b) > config_.reset_translation;
}

void EtaFilter::add(double eta_raw) {
  switch (config_.mode) {
    case EtaFilterMode::kMedian: {
      window_.push_back(eta_raw);
      while (static_cast<int>(window_.size()) > std::max(1, config_.window)) window_.pop_front();
      std::vector<double> v(window_.begin(), window_.end());
      std::sort(v.begin(), v.end());
      const std::size_t n = v.size();
      value_ = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
      break;
    }
    case EtaFilterMode::kRunningMax:
    case EtaFilterMode::kRunningMaxReset:
      value_ = has_value_ ? std::max(value_, eta_raw) : eta_raw;
      break;
    case EtaFilterMode::kNone:
      value_ = eta_raw;
      break;
  }
  has_value_ = true;
}

double EtaFilter::update(double eta_raw, const Pose& T_cell_part) {
  if (!std::isfinite(eta_raw) || !T_cell_part.matrix().allFinite()) return value_;
  // A pose jump (the part was pushed or fell over) changes H_max / H_min: the old values
  // describe another geometry, so start again (Eq. 2 is "always estimated based on the current pose").
  // A single glitched pose is a jump too, and so is the correct pose after it: clearing on it would
  // pass the glitched frame's eta straight through (a median of one). So a jump is only taken once
  // the next frame confirms it (also far from the reference, and near the jumped pose); until then
  // the frame's eta is not used and the previous value is returned. A topple is followed one frame later.
  if (has_value_ && (config_.mode == EtaFilterMode::kMedian || config_.mode == EtaFilterMode::kRunningMaxReset) &&
      farFrom(reference_, T_cell_part)) {
    if (!jump_pending_ || farFrom(jump_pose_, T_cell_part)) {
      jump_pending_ = true;  // not confirmed (yet): a glitch until the next frame says otherwise
      jump_pose_ = T_cell_part;
      jump_eta_ = eta_raw;
      return value_;
    }
    const double jumped_eta = jump_eta_;  // the first frame at the new pose counts too
    reset();
    ++resets_;
    reference_ = T_cell_part;
    add(jumped_eta);
  }
  jump_pending_ = false;
  if (!has_value_) reference_ = T_cell_part;
  add(eta_raw);
  return value_;
}

const char* toString(Phase p) {
  switch (p) {
    case Phase::kVacuumBuried:
      return "vacuum_buried";
    case Phase::kVacuumTracked:
      return "vacuum_tracked";
    case Phase::kAirBlast:
      return "air_blast";
    case Phase::kDone:
      return "done";
  }
  return "unknown";
}

void PhaseMachine::airBlastStarted(std::int64_t utime) {
  if (phase_ == Phase::kAirBlast && blast_utime_ < 0) blast_utime_ = utime;
}

Phase PhaseMachine::update(double eta, std::int64_t utime) {
  if (!std::isfinite(eta) || phase_ == Phase::kDone) return phase_;
  const std::int64_t previous = std::exchange(last_utime_, utime);
  // Sec. III-B: phase 1 while eta <= eta1, phase 2 while eta <= eta2, phase 3 above.
  if (phase_ == Phase::kAirBlast && eta < config_.eta2 - config_.hysteresis) {
    phase_ = Phase::kVacuumTracked;  // powder came back: vacuum again, and a new blast later
    blast_utime_ = -1;
    frames_at_target_ = 0;
  }
  if (phase_ == Phase::kVacuumBuried && eta > config_.eta1) phase_ = Phase::kVacuumTracked;
  if (phase_ == Phase::kVacuumTracked && eta > config_.eta2) {
    phase_ = Phase::kAirBlast;
    blast_utime_ = config_.require_blast ? -1 : utime;
    frames_at_target_ = 0;
    return phase_;  // the blast has not run yet
  }
  if (phase_ != Phase::kAirBlast) return phase_;

  // Done once the blast pass has run long enough and then confirms eta at the target. The blast
  // is timed in the frames' time (depowder/clock.hpp): from a frame far behind its start anew (the
  // clock went back), and without a gap of more than kClockJumpBack between two frames of it (the
  // clock jumped forward, or no frame came, so no plan from one ran).
  if (blast_utime_ >= 0 && clockWentBack(blast_utime_, utime))
    blast_utime_ = utime;
  else if (blast_utime_ >= 0 && previous >= blast_utime_ && clockJumpedAhead(previous, utime))
    blast_utime_ += utime - previous;
  const bool blasted = blast_utime_ >= 0 && (utime - blast_utime_) * 1e-6 >= config_.blast_min_s;
  frames_at_target_ = blasted && eta >= config_.done_eta ? frames_at_target_ + 1 : 0;
  if (frames_at_target_ >= config_.done_frames) phase_ = Phase::kDone;
  return phase_;
}

}  // namespace depowder::progress
