// Draws a Scene with VTK (renderer.cpp is the only file that includes VTK), in a
// live window or off-screen into an image / PNG. Needs an X display (Debian's VTK
// renders through GLX): see display.hpp for starting a private Xvfb.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "depowder/viewer/scene.hpp"

namespace depowder::viewer {

class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A pinhole view of the cell (VTK camera conventions: vertical view angle).
struct CameraSetup {
  Eigen::Vector3d position{0.0, -0.55, 0.50};   ///< m, cell frame
  Eigen::Vector3d focal_point{0.0, 0.0, 0.06};  ///< m, cell frame
  Eigen::Vector3d view_up{0.0, 0.0, 1.0};
  double view_angle_deg = 30;  ///< vertical field of view
};

/// Looks at the box from the front (-y), above, so the whole box fills most of the picture.
CameraSetup defaultCamera(const Eigen::Vector3d& box_size);

struct RenderOptions {
  int width = 1280;  ///< pixels
  int height = 720;
  bool offscreen = false;  ///< true: no window is shown (snapshots)
  std::string title = "depowder-viewer";
  CameraSetup camera;
};

/// An RGB picture, row 0 at the top.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3
  const std::uint8_t* at(int u, int v) const { return &rgb[3 * (static_cast<std::size_t>(v) * width + u)]; }
};

class Renderer {
 public:
  /// Throws RenderError if there is no usable X display.
  explicit Renderer(const RenderOptions& options);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// Brings the actors up to date with `scene` (only what changed since the last call).
  void update(const Scene& scene);
  /// Renders and reads the picture back.
  Image capture();
  /// Renders and writes a PNG (parent directories are created). Throws RenderError.
  void savePng(const std::string& path);

  /// Live window: calls `tick` every `period_ms` from the window's event loop; `tick`
  /// returns false to close. Returns when the window is closed or tick says so.
  void runInteractive(const std::function<bool()>& tick, int period_ms = 33);
  /// Renders the window now (from inside tick).
  void render();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reads a PNG (8-bit RGB or RGBA) into an Image; throws RenderError.
Image readPng(const std::string& path);

}  // namespace depowder::viewer
