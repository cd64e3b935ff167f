#pragma once
/// Hounsfield units -> linear attenuation, and the contrast recipe of a selective injection.
///
/// Units: mu in mm^-1. mu_water = 0.02 mm^-1 (0.2 cm^-1, water near a 70 keV effective energy
/// of a filtered ~90 kVp angiography beam). mu(HU) = mu_water (1 + HU / 1000), clipped at 0
/// (air and lung are -1000 .. -500 HU).
///
/// A recipe turns the CT (HU) and the mask of the injected coronary system into the
/// attenuation volume the X-ray "sees":
///   reference   - the released dataset's recipe, exactly (its project_ct_drr_*_selective
///                 with the released DRR_PARAMS): mu0 = mu(HU); outside the injected mask,
///                 voxels with HU > -100 get 0.05 mu0; inside the mask mu0 plus a coronary
///                 boost of 2 mu0 (3 mu0 in all); then every voxel with HU > 200 adds
///                 0.10 mu0 (bone). docs/recipes.md lists what else differs from the reference.
///   angiography - a selective coronary injection as a cath lab shows it: the injected lumen
///                 holds iodine at `lumen_hu`; the CCTA's contrast-enhanced blood outside the
///                 injected system reverts to native blood; soft tissue is weighted by
///                 `soft_weight` (the faint background of a log-windowed angiogram); bone keeps
///                 `bone_weight`. Bone and contrast are told apart by structure, not by HU
///                 alone (classify_dense_tissue): in a CCTA undiluted contrast in the vena cava
///                 reaches 1000+ HU and trabecular bone sits at 150-400 HU, so no threshold
///                 separates them. docs/recipes.md.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "gimm/anatomy/components.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

constexpr double kMuWaterPerMm = 0.02;

inline double hu_to_mu(double hu, double mu_water = kMuWaterPerMm) {
  return std::max(0.0, mu_water * (1.0 + hu / 1000.0));
}

enum class ContrastPreset { reference, angiography, none };

inline ContrastPreset parse_contrast_preset(const std::string& name) {
  if (name == "reference") return ContrastPreset::reference;
  if (name == "angiography") return ContrastPreset::angiography;
  if (name == "none") return ContrastPreset::none;
  GIMM_FAIL("contrast recipe must be reference|angiography|none, got '" << name << "'");
}

inline const char* to_string(ContrastPreset p) {
  switch (p) {
    case ContrastPreset::reference:
      return "reference";
    case ContrastPreset::angiography:
      return "angiography";
    case ContrastPreset::none:
      return "none";
  }
  return "?";
}

struct ContrastRecipe {
  ContrastPreset preset = ContrastPreset::angiography;
  double mu_water = kMuWaterPerMm;
  // reference preset (released dataset)
  double reference_soft_threshold_hu = -100;
  double reference_soft_factor = 0.05;
  double reference_coronary_boost = 2.0;  ///< added to the injected lumen, times mu0
  double reference_bone_threshold_hu = 200;
  double reference_bone_weight = 0.10;
  // angiography preset
  /// Iodine in the selectively injected lumen. Undiluted contrast (300-370 mgI/mL) attenuates
  /// several times more than water at angiographic energies; 3000 HU (4x water) gives a 3 mm
  /// coronary an optical depth of ~0.35, the dark, crisp vessels of a clinical angiogram
  /// (1400 HU, tried first, left them at ~0.12: barely visible over the heart shadow).
  double lumen_hu = 3000;
  double blood_pool_lo_hu = 150;  ///< CCTA-enhanced blood and bone start here
  /// A dense component with no inside (thinner than 3 voxels) is bone from this mean HU on
  /// (calcium, thin cortex), else blood (small enhanced vessels); also the per-voxel rule of
  /// mu(hu, injected) when no structure is known.
  double bone_hu = 700;
  /// A dense component is bone when its surface is this much brighter than its inside.
  double bone_shell_margin_hu = 150;
  /// ...or when its inside is this rough: the median, over its voxels deeper than layer 2 (out
  /// of the surface's partial volume: a thin vessel's blurred edge is rough, not a lattice), of
  /// |HU - the mean of the 6 face neighbours|. Trabecular bone is a lattice (real arterial CT at
  /// 1.5 mm: 74 HU in the spine), blood a fluid whose roughness is the scanner's
  /// noise (about 0.7 sigma: 21-25 HU there, the phantoms 11). 0 turns the rule off.
  double bone_texture_hu = 50;
  /// Dense components joined by necks no thicker than this (a descending aorta lying on a
  /// vertebra, a rib at an enhanced vein: the normal case in arterial CT) are cut at them: each
  /// core deeper than the neck (at least a voxel) grows back over its component, the nearest
  /// core taking each voxel, and each part is classified on its own. 0 turns splitting off.
  double split_neck_mm = 1.5;
  double native_blood_hu = 45;
  double soft_weight = 0.35;
  double bone_weight = 1.0;

