// depowder-viewer: the cell in 3D, as in the paper's Fig. 9 (estimated CAD model red,
// template green), live in a window or as PNG pictures of a run. It only listens: it
// keeps the newest message of each kind and draws at its own pace, so a slow viewer
// drops frames here and never slows the cell.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "depowder/heartbeat_t.hpp"
#include "depowder/node/bus.hpp"
#include "depowder/node/cell.hpp"
#include "depowder/node/heartbeat.hpp"
#include "depowder/node/shutdown.hpp"
#include "depowder/viewer/display.hpp"
#include "depowder/viewer/listen.hpp"
#include "depowder/viewer/renderer.hpp"
#include "depowder/viewer/snapshots.hpp"

using namespace depowder;

namespace {

struct Options {
  std::string config;
  std::optional<std::string> url, prefix;
  int width = 1280, height = 720;
  std::string snapshot;       ///< one picture, then exit
  double wait_s = -1;         ///< --snapshot: listen this long (else: until the first PART_POSE)
  double timeout_s = 30;      ///< --snapshot: give up waiting for PART_POSE after this long
  std::string snapshots_dir;  ///< --snapshots DIR --every N
  int every = 0;
  std::string phase_dir;  ///< --snapshot-on-phase DIR
  double duration_s = 0;  ///< stop after this long (0 = until SIGINT/SIGTERM or the window closes)
};

int usage(const std::string& error = "") {
  if (!error.empty()) std::cerr << "depowder-viewer: " << error << "\n";
  std::cerr
      << "usage: depowder-viewer [--config CELL.yaml] [--url URL] [--prefix P] [--size WxH]\n"
         "                       [--snapshot FILE.png [--wait S] [--timeout S]]\n"
         "                       [--snapshots DIR --every N] [--snapshot-on-phase DIR] [--duration S]\n"
         "  Live window by default (needs DISPLAY). Snapshot modes render off-screen and start a private\n"
         "  Xvfb when there is no display.\n"
         "  --snapshot FILE.png   one picture after the first PART_POSE (or after --wait S), then exit;\n"
         "                        exit 1 if no PART_POSE came within --timeout S (default 30; picture still written)\n"
         "  --snapshots DIR       a picture DIR/points-<seq>.png every --every N POINTS frames\n"
         "  --snapshot-on-phase DIR  a picture DIR/<part>-phase<k>-<name>.png when a part's phase changes\n"
         "  --duration S          stop after S seconds (default: until SIGINT/SIGTERM or the window closes)\n"
         "  Red: CAD model at the estimated pose; green: template; faint grey: ground truth (SIM_TRUTH);\n"
         "  orange: powder contour; blue: nozzle plan; cylinders: the tool.\n";
  return error.empty() ? 0 : 2;
}

std::optional<Options> parse(int argc, char** argv, int* rc) {
  Options o;
  o.config = node::defaultCellPath();
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      *rc = usage();
      return std::nullopt;
    }
    if (i + 1 >= argc) {
      *rc = usage("missing value after " + a);
      return std::nullopt;
    }
    const std::string v = argv[++i];
    char* end = nullptr;
    if (a == "--config") {
      o.config = v;
    } else if (a == "--url") {
      o.url = v;
    } else if (a == "--prefix") {
      o.prefix = v;
    } else if (a == "--size") {
      if (std::sscanf(v.c_str(), "%dx%d", &o.width, &o.height) != 2 || o.width < 16 || o.height < 16 ||
          o.width > 8192 || o.height > 8192) {
        *rc = usage("--size must be WxH with 16..8192 pixels a side, got " + v);
        return std::nullopt;
      }
    } else if (a == "--snapshot") {
      o.snapshot = v;
    } else if (a == "--snapshots") {
      o.snapshots_dir = v;
    } else if (a == "--snapshot-on-phase") {
      o.phase_dir = v;
    } else if (a == "--every" || a == "--wait" || a == "--timeout" || a == "--duration") {
      const double x = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end || !(x >= 0) || x > 1e6) {
        *rc = usage(a + " needs a non-negative number, got " + v);
        return std::nullopt;
      }
      if (a == "--every") o.every = static_cast<int>(x);
      if (a == "--wait") o.wait_s = x;
      if (a == "--timeout") o.timeout_s = x;
      if (a == "--duration") o.duration_s = x;
    } else {
      *rc = usage("unknown option " + a);
      return std::nullopt;
    }
  }
  if (!o.snapshots_dir.empty() && o.every <= 0) {
    *rc = usage("--snapshots DIR needs --every N (N >= 1)");
    return std::nullopt;
  }
  if (o.every > 0 && o.snapshots_dir.empty()) {
    *rc = usage("--every N needs --snapshots DIR");
    return std::nullopt;
  }
  if (!o.snapshot.empty() && (!o.snapshots_dir.empty() || !o.phase_dir.empty())) {
    *rc = usage("--snapshot (one picture) cannot be combined with --snapshots / --snapshot-on-phase");
    return std::nullopt;
  }
  return o;
}

