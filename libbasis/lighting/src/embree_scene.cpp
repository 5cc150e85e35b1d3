#include "basis/lighting/embree_scene.h"

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace basis {

struct EmbreeScene::State {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<Color> emission;
  bool emitters = false;
};

namespace {

void throw_device_error(RTCDevice device, const char* what) {
  throw std::runtime_error(std::string("Embree: ") + what + " (error " +
                           std::to_string(int(rtcGetDeviceError(device))) + ")");
}

}  // namespace

EmbreeScene::EmbreeScene(const TriangleMesh& mesh) : state_(std::make_unique<State>()) {
  state_->device = rtcNewDevice("verbose=0");
  if (!state_->device) throw std::runtime_error("Embree: cannot create a device");
  state_->scene = rtcNewScene(state_->device);
  rtcSetSceneBuildQuality(state_->scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(state_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0,
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                               mesh.vertices.size()));
  auto* indices = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                              3 * sizeof(unsigned), mesh.triangles.size()));
  if (!vertices || !indices) throw_device_error(state_->device, "cannot allocate the mesh");
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k)
      vertices[3 * i + k] = mesh.vertices[i][k];
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      indices[3 * t + k] = mesh.triangles[t][k];
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(state_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(state_->scene);
  if (rtcGetDeviceError(state_->device) != RTC_ERROR_NONE)
    throw_device_error(state_->device, "cannot build the scene");
  state_->emission = mesh.emission;
  state_->emitters = mesh.has_emitters();
}

EmbreeScene::~EmbreeScene() {
  if (state_->scene) rtcReleaseScene(state_->scene);
  if (state_->device) rtcReleaseDevice(state_->device);
}

namespace {

RTCRay embree_ray(const Ray& r, unsigned id) {
  RTCRay q;
  q.org_x = float(r.origin.x());
  q.org_y = float(r.origin.y());
  q.org_z = float(r.origin.z());
  q.dir_x = float(r.direction.x());
  q.dir_y = float(r.direction.y());
  q.dir_z = float(r.direction.z());
  q.tnear = 0;
  q.tfar = std::numeric_limits<float>::infinity();
  q.time = 0;
  q.mask = ~0u;
  q.id = id;
  q.flags = 0;
  return q;
}

constexpr std::size_t kBatch = 256;

void check_room(std::size_t rays, std::size_t hits) {
  if (hits < rays)
    throw std::invalid_argument("tracing " + std::to_string(rays) + " rays into room for " +
                                std::to_string(hits) + " hits");
}

// Flush-to-zero and denormals-are-zero, as Embree asks for while it traces, in this thread until
// the scope ends; then the caller's two modes again (a program's own arithmetic, NumPy's from
// Python, keeps its subnormals).
class FlushDenormalsWhileTracing {
 public:
  FlushDenormalsWhileTracing() : saved_(_mm_getcsr() & kModes) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  }
  ~FlushDenormalsWhileTracing() { _mm_setcsr((_mm_getcsr() & ~kModes) | saved_); }
  FlushDenormalsWhileTracing(const FlushDenormalsWhileTracing&) = delete;
  FlushDenormalsWhileTracing& operator=(const FlushDenormalsWhileTracing&) = delete;

 private:
  static constexpr unsigned kModes = _MM_FLUSH_ZERO_MASK | _MM_DENORMALS_ZERO_MASK;
  unsigned saved_;
};

// Calls found(index, hit) for every ray with its nearest hit (geomID invalid when it escapes).
template <typename Found>
void intersect_batches(RTCScene scene, std::span<const Ray> rays, Found&& found) {
  const FlushDenormalsWhileTracing mode;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  std::vector<RTCRayHit> batch(kBatch);
  for (std::size_t start = 0; start < rays.size(); start += kBatch) {
    const std::size_t count = std::min(kBatch, rays.size() - start);
    for (std::size_t i = 0; i < count; ++i) {
      batch[i].ray = embree_ray(rays[start + i], unsigned(i));
      batch[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
      batch[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect1M(scene, &context, batch.data(), unsigned(count), sizeof(RTCRayHit));
    for (std::size_t i = 0; i < count; ++i)
      found(start + i, batch[i]);
  }
}

}  // namespace

void EmbreeScene::trace(std::span<const Ray> rays, std::span<RayHit> hits) const {
  check_room(rays.size(), hits.size());
  if (state_->emitters) return trace_nearest(rays, hits);
  const FlushDenormalsWhileTracing mode;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay batch[kBatch];
  for (std::size_t start = 0; start < rays.size(); start += kBatch) {
    const std::size_t count = std::min(kBatch, rays.size() - start);
    for (std::size_t i = 0; i < count; ++i)
      batch[i] = embree_ray(rays[start + i], unsigned(i));
    rtcOccluded1M(state_->scene, &context, batch, unsigned(count), sizeof(RTCRay));
    for (std::size_t i = 0; i < count; ++i)
      hits[start + i] = {batch[i].tfar < 0, {0, 0, 0}};
  }
}

void EmbreeScene::trace_nearest(std::span<const Ray> rays, std::span<RayHit> hits) const {
  check_room(rays.size(), hits.size());
  intersect_batches(state_->scene, rays, [&](std::size_t i, const RTCRayHit& q) {
    const bool hit = q.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    hits[i] = {hit, hit ? state_->emission[q.hit.primID] : Color{0, 0, 0},
               hit ? q.ray.tfar : std::numeric_limits<float>::infinity()};
  });
}

void EmbreeScene::intersect(std::span<const Ray> rays, std::span<RayIntersection> hits) const {
  check_room(rays.size(), hits.size());
  intersect_batches(state_->scene, rays, [&](std::size_t i, const RTCRayHit& q) {
    if (q.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
      hits[i] = {};
      return;
    }
    hits[i] = {true, q.ray.tfar, q.hit.primID, q.hit.u, q.hit.v};
  });
}

}  // namespace basis
