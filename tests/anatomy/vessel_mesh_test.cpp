// Vessel meshes: closed, outward, volume agrees with the voxel count.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/anatomy/vessel_mesh.hpp"

using namespace gimm;

namespace {
Volume<std::uint8_t> ball(double radius_vox, Eigen::Vector3d spacing = {1, 1, 1}) {
  VolumeGeometry g;
  g.dims = {32, 32, 32};
  g.spacing = spacing;
  g.origin = Eigen::Vector3d(-10, 4, 7);
  Volume<std::uint8_t> v(g, 0);
  for (int k = 0; k < 32; ++k)
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i)
        if ((Eigen::Vector3d(i, j, k) - Eigen::Vector3d(15.3, 16.1, 15.7)).norm() < radius_vox)
          v(i, j, k) = 1;
  return v;
}
std::int64_t count(const Volume<std::uint8_t>& v) {
  std::int64_t n = 0;
  for (auto x : v.storage()) n += x;
  return n;
}
}  // namespace

TEST_CASE("Vessel mesh: a ball gives a closed, outward surface of the right volume",
          "[anatomy][mesh]") {
  const double sigma = GENERATE(0.0, 0.7);
  const Eigen::Vector3d spacing(0.4, 0.5, 0.6);
  const auto mask = ball(9.0, spacing);
  MeshOptions options;
  options.smoothing_sigma_voxels = sigma;
  const TriangleMesh mesh = mesh_from_mask(mask, options);
  REQUIRE(!mesh.triangles.empty());
  CHECK(mesh.is_closed());
  const double voxel_volume = static_cast<double>(count(mask)) * 0.4 * 0.5 * 0.6;
  CHECK(mesh.enclosed_volume() > 0);  // outward-facing
  CHECK(mesh.enclosed_volume() == Approx(voxel_volume).epsilon(0.05));
}

TEST_CASE("Vessel mesh: a thin oblique tube stays closed and keeps its volume", "[anatomy][mesh]") {
  VolumeGeometry g;
  g.dims = {40, 40, 40};
  g.spacing = {0.4, 0.4, 0.5};
  Volume<std::uint8_t> mask(g, 0);
  const Eigen::Vector3d a(5, 6, 4), b(34, 30, 35);
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 40; ++i) {
        const Eigen::Vector3d p(i, j, k);
        const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
        if ((p - (a + t * (b - a))).norm() < 2.6) mask(i, j, k) = 1;
      }
  const TriangleMesh mesh = mesh_from_mask(mask);
  CHECK(mesh.is_closed());
  const double voxel_volume = static_cast<double>(count(mask)) * 0.4 * 0.4 * 0.5;
  CHECK(mesh.enclosed_volume() == Approx(voxel_volume).epsilon(0.10));
}

TEST_CASE("Vessel mesh: empty masks and bad options", "[anatomy][mesh]") {
  VolumeGeometry g;
  g.dims = {8, 8, 8};
  CHECK(mesh_from_mask(Volume<std::uint8_t>(g, 0)).triangles.empty());
  MeshOptions bad;
  bad.iso = 1.5;
  CHECK_THROWS_WITH(mesh_from_mask(Volume<std::uint8_t>(g, 1), bad), Catch::Contains("iso"));
  bad = {};
  bad.smoothing_sigma_voxels = -1;
  CHECK_THROWS_WITH(mesh_from_mask(Volume<std::uint8_t>(g, 1), bad),
                    Catch::Contains("smoothing sigma"));
  // A mask touching the grid border still closes (the border is padded with zeros).
  CHECK(mesh_from_mask(Volume<std::uint8_t>(g, 1)).is_closed());
}
