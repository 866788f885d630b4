// FCL helpers shared inside the planner library (kept out of the public headers).
#pragma once

#include <fcl/fcl.h>

#include <memory>

#include "depowder/mesh.hpp"
#include "depowder/planner/collision.hpp"

namespace depowder::planner {

using FclGeometry = fcl::CollisionGeometryd;
using FclObject = fcl::CollisionObjectd;
using FclMesh = fcl::BVHModel<fcl::OBBRSSd>;

struct PartShape::Impl {
  std::shared_ptr<FclMesh> bvh;
};

/// A BVH of the mesh's triangles (part frame).
std::shared_ptr<FclMesh> makeBvh(const Mesh& mesh);

/// `geometry` with its local bounding box computed: done once, where it is made. Placing it
/// afterwards only reads it.
template <class G>
std::shared_ptr<G> prepared(std::shared_ptr<G> geometry) {
  geometry->computeLocalAABB();
  return geometry;
}

/// A prepared geometry at pose T, with its bounding box in the cell: what collide() takes.
/// Not an fcl::CollisionObject: that one's constructor recomputes the local bounding box of the
/// geometry it is given, a write into a geometry that the planner's edge-checking threads share.
struct Placed {
  std::shared_ptr<const FclGeometry> geometry;
  fcl::Transform3d T = fcl::Transform3d::Identity();
  fcl::AABBd aabb;
};

inline Placed place(std::shared_ptr<const FclGeometry> geometry, const Pose& T = Pose::Identity()) {
  Placed p{std::move(geometry), T, {}};
  // As fcl::CollisionObject::computeAABB.
  if (T.linear().isIdentity()) {
    p.aabb = fcl::translate(p.geometry->aabb_local, T.translation());
  } else {
    const fcl::Vector3d centre = T * p.geometry->aabb_center;
    const fcl::Vector3d delta = fcl::Vector3d::Constant(p.geometry->aabb_radius);
    p.aabb.min_ = centre - delta;
    p.aabb.max_ = centre + delta;
  }
  return p;
}

/// True if the two intersect (bounding boxes first).
inline bool collide(const Placed& a, const Placed& b) {
  if (!a.aabb.overlap(b.aabb)) return false;
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  return fcl::collide(a.geometry.get(), a.T, b.geometry.get(), b.T, request, result) > 0;
}

}  // namespace depowder::planner
