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
  const EmbreeScene::MeshGeometry& data = *static_cast<const EmbreeScene::MeshGeometry*>(args->geometryUserPtr);
  const Scene& scene = *data.scene;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = data.first_triangle + RTCHitN_primID(args->hit, args->N, i);
    if (!scene.alpha_tested(prim)) continue;
    if (!scene.alpha_sample(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)).opaque)
      args->valid[i] = 0;
  }
}
// One triangle geometry of vertices [first_vertex, +vertex_count) and triangles
// [first_triangle, +triangle_count), renumbered from 0, attached as geometry 0.
void attach_triangles(RTCDevice device, RTCScene target, const Scene& scene, uint32_t first_vertex,
                      uint32_t vertex_count, uint32_t first_triangle, uint32_t triangle_count,
                      EmbreeScene::Quality quality, const void* filter_data) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (quality == EmbreeScene::Quality::fast) rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_LOW);
  // Embree reads vertex buffers with 16-byte loads: give it one float of padding.
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), size_t(vertex_count) + 1));
  for (size_t i = 0; i < vertex_count; ++i) {
    const vec3& v = scene.vertices[first_vertex + i];
    vb[3 * i + 0] = v.x;
    vb[3 * i + 1] = v.y;
    vb[3 * i + 2] = v.z;
  }
  vb[3 * size_t(vertex_count) + 0] = vb[3 * size_t(vertex_count) + 1] = vb[3 * size_t(vertex_count) + 2] = 0.0f;
  auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangle_count));
  for (size_t i = 0; i < triangle_count; ++i) {
    const uvec3& t = scene.triangles[first_triangle + i];
    ib[3 * i + 0] = t.x - first_vertex;
    ib[3 * i + 1] = t.y - first_vertex;
    ib[3 * i + 2] = t.z - first_vertex;
  }
  if (scene.alpha_tested_triangles() > 0) {  // the scene outlives this Embree scene
    rtcSetGeometryUserData(geom, const_cast<void*>(filter_data));
    rtcSetGeometryIntersectFilterFunction(geom, alpha_filter);
    rtcSetGeometryOccludedFilterFunction(geom, alpha_filter);
  }
  rtcCommitGeometry(geom);
  rtcAttachGeometryByID(target, geom, 0);
  rtcReleaseGeometry(geom);
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
  source_ = &scene;
  if (!scene.instanced()) {
    mesh_geometry_.push_back({&scene, 0});
    attach_triangles(device_, scene_, scene, 0, uint32_t(scene.vertices.size()), 0,
                     uint32_t(scene.triangles.size()), quality, &mesh_geometry_.back());
  } else {
    mesh_geometry_.reserve(scene.meshes.size());  // the filters point into it
    for (const SceneMesh& mesh : scene.meshes) {
      mesh_geometry_.push_back({&scene, mesh.first_triangle});
      RTCScene part = rtcNewScene(device_);
      rtcSetSceneBuildQuality(part, build_quality);
      rtcSetSceneFlags(part, RTC_SCENE_FLAG_ROBUST);
      if (mesh.triangle_count)
        attach_triangles(device_, part, scene, mesh.first_vertex, mesh.vertex_count, mesh.first_triangle,
                         mesh.triangle_count, quality, &mesh_geometry_.back());
      rtcCommitScene(part);
      mesh_scenes_.push_back(part);
    }
    for (uint32_t i = 0; i < scene.instances.size(); ++i) {
      const Instance& instance = scene.instances[i];
      RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(geom, mesh_scenes_[instance.mesh]);
      rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &instance.object_to_world[0][0]);
      rtcCommitGeometry(geom);
      rtcAttachGeometryByID(scene_, geom, i);
      rtcReleaseGeometry(geom);
    }
  }
  rtcCommitScene(scene_);
  check(device_, "building the Embree scene");
}

EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(scene_);
  for (RTCScene part : mesh_scenes_) rtcReleaseScene(part);
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
    if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
      // Embree 3 reports an instanced hit's normal in object space.
      hit.instance = rh.hit.instID[0];
      hit.prim += mesh_geometry_[source_->instances[hit.instance].mesh].first_triangle;
      hit.geometric_normal = glm::transpose(glm::mat3(source_->world_to_object(hit.instance))) * hit.geometric_normal;
    }
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
