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

/// A collision object owning `geometry` at pose T (AABB computed).
inline FclObject makeObject(std::shared_ptr<FclGeometry> geometry, const Pose& T = Pose::Identity()) {
  FclObject object(std::move(geometry), T);
  object.computeAABB();
  return object;
}

inline void place(FclObject& object, const Pose& T) {
  object.setTransform(T);
  object.computeAABB();
}

/// True if the two objects intersect (AABB test first).
inline bool collide(const FclObject& a, const FclObject& b) {
  if (!a.getAABB().overlap(b.getAABB())) return false;
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  return fcl::collide(&a, &b, request, result) > 0;
}

}  // namespace depowder::planner
