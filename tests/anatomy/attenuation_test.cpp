// The angiography recipe tells bone from contrast by structure (classify_dense_tissue):
// undiluted contrast in a vein is blood however dense, trabecular bone is bone however faint.
// The threshold rule it replaces (HU >= 700 bone, [150, 700) blood) fails every case below.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/io/nifti.hpp"

using namespace gimm;
using Dense = ContrastRecipe::Dense;

namespace {

/// Soft tissue with: a vein of undiluted contrast along z through the whole grid (cut by the
/// scan's coverage), its edge blurred by partial volume; a vertebra (2-voxel cortex around
/// trabecular bone and a canal); a thin enhanced vessel; a small calcification.
struct Scene {
  Volume<float> hu;
  Volume<std::uint8_t> injected;
};

Scene make_scene() {
  VolumeGeometry g;
  g.dims = {60, 40, 24};
  g.spacing = Eigen::Vector3d(0.8, 0.8, 1.0);
  Scene s{Volume<float>(g, 40.0f), Volume<std::uint8_t>(g, 0)};
  for (int k = 0; k < 24; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 60; ++i) {
        const double vein = std::hypot(i - 12.0, j - 20.0);
        const double bone = std::hypot(i - 38.0, j - 20.0);
        float& v = s.hu(i, j, k);
        if (vein < 5)
          v = 1100;
        else if (vein < 6)
          v = 520;  // partial volume
        if (bone < 9) v = bone >= 7 ? 1150.0f : (bone < 2.5 ? 20.0f : 240.0f);
        if (std::hypot(i - 54.0, j - 6.0) < 1.2 && k > 3) v = 320;  // thin vessel
      }
  for (int k = 10; k < 12; ++k)
    for (int j = 34; j < 36; ++j)
      for (int i = 24; i < 26; ++i) s.hu(i, j, k) = 900;  // calcification
  // An injected lumen: dense tissue too, but the recipe makes it iodine whatever its class.
  for (int k = 0; k < 24; ++k) s.injected(20, 30, k) = 1, s.hu(20, 30, k) = 400;
  return s;
}

}  // namespace

TEST_CASE("Dense tissue: a dense vein is blood, trabecular bone is bone", "[anatomy][recipe]") {
  const Scene s = make_scene();
  const ContrastRecipe recipe;
  const DenseTissue d = classify_dense_tissue(s.hu, recipe);
  auto cls = [&](int i, int j, int k) { return static_cast<Dense>(d.classes(i, j, k)); };
  CHECK(cls(12, 20, 0) == Dense::blood);      // 1100 HU contrast, at the grid's bottom face
  CHECK(cls(12, 20, 12) == Dense::blood);     // and inside
  CHECK(cls(12, 25, 12) == Dense::blood);     // the blurred edge
  CHECK(cls(38, 20 + 8, 12) == Dense::bone);  // cortex
  CHECK(cls(38, 20 + 4, 12) == Dense::bone);  // trabecular, 240 HU
  CHECK(cls(38, 20, 12) == Dense::none);      // the canal
  CHECK(cls(54, 6, 12) == Dense::blood);      // a thin vessel at 320 HU
  CHECK(cls(24, 34, 10) == Dense::bone);      // calcium: too small for an inside, 900 HU
  CHECK(cls(20, 30, 5) == Dense::blood);      // the injected lumen: the recipe overrides it
  CHECK(cls(2, 2, 2) == Dense::none);         // soft tissue
  CHECK(d.bone_components == 2);
  CHECK(d.blood_components == 3);  // the vein, the thin vessel, the lumen

  // What that means for attenuation: the vein loses its contrast, the vertebra keeps all of
  // its physical attenuation, trabecular bone included.
  const Volume<float> mu = make_attenuation(s.hu, &s.injected, recipe);
  CHECK(mu(12, 20, 12) == Approx(recipe.soft_weight * hu_to_mu(recipe.native_blood_hu)));
  CHECK(mu(38, 24, 12) == Approx(recipe.bone_weight * hu_to_mu(240)));
  CHECK(mu(38, 28, 12) == Approx(recipe.bone_weight * hu_to_mu(1150)));
  CHECK(mu(20, 30, 5) == Approx(hu_to_mu(recipe.lumen_hu)));
  // A classification made once (for both systems of a patient) gives the same volume.
  CHECK(make_attenuation(s.hu, &s.injected, recipe, "scene", &d).storage() == mu.storage());
  // The per-voxel rule gets both wrong, which is why it is no longer used for volumes.
  CHECK(recipe.mu(1100, false) == Approx(hu_to_mu(1100)));
  CHECK(recipe.mu(240, false) == Approx(recipe.soft_weight * hu_to_mu(recipe.native_blood_hu)));
}

