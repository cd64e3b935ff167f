// The analytic tube mesh of a coronary tree (anatomy/tube_mesh.hpp): closed and outward, the
// tube's volume and chord, one passage where a child leaves its parent, and every centreline
// point of a phantom's tree inside the imaged vessel.
#include <algorithm>
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

CenterlineTree tree_with_one_branch() {
  CenterlineTree tree;
  tree.branches.push_back(branch({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, 1, 1));
  return tree;
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
  const CenterlineTree axes = tube_axes(p.centerlines);
  const TriangleMesh mesh = tube_mesh(axes, CoronarySystem::LCA);
  CHECK(mesh.is_closed());
  const VesselMeshProjector projector(mesh);
  CArm carm;
  carm.primary_deg = 30;
  carm.secondary_deg = 20;
  carm.isocenter = Eigen::Vector3d(0, 0, -12);
  const Camerad camera = carm.camera();
  const VesselProjection view = projector.project(camera);
  int seen = 0, inside = 0;
  for (const auto& b : axes.branches) {
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

TEST_CASE("Tube axes: no bend tighter than the tube, smooth paths kept", "[anatomy][tubes]") {
  // The minimum over interior samples of (bend radius / tube radius).
  const auto tightest = [](const CenterlineBranch& b) {
    double worst = 1e9;
    for (std::size_t i = 1; i + 1 < b.points.size(); ++i) {
      const Eigen::Vector3d a = b.points[i] - b.points[i - 1], c = b.points[i + 1] - b.points[i];
      const double turn = std::acos(std::clamp(a.dot(c) / (a.norm() * c.norm()), -1.0, 1.0));
      if (turn > 1e-9) worst = std::min(worst, 0.5 * (a.norm() + c.norm()) / turn / b.radii[i]);
    }
    return worst;
  };
  SECTION("a path that jumps 3 mm and doubles back, as the phantom's RCA where its parts meet") {
    std::vector<Eigen::Vector3d> path;
    for (int n = 0; n <= 20; ++n) path.emplace_back(0.5 * n, 0, 0);
    for (int n = 0; n <= 40; ++n) path.emplace_back(8.0 + 0.5 * n * 0.2, 3.0 + 0.5 * n, 0);
    CenterlineTree tree;
    tree.branches.push_back(branch(path, 2.0, 1.2));
    REQUIRE(tightest(tree.branches[0]) < 1);  // a swept circle would fold there
    const CenterlineTree axes = tube_axes(tree);
    const auto& b = axes.branches[0];
    CHECK(tightest(b) >= 1.25 - 1e-9);
    CHECK(b.points.front() == path.front());  // the ends stay
    CHECK(b.points.back().isApprox(path.back()));
    CHECK(b.radii.front() == Approx(2.0));
    CHECK(b.radii.back() == Approx(1.2));
    CHECK(tube_mesh(axes, CoronarySystem::LCA).is_closed());
  }
  SECTION("a smooth helix: only resampled") {
    CenterlineTree tree;
    tree.branches.push_back(branch(helix(300, 20, 15, 1.5), 1.5, 0.7));
    const CenterlineTree axes = tube_axes(tree);
    const auto& in = tree.branches[0].points;
    double far = 0;
    for (const auto& q : axes.branches[0].points) {
      double nearest = 1e9;
      for (std::size_t i = 1; i < in.size(); ++i) {
        const Eigen::Vector3d ab = in[i] - in[i - 1];
        const double t = std::clamp((q - in[i - 1]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
        nearest = std::min(nearest, (q - (in[i - 1] + t * ab)).norm());
      }
      far = std::max(far, nearest);
    }
    CHECK(far < 1e-9);
    CHECK(tube_axes(tree, 0.25).branches[0].points.size() >
          1.9 * axes.branches[0].points.size() - 4);
  }
  CHECK_THROWS_WITH(tube_axes(tree_with_one_branch(), 0), Catch::Contains("step_mm must be > 0"));
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
