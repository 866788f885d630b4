// The only file of the project that includes VTK (plain VTK, not pcl::visualization:
// it compiles in seconds instead of minutes and needs nothing PCL adds here).
// Colours follow the paper's Fig. 9: estimated CAD model red, template green.
#include "depowder/viewer/renderer.hpp"

#include <vtkActor.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkImageData.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPNGWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>

#include "depowder/part_pose_t.hpp"
#include "depowder/viewer/display.hpp"
#include "depowder/waypoint_t.hpp"

namespace depowder::viewer {

namespace {

struct Rgb {
  double r, g, b;
};
// Fig. 9: "estimated pose in red and the corresponding template in green".
constexpr Rgb kEstimate{0.85, 0.08, 0.08};
constexpr Rgb kTemplate{0.10, 0.95, 0.10};
constexpr Rgb kTruth{0.80, 0.80, 0.85};
constexpr Rgb kContour{1.00, 0.62, 0.00};
constexpr Rgb kPlan{0.20, 0.45, 1.00};
constexpr Rgb kBox{0.55, 0.55, 0.60};
constexpr Rgb kBackground{0.10, 0.10, 0.12};
constexpr double kTruthOpacity = 0.25;
constexpr double kToolOpacity = 0.6;  // the part stays visible through the tool above it
constexpr double kMarkerRadius = 0.008, kMarkerLength = 0.06;  // m, the nozzle drawn when the cell's tool is not known

void setColor(vtkActor* a, const Rgb& c) { a->GetProperty()->SetColor(c.r, c.g, c.b); }

vtkSmartPointer<vtkMatrix4x4> toVtk(const Pose& T) {
  auto m = vtkSmartPointer<vtkMatrix4x4>::New();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m->SetElement(i, j, T.matrix()(i, j));
  return m;
}

vtkSmartPointer<vtkPolyData> meshPolyData(const Mesh& mesh) {
  vtkNew<vtkPoints> points;
  points->SetNumberOfPoints(static_cast<vtkIdType>(mesh.vertices.size()));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), mesh.vertices[i].data());
  vtkNew<vtkCellArray> tris;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    tris->InsertNextCell(3, ids);
  }
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetPolys(tris);
  return pd;
}

/// Points as vertices, optionally with per-point RGB.
vtkSmartPointer<vtkPolyData> pointsPolyData(const Cloud& cloud, const std::vector<std::uint8_t>* rgb = nullptr) {
  vtkNew<vtkPoints> points;
  points->SetNumberOfPoints(static_cast<vtkIdType>(cloud.size()));
  vtkNew<vtkCellArray> verts;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    points->SetPoint(static_cast<vtkIdType>(i), cloud[i].data());
    const vtkIdType id = static_cast<vtkIdType>(i);
    verts->InsertNextCell(1, &id);
  }
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetVerts(verts);
  if (rgb) {
    vtkNew<vtkUnsignedCharArray> colors;
    colors->SetNumberOfComponents(3);
    colors->SetNumberOfTuples(static_cast<vtkIdType>(cloud.size()));
    std::memcpy(colors->GetPointer(0), rgb->data(), rgb->size());
    pd->GetPointData()->SetScalars(colors);
  }
  return pd;
}

/// Line segments (pairs) and/or one polyline through `path`.
vtkSmartPointer<vtkPolyData> polylinePolyData(const std::vector<Eigen::Vector3d>& path, bool closed) {
  vtkNew<vtkPoints> points;
  for (const Eigen::Vector3d& p : path) points->InsertNextPoint(p.data());
  vtkNew<vtkCellArray> lines;
  if (path.size() >= 2) {
    std::vector<vtkIdType> ids(path.size());
    for (std::size_t i = 0; i < path.size(); ++i) ids[i] = static_cast<vtkIdType>(i);
    if (closed) ids.push_back(0);
    lines->InsertNextCell(static_cast<vtkIdType>(ids.size()), ids.data());
  }
  vtkNew<vtkCellArray> verts;
  for (std::size_t i = 0; i < path.size(); ++i) {
    const vtkIdType id = static_cast<vtkIdType>(i);
    verts->InsertNextCell(1, &id);
  }
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetLines(lines);
  pd->SetVerts(verts);
  return pd;
}

