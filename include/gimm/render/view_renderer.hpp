#pragma once
/// The prepared view renderer: prepare a patient once, render any number of C-arm views.
///
/// Construction builds everything that depends on the patient and not on the view: the
/// attenuation volume with its axial pads (padded_attenuation.hpp), its empty-block grid, and for
/// the injected vessels either their voxel box (voxel mode) or a vessel surface with the lumen's
/// attenuation gain (mesh mode). render(camera) then gives the view's line integrals, vessel
/// mask, overlap count and vessel depth. As DiffDRR's `DRR(subject, ...)` then `drr(pose)`.
///
///   ViewRenderer renderer(hu, &lca_mask, options);          // once per patient and system
///   RenderedView view = renderer.render(carm.camera());     // per view
///   Image<float> intensity = view.intensity();              // Beer-Lambert, I0 = 1
///
/// Thread safety: render() and unoccluded() are const and may be called from several threads
/// (each render is itself parallel over detector rows).
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

#include "gimm/anatomy/attenuation.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/filter.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/padded_attenuation.hpp"
#include "gimm/render/ray_volume.hpp"
#include "gimm/render/siddon.hpp"
#include "gimm/render/vessel_surface.hpp"

namespace gimm {

/// Where the injected vessels' image comes from. voxel: the label's voxels carry the lumen
/// attenuation (as the reference does; staircase edges). mesh: the background is rendered
/// without injection and the lumen is added as exact chord length through a smoothed vessel
/// surface (VesselSurface; Embree's in vessel_mesh_projector.hpp), anti-aliased; the 2D mask,
/// depth and overlap count come from the same surface.
enum class VesselMode { voxel, mesh };

inline VesselMode parse_vessel_mode(const std::string& s) {
  if (s == "voxel") return VesselMode::voxel;
  if (s == "mesh") return VesselMode::mesh;
  GIMM_FAIL("vessel mode must be voxel|mesh, got '" << s << "'");
}
inline const char* to_string(VesselMode m) {
  return m == VesselMode::mesh ? "mesh" : "voxel";
}

struct RendererOptions {
  ContrastRecipe recipe;                    ///< HU -> mm^-1; preset none: the volume is mm^-1
  double pad_mm = kDefaultPadMm;            ///< tissue beyond the axial coverage, mm; 0 = air
  Projector projector = Projector::siddon;  ///< siddon (exact) | trilinear
  double step_mm = 0.0;                     ///< trilinear step, mm; 0 = smallest voxel spacing
  VesselMode vessels = VesselMode::voxel;   ///< how the injected lumen is imaged
  /// Voxel mode: a pixel is vessel when its ray crosses at least this much vessel, mm.
  double min_chord_mm = 1e-6;
  /// Voxel mode: also the vessel depth and overlap count per pixel (one more walk through the
  /// vessel box per pixel). Mesh mode always has them.
  bool vessel_depth = false;
  /// Mesh mode: blur the background's line integrals by half a voxel's footprint on the
  /// detector (at the volume's centre) before the vessels are added. A volume's voxels imaged
  /// at pixels several times finer show as steps - a chest phantom's 1.6 mm voxel covers 7 px
  /// of 0.3 mm at a magnification of 1.33 - which are the grid, not anatomy (clinical frames
  /// show soft rib and spine edges). The vessels, their mask and the labels are untouched.
  bool smooth_voxel_steps = false;
};

struct RenderedView {
  Image<float> line_integrals;      ///< (rows, cols) optical depth, unitless
  Image<std::uint8_t> vessel_mask;  ///< (rows, cols) 1 = vessel; empty without vessels
  Image<std::uint8_t> overlap;      ///< (rows, cols) vessel passages per pixel; see options
  Image<float> depth_mm;            ///< (rows, cols) source to first vessel, mm; +inf: none