  /// Refuses a recipe no scanner could give: mu_water must be > 0, every HU finite, the
  /// factors and weights >= 0 (a NaN or a negative mu would render NaN or negative depths).
  void validate(const std::string& what = "recipe") const {
    GIMM_CHECK(std::isfinite(mu_water) && mu_water > 0,
               what << ": mu_water must be > 0 mm^-1, got " << mu_water);
    const std::pair<const char*, double> hus[] = {
        {"reference_soft_threshold_hu", reference_soft_threshold_hu},
        {"reference_bone_threshold_hu", reference_bone_threshold_hu},
        {"lumen_hu", lumen_hu},
        {"blood_pool_lo_hu", blood_pool_lo_hu},
        {"bone_hu", bone_hu},
        {"bone_shell_margin_hu", bone_shell_margin_hu},
        {"native_blood_hu", native_blood_hu}};
    for (const auto& [name, value] : hus)
      GIMM_CHECK(std::isfinite(value), what << ": " << name << " must be finite, got " << value);
    const std::pair<const char*, double> weights[] = {
        {"reference_soft_factor", reference_soft_factor},
        {"reference_coronary_boost", reference_coronary_boost},
        {"reference_bone_weight", reference_bone_weight},
        {"soft_weight", soft_weight},
        {"bone_weight", bone_weight},
        {"bone_texture_hu", bone_texture_hu},
        {"split_neck_mm", split_neck_mm}};
    for (const auto& [name, value] : weights)
      GIMM_CHECK(std::isfinite(value) && value >= 0,
                 what << ": " << name << " must be >= 0, got " << value);
  }

  /// What the angiography preset makes of a voxel at or above blood_pool_lo_hu.
  enum class Dense : std::uint8_t { none = 0, blood = 1, bone = 2 };

  /// Attenuation (mm^-1) of one voxel, with the angiography preset's dense class known
  /// (classify_dense_tissue); the other presets ignore it.
  double mu(double hu, bool injected, Dense dense) const {
    if (preset != ContrastPreset::angiography) return mu(hu, injected);
    if (injected) return hu_to_mu(std::max(hu, lumen_hu), mu_water);
    if (dense == Dense::bone) return bone_weight * hu_to_mu(hu, mu_water);
    const double tissue_hu = dense == Dense::blood ? native_blood_hu : hu;
    return soft_weight * hu_to_mu(tissue_hu, mu_water);
  }

  /// Attenuation (mm^-1) of one voxel on its own: the angiography preset then calls every voxel
  /// at or above bone_hu bone and every one in [blood_pool_lo_hu, bone_hu) blood.
  double mu(double hu, bool injected) const {
    const double mu0 = hu_to_mu(hu, mu_water);
    switch (preset) {
      case ContrastPreset::none:
        return mu0;
      case ContrastPreset::reference: {
        double m = injected
                       ? (1.0 + reference_coronary_boost) * mu0
                       : (hu > reference_soft_threshold_hu ? reference_soft_factor * mu0 : mu0);
        if (hu > reference_bone_threshold_hu) m += reference_bone_weight * mu0;
        return m;
      }
      case ContrastPreset::angiography:
        return mu(hu, injected,
                  hu >= bone_hu            ? Dense::bone
                  : hu >= blood_pool_lo_hu ? Dense::blood
                                           : Dense::none);
    }
    return mu0;
  }
};

/// Checks that `mu` can be attenuation (mm^-1): finite and >= 0 everywhere. A CT in HU read as
/// attenuation (-1000 in air) would otherwise give exp(+large) intensities and no error.
inline void check_attenuation(const Volume<float>& mu, const std::string& name) {
  for (std::size_t v = 0; v < mu.size(); ++v)
    GIMM_CHECK(std::isfinite(mu.data()[v]) && mu.data()[v] >= 0,
               name << ": attenuation must be finite and >= 0 mm^-1, got " << mu.data()[v]
                    << " at voxel " << v << " (a CT in HU needs a contrast recipe)");
}

