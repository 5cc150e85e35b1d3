// Ray tracing with Embree: a triangle mesh as a RayScene for captures (occlusion, and the
// emission of emitters hit).
#pragma once

#include <memory>

#include "basis/lighting/mesh.h"
#include "basis/lighting/ray_scene.h"

namespace basis {

class EmbreeScene : public RayScene {
 public:
  // Builds the acceleration structure. Throws std::runtime_error if Embree fails.
  explicit EmbreeScene(const TriangleMesh& mesh);
  ~EmbreeScene() override;
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // Rays start at their origin (tnear 0) and run to infinity. Thread-safe. Flush-to-zero and
  // denormals-are-zero are on while a call traces, as Embree expects, and the calling thread's
  // own modes are restored when it returns. `hits` must hold at least as many entries as `rays`
  // (std::invalid_argument otherwise).
  void trace(std::span<const Ray> rays, std::span<RayHit> hits) const override;
  void trace_nearest(std::span<const Ray> rays, std::span<RayHit> hits) const override;
  void intersect(std::span<const Ray> rays, std::span<RayIntersection> hits) const override;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace basis