TEST_CASE("Dense tissue: a vessel cut by the scan's coverage is not a bone shell",
          "[anatomy][recipe]") {
  // Uniform dense contrast filling whole slices at the top of the grid: its only "surface"
  // brighter than its inside would be the grid's face, which does not count.
  VolumeGeometry g;
  g.dims = {20, 20, 10};
  Volume<float> hu(g, 40.0f);
  for (int k = 6; k < 10; ++k)
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 20; ++i) hu(i, j, k) = k == 6 ? 500.0f : 1000.0f;
  const DenseTissue d = classify_dense_tissue(hu, ContrastRecipe{});
  CHECK(static_cast<Dense>(d.classes(10, 10, 9)) == Dense::blood);
  CHECK(d.bone_components == 0);
}

TEST_CASE("Dense tissue: the phantom has both cases and the recipe handles them",
          "[anatomy][recipe][phantom]") {
  for (const std::uint64_t seed : {0u, 3u}) {
    PhantomOptions po;
    po.seed = seed;
    po.noise_hu = 0;  // exact tissue values identify the structures
    const Phantom p = make_phantom(po);
    const detail::TissueHu tissue(Rng(seed).fork(0x7155e));
    const Volume<float> hu = volume_cast<float>(p.hu);
    const DenseTissue d = classify_dense_tissue(hu, ContrastRecipe{});
    std::int64_t svc = 0, svc_blood = 0, trabecular = 0, trabecular_bone = 0, cortex = 0,
                 cortex_bone = 0;
    for (std::size_t v = 0; v < hu.size(); ++v) {
      const double h = hu.data()[v];
      const auto c = static_cast<Dense>(d.classes.data()[v]);
      if (h == std::round(tissue.svc)) svc += 1, svc_blood += c == Dense::blood;
      if (h == std::round(tissue.trabecular)) trabecular += 1, trabecular_bone += c == Dense::bone;
      if (h == std::round(tissue.cortex)) cortex += 1, cortex_bone += c == Dense::bone;
    }
    INFO("seed " << seed << ": SVC " << svc_blood << "/" << svc << " blood, trabecular "
                 << trabecular_bone << "/" << trabecular << " bone, cortex " << cortex_bone << "/"
                 << cortex << " bone");
    // Dense contrast in a vein (>= 700 HU) and trabecular bone in [150, 700) are in the phantom.
    REQUIRE(tissue.svc >= 800);
    REQUIRE(tissue.trabecular < 700);
    REQUIRE(svc > 500);
    REQUIRE(trabecular > 500);
    CHECK(svc_blood == svc);
    CHECK(trabecular_bone >= 0.99 * trabecular);
    CHECK(cortex_bone >= 0.99 * cortex);
  }
}

