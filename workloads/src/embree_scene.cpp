#include <rtsim/workloads/embree_scene.h>

#include <cmath>

#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

namespace rtsim {

namespace {
void report_embree_error(void*, RTCError code, const char* message) {
  // Embree calls this from inside its API; the caller checks rtcGetDeviceError.
  (void)code;
  (void)message;
}

void check(RTCDevice device, const char* what) {
  const RTCError err = rtcGetDeviceError(device);
  if (err != RTC_ERROR_NONE)
    throw std::runtime_error(std::string("Embree error ") + std::to_string(int(err)) + " in " + what);
}
}  // namespace

RTCDevice shared_embree_device() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (!d) throw std::runtime_error("Embree: cannot create a device");
    rtcSetDeviceErrorFunction(d, report_embree_error, nullptr);
    return d;
  }();
  return device;
}

EmbreeScene::EmbreeScene(const Scene& scene, Quality quality) { build(scene, std::string(), quality); }

EmbreeScene::EmbreeScene(const Scene& scene, const std::string& device_config) {
  build(scene, device_config, Quality::oracle);
}

namespace {
// Alpha-tested triangles: Embree offers each hit on one to this filter, which runs
// the scene's own alpha test (Scene::alpha_sample, the model's any-hit stage's
// definition) and rejects the hit where the texel lets the ray through; Embree
// then goes on looking, for the closest accepted hit or any accepted one.
void alpha_filter(const RTCFilterFunctionNArguments* args) {
  const Scene& scene = *static_cast<const Scene*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    if (!scene.alpha_tested(prim)) continue;
    if (!scene.alpha_sample(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)).opaque)
      args->valid[i] = 0;
  }
}
}  // namespace

void EmbreeScene::build(const Scene& scene, const std::string& device_config, Quality quality) {
  if (device_config.empty()) {
    device_ = shared_embree_device();
    rtcRetainDevice(device_);
  } else {
    device_ = rtcNewDevice(device_config.c_str());
    if (!device_) throw std::runtime_error("Embree: cannot create a device with '" + device_config + "'");
    rtcSetDeviceErrorFunction(device_, report_embree_error, nullptr);
  }
  scene_ = rtcNewScene(device_);
  const RTCBuildQuality build_quality =
      quality == Quality::fast ? RTC_BUILD_QUALITY_LOW : RTC_BUILD_QUALITY_HIGH;
  rtcSetSceneBuildQuality(scene_, build_quality);
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (quality == Quality::fast) rtcSetGeometryBuildQuality(geom, build_quality);
  // Embree reads vertex buffers with 16-byte loads: give it one float of padding.
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
      scene.vertices.size() + 1));
  for (size_t i = 0; i < scene.vertices.size(); ++i) {
    vb[3 * i + 0] = scene.vertices[i].x;
    vb[3 * i + 1] = scene.vertices[i].y;
    vb[3 * i + 2] = scene.vertices[i].z;
  }
  vb[3 * scene.vertices.size() + 0] = vb[3 * scene.vertices.size() + 1] =
      vb[3 * scene.vertices.size() + 2] = 0.0f;
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
      scene.triangles.size()));
  for (size_t i = 0; i < scene.triangles.size(); ++i) {
    ib[3 * i + 0] = scene.triangles[i].x;
    ib[3 * i + 1] = scene.triangles[i].y;
    ib[3 * i + 2] = scene.triangles[i].z;
  }
  if (scene.alpha_tested_triangles() > 0) {  // the scene outlives this Embree scene
    rtcSetGeometryUserData(geom, const_cast<Scene*>(&scene));
    rtcSetGeometryIntersectFilterFunction(geom, alpha_filter);
    rtcSetGeometryOccludedFilterFunction(geom, alpha_filter);
  }
  rtcCommitGeometry(geom);
  rtcAttachGeometryByID(scene_, geom, 0);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene_);
  check(device_, "building the Embree scene");
}

EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
}

namespace {
// Embree's ray precondition (RayK::valid: |org|, |dir| <= FLT_LARGE = 1.844e18,
// tnear/tfar not NaN). Its Debian build asserts on it and aborts the process, so
// a ray it cannot take (e.g. an AO ray from a kept 1e30 vertex) is answered here:
// no hit, not occluded.
bool embree_accepts(const vec3& origin, const vec3& direction, float tmin, float tmax) {
  constexpr float kEmbreeLarge = 1.844e18f;
  for (int a = 0; a < 3; ++a)
    if (!(std::fabs(origin[a]) <= kEmbreeLarge) || !(std::fabs(direction[a]) <= kEmbreeLarge))
      return false;  // also false for NaN
  return !std::isnan(tmin) && !std::isnan(tmax);
}
}  // namespace

EmbreeHit EmbreeScene::intersect(const vec3& origin, const vec3& direction, float tmin,
                                 float tmax) const {
  if (!embree_accepts(origin, direction, tmin, tmax)) return EmbreeHit{};
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = origin.x;
  rh.ray.org_y = origin.y;
  rh.ray.org_z = origin.z;
  rh.ray.dir_x = direction.x;
  rh.ray.dir_y = direction.y;
  rh.ray.dir_z = direction.z;
  rh.ray.tnear = tmin;
  rh.ray.tfar = tmax;
  rh.ray.time = 0.0f;
  rh.ray.mask = ~0u;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &context, &rh);
  EmbreeHit hit;
  if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
    hit.hit = true;
    hit.t = rh.ray.tfar;
    hit.prim = rh.hit.primID;
    hit.u = rh.hit.u;
    hit.v = rh.hit.v;
    hit.geometric_normal = vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
  }
  return hit;
}

bool EmbreeScene::occluded(const vec3& origin, const vec3& direction, float tmin,
                           float tmax) const {
  if (!embree_accepts(origin, direction, tmin, tmax)) return false;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = origin.x;
  ray.org_y = origin.y;
  ray.org_z = origin.z;
  ray.dir_x = direction.x;
  ray.dir_y = direction.y;
  ray.dir_z = direction.z;
  ray.tnear = tmin;
  ray.tfar = tmax;
  ray.time = 0.0f;
  ray.mask = ~0u;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(scene_, &context, &ray);
  return ray.tfar == -std::numeric_limits<float>::infinity();
}

}  // namespace rtsim
