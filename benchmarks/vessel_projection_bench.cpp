// 2D vessel masks of one view, two ways, on the ImageCAS-size phantom's LCA: the voxel path
// (exact Siddon chord through the label, cropped to its bounding box; what --vessels voxel
// uses) and the Embree mesh path (chord, first hit and overlap through the smoothed surface;
// --vessels mesh). Counters: mask IoU between the two and mean chord difference (mm) where
// both see vessel. The mesh is built once (its build time is a separate case); the voxel path
// both as one call (project_mask) and prepared once per system as the dataset does it. And the
// phantom's analytic tubes (--vessels tubes): tube_axes, tube_mesh, and their projection, with
// the same agreement counters against the voxel path.
#include <benchmark/benchmark.h>

#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/skeleton.hpp"
#include "gimm/anatomy/tube_mesh.hpp"
#include "gimm/anatomy/vessel_mesh.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/vessel_mesh_projector.hpp"

namespace {

struct Scene {
  gimm::Volume<std::uint8_t> lca_box;  // LCA label cropped to its bounding box (+1 voxel)
  gimm::TriangleMesh mesh;
  gimm::CenterlineTree tree;  // the phantom's analytic tree
};

const Scene& scene() {
  static const Scene s = [] {
    gimm::PhantomOptions o;
    o.seed = 1;
    o.size = gimm::PhantomSize::imagecas;
    const auto phantom = gimm::make_phantom(o);
    const auto split = gimm::split_coronary_systems(phantom.label);
    return Scene{gimm::crop_to_foreground(split.lca, 1), gimm::mesh_from_mask(split.lca),
                 phantom.centerlines};
  }();
  return s;
}

gimm::Camerad camera() {
  gimm::CArm carm;
  carm.primary_deg = 40;
  carm.secondary_deg = 20;
  carm.isocenter = Eigen::Vector3d(5, -5, 0);
  return carm.camera();
}

void BM_VoxelMask_512(benchmark::State& state) {
  const auto& s = scene();
  const auto cam = camera();
  for (auto _ : state) benchmark::DoNotOptimize(gimm::project_mask(s.lca_box, cam));
}

/// What the dataset does per view: the 0/1 box and its empty blocks made once per system.
void BM_VoxelMaskPrepared_512(benchmark::State& state) {
  const auto& s = scene();
  const auto cam = camera();
  const gimm::Volume<float> unit = gimm::unit_mask(s.lca_box);
  const gimm::EmptyBlocks empty(unit);
  for (auto _ : state) benchmark::DoNotOptimize(gimm::project_unit_mask(unit, cam, 1e-6, &empty));
  state.counters["empty_blocks"] = empty.empty_fraction();
}

/// The mesh path on `mesh`, with its agreement with the voxel path as counters.
void mesh_projection(benchmark::State& state, const gimm::TriangleMesh& mesh) {
  const auto& s = scene();
  const gimm::VesselMeshProjector projector(mesh);
  const auto cam = camera();
  gimm::VesselProjection p;
  for (auto _ : state) benchmark::DoNotOptimize(p = projector.project(cam));
  // Agreement with the voxel path, same view.
  const auto voxel = gimm::render_line_integrals(gimm::unit_mask(s.lca_box), cam);
  double both = 0, either = 0, diff = 0;
  for (std::size_t n = 0; n < voxel.size(); ++n) {
    const bool a = p.chord_mm.data()[n] > 0, b = voxel.data()[n] > 0;
    both += a && b;
    either += a || b;
    if (a && b) diff += std::abs(p.chord_mm.data()[n] - voxel.data()[n]);
  }
  state.counters["mask_iou"] = both / std::max(1.0, either);
  state.counters["chord_diff_mm"] = diff / std::max(1.0, both);
  state.counters["triangles"] = static_cast<double>(mesh.triangles.size());
}

void BM_MeshProjection_512(benchmark::State& state) {
  mesh_projection(state, scene().mesh);
}

void BM_TubeProjection_512(benchmark::State& state) {
  mesh_projection(state, gimm::tube_mesh(gimm::tube_axes(scene().tree), gimm::CoronarySystem::LCA));
}

/// What --vessels tubes adds per system: the axes, the mesh and its Embree scene.
void BM_TubeBuild(benchmark::State& state) {
  const auto& s = scene();
  for (auto _ : state) {
    const gimm::VesselMeshProjector projector(
        gimm::tube_mesh(gimm::tube_axes(s.tree), gimm::CoronarySystem::LCA));
    benchmark::DoNotOptimize(&projector);
  }
}

void BM_MeshBuild(benchmark::State& state) {
  const auto& s = scene();
  for (auto _ : state) {
    const gimm::VesselMeshProjector projector(s.mesh);
    benchmark::DoNotOptimize(&projector);
  }
}

}  // namespace

BENCHMARK(BM_VoxelMask_512)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_VoxelMaskPrepared_512)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MeshProjection_512)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MeshBuild)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TubeProjection_512)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TubeBuild)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
