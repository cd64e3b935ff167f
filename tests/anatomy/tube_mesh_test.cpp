// The analytic tube mesh of a coronary tree (anatomy/tube_mesh.hpp): closed and outward, the
// tube's volume and chord, one passage where a child leaves its parent, and every centreline
// point of a phantom's tree inside the imaged vessel.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/tube_mesh.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/vessel_mesh_projector.hpp"

using namespace gimm;

namespace {

CenterlineBranch branch(const std::vector<Eigen::Vector3d>& points, double r0, double r1,
                        int parent = -1) {
  CenterlineBranch b;
  b.name = "B" + std::to_string(points.size());
  b.system = CoronarySystem::LCA;
  b.parent = parent;
  b.points = points;
  for (std::size_t n = 0; n < points.size(); ++n)
    b.radii.push_back(r0 + (r1 - r0) * n / (points.size() - 1.0));
  return b;
}

std::vector<Eigen::Vector3d> helix(int samples, double radius, double pitch, double turns) {
  std::vector<Eigen::Vector3d> p;
  for (int n = 0; n < samples; ++n) {
    const double a = 2 * kPi * turns * n / (samples - 1.0);
    p.emplace_back(radius * std::cos(a), radius * std::sin(a), pitch * a / (2 * kPi));
  }
  return p;
}

}  // namespace

TEST_CASE("Tube mesh: closed, outward, the tube's volume", "[anatomy][tubes]") {
  SECTION("a straight tube") {
    CenterlineTree tree;
    std::vector<Eigen::Vector3d> line;
    for (int n = 0; n <= 40; ++n) line.emplace_back(0.5 * n, 0, 0);
    tree.branches.push_back(branch(line, 1.5, 1.5));
    const TriangleMesh mesh = tube_mesh(tree, CoronarySystem::LCA);
    CHECK(mesh.is_closed());
    // The cylinder and its two hemispherical ends (a sphere; its 4-ring polygons are short of
    // it by a few %, 2% of the whole).
    CHECK(mesh.enclosed_volume() ==
          Approx(kPi * 1.5 * 1.5 * 20 + 4.0 / 3 * kPi * 1.5 * 1.5 * 1.5).epsilon(0.02));
    // The ends are round: along the axis (just off it, not through the poles' vertices) the
    // tube reaches a radius past its last point.
    const MeshRayResult along =
        trace_mesh_reference(mesh, Ray<double>{{-10, 0.1, 0.05}, {1, 0, 0}});
    CHECK(along.passages == 1);
    CHECK(along.chord_mm == Approx(20 + 2 * 1.5).epsilon(0.01));
    // A ray across the axis: a chord of the tube's diameter, within the polygon's error.
    const MeshRayResult across = trace_mesh_reference(mesh, Ray<double>{{10, -10, 0.3}, {0, 1, 0}});
    CHECK(across.passages == 1);
    CHECK(across.chord_mm == Approx(2 * std::sqrt(1.5 * 1.5 - 0.09)).epsilon(0.03));
  }
  SECTION("a tapering helix: no twist, no fold") {
    CenterlineTree tree;
    tree.branches.push_back(branch(helix(400, 20, 15, 2), 2.0, 0.6));
    const TriangleMesh mesh = tube_mesh(tree, CoronarySystem::LCA, 12);
    CHECK(mesh.is_closed());
    // Frustum sum over the samples.
    double volume = 0;
    const auto& b = tree.branches[0];
    for (std::size_t n = 1; n < b.points.size(); ++n) {
      const double r0 = b.radii[n - 1], r1 = b.radii[n];
      volume += kPi / 3 * (b.points[n] - b.points[n - 1]).norm() * (r0 * r0 + r0 * r1 + r1 * r1);
    }
    volume += 2.0 / 3 * kPi * (std::pow(b.radii.front(), 3) + std::pow(b.radii.back(), 3));
    CHECK(mesh.enclosed_volume() == Approx(volume).epsilon(0.01));
  }
}

TEST_CASE("Tube mesh: a child leaving its parent images as one vessel", "[anatomy][tubes]") {
  CenterlineTree tree;
  std::vector<Eigen::Vector3d> parent, child;
  for (int n = 0; n <= 60; ++n) parent.emplace_back(0.5 * n, 0, 0);
  for (int n = 0; n <= 40; ++n) child.emplace_back(15 + 0.35 * n, 0.35 * n, 0);
  tree.branches.push_back(branch(parent, 2.0, 1.5));
  tree.branches.push_back(branch(child, 1.2, 0.8, 0));
  const TriangleMesh mesh = tube_mesh(tree, CoronarySystem::LCA);
  CHECK(mesh.is_closed());
  // Through the junction, along z: the union is one passage, as thick as the parent there.
  const MeshRayResult r = trace_mesh_reference(mesh, Ray<double>{{15.2, 0.1, -10}, {0, 0, 1}});
  CHECK(r.passages == 1);
  CHECK(r.chord_mm == Approx(2 * 1.75).epsilon(0.05));
}

TEST_CASE("Tube mesh: every centreline point of a phantom images inside its vessel",
          "[anatomy][tubes][phantom]") {
  PhantomOptions po;
  po.seed = 2;
  const Phantom p = make_phantom(po);
  const TriangleMesh mesh = tube_mesh(p.centerlines, CoronarySystem::LCA);
  CHECK(mesh.is_closed());
  const VesselMeshProjector projector(mesh);
  CArm carm;
  carm.primary_deg = 30;
  carm.secondary_deg = 20;
  carm.isocenter = Eigen::Vector3d(0, 0, -12);
  const Camerad camera = carm.camera();
  const VesselProjection view = projector.project(camera);
  int seen = 0, inside = 0;
  for (const auto& b : p.centerlines.branches) {
    if (b.system != CoronarySystem::LCA) continue;
    for (const auto& X : b.points) {
      const Eigen::Vector2d uv = camera.project(X).uv;
      const int c = static_cast<int>(std::lround(uv.x())),
                r = static_cast<int>(std::lround(uv.y()));
      if (r < 0 || c < 0 || r >= view.chord_mm.rows() || c >= view.chord_mm.cols()) continue;
      ++seen;
      inside += view.chord_mm(r, c) > 0;
    }
  }
  INFO(inside << " of " << seen << " centreline points on a vessel pixel");
  REQUIRE(seen > 500);
  CHECK(inside == seen);
}

TEST_CASE("Tube mesh: bad input is named", "[anatomy][tubes]") {
  CenterlineTree tree;
  std::vector<Eigen::Vector3d> line{{0, 0, 0}, {1, 0, 0}};
  tree.branches.push_back(branch(line, 1, 1));
  CHECK_THROWS_WITH(tube_mesh(tree, CoronarySystem::LCA, 4),
                    Catch::Contains("sides must be in [6, 256], got 4"));
  CHECK_THROWS_WITH(tube_mesh(tree, CoronarySystem::RCA),
                    Catch::Contains("no branch of the RCA system"));
  tree.branches[0].radii[1] = -1;
  CHECK_THROWS_WITH(tube_mesh(tree, CoronarySystem::LCA), Catch::Contains("radius -1"));
}
