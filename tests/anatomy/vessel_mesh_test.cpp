// Vessel meshes: closed, outward, volume agrees with the voxel count, thin vessels survive.
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
/// Whether world point p is inside the closed mesh: parity of the crossings of a ray in a
/// generic direction (Moller-Trumbore against every triangle).
bool inside(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = Eigen::Vector3d(1.0, 0.37, 0.23).normalized();
  int crossings = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d e1 = mesh.vertices[t[1]].cast<double>() - a;
    const Eigen::Vector3d e2 = mesh.vertices[t[2]].cast<double>() - a;
    const Eigen::Vector3d q = d.cross(e2);
    const double det = e1.dot(q);
    if (std::abs(det) < 1e-12) continue;
    const Eigen::Vector3d s = p - a;
    const double u = s.dot(q) / det;
    const Eigen::Vector3d r = s.cross(e1);
    const double v = d.dot(r) / det;
    const double dist = e2.dot(r) / det;
    crossings += u >= 0 && v >= 0 && u + v <= 1 && dist > 0;
  }
  return crossings % 2 == 1;
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

TEST_CASE("Vessel mesh: vessels thinner than the blur keep every voxel centre inside",
          "[anatomy][mesh]") {
  // A single voxel and a one-voxel-wide 26-connected staircase (a coronary on a coarse grid):
  // blurred alone they fall below the iso level everywhere, and used to vanish.
  VolumeGeometry g;
  g.dims = {24, 24, 24};
  g.spacing = {0.8, 0.9, 1.1};
  g.origin = Eigen::Vector3d(3, -2, 5);
  Volume<std::uint8_t> mask(g, 0);
  mask(4, 4, 4) = 1;
  for (int s = 0; s < 12; ++s) mask(9 + s, 8 + s, 6 + s / 2) = 1;
  const TriangleMesh mesh = mesh_from_mask(mask);
  REQUIRE(!mesh.triangles.empty());
  CHECK(mesh.is_closed());
  CHECK(mesh.enclosed_volume() > 0);
  int centres_in = 0, neighbours_in = 0, masked = 0, neighbours = 0;
  for (int k = 1; k + 1 < 24; ++k)
    for (int j = 1; j + 1 < 24; ++j)
      for (int i = 1; i + 1 < 24; ++i) {
        const bool in = inside(mesh, mask.index_to_world(Eigen::Vector3d(i, j, k)));
        if (mask(i, j, k)) {
          ++masked;
          centres_in += in;
        } else if (mask(i + 1, j, k) || mask(i - 1, j, k) || mask(i, j + 1, k) ||
                   mask(i, j - 1, k) || mask(i, j, k + 1) || mask(i, j, k - 1)) {
          ++neighbours;
          neighbours_in += in;
        }
      }
  CHECK(masked == 13);
  CHECK(centres_in == masked);
  CHECK(neighbours > 50);
  CHECK(neighbours_in == 0);
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