  /// Beer-Lambert intensity I0 exp(-line integral).
  Image<float> intensity(double i0 = 1.0) const { return beer_lambert(line_integrals, i0); }
};

class ViewRenderer {
 public:
  /// `volume`: the CT in HU, float or int16 (or attenuation in mm^-1, float only, when
  /// options.recipe.preset is none); a Volume view of the caller's buffer is read in place.
  /// `vessels`: the injected system's mask on the same grid (nonzero = lumen), or nullptr for a
  /// plain DRR without vessel outputs. `surface`: the vessels' surface, required in mesh mode.
  /// `dense`: the dense-tissue classes of `volume` when already computed (angiography recipe).
  /// `name` prefixes error messages. Nothing of `volume` or `vessels` is kept.
  template <class H>
  ViewRenderer(const Volume<H>& volume, const Volume<std::uint8_t>* vessels,
               const RendererOptions& options, const std::string& name = "volume",
               const DenseTissue* dense = nullptr,
               std::shared_ptr<const VesselSurface> surface = nullptr)
      : options_(options), surface_(std::move(surface)) {
    check_options(vessels, name);
    // One grid: the injection, the vessel mask and the lumen gain index the CT voxel by voxel.
    if (vessels) check_same_grid(volume.geometry(), vessels->geometry(), name);
    if (options.recipe.preset == ContrastPreset::none) {
      GIMM_CHECK(!vessels, name << ": with the recipe 'none' the volume already is attenuation: "
                                   "it has no injection to add (give no vessel mask)");
      if constexpr (std::is_same_v<H, float>) {
        check_attenuation(volume, name);
        attenuation_ = padded_attenuation(volume, options.pad_mm, options.projector);
      } else {
        GIMM_FAIL(name << ": with the recipe 'none' the volume is attenuation in mm^-1 and must "
                          "be float, not an integer type");
      }
    } else {
      const bool mesh = options.vessels == VesselMode::mesh;
      // The angiography recipe's bone/contrast classes, found once for the attenuation and the
      // lumen gain (a second classification costs about a second on a CCTA).
      std::optional<DenseTissue> own;
      if (options.recipe.preset == ContrastPreset::angiography && !dense)
        dense = &own.emplace(classify_dense_tissue(volume, options.recipe));
      attenuation_ = padded_attenuation(volume, mesh ? nullptr : vessels, options.recipe,
                                        options.pad_mm, options.projector, name, dense);
      if (vessels && mesh) lumen_gain_ = lumen_gain(volume, *vessels, options.recipe, dense);
    }
    prepare(vessels);
  }

  /// The same from attenuation (mm^-1) given by value: moved in, not copied (a CT-sized
  /// float volume is hundreds of MB). No vessels.
  static ViewRenderer from_attenuation(Volume<float> mu, RendererOptions options,
                                       const std::string& name = "volume") {
    options.recipe.preset = ContrastPreset::none;
    check_attenuation(mu, name);
    return ViewRenderer(std::move(mu), options, name);
  }

  /// Line integrals of `camera`'s detector and, with vessels, their mask, overlap and depth.
  RenderedView render(const Camerad& camera) const {
    DrrOptions drr;
    drr.projector = options_.projector;
    drr.step_mm = options_.step_mm;
    drr.empty_blocks = &mu_blocks_;
    RenderedView out;
    out.line_integrals = render_line_integrals(attenuation_.mu, attenuation_.pads, camera, drr);
    if (surface_ && options_.smooth_voxel_steps)
      out.line_integrals = gaussian_blur(out.line_integrals, 0.5 * voxel_footprint_px(camera));
    if (surface_) {
      VesselProjection vp = surface_->project(camera);
      out.vessel_mask = Image<std::uint8_t>(camera.rows(), camera.cols(), 0);
      for (std::size_t p = 0; p < out.line_integrals.size(); ++p) {
        out.line_integrals.data()[p] += static_cast<float>(lumen_gain_ * vp.chord_mm.data()[p]);
        out.vessel_mask.data()[p] = vp.chord_mm.data()[p] > 0;
      }
      out.overlap = std::move(vp.passages);
      out.depth_mm = std::move(vp.first_hit_mm);
    } else if (has_vessels()) {
      out.vessel_mask =
          project_unit_mask(vessel_box_, camera, options_.min_chord_mm, &vessel_blocks_);
      if (options_.vessel_depth) voxel_depth(camera, out);
    }
    return out;
  }

  /// Whether world point X (on a vessel centreline) is seen by `camera` with no other vessel
  /// passage between the source and X (the ray through X's projection). True without vessels.
  bool unoccluded(const Camerad& camera, const Eigen::Vector3d& X) const {
    if (surface_) return surface_->unoccluded(camera, X);
    if (!has_vessels()) return true;
    const Eigen::Vector2d uv = camera.project(X).uv;
    const Ray<double> ray = camera.ray(uv.x(), uv.y());
    const double distance = (X - ray.origin).dot(ray.direction);
    if (!(distance > 0)) return true;
    return siddon_mask_hits(vessel_box_, to_index_ray(vessel_box_.geometry(), ray), 0.0, distance)
               .passages <= 1;
  }

  bool has_vessels() const { return surface_ != nullptr || vessel_box_.size() > 0; }
  /// The length on `camera`'s detector (px) of one voxel (the mean spacing) at the volume's
  /// centre, across the view.
  double voxel_footprint_px(const Camerad& camera) const {
    const Volume<float>& mu = attenuation_.mu;
    const Eigen::Vector3d centre = mu.index_to_world(
        Eigen::Vector3d((mu.nx() - 1) / 2.0, (mu.ny() - 1) / 2.0, (mu.nz() - 1) / 2.0));
    const Eigen::Vector3d across = camera.R().row(0).transpose();  // the detector's u axis
    const double voxel = mu.spacing().mean();
    return (camera.project(centre + voxel * across).uv - camera.project(centre).uv).norm();
  }
  const RendererOptions& options() const { return options_; }
  /// The attenuation the views integrate (mm^-1): the scan, and its pads (siddon).
  const PaddedAttenuation& attenuation() const { return attenuation_; }
  /// Mesh mode: the attenuation the lumen adds over the uninjected background, mm^-1.
  double lumen_gain_per_mm() const { return lumen_gain_; }

