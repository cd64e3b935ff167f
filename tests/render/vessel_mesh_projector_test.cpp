// The Embree vessel-mesh projector: against brute force, analytic chords, overlap counts, and
// the voxel path (Siddon through the mask).
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/vessel_mesh_projector.hpp"

using namespace gimm;

namespace {
/// Two balls (radius r mm) at world centres c1, c2, 0.25 mm voxels.
Volume<std::uint8_t> balls(const Eigen::Vector3d& c1, const Eigen::Vector3d& c2, double r) {
  VolumeGeometry g;
  g.dims = {96, 96, 96};
  g.spacing = Eigen::Vector3d::Constant(0.25);
  g.origin = Eigen::Vector3d::Constant(-95 * 0.25 / 2);
  Volume<std::uint8_t> v(g, 0);
  for (int k = 0; k < 96; ++k)
    for (int j = 0; j < 96; ++j)
      for (int i = 0; i < 96; ++i) {
        const Eigen::Vector3d p = v.index_to_world(Eigen::Vector3d(i, j, k));
        if ((p - c1).norm() < r || (p - c2).norm() < r) v(i, j, k) = 1;
      }
  return v;
}
}  // namespace

TEST_CASE("Mesh projector: Embree equals brute force, chords match the analytic ball",
          "[render][embree]") {
  const Eigen::Vector3d c1(-3, 0, 2), c2(4, 1, -3);
  const double r = 2.5;
  const TriangleMesh mesh = mesh_from_mask(balls(c1, c2, r));
  REQUIRE(mesh.is_closed());
  const VesselMeshProjector projector(mesh);
  Rng rng(4);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d source(rng.uniform(-200, 200), 500, rng.uniform(-200, 200));
    const Eigen::Vector3d target =
        c1 + Eigen::Vector3d(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
    const Ray<double> ray{source, (target - source).normalized()};
    const MeshRayResult fast = projector.trace(ray);
    const MeshRayResult slow = trace_mesh_reference(mesh, ray);
    REQUIRE(fast.chord_mm == Approx(slow.chord_mm).margin(1e-3));
    REQUIRE(fast.passages == slow.passages);
    // Analytic chord through the ball (the mesh is within a fraction of a voxel of it).
    const Eigen::Vector3d w = c1 - source;
    const double d2 = (w - w.dot(ray.direction) * ray.direction).squaredNorm();
    const double analytic = d2 < r * r ? 2 * std::sqrt(r * r - d2) : 0.0;
    if (d2 < 0.5 * r * r && (c2 - source).cross(ray.direction).norm() > r + 1)
      CHECK(fast.chord_mm == Approx(analytic).margin(0.15));
  }
}

TEST_CASE("Mesh projector: overlap count, first-hit depth and the voxel path agree",
          "[render][embree]") {
  // In AP (view along -y) two balls one behind the other overlap in the image.
  const Eigen::Vector3d front(0, -5, 0), back(1, 5, 0.5);
  const auto mask = balls(front, back, 2.0);
  const VesselMeshProjector projector(mesh_from_mask(mask));
  CArm carm;
  carm.rows = 64;
  carm.cols = 64;
  carm.pixel_mm = 0.25;
  const Camerad camera = carm.camera();
  const VesselProjection p = projector.project(camera);
  const Eigen::Vector2d uv = camera.project(Eigen::Vector3d(0.5, 0, 0.25)).uv;
  const int row = static_cast<int>(std::lround(uv.y())),
            col = static_cast<int>(std::lround(uv.x()));
  CHECK(p.passages(row, col) == 2);
  // The first hit is on the back ball's far side from the detector... i.e. the source side:
  // the source is posterior (+y), so the ball at y = +5 is hit first, about SOD - 5 - 2 mm away.
  CHECK(p.first_hit_mm(row, col) == Approx(750 - 5 - 2).margin(0.6));
  // Visibility: the source is on the +y side, so the back ball (y = +5) hides the front one.
  CHECK(projector.unoccluded(camera, back));
  CHECK_FALSE(projector.unoccluded(camera, front));
  // A partial trace stops at the point: one passage, a chord of about the ball's radius.
  const Ray<double> ray = camera.ray(camera.project(back).uv.x(), camera.project(back).uv.y());
  const MeshRayResult half = projector.trace(ray, (back - ray.origin).dot(ray.direction));
  CHECK(half.passages == 1);
  CHECK(half.chord_mm == Approx(2.0).margin(0.4));

  // Voxel path: Siddon through the binary mask. Same silhouette, similar chords.
  Volume<float> mask_f(mask.geometry(), 0.0f);
  for (std::size_t v = 0; v < mask.size(); ++v) mask_f.data()[v] = mask.data()[v];
  const Image<float> voxel_chord = render_line_integrals(mask_f, camera);
  int both = 0, either = 0;
  double chord_diff = 0;
  for (int r = 0; r < camera.rows(); ++r)
    for (int c = 0; c < camera.cols(); ++c) {
      const bool a = p.chord_mm(r, c) > 0, b = voxel_chord(r, c) > 0;
      both += a && b;
      either += a || b;
      if (a && b) chord_diff += std::abs(p.chord_mm(r, c) - voxel_chord(r, c));
    }
  CHECK(static_cast<double>(both) / either > 0.9);  // mask IoU
  CHECK(chord_diff / both < 0.35);  // mean chord difference, mm (voxel staircase: ~1 voxel)
}

TEST_CASE("Mesh projector: bad meshes are refused", "[render][embree]") {
  CHECK_THROWS_WITH(VesselMeshProjector(TriangleMesh{}), Catch::Contains("empty"));
  TriangleMesh bad;
  bad.vertices = {Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY()};
  bad.triangles = {{0, 1, 7}};
  CHECK_THROWS_WITH(VesselMeshProjector(bad), Catch::Contains("indexes vertex 7"));
}
