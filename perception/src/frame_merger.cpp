#include "depowder/perception/frame_merger.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "depowder/clock.hpp"

namespace depowder::perception {

namespace {
std::int64_t micros(double seconds) { return static_cast<std::int64_t>(seconds * 1e6); }
}  // namespace

FrameMerger::FrameMerger(MergerConfig config, std::vector<std::string> known_cameras) : config_(config) {
  for (auto& name : known_cameras) cameras_.try_emplace(std::move(name));
}

bool FrameMerger::expected(const Camera& c, std::int64_t now) const {
  // A known camera that has not sent anything yet counts as heard from at start-up, so the
  // first time steps wait for it too (else its first frame would arrive "late").
  const std::int64_t heard = std::max(c.last_arrival, start_);
  return heard > 0 && now - heard <= micros(config_.silent_after) && !stale(c);
}

bool FrameMerger::stale(const Camera& c) const {
  return c.last_arrival > 0 && newest_utime_ - c.last_utime > micros(config_.stale_after);
}

FrameError FrameMerger::add(CameraFrame frame, std::int64_t arrival) {
  if (start_ == 0) start_ = arrival;
  // Health first: a camera whose frames are all late is stale, not silent.
  Camera& cam = cameras_[frame.camera];
  cam.last_arrival = arrival;
  // Far ahead (the rule in frame_merger.hpp): refused unless it confirms the camera's frame
  // refused before. A refused frame changes no time step, lag or staleness.
  const std::int64_t ahead =
      newest_utime_ == INT64_MIN ? 0 : runsAhead(newest_utime_, newest_arrival_, frame.utime, arrival);
  if (ahead > kClockJumpBack && !cam.ahead.confirms(frame.utime, arrival)) {
    char buf[80];
    std::snprintf(buf, sizeof buf, " is %.1f s ahead", static_cast<double>(ahead) * 1e-6);
    return {FrameStatus::kAhead, "camera '" + frame.camera + "': frame at utime " + std::to_string(frame.utime) + buf +
                                     " of the newest frame taken and the time since (a bad stamp, or its clock "
                                     "jumped forward: taken if its next frame confirms it)"};
  }
  cam.ahead.forget();
  if (clockWentBack(released_utime_, frame.utime)) {
    ++cam.back_frames;
    cam.back_utime = frame.utime;
    restartIfClockWentBack(arrival);  // else late, as from a camera whose clock runs behind the others'
  } else {
    cam.back_frames = 0;
    cam.back_utime = 0;
  }
  cam.last_utime = std::max(cam.last_utime, frame.utime);
  if (frame.utime > newest_utime_) newest_utime_ = frame.utime, newest_arrival_ = arrival;

  const std::int64_t tol = micros(config_.match_tolerance);
  // A frame whose time step may already have been released cannot be used any more.
  if (released_utime_ != INT64_MIN && frame.utime <= released_utime_ + tol)
    return {FrameStatus::kLate, "camera '" + frame.camera + "': frame at utime " + std::to_string(frame.utime) +
                                    " arrived after its time step was published (" +
                                    std::to_string((released_utime_ - frame.utime) / 1000) +
                                    " ms older than the last one published)"};
  // The closest waiting time step within tolerance that lacks this camera.
  Group* best = nullptr;
  std::int64_t best_gap = tol + 1;
  for (Group& g : pending_) {
    const auto it = g.frames.find(frame.camera);
    if (it != g.frames.end()) {
      if (it->second.utime == frame.utime)
        return {FrameStatus::kDuplicate, "camera '" + frame.camera + "': a frame with utime " +
                                             std::to_string(frame.utime) + " is already waiting"};
      continue;
    }
    const std::int64_t gap = std::llabs(g.utime - frame.utime);
    if (gap < best_gap) {
      best_gap = gap;
      best = &g;
    }
  }
  ++cam.frames;
  if (!best) {
    Group g;
    g.utime = frame.utime;
    g.first_arrival = arrival;
    const auto at = std::upper_bound(pending_.begin(), pending_.end(), g.utime,
                                     [](std::int64_t u, const Group& other) { return u < other.utime; });
    best = &*pending_.insert(at, std::move(g));
  }
  const std::string name = frame.camera;
  best->frames.emplace(name, std::move(frame));
  return {};
}

void FrameMerger::restartIfClockWentBack(std::int64_t arrival) {
  std::int64_t newest_back = INT64_MIN;
  int back_frames = 0;
  for (const auto& [name, c] : cameras_) {
    const bool heard = c.last_arrival > 0 && arrival - c.last_arrival <= micros(config_.silent_after);
    if (!heard) continue;  // what a silent camera sent back then confirms nothing now
    if (c.back_frames == 0) return;
    newest_back = std::max(newest_back, c.back_utime);
    back_frames += c.back_frames;
  }
  if (back_frames < 2) return;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "every camera's frames went back %.1f s behind the last time step published (a log played again, "
                "or the cameras restarted): time steps start over",
                static_cast<double>(behind(released_utime_, newest_back)) * 1e-6);
  last_restart_ = buf;
  ++restarts_;
  for (Group& g : pending_) flushed_.push_back(release(std::move(g), arrival));
  pending_.clear();
  released_utime_ = INT64_MIN;
  newest_utime_ = newest_back;
  newest_arrival_ = arrival;
  for (auto& [name, c] : cameras_) {
    c.last_utime = c.back_utime;
    c.back_frames = 0;
    c.back_utime = 0;
  }
}