double seconds() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

/// Reports bus errors (garbage on a channel, a handler that threw) without flooding stderr.
class ErrorReporter {
 public:
  void report(node::Bus& bus) {
    for (const std::string& e : bus.takeErrors()) {
      if (++shown_ <= 10) std::cerr << "depowder-viewer: " << e << "\n";
      if (shown_ == 10) std::cerr << "depowder-viewer: (further errors are only counted)\n";
    }
  }

 private:
  long shown_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  int rc = 0;
  const std::optional<Options> opt = parse(argc, argv, &rc);
  if (!opt) return rc;
  const Options& o = *opt;
  const bool offscreen = !o.snapshot.empty() || !o.snapshots_dir.empty() || !o.phase_dir.empty();

  try {
    node::installShutdownHandlers();
    const node::CellConfig cell = node::loadCell(o.config);

    // 1. A display: snapshots must work without one, so start a private Xvfb (before
    //    the LCM socket exists, so the X server does not inherit it).
    std::unique_ptr<viewer::Xvfb> xvfb;
    if (!viewer::displayUsable()) {
      if (!offscreen) {
        std::cerr << "depowder-viewer: no X display (DISPLAY is unset or does not answer). Run it on a desktop, "
                     "under xvfb-run, or use --snapshot / --snapshots, which need no display.\n";
        return 1;
      }
      xvfb = std::make_unique<viewer::Xvfb>(o.width, o.height);
    }

    // 2. The scene (box, meshes) and the renderer.
    viewer::SceneModel model(viewer::sceneFromCell(cell));
    viewer::RenderOptions ro;
    ro.width = o.width;
    ro.height = o.height;
    ro.offscreen = offscreen;
    ro.camera = viewer::defaultCamera(cell.box.size);
    viewer::Renderer renderer(ro);

    // 3. LCM: listen only; the heartbeat carries the decode-error count.
    const std::string bus_url = o.url.value_or(cell.lcm.url);
    node::Bus bus(bus_url, o.prefix.value_or(cell.lcm.prefix));
    viewer::subscribe(bus, model);
    const bool replay = bus_url.rfind("file://", 0) == 0;  // reading a log: nothing to publish to
    node::Heartbeat heartbeat(bus, "depowder-viewer");
    heartbeat.setStat("cell_model", node::cellModelId(cell));  // depowder-status compares hosts
    heartbeat.setState(heartbeat_t::RUNNING);
    ErrorReporter errors;

    const double start = seconds();
    std::int64_t rendered = 0, written = 0, skipped = 0, last_seq = -1, last_rejected = 0;
    auto draw = [&]() {
      const viewer::Scene& s = model.scene();
      if (last_seq >= 0 && s.cloud_seq > last_seq + 1) skipped += s.cloud_seq - last_seq - 1;
      if (s.cloud_seq >= 0) last_seq = s.cloud_seq;
      renderer.update(s);
      ++rendered;
    };
    auto bookkeeping = [&]() {
      errors.report(bus);
      const viewer::Rejected& r = model.rejected();
      if (r.count > last_rejected) {
        heartbeat.addDropped(r.count - last_rejected);
        std::cerr << "depowder-viewer: ignored a message: " << r.last_reason << "\n";
        last_rejected = r.count;
      }
      heartbeat.setStat("frames_rendered", static_cast<double>(rendered));
      heartbeat.setStat("points_skipped", static_cast<double>(skipped));
      heartbeat.setStat("snapshots_written", static_cast<double>(written));
      if (!replay) heartbeat.tick();
    };
    auto expired = [&]() { return o.duration_s > 0 && seconds() - start >= o.duration_s; };
    auto write = [&](const std::string& path) {
      draw();
      renderer.savePng(path);
      ++written;
      std::cout << "depowder-viewer: wrote " << path << std::endl;
    };

    // One LCM message (or a timeout). False at the end of a log (--url file://...): LCM's
    // log provider reports it as a failed handle.
    auto pump = [&](int wait_ms) {
      try {
        bus.spinOnce(wait_ms);
        return true;
      } catch (const node::BusError&) {
        if (replay) return false;
        throw;
      }
    };

    // 4a. One picture, then exit.
    if (!o.snapshot.empty()) {
      double first_pose_s = -1;
      bool more = true;
      while (more && !node::shutdownRequested()) {
        more = pump(20);
        bookkeeping();
        const double now = seconds() - start;
        if (o.wait_s >= 0) {
          if (now >= o.wait_s) break;
          continue;
        }
        if (first_pose_s < 0)
          for (const viewer::PartScene& p : model.scene().parts)
            if (p.has_estimate) first_pose_s = now;
        // After the first PART_POSE, listen a little longer for the other parts' poses and PROGRESS.
        if (first_pose_s >= 0 && now - first_pose_s >= 0.3) break;
        if (now >= o.timeout_s) break;
      }
      write(o.snapshot);
      bookkeeping();
      bool any_pose = false;
      for (const viewer::PartScene& p : model.scene().parts) any_pose = any_pose || p.has_estimate;
      if (o.wait_s < 0 && !any_pose) {
        std::cerr << "depowder-viewer: no PART_POSE ";
        if (more)
          std::cerr << "within " << o.timeout_s << " s";
        else
          std::cerr << "in the log";
        std::cerr << "; wrote the picture anyway\n";
        return 1;
      }
      return 0;
    }

    // 4b. Pictures of a run: every N POINTS frames and/or on phase changes. The policies
    //     look after every message, so a frame is never skipped by batching.
    if (offscreen) {
      viewer::SnapshotConfig sc;
      sc.every = o.every;
      viewer::SnapshotPolicy every_n(sc);
      viewer::SnapshotPolicy on_phase(viewer::SnapshotConfig{0, true, 0});
      bool more = true;
      while (more && !node::shutdownRequested() && !expired()) {
        more = pump(20);
        const double now = seconds();
        if (!o.snapshots_dir.empty())
          for (const std::string& name : every_n.due(model.scene(), now)) write(o.snapshots_dir + "/" + name);
        if (!o.phase_dir.empty())
          for (const std::string& name : on_phase.due(model.scene(), now)) write(o.phase_dir + "/" + name);
        bookkeeping();
      }
      if (!o.snapshots_dir.empty())
        for (const std::string& name : every_n.flush()) write(o.snapshots_dir + "/" + name);
      return 0;
    }

    // 4c. Live window: drain, redraw what changed, at most ~30 times a second. At the end
    //     of a log the window stays open on the last state.
    std::uint64_t drawn_version = ~0ull;
    bool more = true;
    std::string failure;  // an exception must not unwind through VTK's event loop
    renderer.runInteractive([&]() {
      try {
        if (more) {
          try {
            viewer::drain(bus, 0, 20);
          } catch (const node::BusError&) {
            if (!replay) throw;
            more = false;  // end of the log: keep showing the last state
          }
        }
        if (model.scene().versions.total() != drawn_version) {
          draw();
          renderer.render();
          drawn_version = model.scene().versions.total();
        }
        bookkeeping();
        return !node::shutdownRequested() && !expired();
      } catch (const std::exception& e) {
        failure = e.what();
        return false;
      }
    });
    if (!failure.empty()) throw std::runtime_error(failure);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "depowder-viewer: " << e.what() << "\n";
    return 1;
  }
}