vtkSmartPointer<vtkActor> makeActor(vtkPolyData* pd) {
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(pd);
  mapper->ScalarVisibilityOff();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  return actor;
}

void setInput(vtkActor* actor, vtkPolyData* pd) {
  vtkPolyDataMapper::SafeDownCast(actor->GetMapper())->SetInputData(pd);
}

/// The 12 interior edges of the build box (origin at the floor centre).
vtkSmartPointer<vtkPolyData> boxPolyData(const Eigen::Vector3d& size) {
  vtkNew<vtkPoints> points;
  for (int i = 0; i < 8; ++i)
    points->InsertNextPoint((i & 1 ? 0.5 : -0.5) * size.x(), (i & 2 ? 0.5 : -0.5) * size.y(), i & 4 ? size.z() : 0.0);
  vtkNew<vtkCellArray> lines;
  for (int i = 0; i < 8; ++i)
    for (int bit : {1, 2, 4})
      if (!(i & bit)) {
        const vtkIdType ids[2] = {i, i | bit};
        lines->InsertNextCell(2, ids);
      }
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetLines(lines);
  return pd;
}

Rgb statusColor(const PartScene& p) {
  if (!p.has_estimate) return {0.8, 0.8, 0.8};
  switch (p.track_status) {
    case part_pose_t::TRACKING:
      return {0.75, 1.0, 0.75};
    case part_pose_t::DEGRADED:
      return {1.0, 0.9, 0.4};
    case part_pose_t::LOST:
      return {1.0, 0.5, 0.5};
    default:
      return {0.9, 0.9, 0.9};
  }
}

Rgb toolColor(int tool) {
  switch (tool) {
    case waypoint_t::TOOL_VACUUM:
      return {0.2, 0.9, 0.9};
    case waypoint_t::TOOL_AIR:
      return {0.9, 0.9, 1.0};
    default:
      return {0.6, 0.6, 0.6};
  }
}

Image toImage(vtkImageData* data) {
  int dims[3];
  data->GetDimensions(dims);
  const int comps = data->GetNumberOfScalarComponents();
  if (data->GetScalarType() != VTK_UNSIGNED_CHAR || comps < 3)
    throw RenderError("image is not 8-bit RGB (" + std::to_string(comps) + " components)");
  Image img;
  img.width = dims[0];
  img.height = dims[1];
  img.rgb.resize(static_cast<std::size_t>(img.width) * img.height * 3);
  const auto* src = static_cast<const std::uint8_t*>(data->GetScalarPointer());
  for (int v = 0; v < img.height; ++v)  // VTK's row 0 is the bottom one
    for (int u = 0; u < img.width; ++u)
      for (int c = 0; c < 3; ++c)
        img.rgb[3 * (static_cast<std::size_t>(v) * img.width + u) + c] =
            src[comps * (static_cast<std::size_t>(img.height - 1 - v) * img.width + u) + c];
  return img;
}

struct PartActors {
  vtkSmartPointer<vtkActor> estimate, truth, templ, contour;
  std::int32_t template_version = -2;
  std::size_t template_size = 0;
};

}  // namespace

CameraSetup defaultCamera(const Eigen::Vector3d& box_size) {
  CameraSetup c;
  const double extent = box_size.head<2>().norm();
  c.focal_point = Eigen::Vector3d(0, 0, 0.3 * box_size.z());
  const double elevation = 50 * M_PI / 180, distance = 1.7 * extent;
  c.position = c.focal_point + distance * Eigen::Vector3d(0, -std::cos(elevation), std::sin(elevation));
  c.view_up = Eigen::Vector3d::UnitZ();
  c.view_angle_deg = 30;
  return c;
}

struct Renderer::Impl {
  RenderOptions options;
  vtkNew<vtkRenderer> renderer;
  vtkNew<vtkRenderWindow> window;
  vtkSmartPointer<vtkActor> box, cloud, plan, nozzle;
  std::map<std::string, PartActors> parts;
  std::vector<vtkSmartPointer<vtkTextActor>> text;
  vtkSmartPointer<vtkTextActor> legend;
  Scene::Versions seen;
  bool first = true;
  Eigen::Vector3d box_size = Eigen::Vector3d::Zero();
  std::shared_ptr<const Mesh> tool_mesh;  ///< the one drawn
  std::map<const Mesh*, vtkSmartPointer<vtkPolyData>> mesh_cache;

