// A compressed model inside a host ray tracer: one Embree 3 user geometry whose intersect
// callback asks sspc::RenderScene::intersect (include/sspc/render.hpp) for the first hit on the
// model's MLS surface, decoding the bricks each ray reaches. Embree's user geometries are
// described in its API manual, "RTC_GEOMETRY_TYPE_USER" and "rtcSetGeometryIntersectFunction".
//
//   sspc_embree_example MODEL.sspc OUT.png [SIZE]
//
// renders the model from the camera `sspc render` frames it with, primary rays through
// rtcIntersect1 on image tiles in parallel, shaded as `sspc render --shade lambert` shades, so
// that `sspc render MODEL.sspc -o ref.png --size SIZExSIZE --compare OUT.png` compares the two
// pixel for pixel (the test `example.embree` does). Built as `sspc_embree_example` when CMake
// finds Embree 3.
#include <embree3/rtcore.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <string>

#include <sspc/compressed_model.hpp>
#include <sspc/render.hpp>

namespace {

// What the callbacks reach through the geometry's user pointer. Embree's callbacks return
// nothing, so a failed intersect (corrupt model data) is kept here and reported after the frame.
struct SspcGeometry {
  const sspc::RenderScene* scene = nullptr;
  std::mutex mutex;
  std::string error;

  void fail(const sspc::Status& status) {
    std::lock_guard lock(mutex);
    if (error.empty()) error = status.to_string();
  }
};

// The one primitive's box: surface_bounds(), which holds every hit intersect() can return.
// Embree never calls back for a ray that misses it, and bounds(), the points' box, would lose
// the surface that reaches beyond the last points.
void bounds(const RTCBoundsFunctionArguments* args) {
  const auto* geometry = static_cast<const SspcGeometry*>(args->geometryUserPtr);
  const sspc::Box3f box = geometry->scene->surface_bounds();
  *args->bounds_o = RTCBounds{box.min().x(), box.min().y(), box.min().z(), 0,
                              box.max().x(), box.max().y(), box.max().z(), 0};
}

// Called for a packet of N rays (1 from rtcIntersect1; 4, 8 or 16 from rtcIntersect4/8/16), the
// ray and hit fields stored as structures of arrays; valid[i] is -1 for the rays to trace.
void intersect(const RTCIntersectFunctionNArguments* args) {
  auto* geometry = static_cast<SspcGeometry*>(args->geometryUserPtr);
  RTCRayN* rays = RTCRayHitN_RayN(args->rayhit, args->N);
  RTCHitN* hits = RTCRayHitN_HitN(args->rayhit, args->N);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned n = args->N;
    const sspc::Vec3f origin(RTCRayN_org_x(rays, n, i), RTCRayN_org_y(rays, n, i), RTCRayN_org_z(rays, n, i));
    const sspc::Vec3f direction(RTCRayN_dir_x(rays, n, i), RTCRayN_dir_y(rays, n, i), RTCRayN_dir_z(rays, n, i));
    // [tnear, tfar]: tfar is already the nearest hit of any other geometry, so a hit behind it
    // is not looked for.
    const auto hit = geometry->scene->intersect(origin, direction, RTCRayN_tnear(rays, n, i), RTCRayN_tfar(rays, n, i));
    if (!hit.ok()) {
      geometry->fail(hit.status());
      continue;
    }
    if (!hit->has_value()) continue;
    const sspc::RayHit& h = **hit;
    RTCRayN_tfar(rays, n, i) = h.t;
    RTCHitN_Ng_x(hits, n, i) = h.normal.x();
    RTCHitN_Ng_y(hits, n, i) = h.normal.y();
    RTCHitN_Ng_z(hits, n, i) = h.normal.z();
    RTCHitN_u(hits, n, i) = 0;
    RTCHitN_v(hits, n, i) = 0;
    RTCHitN_primID(hits, n, i) = args->primID;
    RTCHitN_geomID(hits, n, i) = args->geomID;
    RTCHitN_instID(hits, n, i, 0) = args->context->instID[0];
  }
}

// Shadow rays (rtcOccluded1): any hit in [tnear, tfar] occludes, marked by tfar = -inf.
void occluded(const RTCOccludedFunctionNArguments* args) {
  auto* geometry = static_cast<SspcGeometry*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned n = args->N;
    const sspc::Vec3f origin(RTCRayN_org_x(args->ray, n, i), RTCRayN_org_y(args->ray, n, i), RTCRayN_org_z(args->ray, n, i));
    const sspc::Vec3f direction(RTCRayN_dir_x(args->ray, n, i), RTCRayN_dir_y(args->ray, n, i),
                                RTCRayN_dir_z(args->ray, n, i));
    const auto hit = geometry->scene->intersect(origin, direction, RTCRayN_tnear(args->ray, n, i),
                                                RTCRayN_tfar(args->ray, n, i));
    if (!hit.ok()) geometry->fail(hit.status());
    if (hit.ok() && hit->has_value()) RTCRayN_tfar(args->ray, n, i) = -std::numeric_limits<float>::infinity();
  }
}