namespace {

/// A descending aorta (uniform enhanced blood, CT noise) lying on a vertebral body whose cortex
/// is faint (one partial-volume voxel, as at 1.5 mm) over a trabecular lattice: they touch over
/// a neck one voxel thick, so every voxel >= 150 HU is one component, as in real arterial CT.
Volume<float> fused_aorta_and_vertebra(std::uint64_t seed) {
  VolumeGeometry g;
  g.dims = {48, 30, 20};
  g.spacing = Eigen::Vector3d(1.5, 1.5, 1.5);
  Volume<float> hu(g, 40.0f);
  Rng rng(seed);
  for (int k = 0; k < 20; ++k)
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 48; ++i) {
        float& v = hu(i, j, k);
        const double aorta = std::hypot(i - 12.0, j - 15.0);
        const double body = std::hypot(i - 33.0, j - 15.0);
        if (aorta < 8) v = static_cast<float>(420 + rng.normal() * 40);  // blood, noise 40 HU
        if (body < 11) {  // a lattice: marrow 180-260 HU, trabeculae 450-650 HU
          const bool strut = (i + 2 * j + 3 * k) % 4 == 0;
          v = static_cast<float>(strut ? rng.uniform(450, 650) : rng.uniform(180, 260));
        }
      }
  for (int k = 0; k < 20; ++k) hu(20, 15, k) = 300;  // the neck between them (x = 20..22)
  for (int k = 0; k < 20; ++k) hu(21, 15, k) = 300, hu(22, 15, k) = 300;
  return hu;
}

}  // namespace

TEST_CASE("Dense tissue: blood fused to bone over a neck is cut apart and told apart",
          "[anatomy][recipe]") {
  const Volume<float> hu = fused_aorta_and_vertebra(7);
  Volume<std::uint8_t> dense(hu.geometry(), 0);
  for (std::size_t v = 0; v < hu.size(); ++v) dense.data()[v] = hu.data()[v] >= 150;
  REQUIRE(connected_components(dense).count() == 1);  // fused, as the real CT is

  const ContrastRecipe recipe;
  const DenseTissue d = classify_dense_tissue(hu, recipe);
  auto cls = [&](int i, int j, int k) { return static_cast<Dense>(d.classes(i, j, k)); };
  CHECK(d.split_components == 1);
  CHECK(cls(12, 15, 10) == Dense::blood);  // the aorta's centre
  CHECK(cls(6, 15, 10) == Dense::blood);   // and its far wall
  CHECK(cls(33, 15, 10) == Dense::bone);   // the body's centre
  CHECK(cls(42, 15, 10) == Dense::bone);   // and its far side
  std::int64_t aorta = 0, aorta_blood = 0, body = 0, body_bone = 0;
  for (int k = 0; k < 20; ++k)
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 48; ++i) {
        if (std::hypot(i - 12.0, j - 15.0) < 8)
          aorta += 1, aorta_blood += cls(i, j, k) == Dense::blood;
        if (std::hypot(i - 33.0, j - 15.0) < 11)
          body += 1, body_bone += cls(i, j, k) == Dense::bone;
      }
  CHECK(aorta_blood >= 0.98 * aorta);
  CHECK(body_bone >= 0.98 * body);

  // Without the cut the whole component gets one class: the bone is lost (or the aorta made
  // bone). Without the texture rule the faint-cortex body is not bone.
  ContrastRecipe uncut = recipe;
  uncut.split_neck_mm = 0;
  const DenseTissue one = classify_dense_tissue(hu, uncut);
  CHECK(one.split_components == 0);
  CHECK(one.classes(12, 15, 10) == one.classes(33, 15, 10));
  ContrastRecipe smooth = recipe;
  smooth.bone_texture_hu = 0;
  CHECK(static_cast<Dense>(classify_dense_tissue(hu, smooth).classes(33, 15, 10)) == Dense::blood);
}

TEST_CASE("Dense tissue: noisy blood is no lattice, and the cut leaves one-core blood alone",
          "[anatomy][recipe]") {
  // A blood pool at a noisy scan's 50 HU: its roughness (about 36 HU) stays under bone_texture_hu.
  VolumeGeometry g;
  g.dims = {30, 30, 12};
  Volume<float> hu(g, 40.0f);
  Rng rng(3);
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 30; ++i)
        if (std::hypot(i - 15.0, j - 15.0) < 10)
          hu(i, j, k) = static_cast<float>(450 + 50 * rng.normal());
  const DenseTissue d = classify_dense_tissue(hu, ContrastRecipe{});
  CHECK(d.bone_components == 0);
  CHECK(d.split_components == 0);
  CHECK(static_cast<Dense>(d.classes(15, 15, 6)) == Dense::blood);
}