  vtkPolyData* meshData(const std::shared_ptr<const Mesh>& mesh) {
    auto& pd = mesh_cache[mesh.get()];
    if (!pd) pd = meshPolyData(*mesh);
    return pd;
  }

  vtkSmartPointer<vtkTextActor> makeText(double size_scale = 1.0) {
    auto t = vtkSmartPointer<vtkTextActor>::New();
    vtkTextProperty* p = t->GetTextProperty();
    p->SetFontSize(std::max(12, static_cast<int>(size_scale * window->GetSize()[1] / 40)));
    p->SetFontFamilyToCourier();
    p->SetShadow(1);
    renderer->AddActor2D(t);
    return t;
  }

  void updateParts(const Scene& scene) {
    for (const PartScene& p : scene.parts) {
      PartActors& a = parts[p.name];
      if (!a.estimate && p.mesh) {
        a.estimate = makeActor(meshData(p.mesh));
        setColor(a.estimate, kEstimate);
        a.estimate->GetProperty()->SetAmbient(0.35);
        a.estimate->GetProperty()->SetDiffuse(0.7);
        renderer->AddActor(a.estimate);
        a.truth = makeActor(meshData(p.mesh));
        setColor(a.truth, kTruth);
        a.truth->GetProperty()->SetOpacity(kTruthOpacity);
        renderer->AddActor(a.truth);
      }
      if (!a.templ) {
        a.templ = makeActor(pointsPolyData({}));
        setColor(a.templ, kTemplate);
        a.templ->GetProperty()->SetPointSize(std::max(3.0, window->GetSize()[1] / 180.0));
        a.templ->GetProperty()->LightingOff();
        renderer->AddActor(a.templ);
        a.contour = makeActor(polylinePolyData({}, true));
        setColor(a.contour, kContour);
        a.contour->GetProperty()->SetLineWidth(3);
        a.contour->GetProperty()->SetPointSize(4);
        a.contour->GetProperty()->LightingOff();
        renderer->AddActor(a.contour);
      }
      if (a.estimate) {
        a.estimate->SetVisibility(p.has_estimate);
        a.estimate->SetUserMatrix(toVtk(p.T_cell_part));
        a.truth->SetVisibility(p.has_truth);
        a.truth->SetUserMatrix(toVtk(p.T_cell_part_true));
      }
      if (a.template_version != p.template_version || a.template_size != p.template_points.size()) {
        setInput(a.templ, pointsPolyData(p.template_points));
        a.template_version = p.template_version;
        a.template_size = p.template_points.size();
      }
      a.templ->SetVisibility(p.has_estimate && !p.template_points.empty());
      a.templ->SetUserMatrix(toVtk(p.T_cell_part));
    }
  }

  void updateOverlays(const Scene& scene) {
    for (const PartScene& p : scene.parts) {
      auto it = parts.find(p.name);
      if (it == parts.end() || !it->second.contour) continue;
      setInput(it->second.contour, polylinePolyData(p.contour, true));
      it->second.contour->SetVisibility(!p.contour.empty());
    }
    setInput(plan, polylinePolyData(scene.plan, false));
    plan->SetVisibility(!scene.plan.empty());
  }

  void updateCloud(const Scene& scene) {
    // White/grey by height: darker low, brighter high, over the cloud's own z range.
    double zmin = 0, zmax = 0;
    if (!scene.cloud.empty()) {
      zmin = zmax = scene.cloud.front().z();
      for (const Point& q : scene.cloud) {
        zmin = std::min(zmin, q.z());
        zmax = std::max(zmax, q.z());
      }
    }
    std::vector<std::uint8_t> rgb(3 * scene.cloud.size());
    for (std::size_t i = 0; i < scene.cloud.size(); ++i) {
      const double s = zmax > zmin ? (scene.cloud[i].z() - zmin) / (zmax - zmin) : 1.0;
      const auto g = static_cast<std::uint8_t>(90 + 160 * s);
      rgb[3 * i] = rgb[3 * i + 1] = g;
      rgb[3 * i + 2] = static_cast<std::uint8_t>(std::min(255, g + 8));
    }
    setInput(cloud, pointsPolyData(scene.cloud, &rgb));
  }

