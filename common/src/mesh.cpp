#include "depowder/mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <unordered_map>

#include "depowder/files.hpp"
#include "depowder/ply.hpp"

namespace depowder {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw MeshError("mesh '" + path + "': " + what);
}

// Binary STL: 80-byte header, uint32 count, then 50 bytes a triangle.
bool looksLikeBinaryStl(const std::string& data) {
  if (data.size() < 84) return false;
  std::uint32_t n;
  std::memcpy(&n, data.data() + 80, 4);
  return data.size() == 84 + 50ull * n;
}

Mesh parseBinaryStl(const std::string& path, const std::string& data) {
  std::uint32_t n;
  std::memcpy(&n, data.data() + 80, 4);
  Mesh mesh;
  mesh.vertices.reserve(3ull * n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const char* tri = data.data() + 84 + 50ull * i + 12;  // skip the facet normal
    for (int k = 0; k < 3; ++k) {
      float v[3];
      std::memcpy(v, tri + 12 * k, 12);
      mesh.vertices.emplace_back(v[0], v[1], v[2]);
    }
    const int b = static_cast<int>(3 * i);
    mesh.triangles.emplace_back(b, b + 1, b + 2);
  }
  return mesh;
}

Mesh parseAsciiStl(const std::string& path, const std::string& data) {
  std::istringstream in(data);
  std::string word;
  Mesh mesh;
  int in_facet = 0;
  bool ended = false;
  while (in >> word) {
    if (word == "endsolid") {
      ended = true;
    } else if (word == "vertex") {
      Eigen::Vector3d v;
      if (!(in >> v.x() >> v.y() >> v.z())) fail(path, "malformed ascii STL vertex");
      mesh.vertices.push_back(v);
      ++in_facet;
    } else if (word == "endfacet") {
      if (in_facet != 3) fail(path, "ascii STL facet with " + std::to_string(in_facet) + " vertices");
      const int b = static_cast<int>(mesh.vertices.size()) - 3;
      mesh.triangles.emplace_back(b, b + 1, b + 2);
      in_facet = 0;
    }
  }
  // A file cut short (a copy or transfer that stopped) must not load as a part with facets missing.
  if (in_facet != 0) fail(path, "ascii STL ends inside a facet (truncated?)");
  if (!ended) fail(path, "ascii STL has no 'endsolid' (truncated?)");
  return mesh;
}

// OBJ: "v x y z" and "f a b c ..." (a may be a/b/c or negative); polygons as fans.
Mesh parseObj(const std::string& path, const std::string& data) {
  std::istringstream in(data);
  std::string line;
  Mesh mesh;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      Eigen::Vector3d v;
      if (!(ls >> v.x() >> v.y() >> v.z())) fail(path, "bad vertex on line " + std::to_string(line_no));
      mesh.vertices.push_back(v);
    } else if (tag == "f") {
      std::vector<int> idx;
      std::string tok;
      while (ls >> tok) {
        int i = 0;
        try {
          i = std::stoi(tok.substr(0, tok.find('/')));
        } catch (const std::exception&) {
          fail(path, "bad face index '" + tok + "' on line " + std::to_string(line_no));
        }
        i = i < 0 ? static_cast<int>(mesh.vertices.size()) + i : i - 1;
        if (i < 0 || i >= static_cast<int>(mesh.vertices.size()))
          fail(path, "face index out of range on line " + std::to_string(line_no));
        idx.push_back(i);
      }
      if (idx.size() < 3) fail(path, "face with fewer than 3 vertices on line " + std::to_string(line_no));
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) mesh.triangles.emplace_back(idx[0], idx[k], idx[k + 1]);
    }
  }
  return mesh;
}

}  // namespace