 private:
  ViewRenderer(Volume<float>&& mu, const RendererOptions& options, const std::string& name)
      : options_(options) {
    check_options(nullptr, name);
    attenuation_ = padded_attenuation(std::move(mu), options.pad_mm, options.projector);
    prepare(nullptr);
  }

  void check_options(const Volume<std::uint8_t>* vessels, const std::string& name) const {
    options_.recipe.validate(name + ": recipe");
    GIMM_CHECK(
        std::isfinite(options_.step_mm) && options_.step_mm >= 0,
        name << ": step_mm must be >= 0 (0: the smallest voxel spacing), got " << options_.step_mm);
    GIMM_CHECK(std::isfinite(options_.min_chord_mm) && options_.min_chord_mm > 0,
               name << ": min_chord_mm must be > 0, got " << options_.min_chord_mm);
    const bool mesh = options_.vessels == VesselMode::mesh;
    GIMM_CHECK(!mesh || !vessels || surface_,
               name << ": mesh vessels need a vessel surface (vessel_surface_from_mask in "
                       "render/vessel_mesh_projector.hpp, target gimm::embree)");
    GIMM_CHECK(!surface_ || (mesh && vessels),
               name << ": a vessel surface is used in mesh mode with a vessel mask only");
  }

  /// The empty blocks of the attenuation and, in voxel mode, the vessels' box.
  void prepare(const Volume<std::uint8_t>* vessels) {
    mu_blocks_ = EmptyBlocks(attenuation_.mu);
    if (vessels && !surface_) {
      // The voxel mask projects through its bounding box only (a few % of the CT grid), as 0/1
      // floats with its empty blocks found once for all views.
      vessel_box_ = unit_mask(crop_to_foreground(*vessels, 1));
      vessel_blocks_ = EmptyBlocks(vessel_box_);
    }
  }

  /// The mean attenuation the injection adds inside the lumen, with the dense-tissue classes the
  /// attenuation used (a lumen voxel's uninjected value is blood, not bone); `dense` is given
  /// whenever the recipe classifies.
  template <class H>
  static double lumen_gain(const Volume<H>& hu, const Volume<std::uint8_t>& vessels,
                           const ContrastRecipe& recipe, const DenseTissue* dense) {
    double injected = 0, plain = 0;
    std::size_t count = 0;
    for (std::size_t n = 0; n < vessels.size(); ++n)
      if (vessels.data()[n]) {
        const auto cls = dense ? static_cast<ContrastRecipe::Dense>(dense->classes.data()[n])
                               : ContrastRecipe::Dense::none;
        injected += recipe.mu(hu.data()[n], true, cls);
        plain += recipe.mu(hu.data()[n], false, cls);
        ++count;
      }
    return count ? (injected - plain) / count : 0.0;
  }

  /// Voxel mode: first-hit depth and passages of every pixel's ray through the vessel box.
  void voxel_depth(const Camerad& camera, RenderedView& out) const {
    out.depth_mm =
        Image<float>(camera.rows(), camera.cols(), std::numeric_limits<float>::infinity());
    out.overlap = Image<std::uint8_t>(camera.rows(), camera.cols(), 0);
    const RayGenerator rays(camera);
    const IndexSpace to_index(vessel_box_.geometry());
    parallel_for_dynamic(0, camera.rows(), 4, [&](std::int64_t row) {
      for (int col = 0; col < camera.cols(); ++col) {
        const MaskRayHits hits =
            siddon_mask_hits(vessel_box_, to_index(rays(col, static_cast<double>(row))));
        const int r = static_cast<int>(row);
        out.depth_mm(r, col) = static_cast<float>(hits.first_hit_mm);
        out.overlap(r, col) = static_cast<std::uint8_t>(std::min(hits.passages, 255));
      }
    });
  }

  RendererOptions options_;
  PaddedAttenuation attenuation_;
  EmptyBlocks mu_blocks_;
  Volume<float> vessel_box_;  ///< voxel mode: 0/1 vessels cropped to their box (+1 voxel)
  EmptyBlocks vessel_blocks_;
  std::shared_ptr<const VesselSurface> surface_;  ///< mesh mode
  double lumen_gain_ = 0.0;                       ///< mesh mode, mm^-1
};

}  // namespace gimm