  void updateText(const Scene& scene) {
    const std::vector<std::string> lines = statusLines(scene);
    while (text.size() < lines.size()) text.push_back(makeText());
    const int height = window->GetSize()[1];
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (i >= lines.size()) {
        text[i]->SetVisibility(false);
        continue;
      }
      text[i]->SetVisibility(true);
      text[i]->SetInput(lines[i].c_str());
      const int font = text[i]->GetTextProperty()->GetFontSize();
      text[i]->SetDisplayPosition(10, height - static_cast<int>((i + 1) * 1.35 * font) - 4);
      const Rgb c = i < scene.parts.size() ? statusColor(scene.parts[i]) : Rgb{0.8, 0.8, 0.8};
      text[i]->GetTextProperty()->SetColor(c.r, c.g, c.b);
    }
  }

  void updateNozzle(const Scene& scene) {
    if (first || scene.tool_mesh != tool_mesh) {
      tool_mesh = scene.tool_mesh;
      vtkPolyDataMapper::SafeDownCast(nozzle->GetMapper())
          ->SetInputData(meshPolyData(tool_mesh ? *tool_mesh : cylinderMesh(kMarkerRadius, kMarkerLength, 16)));
    }
    nozzle->SetVisibility(scene.has_nozzle);
    nozzle->SetUserMatrix(toVtk(scene.T_cell_nozzle));
    setColor(nozzle, toolColor(scene.tool));
  }
};

Renderer::Renderer(const RenderOptions& options) : impl_(std::make_unique<Impl>()) {
  if (!displayUsable()) {
    const char* display = getenv("DISPLAY");
    throw RenderError("no usable X display (DISPLAY=" + std::string(display ? display : "") +
                      "); VTK renders through GLX: run under Xvfb or let depowder-viewer start one (snapshot modes)");
  }
  if (options.width < 16 || options.height < 16 || options.width > 8192 || options.height > 8192)
    throw RenderError("picture size must be 16..8192 pixels a side");
  Impl& d = *impl_;
  d.options = options;
  // Template points lie on the model's surface: push the polygons back so the points win.
  vtkMapper::SetResolveCoincidentTopologyToPolygonOffset();
  d.window->SetOffScreenRendering(options.offscreen ? 1 : 0);
  d.window->SetSize(options.width, options.height);
  d.window->SetWindowName(options.title.c_str());
  d.window->SetMultiSamples(options.offscreen ? 0 : 4);
  d.window->AddRenderer(d.renderer);
  d.renderer->SetBackground(kBackground.r, kBackground.g, kBackground.b);

  vtkCamera* cam = d.renderer->GetActiveCamera();
  cam->SetPosition(options.camera.position.data());
  cam->SetFocalPoint(options.camera.focal_point.data());
  cam->SetViewUp(options.camera.view_up.data());
  cam->SetViewAngle(options.camera.view_angle_deg);
  cam->SetClippingRange(0.01, 20.0);

  d.cloud = makeActor(pointsPolyData({}));
  vtkPolyDataMapper::SafeDownCast(d.cloud->GetMapper())->ScalarVisibilityOn();
  vtkPolyDataMapper::SafeDownCast(d.cloud->GetMapper())->SetColorModeToDirectScalars();
  d.cloud->GetProperty()->SetPointSize(2);
  d.cloud->GetProperty()->LightingOff();
  d.renderer->AddActor(d.cloud);
  d.plan = makeActor(polylinePolyData({}, false));
  setColor(d.plan, kPlan);
  d.plan->GetProperty()->SetLineWidth(2);
  d.plan->GetProperty()->SetPointSize(5);
  d.plan->GetProperty()->LightingOff();
  d.renderer->AddActor(d.plan);
  d.nozzle = makeActor(meshPolyData({}));  // the tool's mesh at the first update
  d.nozzle->GetProperty()->SetAmbient(0.3);
  d.nozzle->GetProperty()->SetOpacity(kToolOpacity);
  d.nozzle->SetVisibility(false);
  d.renderer->AddActor(d.nozzle);

  d.legend = d.makeText(0.8);
  d.legend->SetInput("red estimate  green template  grey truth  orange contour  blue plan");
  d.legend->GetTextProperty()->SetColor(0.7, 0.7, 0.7);
  d.legend->SetDisplayPosition(10, 6);
}

