#pragma once
/// The attenuation of a patient with the tissue beyond the scan's axial coverage (axial_pad.hpp),
/// in the form the chosen projector integrates exactly:
/// - siddon: the scan's mu plus two thick pads (AxialPads), one voxel each;
/// - trilinear: one padded volume (pad_axial, whole slices), since the trilinear field of a
///   thick slab fades over half its thickness.
/// The pads continue the edge slices' tissue (HU and dense-tissue class) without the injection:
/// contrast in a coronary cut by the scan's coverage does not carry on for centimetres beyond.
#include <optional>
#include <string>
#include <utility>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/render/axial_pad.hpp"
#include "gimm/render/drr.hpp"

namespace gimm {

struct PaddedAttenuation {
  Volume<float> mu;       ///< the scan (siddon) or the padded scan (trilinear)
  AxialPads<float> pads;  ///< siddon only; empty otherwise
};

/// From a volume that already is attenuation (mm^-1): its edge slices carry on. The result owns
/// its voxels: a view (Volume::view) is copied, as the renderer outlives its caller's buffer.
inline PaddedAttenuation padded_attenuation(Volume<float> mu, double pad_mm, Projector projector) {
  if (!mu.owns_data()) mu = Volume<float>(std::as_const(mu));  // the copy owns its voxels
  if (projector == Projector::siddon) {
    AxialPads<float> pads = axial_pads(mu, pad_mm);
    return {std::move(mu), std::move(pads)};
  }
  return {pad_axial(std::move(mu), pad_mm), {}};
}

/// make_attenuation(hu, injected, recipe, name, dense) with `pad_mm` of the patient beyond the
/// scan on both axial sides (uninjected), for `projector`.
template <class T, class H>
PaddedAttenuation padded_attenuation(const Volume<H>& hu, const Volume<T>* injected,
                                     const ContrastRecipe& recipe, double pad_mm,
                                     Projector projector, const std::string& name = "volume",
                                     const DenseTissue* dense = nullptr) {
  std::optional<DenseTissue> own;
  if (recipe.preset == ContrastPreset::angiography && !dense)
    dense = &own.emplace(classify_dense_tissue(hu, recipe));
  // A pad's voxels keep the class of the edge voxel they continue: a one-voxel slab has no
  // structure of its own to classify.
  const auto attenuate = [&](const Volume<H>& hu_pad, Volume<std::uint8_t>* classes) {
    DenseTissue carried;
    if (classes) carried.classes = std::move(*classes);
    return make_attenuation<std::uint8_t>(hu_pad, nullptr, recipe, name + " (axial pad)",
                                          classes ? &carried : nullptr);
  };
  if (projector == Projector::siddon) {
    Volume<float> mu = make_attenuation(hu, injected, recipe, name, dense);
    if (pad_mm == 0) return {std::move(mu), {}};
    const AxialPads<H> hu_pads = axial_pads(hu, pad_mm);
    AxialPads<std::uint8_t> class_pads;
    if (dense) class_pads = axial_pads(dense->classes, pad_mm);
    AxialPads<float> pads{attenuate(hu_pads.below, dense ? &class_pads.below : nullptr),
                          attenuate(hu_pads.above, dense ? &class_pads.above : nullptr)};
    return {std::move(mu), std::move(pads)};
  }
  // Trilinear: the whole padded grid at once (its classes copied along, its injection not).
  std::optional<Volume<std::uint8_t>> classes;
  if (dense) classes = pad_axial(dense->classes, pad_mm);
  DenseTissue padded_dense;
  if (classes) padded_dense.classes = std::move(*classes);
  std::optional<Volume<T>> injected_padded;
  if (injected) injected_padded = pad_axial(*injected, pad_mm, std::optional<T>(T(0)));
  return {make_attenuation(pad_axial(hu, pad_mm), injected ? &*injected_padded : nullptr, recipe,
                           name, dense ? &padded_dense : nullptr),
          {}};
}

}  // namespace gimm