/// The dense tissue of a CCTA (HU >= blood_pool_lo_hu), told apart by structure.
/// 1. Parts: the 26-connected components, those joined by thin necks cut apart (a descending
///    aorta on a vertebra, ribs at an enhanced vein: in real arterial CT every voxel >= 150 HU,
///    skeleton included, is one component with the blood; split_neck_mm).
/// 2. Per part, bone when it has a cortex - a layer brighter than what it encloses by
///    bone_shell_margin_hu - or a trabecular inside (bone_texture_hu), blood otherwise: a vessel
///    or chamber is a fluid, as bright or brighter inside, however dense its contrast. The cortex
///    is looked for in two places: the surface (layer 1: voxels with a face neighbour inside the
///    grid below blood_pool_lo_hu or in another part) against all inside it, and, because
///    partial volume dims the outermost voxels of a bone whose cortex is about a voxel thick
///    (every real CT, and the chest phantom's blended edges), layer 2 (face neighbours of layer
///    1) against all deeper. A part whose layer 2 has nothing deeper goes by layer 2's mean HU
///    (bone_hu); one of layer 1 only by its mean HU. The grid's own faces are not surface: a
///    vessel cut by the scan's coverage stays blood.
/// Limitation: a blood pool and a bone fused over more than the neck stay one part, classified
/// as one (docs/recipes.md). The injected lumen is not excluded (the recipe overrides it), so
/// one classification serves both coronary systems of a patient.
struct DenseTissue {
  Volume<std::uint8_t> classes;                   ///< ContrastRecipe::Dense per voxel
  int blood_components = 0, bone_components = 0;  ///< parts of each class
  std::int64_t blood_voxels = 0, bone_voxels = 0;
  int split_components = 0;  ///< components cut at necks into several parts
};