int fail(const std::string& message) {
  std::fprintf(stderr, "sspc_embree_example: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: sspc_embree_example MODEL.sspc OUT.png [SIZE]\n");
    return 2;
  }
  const int size = argc > 3 ? std::atoi(argv[3]) : 512;
  if (size < 1 || size > 16384) return fail("SIZE must be 1..16384 pixels");
  auto model = sspc::CompressedModel::open(argv[1]);
  if (!model.ok()) return fail(model.status().to_string());
  auto scene = sspc::RenderScene::from_compressed(std::make_shared<const sspc::CompressedModel>(std::move(model).value()));
  if (!scene.ok()) return fail(scene.status().to_string());

  // One user geometry of one primitive: the whole model. Embree's BVH then only culls the rays
  // that miss its box; sspc's own brick grid does the rest.
  RTCDevice device = rtcNewDevice(nullptr);
  if (device == nullptr) return fail("rtcNewDevice failed");
  SspcGeometry user;
  user.scene = scene->get();
  RTCScene rtc_scene = rtcNewScene(device);
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  rtcSetGeometryUserPrimitiveCount(geometry, 1);
  rtcSetGeometryUserData(geometry, &user);
  rtcSetGeometryBoundsFunction(geometry, bounds, nullptr);
  rtcSetGeometryIntersectFunction(geometry, intersect);
  rtcSetGeometryOccludedFunction(geometry, occluded);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(rtc_scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(rtc_scene);

  // sspc render's camera: frame_bounds() of the scene, and its pinhole (src/render/camera.cpp):
  // the ray through pixel centre (x + ½, y + ½) of an image plane at distance 1, y down.
  const sspc::Camera camera = sspc::frame_bounds((*scene)->bounds());
  const sspc::Vec3f forward = (camera.target - camera.eye).normalized();
  const sspc::Vec3f right = forward.cross(camera.up).normalized();
  const sspc::Vec3f down = forward.cross(right);
  const float scale =
      2.0f * std::tan(0.5f * camera.fov_degrees * std::numbers::pi_v<float> / 180.0f) / static_cast<float>(size);
  sspc::Image image;
  image.width = image.height = size;
  image.rgb.assign(3 * static_cast<std::size_t>(size) * static_cast<std::size_t>(size), 0);

  // Tiles of 16 × 16 pixels in parallel; each pixel is written once, so the image does not
  // depend on the thread count.
  tbb::parallel_for(tbb::blocked_range2d<int>(0, size, 16, 0, size, 16), [&](const tbb::blocked_range2d<int>& tile) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (int y = tile.rows().begin(); y < tile.rows().end(); ++y) {
      for (int x = tile.cols().begin(); x < tile.cols().end(); ++x) {
        const float u = (static_cast<float>(x) + 0.5f - 0.5f * static_cast<float>(size)) * scale;
        const float v = (static_cast<float>(y) + 0.5f - 0.5f * static_cast<float>(size)) * scale;
        const sspc::Vec3f d = (forward + u * right + v * down).normalized();
        RTCRayHit rayhit{};
        rayhit.ray = RTCRay{camera.eye.x(), camera.eye.y(), camera.eye.z(), 0, d.x(), d.y(), d.z(), 0,
                            std::numeric_limits<float>::infinity(), ~0u, 0, 0};
        rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(rtc_scene, &context, &rayhit);
        if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;  // black: what sspc leaves a miss
        // sspc's Lambert shading: a headlight at the eye, |n · d| whichever way n points.
        const sspc::Vec3f n(rayhit.hit.Ng_x, rayhit.hit.Ng_y, rayhit.hit.Ng_z);
        const float lambert = 0.15f + 0.85f * std::abs(n.dot(d));
        const auto byte = static_cast<std::uint8_t>(std::clamp(lambert, 0.0f, 1.0f) * 255.0f + 0.5f);
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size) + static_cast<std::size_t>(x);
        std::fill_n(image.rgb.begin() + static_cast<std::ptrdiff_t>(3 * i), 3, byte);
      }
    }
  });
  rtcReleaseScene(rtc_scene);
  rtcReleaseDevice(device);
  if (!user.error.empty()) return fail(user.error);
  if (const sspc::Status s = sspc::write_png(image, argv[2]); !s.ok()) return fail(s.to_string());
  std::printf("%s: %dx%d -> %s\n", argv[1], size, size, argv[2]);
  return 0;
}