TEST_CASE("Recipe: the cut and the texture rule refuse values no scan could use",
          "[anatomy][recipe]") {
  ContrastRecipe r;
  r.split_neck_mm = -1;
  CHECK_THROWS_WITH(r.validate("test"), Catch::Contains("split_neck_mm must be >= 0, got -1"));
  r = ContrastRecipe{};
  r.bone_texture_hu = std::nan("");
  CHECK_THROWS_WITH(r.validate("test"), Catch::Contains("bone_texture_hu must be >= 0"));
}

// The real arterial-phase chest CT of ../shared (TotalSegmentator's test file): every voxel
// >= 150 HU, spine and ribs included, is one component with the enhanced blood. The recipe must
// keep the T12 vertebra as bone (its physical optical depth within 30%) and the aorta as blood.
// Skipped (with a warning) where ../shared is not beside the project.
TEST_CASE("Dense tissue: real arterial CT keeps its spine and loses its contrast",
          "[anatomy][recipe][realct]") {
  const std::filesystem::path dir =
      std::filesystem::path(GIMM_SOURCE_DIR) / ".." / "shared" / "data" / "real-ct";
  if (!std::filesystem::exists(dir / "chest_arterial.nii.gz")) {
    WARN("skipped: no " << (dir / "chest_arterial.nii.gz").string());
    return;
  }
  const Volume<float> hu = read_nifti<float>(dir / "chest_arterial.nii.gz");
  const Volume<float> t12 = read_nifti<float>(dir / "chest_arterial.T12.nii.gz");
  const Volume<float> aorta = read_nifti<float>(dir / "chest_arterial.aorta.nii.gz");
  REQUIRE(t12.dims() == hu.dims());
  REQUIRE(aorta.dims() == hu.dims());
  const ContrastRecipe recipe;
  const DenseTissue d = classify_dense_tissue(hu, recipe);
  const Volume<float> mu = make_attenuation<std::uint8_t>(hu, nullptr, recipe, "real CT", &d);
  // Over T12's dense voxels (its bone; the marrow below 150 HU is soft tissue to every recipe):
  // the recipe's attenuation against the physical one (hu_to_mu), i.e. the optical depth the
  // vertebra's bone adds to the rays through it, recipe over physical DRR.
  double recipe_depth = 0, physical_depth = 0;
  std::int64_t t12_dense = 0, t12_bone = 0, aorta_dense = 0, aorta_blood = 0;
  for (std::size_t v = 0; v < hu.size(); ++v) {
    const auto c = static_cast<Dense>(d.classes.data()[v]);
    if (t12.data()[v] > 0 && c != Dense::none) {
      recipe_depth += mu.data()[v];
      physical_depth += hu_to_mu(hu.data()[v]);
      t12_dense += 1, t12_bone += c == Dense::bone;
    }
    if (aorta.data()[v] > 0 && c != Dense::none) aorta_dense += 1, aorta_blood += c == Dense::blood;
  }
  INFO("T12 dense voxels bone " << t12_bone << "/" << t12_dense << ", aorta dense voxels blood "
                                << aorta_blood << "/" << aorta_dense
                                << ", T12 depth recipe/physical " << recipe_depth / physical_depth
                                << ", components split " << d.split_components);
  CHECK(d.split_components >= 1);
  CHECK(t12_bone >= 0.9 * t12_dense);
  CHECK(aorta_blood >= 0.95 * aorta_dense);
  CHECK(recipe_depth / physical_depth == Approx(1.0).margin(0.3));
}