namespace detail {

/// Whether dense voxel (i, j, k) has a face neighbour inside the grid for which `outside` holds.
template <class Outside>
bool touches(const Volume<std::uint8_t>& dense, int i, int j, int k, Outside outside) {
  const int nx = dense.nx(), ny = dense.ny(), nz = dense.nz();
  return (i > 0 && outside(i - 1, j, k)) || (i + 1 < nx && outside(i + 1, j, k)) ||
         (j > 0 && outside(i, j - 1, k)) || (j + 1 < ny && outside(i, j + 1, k)) ||
         (k > 0 && outside(i, j, k - 1)) || (k + 1 < nz && outside(i, j, k + 1));
}

/// Per part: HU sums and counts of layer 1, layer 2 and deeper, and the roughness of the voxels
/// below its surface.
struct LayerSums {
  std::array<double, 3> sum{};
  std::array<std::int64_t, 3> n{};
  std::vector<float> roughness;
  double mean(int a, int b) const {
    double s = 0;
    std::int64_t c = 0;
    for (int l = a; l <= b; ++l) s += sum[l], c += n[l];
    return c ? s / c : 0.0;
  }
  /// Median roughness below the surface; 0 with fewer than 27 such voxels (a 3x3x3 box).
  double texture() {
    if (roughness.size() < 27) return 0.0;
    auto mid = roughness.begin() + static_cast<std::ptrdiff_t>(roughness.size() / 2);
    std::nth_element(roughness.begin(), mid, roughness.end());
    return *mid;
  }
  bool bone(const ContrastRecipe& r) {
    const bool surface_cortex = n[1] + n[2] > 0 ? mean(0, 0) > mean(1, 2) + r.bone_shell_margin_hu
                                                : mean(0, 0) >= r.bone_hu;
    const bool inner_cortex = n[2] > 0   ? mean(1, 1) > mean(2, 2) + r.bone_shell_margin_hu
                              : n[1] > 0 ? mean(1, 1) >= r.bone_hu
                                         : false;
    const bool trabecular = r.bone_texture_hu > 0 && texture() >= r.bone_texture_hu;
    return surface_cortex || inner_cortex || trabecular;
  }
};

/// How far voxel (i, j, k) stands out of its face neighbours: |HU - their mean| (neighbours
/// clipped to the grid). Zero on a fluid's smooth inside and along a partial-volume ramp; large
/// on a lattice, whose every voxel differs from the ones beside it.
template <class H>
double roughness(const Volume<H>& hu, int i, int j, int k) {
  double s = 0;
  int c = 0;
  const auto add = [&](int x, int y, int z) {
    if (hu.contains(x, y, z)) s += hu(x, y, z), ++c;
  };
  add(i - 1, j, k), add(i + 1, j, k), add(i, j - 1, k), add(i, j + 1, k), add(i, j, k - 1),
      add(i, j, k + 1);
  return c ? std::abs(hu(i, j, k) - s / c) : 0.0;
}

/// Binary erosion along one axis by `half` voxels each way: a voxel stays set when every voxel
/// within `half` of it along `axis` is; the grid's faces count as set (they are not surface).
/// Whole rows at a time (the neighbours along y and z are rows away), so it runs along
/// contiguous memory whatever the axis. Along the three axes, an erosion by a box.
inline void erode_along(Volume<std::uint8_t>& mask, int axis, int half,
                        std::vector<std::uint8_t>& before) {
  const int nx = mask.nx(), ny = mask.ny(), nz = mask.nz();
  const std::int64_t stride[3] = {1, nx, static_cast<std::int64_t>(nx) * ny};
  const int len[3] = {nx, ny, nz};
  before.assign(mask.data(), mask.data() + mask.size());
  const std::uint8_t* in = before.data();
  std::uint8_t* out = mask.data();
  parallel_for(0, static_cast<std::int64_t>(ny) * nz, [&](std::int64_t row) {
    const int at[3] = {0, static_cast<int>(row % ny), static_cast<int>(row / ny)};
    const std::uint8_t* here = in + row * nx;
    std::uint8_t* o = out + row * nx;
    if (axis == 0) {  // along the row itself: the nearest clear voxel on either side
      for (int i = 0, last = -half - 1; i < nx; ++i) {
        if (!here[i]) last = i;
        o[i] = i - last > half;
      }
      for (int i = nx - 1, next = nx + half; i >= 0; --i) {
        if (!here[i]) next = i;
        o[i] &= next - i > half;
      }
      return;
    }
    // Along y or z: the rows within `half`, clipped to the grid.
    std::copy(here, here + nx, o);
    const int from = std::max(0, at[axis] - half), to = std::min(len[axis] - 1, at[axis] + half);
    for (int r = from; r <= to; ++r) {
      const std::uint8_t* other = here + (r - at[axis]) * stride[axis];
      for (int i = 0; i < nx; ++i) o[i] &= other[i];
    }
  });
}

/// The parts of the dense voxels (step 1 of classify_dense_tissue): 1..count per dense voxel,
/// 0 elsewhere. A component with at most one core (26-connected voxels, a box three necks wide,
/// left by an erosion by a box reaching the neck, at least a voxel, along each axis) is one part,
/// as it was; one with several is shared among its cores by a breadth-first growth from all of them
/// at once (26-connected steps; ties to the core met first in scan order, so the result is
/// deterministic).
inline Volume<std::int32_t> dense_parts(const Volume<std::uint8_t>& dense, Components comps,
                                        double neck_mm, int& count, int& split) {
  count = 0, split = 0;
  if (neck_mm <= 0) {
    count = comps.count();
    return std::move(comps.labels);
  }
  Volume<std::uint8_t> core_mask = dense;
  int half[3];
  std::vector<std::uint8_t> scratch;
  for (int axis = 0; axis < 3; ++axis) {
    half[axis] = std::max(1, static_cast<int>(std::ceil(neck_mm / dense.spacing()[axis] - 1e-9)));
    erode_along(core_mask, axis, half[axis], scratch);
  }
  Components cores = connected_components(core_mask);
  // Specks left by the erosion (a trabecular lattice leaves many) are no cores: the parts they
  // would make are too small to show a cortex or a texture. A core is at least a box three necks
  // wide, and 27 voxels.
  const double voxel_mm3 = dense.spacing().prod();
  const auto min_core_voxels = std::max<std::int64_t>(
      27, static_cast<std::int64_t>(std::ceil(std::pow(3 * neck_mm, 3) / voxel_mm3)));
  for (std::size_t v = 0; v < dense.size(); ++v) {
    std::int32_t& core = cores.labels.data()[v];
    if (core != 0 && cores.sizes[core - 1] < min_core_voxels) core = 0;
  }
  // Cores per component: the first core's id, and whether there is a second.
  std::vector<std::int32_t> first_core(comps.count() + 1, 0);
  std::vector<std::uint8_t> several(comps.count() + 1, 0);
  for (std::size_t v = 0; v < dense.size(); ++v) {
    const std::int32_t core = cores.labels.data()[v], comp = comps.labels.data()[v];
    if (core == 0) continue;
    if (first_core[comp] == 0)
      first_core[comp] = core;
    else if (first_core[comp] != core)
      several[comp] = 1;
  }
  for (int c = 1; c <= comps.count(); ++c) split += several[c];
  if (split == 0) {
    count = comps.count();
    return std::move(comps.labels);
  }
  // Part ids: one per unsplit component, one per core of a split one.
  std::vector<std::int32_t> part_of_comp(comps.count() + 1, 0), part_of_core(cores.count() + 1, 0);
  for (int c = 1; c <= comps.count(); ++c)
    if (!several[c]) part_of_comp[c] = ++count;
  for (std::size_t v = 0; v < dense.size(); ++v) {
    const std::int32_t core = cores.labels.data()[v];
    if (core != 0 && several[comps.labels.data()[v]] && part_of_core[core] == 0)
      part_of_core[core] = ++count;
  }
  Volume<std::int32_t> parts(dense.geometry(), 0);
  std::vector<std::int64_t> queue;
  for (std::size_t v = 0; v < dense.size(); ++v) {
    const std::int32_t comp = comps.labels.data()[v];
    if (comp == 0) continue;
    if (!several[comp]) {
      parts.data()[v] = part_of_comp[comp];
    } else if (const std::int32_t core = cores.labels.data()[v]; core != 0) {
      parts.data()[v] = part_of_core[core];
      queue.push_back(static_cast<std::int64_t>(v));
    }
  }
  // Each core takes back what the erosion took from it, and a voxel more: a thin process or
  // vessel beyond that is no part of the core's tissue by nearness alone.
  int reach = 1;
  for (int axis = 0; axis < 3; ++axis) reach = std::max(reach, half[axis] + 1);
  const int nx = dense.nx(), ny = dense.ny();
  std::size_t level_end = queue.size();
  for (std::size_t head = 0, step = 0;
       head < queue.size() && step < static_cast<std::size_t>(reach);) {
    for (; head < level_end; ++head) {
      const std::int64_t v = queue[head];
      const int i = static_cast<int>(v % nx), j = static_cast<int>(v / nx % ny),
                k = static_cast<int>(v / nx / ny);
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int x = i + di, y = j + dj, z = k + dk;
            if (!dense.contains(x, y, z) || !dense(x, y, z) || parts(x, y, z) != 0) continue;
            parts(x, y, z) = parts.data()[v];
            queue.push_back(static_cast<std::int64_t>(dense.linear_index(x, y, z)));
          }
    }
    level_end = queue.size(), ++step;
  }
  // What no core reached (processes, ribs, small vessels): a part per 26-connected piece.
  Volume<std::uint8_t> rest(dense.geometry(), 0);
  std::int64_t unreached = 0;
  for (std::size_t v = 0; v < dense.size(); ++v)
    unreached += rest.data()[v] = dense.data()[v] && parts.data()[v] == 0;
  if (unreached == 0) return parts;
  const Components pieces = connected_components(rest);
  for (std::size_t v = 0; v < dense.size(); ++v)
    if (const std::int32_t piece = pieces.labels.data()[v]; piece != 0)
      parts.data()[v] = count + piece;
  count += pieces.count();
  return parts;
}

}  // namespace detail

