#include "depowder/planner/check.hpp"

#include <fcl/fcl.h>

#include <algorithm>
#include <memory>

namespace depowder::planner {

namespace {

using Object = fcl::CollisionObjectd;

std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> bvhOf(const Mesh& mesh) {
  auto m = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  std::vector<fcl::Vector3d> v(mesh.vertices.begin(), mesh.vertices.end());
  std::vector<fcl::Triangle> t;
  for (const auto& tri : mesh.triangles) t.emplace_back(tri[0], tri[1], tri[2]);
  m->beginModel();
  m->addSubModel(v, t);
  m->endModel();
  return m;
}

/// Distance between two objects; <= 0 when they touch. Pairs whose bounding boxes are more
/// than kFar apart are not measured (reported as kFar): only near misses matter here.
constexpr double kFar = 0.05;
double distanceBetween(Object a, Object b) {
  a.computeAABB();
  b.computeAABB();
  if (a.getAABB().distance(b.getAABB()) > kFar) return kFar;
  fcl::CollisionRequestd creq;
  fcl::CollisionResultd cres;
  if (fcl::collide(&a, &b, creq, cres) > 0) return 0;
  fcl::DistanceRequestd req;
  fcl::DistanceResultd res;
  return fcl::distance(&a, &b, req, res);
}

}  // namespace

CheckReport checkWaypoints(const std::vector<Waypoint>& waypoints, const std::vector<TruePart>& parts, const Box& box,
                           const robot::ArmConfig& arm, const NozzleConfig& nozzle, bool include_arm) {
  std::vector<std::pair<std::string, Object>> part_objects, box_objects;
  for (const TruePart& p : parts) part_objects.emplace_back("part:" + p.name, Object(bvhOf(p.mesh), p.T_cell_part));
  // The box: four walls and the floor, each box.wall thick, outside the interior.
  const Eigen::Vector3d s = box.size;
  const double t = box.wall;
  auto slab = [&](const std::string& name, double sx, double sy, double sz, const Eigen::Vector3d& c) {
    Pose T = Pose::Identity();
    T.translation() = c;
    box_objects.emplace_back(name, Object(std::make_shared<fcl::Boxd>(sx, sy, sz), T));
  };
  slab("wall", t, s.y() + 2 * t, s.z() + t, {0.5 * (s.x() + t), 0, 0.5 * (s.z() - t)});
  slab("wall", t, s.y() + 2 * t, s.z() + t, {-0.5 * (s.x() + t), 0, 0.5 * (s.z() - t)});
  slab("wall", s.x() + 2 * t, t, s.z() + t, {0, 0.5 * (s.y() + t), 0.5 * (s.z() - t)});
  slab("wall", s.x() + 2 * t, t, s.z() + t, {0, -0.5 * (s.y() + t), 0.5 * (s.z() - t)});
  slab("floor", s.x() + 2 * t, s.y() + 2 * t, t, {0, 0, -0.5 * t});

  // The arm as capsules, the end effector's cylinder on the flange, and the nozzle cylinder.
  struct Link {
    std::string name;
    int link;
    Pose T_link_capsule;
    std::shared_ptr<fcl::CollisionGeometryd> shape;
  };
  std::vector<Link> links;
  for (const EffectorBody& e : effectorBodies(arm.effector, arm.T_flange_nozzle))
    links.push_back({"effector", 6, e.T_flange_body, std::make_shared<fcl::Cylinderd>(e.radius, e.length)});
  for (const robot::LinkCapsule& c : robot::linkCapsules())
    links.push_back(
        {c.name, c.link, segmentFrame(c.p0, c.p1), std::make_shared<fcl::Capsuled>(c.radius, (c.p1 - c.p0).norm())});
  const double body = std::max(nozzle.length, arm.T_flange_nozzle.translation().norm());
  auto cylinder = std::make_shared<fcl::Cylinderd>(nozzle.radius, body);
  Pose T_nozzle_cylinder = Pose::Identity();
  T_nozzle_cylinder.translation() = Eigen::Vector3d(0, 0, -0.5 * body);

  CheckReport r;
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    const Waypoint& w = waypoints[i];
    ++r.waypoints;
    const Pose fk = robot::forwardNozzle(arm, w.q);
    if ((fk.translation() - w.T_cell_nozzle.translation()).norm() > 1e-3 ||
        rotationAngle(fk.linear(), w.T_cell_nozzle.linear()) > 0.01)
      ++r.ik_mismatch;
    std::string hit;
    const Object n(cylinder, w.T_cell_nozzle * T_nozzle_cylinder);
    for (const auto& [name, o] : part_objects) {
      const double d = distanceBetween(n, o);
      r.min_nozzle_part = std::min(r.min_nozzle_part, d);
      if (d <= 0 && hit.empty()) hit = "nozzle-" + name;
    }
    for (const auto& [name, o] : box_objects) {
      const double d = distanceBetween(n, o);
      r.min_to_box = std::min(r.min_to_box, d);
      if (d <= 0 && hit.empty()) hit = "nozzle-" + name;
    }
    if (include_arm) {
      const std::vector<Pose> poses = robot::linkPoses(w.q);
      for (const Link& l : links) {
        const Object o(l.shape, arm.T_cell_base * poses[l.link] * l.T_link_capsule);
        for (const auto& [name, p] : part_objects) {
          const double d = distanceBetween(o, p);
          r.min_arm_part = std::min(r.min_arm_part, d);
          if (d <= 0 && hit.empty()) hit = l.name + "-" + name;
        }
        for (const auto& [name, b] : box_objects) {
          const double d = distanceBetween(o, b);
          r.min_to_box = std::min(r.min_to_box, d);
          if (d <= 0 && hit.empty()) hit = l.name + "-" + name;
        }
      }
    }
    if (!hit.empty()) {
      ++r.in_collision;
      r.colliding.push_back(static_cast<int>(i));
      if (r.first.empty()) r.first = "waypoint " + std::to_string(i) + ": " + hit;
    }
  }
  return r;
}

}  // namespace depowder::planner
