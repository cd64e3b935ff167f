#pragma once
/// The Embree vessel-mesh projector (target gimm::embree): per detector pixel, the exact chord
/// length (mm) of the pixel's ray through a closed vessel mesh, the depth of the first surface
/// hit (mm along the ray, +inf on a miss), and the number of separate vessel passages along the
/// ray (the overlap count: 2 where two vessels overlap in the image).
///
/// Chords come from the signed crossings of the ray with the surface: entering (ray against the
/// outward normal) raises the inside-depth by one, leaving lowers it; length is accumulated
/// while the depth is positive. This survives a ray that grazes an edge (two hits at one t) or
/// starts inside the mesh. Each ray is traced by repeated rtcIntersect1 calls, each starting just
/// past the previous hit.
/// Thread safety: project() may be called from several threads; the committed scene is
/// read-only. The projector owns its Embree device and scene (move-only).
#include <embree3/rtcore.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "gimm/anatomy/vessel_mesh.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/render/ray_volume.hpp"
#include "gimm/render/vessel_surface.hpp"

namespace gimm {

struct MeshRayResult {
  float chord_mm = 0.0f;                                        ///< length inside the mesh
  float first_hit_mm = std::numeric_limits<float>::infinity();  ///< depth of the first hit
  std::uint8_t passages = 0;                                    ///< separate inside intervals
};

class VesselMeshProjector final : public VesselSurface {
 public:
  explicit VesselMeshProjector(const TriangleMesh& mesh) {
    check_mesh(mesh);  // before any Embree object exists, so a bad mesh allocates nothing
    device_.reset(rtcNewDevice("threads=1"));  // gimm parallelises over rays itself (OpenMP)
    GIMM_CHECK(device_ != nullptr, "VesselMeshProjector: Embree device creation failed (error "
                                       << rtcGetDeviceError(nullptr) << ")");
    scene_.reset(rtcNewScene(device_.get()));
    // Robust: watertight, no ray slips through an edge. Context filter: trace() gathers hits.
    rtcSetSceneFlags(scene_.get(), RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    attach_triangles(mesh);
    triangles_ = mesh.triangles;
    rtcCommitScene(scene_.get());
    GIMM_CHECK(rtcGetDeviceError(device_.get()) == RTC_ERROR_NONE,
               "VesselMeshProjector: Embree scene build failed");
  }
  VesselMeshProjector(const VesselMeshProjector&) = delete;
  VesselMeshProjector& operator=(const VesselMeshProjector&) = delete;
  VesselMeshProjector(VesselMeshProjector&&) noexcept = default;
  VesselMeshProjector& operator=(VesselMeshProjector&&) noexcept = default;

  /// Traces one world ray (unit direction, s in mm from its origin, s >= 0), up to
  /// `max_distance` mm (a passage still open there counts up to that point).
  /// One traversal gathers every crossing (an intersection filter that records and rejects
  /// each hit); crossings are sorted, and a crossing reported twice - through an edge or
  /// vertex shared by two triangles, the same facing within 1 um - is counted once. Stepping
  /// past each hit instead skipped distinct crossings closer than the step: where a branch
  /// leaves its parent two walls are crossed 0.8 um apart (tube meshes), and a lost exit left
  /// the ray "inside" to the end (chord 0).
  MeshRayResult trace(const Ray<double>& ray,
                      double max_distance = std::numeric_limits<double>::infinity()) const {
    thread_local std::vector<Crossing> crossings;
    crossings.clear();
    Collector collector;
    rtcInitIntersectContext(&collector.context);
    collector.context.filter = &Collector::collect;
    collector.crossings = &crossings;
    RTCRayHit hit{};
    hit.ray.org_x = static_cast<float>(ray.origin.x());
    hit.ray.org_y = static_cast<float>(ray.origin.y());
    hit.ray.org_z = static_cast<float>(ray.origin.z());
    hit.ray.dir_x = static_cast<float>(ray.direction.x());
    hit.ray.dir_y = static_cast<float>(ray.direction.y());
    hit.ray.dir_z = static_cast<float>(ray.direction.z());
    hit.ray.tnear = 0.0f;
    hit.ray.tfar = static_cast<float>(std::min(max_distance, 1e30));
    hit.ray.mask = 0xFFFFFFFFu;
    hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_.get(), &collector.context, &hit);  // every hit is rejected: none left
    std::sort(crossings.begin(), crossings.end(),
              [](const Crossing& x, const Crossing& y) { return x.t < y.t; });
    MeshRayResult out;
    int depth = 0;
    double inside_since = 0.0;
    for (std::size_t c = 0; c < crossings.size(); ++c) {
      if (repeats_earlier(crossings, c)) continue;
      const Crossing& x = crossings[c];
      out.first_hit_mm = std::min(out.first_hit_mm, static_cast<float>(x.t));
      // Embree's Ng follows the right-hand rule of (v0, v1, v2): outward for our meshes.
      if (x.facing < 0) {
        if (depth++ == 0) {
          inside_since = x.t;
          if (out.passages < 255) ++out.passages;
        }
      } else if (x.facing > 0 && depth > 0) {
        if (--depth == 0) out.chord_mm += static_cast<float>(x.t - inside_since);
      }
    }
    if (depth > 0 && std::isfinite(max_distance))
      out.chord_mm += static_cast<float>(max_distance - inside_since);
    return out;
  }