/// `hu`: any real voxel type (float, or int16 as CCTAs are stored).
template <class H>
DenseTissue classify_dense_tissue(const Volume<H>& hu, const ContrastRecipe& recipe) {
  const auto n = static_cast<std::int64_t>(hu.size());
  Volume<std::uint8_t> dense(hu.geometry(), 0);
  for (std::int64_t v = 0; v < n; ++v) dense.data()[v] = hu.data()[v] >= recipe.blood_pool_lo_hu;
  DenseTissue out;
  int count = 0;
  const Volume<std::int32_t> parts = detail::dense_parts(
      dense, connected_components(dense), recipe.split_neck_mm, count, out.split_components);
  // Layer of each dense voxel: 1 on the surface, 2 under it, 3 deeper (0: not dense).
  Volume<std::uint8_t> layer(hu.geometry(), 0);
  const int nx = hu.nx(), ny = hu.ny(), nz = hu.nz();
  parallel_for(0, nz, [&](std::int64_t kk) {
    const int k = static_cast<int>(kk);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!dense(i, j, k)) continue;
        const std::int32_t part = parts(i, j, k);
        const auto outside = [&](int x, int y, int z) { return parts(x, y, z) != part; };
        layer(i, j, k) = detail::touches(dense, i, j, k, outside) ? 1 : 3;
      }
  });
  const auto in_layer1 = [&](int i, int j, int k) { return layer(i, j, k) == 1; };
  parallel_for(0, nz, [&](std::int64_t kk) {
    const int k = static_cast<int>(kk);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        if (layer(i, j, k) == 3 && detail::touches(dense, i, j, k, in_layer1)) layer(i, j, k) = 2;
  });
  std::vector<detail::LayerSums> sums(count);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::int32_t id = parts(i, j, k);
        if (id == 0) continue;
        const int l = layer(i, j, k) - 1;
        detail::LayerSums& s = sums[id - 1];
        s.sum[l] += hu(i, j, k);
        s.n[l] += 1;
        if (l == 2 && recipe.bone_texture_hu > 0)  // deeper than layer 2: no partial volume
          s.roughness.push_back(static_cast<float>(detail::roughness(hu, i, j, k)));
      }
  std::vector<std::uint8_t> class_of(count + 1, 0);
  using Dense = ContrastRecipe::Dense;
  for (int c = 0; c < count; ++c) {
    const bool bone = sums[c].bone(recipe);
    class_of[c + 1] = static_cast<std::uint8_t>(bone ? Dense::bone : Dense::blood);
    (bone ? out.bone_components : out.blood_components) += 1;
    const std::int64_t voxels = sums[c].n[0] + sums[c].n[1] + sums[c].n[2];
    (bone ? out.bone_voxels : out.blood_voxels) += voxels;
  }
  out.classes = std::move(dense);
  for (std::int64_t v = 0; v < n; ++v) out.classes.data()[v] = class_of[parts.data()[v]];
  return out;
}