MergedFrame FrameMerger::release(Group&& group, std::int64_t now) const {
  MergedFrame out;
  out.utime = INT64_MIN;
  for (auto& [name, frame] : group.frames) {  // std::map: sorted by camera name
    out.utime = std::max(out.utime, frame.utime);
    out.sources.push_back(std::move(frame));
  }
  for (const auto& [name, cam] : cameras_)
    if (expected(cam, now) && !group.frames.count(name)) out.missing.push_back(name);
  return out;
}

std::vector<MergedFrame> FrameMerger::poll(std::int64_t now) {
  // The newest time step that is complete or has waited long enough; it and every older
  // one go out (older incomplete ones can no longer be published after it).
  const std::int64_t wait = micros(config_.max_wait);
  std::size_t ready = 0;
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    const Group& g = pending_[i];
    bool complete = true;
    for (const auto& [name, cam] : cameras_)
      if (expected(cam, now) && !g.frames.count(name)) {
        complete = false;
        break;
      }
    if (complete || now - g.first_arrival >= wait) ready = i + 1;
  }
  std::vector<MergedFrame> out = std::move(flushed_);  // the old clock's, first
  flushed_.clear();
  out.reserve(out.size() + ready);
  for (std::size_t i = 0; i < ready; ++i) {
    released_utime_ = std::max(released_utime_, pending_[i].utime);
    out.push_back(release(std::move(pending_[i]), now));
  }
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(ready));
  return out;
}

std::int64_t FrameMerger::nextDeadline() const {
  std::int64_t deadline = 0;
  for (const Group& g : pending_) {
    const std::int64_t d = g.first_arrival + micros(config_.max_wait);
    if (deadline == 0 || d < deadline) deadline = d;
  }
  return deadline;
}

std::vector<CameraHealth> FrameMerger::health(std::int64_t now) const {
  std::vector<CameraHealth> out;
  for (const auto& [name, cam] : cameras_) {
    CameraHealth h;
    h.name = name;
    h.frames = cam.frames;
    h.last_seen_age = cam.last_arrival > 0 ? (now - cam.last_arrival) * 1e-6 : -1.0;
    h.utime_lag = cam.last_arrival > 0 ? (newest_utime_ - cam.last_utime) * 1e-6 : 0.0;
    h.silent = cam.last_arrival == 0 || now - cam.last_arrival > micros(config_.silent_after);
    h.stale = stale(cam);
    out.push_back(h);
  }
  return out;
}

}  // namespace depowder::perception