  /// Whether world point X (inside or near a vessel) is seen by `camera` without another
  /// vessel passage in front of it: at most one passage (its own) between the source and X.
  bool unoccluded(const Camerad& camera, const Eigen::Vector3d& X) const override {
    const Eigen::Vector2d uv = camera.project(X).uv;
    const Ray<double> ray = camera.ray(uv.x(), uv.y());
    const double distance = (X - ray.origin).dot(ray.direction);
    return distance <= 0 || trace(ray, distance).passages <= 1;
  }

  /// All detector pixels of `camera`, multithreaded over rows, deterministic.
  VesselProjection project(const Camerad& camera) const override {
    VesselProjection out{
        Image<float>(camera.rows(), camera.cols(), 0.0f),
        Image<float>(camera.rows(), camera.cols(), std::numeric_limits<float>::infinity()),
        Image<std::uint8_t>(camera.rows(), camera.cols(), 0)};
    const RayGenerator rays(camera);
    parallel_for_dynamic(0, camera.rows(), 4, [&](std::int64_t row) {
      for (int col = 0; col < camera.cols(); ++col) {
        const MeshRayResult r = trace(rays(col, static_cast<double>(row)));
        out.chord_mm(static_cast<int>(row), col) = r.chord_mm;
        out.first_hit_mm(static_cast<int>(row), col) = r.first_hit_mm;
        out.passages(static_cast<int>(row), col) = r.passages;
      }
    });
    return out;
  }

 private:
  struct Crossing {
    double t;
    double facing;  ///< geometric normal . ray direction: < 0 entering, > 0 leaving
    unsigned triangle;
  };

  /// An intersect context that records every candidate hit and rejects it, so Embree goes on.
  struct Collector {
    RTCIntersectContext context;  // first: Embree passes a pointer to it back to `collect`
    std::vector<Crossing>* crossings = nullptr;
    static void collect(const RTCFilterFunctionNArguments* args) {
      const auto* self = reinterpret_cast<const Collector*>(args->context);
      const RTCRay ray = rtcGetRayFromRayN(args->ray, args->N, 0);
      const RTCHit h = rtcGetHitFromHitN(args->hit, args->N, 0);
      self->crossings->push_back(
          {static_cast<double>(ray.tfar),
           double(h.Ng_x) * ray.dir_x + double(h.Ng_y) * ray.dir_y + double(h.Ng_z) * ray.dir_z,
           h.primID});
      args->valid[0] = 0;
    }
  };

  /// Whether crossing c is one already counted: an earlier one within 1 um, facing the same
  /// way, on a triangle sharing a vertex with c's (the ray went through their edge or vertex).
  bool repeats_earlier(const std::vector<Crossing>& crossings, std::size_t c) const {
    const Crossing& x = crossings[c];
    for (std::size_t e = c; e-- > 0 && x.t - crossings[e].t < 1e-3;) {
      const Crossing& y = crossings[e];
      if ((y.facing < 0) != (x.facing < 0)) continue;
      const auto& a = triangles_[x.triangle];
      const auto& b = triangles_[y.triangle];
      for (const auto va : a)
        for (const auto vb : b)
          if (va == vb) return true;
    }
    return false;
  }

