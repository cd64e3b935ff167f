// The angiography recipe tells bone from contrast by structure (classify_dense_tissue):
// undiluted contrast in a vein is blood however dense, trabecular bone is bone however faint.
// The threshold rule it replaces (HU >= 700 bone, [150, 700) blood) fails every case below.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/phantom.hpp"

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