Renderer::~Renderer() = default;

void Renderer::update(const Scene& scene) {
  Impl& d = *impl_;
  const Scene::Versions& v = scene.versions;
  if (d.first || scene.box_size != d.box_size) {
    if (d.box) d.renderer->RemoveActor(d.box);
    d.box = makeActor(boxPolyData(scene.box_size));
    setColor(d.box, kBox);
    d.box->GetProperty()->LightingOff();
    d.renderer->AddActor(d.box);
    d.box_size = scene.box_size;
  }
  if (d.first || v.parts != d.seen.parts || v.templates != d.seen.templates) d.updateParts(scene);
  if (d.first || v.plan != d.seen.plan) d.updateOverlays(scene);
  if (d.first || v.cloud != d.seen.cloud) d.updateCloud(scene);
  if (d.first || v.nozzle != d.seen.nozzle) d.updateNozzle(scene);
  if (d.first || v.text != d.seen.text) d.updateText(scene);
  d.seen = v;
  d.first = false;
}

void Renderer::render() { impl_->window->Render(); }

Image Renderer::capture() {
  Impl& d = *impl_;
  d.window->Render();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(d.window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();
  return toImage(grab->GetOutput());
}

void Renderer::savePng(const std::string& path) {
  const Image img = capture();
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  vtkNew<vtkImageData> data;
  data->SetDimensions(img.width, img.height, 1);
  data->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* dst = static_cast<std::uint8_t*>(data->GetScalarPointer());
  const std::size_t row = 3 * static_cast<std::size_t>(img.width);
  for (int v = 0; v < img.height; ++v) std::memcpy(dst + row * (img.height - 1 - v), img.rgb.data() + row * v, row);
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(path.c_str());
  writer->SetInputData(data);
  writer->Write();
  if (writer->GetErrorCode() != 0 || !std::filesystem::exists(path))
    throw RenderError("could not write " + path + (ec ? " (" + ec.message() + ")" : ""));
}

void Renderer::runInteractive(const std::function<bool()>& tick, int period_ms) {
  Impl& d = *impl_;
  vtkNew<vtkRenderWindowInteractor> interactor;
  vtkNew<vtkInteractorStyleTrackballCamera> style;
  interactor->SetInteractorStyle(style);
  interactor->SetRenderWindow(d.window);
  interactor->Initialize();
  struct Ctx {
    const std::function<bool()>* tick;
    vtkRenderWindowInteractor* interactor;
  } ctx{&tick, interactor};
  vtkNew<vtkCallbackCommand> onTimer;
  onTimer->SetClientData(&ctx);
  onTimer->SetCallback([](vtkObject*, unsigned long, void* client, void*) {
    auto* c = static_cast<Ctx*>(client);
    if (!(*c->tick)()) c->interactor->TerminateApp();
  });
  interactor->AddObserver(vtkCommand::TimerEvent, onTimer);
  interactor->CreateRepeatingTimer(static_cast<unsigned long>(std::max(1, period_ms)));
  d.window->Render();
  interactor->Start();
  // Closing the window leaves it mapped on some window managers: hide it explicitly.
  d.window->Finalize();
}

Image readPng(const std::string& path) {
  if (!std::filesystem::exists(path)) throw RenderError("no such PNG: " + path);
  vtkNew<vtkPNGReader> reader;
  if (!reader->CanReadFile(path.c_str())) throw RenderError("not a PNG: " + path);
  reader->SetFileName(path.c_str());
  reader->Update();
  return toImage(reader->GetOutput());
}

}  // namespace depowder::viewer