Mesh loadMesh(const std::string& path, double scale) {
  const std::string ext = lowerExtension(path);
  const std::optional<std::string> bytes = readFile(path);
  if (!bytes) fail(path, "cannot open file");
  const std::string& data = *bytes;
  if (data.empty()) fail(path, "file is empty");
  Mesh mesh;
  if (ext == ".stl") {
    if (looksLikeBinaryStl(data))
      mesh = parseBinaryStl(path, data);
    else if (data.rfind("solid", 0) == 0)
      mesh = parseAsciiStl(path, data);
    else
      fail(path, "neither a binary STL (size mismatch) nor an ascii one");
  } else if (ext == ".obj") {
    mesh = parseObj(path, data);
  } else if (ext == ".ply") {
    try {
      PlyData ply = parsePly(data, true);
      mesh.vertices = std::move(ply.vertices);
      mesh.triangles = std::move(ply.triangles);
    } catch (const PlyError& e) {
      fail(path, std::string("PLY: ") + e.what());
    }
  } else {
    fail(path, (ext.empty() ? "no extension" : "unknown extension '" + ext + "'") + " (expected .stl, .obj or .ply)");
  }
  if (mesh.triangles.empty()) fail(path, "no triangles");
  if (!(std::isfinite(scale) && scale > 0.0))
    fail(path, "scale " + std::to_string(scale) + " is not a positive number");
  for (auto& v : mesh.vertices) {
    if (!v.allFinite()) fail(path, "non-finite vertex coordinate");
    v *= scale;
    if (!v.allFinite()) fail(path, "a vertex coordinate overflows once scaled");
  }
  Eigen::Vector3d lo = mesh.vertices.front(), hi = lo;
  for (const auto& v : mesh.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  if (const double across = (hi - lo).maxCoeff(); across > kMaxMeshSize) {
    std::ostringstream s;
    s << "is " << across << " m across at scale " << scale << ", more than any cell's " << kMaxMeshSize
      << " m (a mesh in millimetres wants a scale of 0.001)";
    fail(path, s.str());
  }
  if (surfaceArea(mesh) <= 0.0) fail(path, "all triangles are degenerate (zero area)");
  return mesh;
}

void saveStl(const Mesh& mesh, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw MeshError("mesh '" + path + "': cannot write file");
  char header[80] = "depowder binary STL, metres";
  out.write(header, 80);
  const auto n = static_cast<std::uint32_t>(mesh.triangles.size());
  out.write(reinterpret_cast<const char*>(&n), 4);
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    float rec[12];
    const Eigen::Vector3d nrm = triangleNormal(mesh, i);
    for (int k = 0; k < 3; ++k) rec[k] = static_cast<float>(nrm[k]);
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) rec[3 + 3 * c + k] = static_cast<float>(mesh.vertices[mesh.triangles[i][c]][k]);
    out.write(reinterpret_cast<const char*>(rec), sizeof(rec));
    const std::uint16_t attr = 0;
    out.write(reinterpret_cast<const char*>(&attr), 2);
  }
  if (!out) throw MeshError("mesh '" + path + "': write failed");
}

void append(Mesh& a, const Mesh& b) {
  const int offset = static_cast<int>(a.vertices.size());
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (const auto& t : b.triangles) a.triangles.push_back(t.array() + offset);
}

Mesh transformed(const Mesh& mesh, const Pose& T) {
  Mesh out = mesh;
  for (auto& v : out.vertices) v = T * v;
  return out;
}

Mesh cylinderMesh(double radius, double length, int segments) {
  Mesh m;
  const int n = std::max(3, segments);
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    m.vertices.emplace_back(radius * std::cos(a), radius * std::sin(a), 0.0);      // 2k: at the origin
    m.vertices.emplace_back(radius * std::cos(a), radius * std::sin(a), -length);  // 2k+1: at -length
  }
  const int near = static_cast<int>(m.vertices.size()), far = near + 1;
  m.vertices.emplace_back(0, 0, 0);
  m.vertices.emplace_back(0, 0, -length);
  for (int k = 0; k < n; ++k) {
    const int a0 = 2 * k, a1 = 2 * k + 1, b0 = 2 * ((k + 1) % n), b1 = b0 + 1;
    m.triangles.emplace_back(a0, a1, b1);  // side, facing out
    m.triangles.emplace_back(a0, b1, b0);
    m.triangles.emplace_back(near, a0, b0);  // disc at the origin, facing +z
    m.triangles.emplace_back(far, b1, a1);   // disc at -length, facing -z
  }
  return m;
}

Mesh welded(const Mesh& mesh, double tolerance) {
  // Sorted by position on a grid of `tolerance`, equal neighbours are the same vertex.
  using Key = std::array<double, 3>;
  std::vector<std::pair<Key, int>> keys(mesh.vertices.size());
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const Eigen::Vector3d g = (mesh.vertices[i] / tolerance).array().round();
    keys[i] = {{g.x(), g.y(), g.z()}, static_cast<int>(i)};
  }
  std::sort(keys.begin(), keys.end());
  Mesh out;
  std::vector<int> index(keys.size());
  for (std::size_t k = 0; k < keys.size(); ++k) {
    if (k == 0 || keys[k].first != keys[k - 1].first) out.vertices.push_back(mesh.vertices[keys[k].second]);
    index[keys[k].second] = static_cast<int>(out.vertices.size()) - 1;
  }
  out.triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) out.triangles.emplace_back(index[t[0]], index[t[1]], index[t[2]]);
  return out;
}