  static void check_mesh(const TriangleMesh& mesh) {
    GIMM_CHECK(!mesh.triangles.empty(), "VesselMeshProjector: the vessel mesh is empty");
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
      for (int a = 0; a < 3; ++a)
        GIMM_CHECK(mesh.triangles[t][a] < mesh.vertices.size(),
                   "VesselMeshProjector: triangle " << t << " indexes vertex "
                                                    << mesh.triangles[t][a] << " of "
                                                    << mesh.vertices.size());
  }

  void attach_triangles(const TriangleMesh& mesh) {
    const std::unique_ptr<RTCGeometryTy, GeometryRelease> geometry(
        rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE));
    GIMM_CHECK(geometry != nullptr, "VesselMeshProjector: Embree geometry creation failed");
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), mesh.vertices.size()));
    auto* indices = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), mesh.triangles.size()));
    GIMM_CHECK(vertices && indices, "VesselMeshProjector: Embree buffer allocation failed");
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
      for (int a = 0; a < 3; ++a) vertices[3 * v + a] = mesh.vertices[v][a];
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
      for (int a = 0; a < 3; ++a) indices[3 * t + a] = mesh.triangles[t][a];
    rtcCommitGeometry(geometry.get());
    rtcAttachGeometry(scene_.get(), geometry.get());  // the scene holds its own reference
  }

  // Owning handles: a constructor that throws half-way still releases what it made, and
  // the scene (declared last) is released before its device.
  struct DeviceRelease {
    void operator()(RTCDevice d) const { rtcReleaseDevice(d); }
  };
  struct SceneRelease {
    void operator()(RTCScene s) const { rtcReleaseScene(s); }
  };
  struct GeometryRelease {
    void operator()(RTCGeometry g) const { rtcReleaseGeometry(g); }
  };
  std::unique_ptr<RTCDeviceTy, DeviceRelease> device_;
  std::unique_ptr<RTCSceneTy, SceneRelease> scene_;
  std::vector<std::array<std::uint32_t, 3>> triangles_;  ///< to tell a repeated crossing
};

/// The Embree surface of a binary vessel mask (mesh_from_mask with its defaults), for
/// ViewRenderer's mesh mode.
template <class T>
std::shared_ptr<const VesselSurface> vessel_surface_from_mask(const Volume<T>& mask) {
  return std::make_shared<const VesselMeshProjector>(mesh_from_mask(mask));
}

/// Slow reference for tests: the same signed-crossing chord by brute force over every triangle
/// (Moller-Trumbore in double precision).
inline MeshRayResult trace_mesh_reference(const TriangleMesh& mesh, const Ray<double>& ray) {
  struct Crossing {
    double t;
    double facing;
  };
  std::vector<Crossing> crossings;
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>(),
                          b = mesh.vertices[tri[1]].cast<double>(),
                          c = mesh.vertices[tri[2]].cast<double>();
    const Eigen::Vector3d e1 = b - a, e2 = c - a;
    const Eigen::Vector3d p = ray.direction.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-14) continue;
    const Eigen::Vector3d q = ray.origin - a;
    const double u = q.dot(p) / det;
    if (u < 0 || u > 1) continue;
    const Eigen::Vector3d r = q.cross(e1);
    const double v = ray.direction.dot(r) / det;
    if (v < 0 || u + v > 1) continue;
    const double t = e2.dot(r) / det;
    if (t < 0) continue;
    crossings.push_back({t, e1.cross(e2).dot(ray.direction)});
  }
  std::sort(crossings.begin(), crossings.end(),
            [](const Crossing& x, const Crossing& y) { return x.t < y.t; });
  MeshRayResult out;
  int depth = 0;
  double since = 0;
  for (const auto& c : crossings) {
    out.first_hit_mm = std::min(out.first_hit_mm, static_cast<float>(c.t));
    if (c.facing < 0) {
      if (depth++ == 0) {
        since = c.t;
        ++out.passages;
      }
    } else if (c.facing > 0 && depth > 0 && --depth == 0) {
      out.chord_mm += static_cast<float>(c.t - since);
    }
  }
  return out;
}

}  // namespace gimm
