#pragma once
/// gimm-dataset's two looks, by name (docs/dataset.md, "Styles"). A style only chooses the
/// defaults of five settings; a setting given on its own wins.
///   clinical (the default): views as a cath lab shows them - formed (iodine, scatter, blur,
///     quantum noise, the system's processing, shutters, the guiding catheter), the whole chest
///     around the heart, the phantoms' analytic tubes with the rich tree (side branches,
///     Murray's-law calibres), the background's voxel steps smoothed, 0.3 mm detector pixels
///     (512 px: a 154 mm field, as the clinical frames).
///   drr: the bare DRR of the crop phantom's classic tree with voxel vessels at 0.5 mm pixels:
///     the images the shipped weights were trained on, and every dataset before the styles.
#include <string>

#include "gimm/anatomy/coronary_branches.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/core/error.hpp"

namespace gimm {

enum class DatasetStyle { clinical, drr };

inline DatasetStyle parse_dataset_style(const std::string& s) {
  if (s == "clinical") return DatasetStyle::clinical;
  if (s == "drr") return DatasetStyle::drr;
  GIMM_FAIL("dataset style must be clinical|drr, got '" << s << "'");
}
inline const char* to_string(DatasetStyle s) {
  return s == DatasetStyle::drr ? "drr" : "clinical";
}

/// What a style chooses.
struct DatasetStyleChoices {
  bool formation = false;  ///< DatasetOptions::form_angiogram
  PhantomSize phantom_size = PhantomSize::small;
  TreeDetail tree = TreeDetail::classic;
  bool phantom_tubes = false;       ///< DatasetOptions::phantom_tubes (vessels "tubes")
  double pixel_mm = 0.5;            ///< CArmConfig::pixel_mm
  bool smooth_voxel_steps = false;  ///< DatasetOptions::smooth_voxel_steps (mesh vessels)
};

inline DatasetStyleChoices style_choices(DatasetStyle s) {
  if (s == DatasetStyle::drr) return {};
  return {true, PhantomSize::chest, TreeDetail::rich, true, 0.3, true};
}

}  // namespace gimm