std::string closednessProblem(const Mesh& mesh, bool manifold) {
  const auto n = static_cast<std::uint64_t>(mesh.vertices.size());
  std::unordered_map<std::uint64_t, int> uses;  // directed edge a -> b as a * n + b
  uses.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++uses[t[k] * n + t[(k + 1) % 3]];
  auto mm = [&](int v) {
    const Eigen::Vector3d p = 1e3 * mesh.vertices[v];
    std::ostringstream s;
    s.precision(1);
    s << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
    return s.str();
  };
  // A triangle with a repeated vertex adds an edge each way round and bounds nothing: harmless to
  // a solid (CAD exports often have them), not to a manifold.
  if (manifold)
    for (const auto& t : mesh.triangles)
      for (int k = 0; k < 3; ++k)
        if (t[k] == t[(k + 1) % 3]) return "a triangle uses the vertex at " + mm(t[k]) + " mm twice";
  for (const auto& t : mesh.triangles)  // in the triangles' order, so the same edge is named each time
    for (int k = 0; k < 3; ++k) {
      const int a = t[k], b = t[(k + 1) % 3];
      const int forth = uses[a * n + b];
      const auto back = uses.find(b * n + a);
      const int against = back == uses.end() ? 0 : back->second;
      if (forth != against || (manifold && forth != 1))
        return "the edge from " + mm(a) + " to " + mm(b) + " mm is in " + std::to_string(forth) +
               " triangle(s) one way round and " + std::to_string(against) + " the other" +
               (forth == against ? " (more than two faces meet there)"
                                 : " (a hole, or triangles wound against their neighbours)");
    }
  return mesh.triangles.empty() ? "no triangles" : "";
}

std::string solidProblem(const Mesh& mesh) {
  if (const std::string problem = closednessProblem(welded(mesh)); !problem.empty())
    return "not a closed surface: " + problem;
  if (!(volume(mesh) > 0))
    return "wound inward (its volume is not positive): its triangles must turn counter-clockwise seen from outside";
  return "";
}

namespace {
double triangleArea(const Mesh& m, const Eigen::Vector3i& t) {
  return 0.5 * (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]).norm();
}
}  // namespace

double surfaceArea(const Mesh& mesh) {
  double area = 0;
  for (const auto& t : mesh.triangles) area += triangleArea(mesh, t);
  return area;
}

double volume(const Mesh& mesh) {
  double v = 0;
  for (const auto& t : mesh.triangles)
    v += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]])) / 6.0;
  return v;
}

Eigen::AlignedBox3d bounds(const Mesh& mesh) {
  Eigen::AlignedBox3d box;
  for (const auto& v : mesh.vertices) box.extend(v);
  return box;
}

Eigen::Vector3d triangleNormal(const Mesh& mesh, std::size_t i) {
  const auto& t = mesh.triangles[i];
  const Eigen::Vector3d n =
      (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
  const double len = n.norm();
  return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
}

SurfaceSamples sampleSurfaceCount(const Mesh& mesh, std::size_t count, std::uint32_t seed) {
  std::vector<double> cumulative(mesh.triangles.size());
  double total = 0;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    cumulative[i] = total += triangleArea(mesh, mesh.triangles[i]);
  if (total <= 0) throw MeshError("mesh has no surface area to sample");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  SurfaceSamples s;
  s.points.reserve(count);
  s.normals.reserve(count);
  for (std::size_t k = 0; k < count; ++k) {
    const double pick = uniform(rng) * total;
    const std::size_t i = std::min<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin(), cumulative.size() - 1);
    const auto& t = mesh.triangles[i];
    double a = uniform(rng), b = uniform(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;  // fold into the triangle: uniform barycentric
    const auto& v0 = mesh.vertices[t[0]];
    s.points.push_back(v0 + a * (mesh.vertices[t[1]] - v0) + b * (mesh.vertices[t[2]] - v0));
    s.normals.push_back(triangleNormal(mesh, i));
  }
  return s;
}

SurfaceSamples sampleSurface(const Mesh& mesh, double spacing, std::uint32_t seed) {
  const double area = surfaceArea(mesh);
  if (!(spacing > 0)) throw MeshError("sample spacing must be positive");
  return sampleSurfaceCount(mesh, static_cast<std::size_t>(std::ceil(area / (spacing * spacing))), seed);
}

namespace {
// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d closestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}
}  // namespace

double distanceToMesh(const Mesh& mesh, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles)
    best = std::min(best,
                    (p - closestOnTriangle(p, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]])).norm());
  return best;
}

}  // namespace depowder