/// The attenuation volume (mm^-1) of `hu` under `recipe`, with `injected` (same grid, nonzero =
/// injected lumen) or no injection when null. NaN HU is an error naming the voxel. The
/// angiography preset classifies the dense tissue itself unless `dense` (classify_dense_tissue
/// of the same `hu` and recipe) is given, e.g. once for both systems of a patient.
template <class T, class H>
Volume<float> make_attenuation(const Volume<H>& hu, const Volume<T>* injected,
                               const ContrastRecipe& recipe, const std::string& name = "volume",
                               const DenseTissue* dense = nullptr) {
  if (injected) {
    GIMM_CHECK(injected->dims() == hu.dims(), name << ": label grid " << injected->nx() << "x"
                                                   << injected->ny() << "x" << injected->nz()
                                                   << " differs from the CT grid " << hu.nx() << "x"
                                                   << hu.ny() << "x" << hu.nz());
  }
  Volume<float> mu(hu.geometry(), 0.0f);
  const H* in = hu.data();
  float* out = mu.data();
  const auto n = static_cast<std::int64_t>(hu.size());
  for (std::int64_t v = 0; v < n; ++v)  // before the structure: NaN would fall out of it
    GIMM_CHECK(std::isfinite(in[v]), name << ": HU at voxel " << v << " is not finite");
  const bool structure = recipe.preset == ContrastPreset::angiography;
  GIMM_CHECK(!dense || dense->classes.dims() == hu.dims(),
             name << ": the dense-tissue classes were made for another grid than " << hu.nx() << "x"
                  << hu.ny() << "x" << hu.nz());
  const DenseTissue own = structure && !dense ? classify_dense_tissue(hu, recipe) : DenseTissue{};
  const std::uint8_t* classes = structure ? (dense ? *dense : own).classes.data() : nullptr;
  parallel_for(
      0, n,
      [&](std::int64_t v) {
        const bool inj = injected && injected->data()[v] != T(0);
        const auto cls =
            classes ? static_cast<ContrastRecipe::Dense>(classes[v]) : ContrastRecipe::Dense::none;
        out[v] = static_cast<float>(recipe.mu(in[v], inj, cls));
      },
      1 << 16);
  return mu;
}

}  // namespace gimm
