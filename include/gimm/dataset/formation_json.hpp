#pragma once
/// AngiogramFormation <-> JSON (nlohmann_json), the per-view record of how a frame was formed:
///   {"scatter_to_primary": 0.5, ..., "window": "percentile", "bits": 8,
///    "shutter": {"shape": "rectangular", "half_width": 0.92, ...}}
/// Keys are the struct's member names, numbers in the units the struct documents. Reading
/// requires every key, refuses unknown ones (a misspelt key in a hand-written config would
/// otherwise be silently ignored) and validates; errors are FormatError naming `where` and the key.
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/io/files.hpp"
#include "gimm/render/angiogram_formation.hpp"

namespace gimm {

inline nlohmann::json to_json(const Shutter& s) {
  return {{"shape", to_string(s.shape)},  {"half_width", s.half_width},
          {"half_height", s.half_height}, {"corner_cut", s.corner_cut},
          {"radius", s.radius},           {"center_u", s.center_u},
          {"center_v", s.center_v},       {"penumbra_px", s.penumbra_px},
          {"frame_level", s.frame_level}};
}

inline nlohmann::json to_json(const AngiogramFormation& f) {
  return {{"scatter_to_primary", f.scatter_to_primary},
          {"scatter_sigma_mm", f.scatter_sigma_mm},
          {"focal_spot_blur_px", f.focal_spot_blur_px},
          {"detector_blur_px", f.detector_blur_px},
          {"detector_photons", f.detector_photons},
          {"electronic_noise", f.electronic_noise},
          {"range_compression", f.range_compression},
          {"range_compression_sigma_px", f.range_compression_sigma_px},
          {"edge_gain", f.edge_gain},
          {"edge_radius_px", f.edge_radius_px},
          {"window", to_string(f.window)},
          {"window_low_percentile", f.window_low_percentile},
          {"window_high_percentile", f.window_high_percentile},
          {"window_min_width", f.window_min_width},
          {"window_width", f.window_width},
          {"gamma", f.gamma},
          {"display_black", f.display_black},
          {"display_white", f.display_white},
          {"bits", f.bits},
          {"shutter", to_json(f.shutter)}};
}

namespace detail {

/// Refuses keys of `j` that `to_json` of a default value does not write.
inline void check_known_keys(const nlohmann::json& j, const nlohmann::json& reference,
                             const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.is_object(), where << ": must be a JSON object, got " << j.dump());
  for (const auto& item : j.items())
    GIMM_CHECK_AS(FormatError, reference.contains(item.key()),
                  where << ": unknown field '" << item.key() << "'");
}

}  // namespace detail

inline Shutter shutter_from_json(const nlohmann::json& j, const std::string& where) {
  detail::check_known_keys(j, to_json(Shutter{}), where);
  Shutter s;
  try {
    s.shape = parse_shutter_shape(json_string(j, "shape", where));
  } catch (const FormatError&) {
    throw;
  } catch (const Error& e) {
    throw FormatError(std::string(e.what()) + " (" + where + ")");
  }
  s.half_width = json_number(j, "half_width", where);
  s.half_height = json_number(j, "half_height", where);
  s.corner_cut = json_number(j, "corner_cut", where);
  s.radius = json_number(j, "radius", where);
  s.center_u = json_number(j, "center_u", where);
  s.center_v = json_number(j, "center_v", where);
  s.penumbra_px = json_number(j, "penumbra_px", where);
  s.frame_level = json_number(j, "frame_level", where);
  return s;
}

/// Parses and validates; `where` (a file, a view) prefixes every error.
inline AngiogramFormation angiogram_formation_from_json(const nlohmann::json& j,
                                                        const std::string& where) {
  detail::check_known_keys(j, to_json(AngiogramFormation{}), where);
  AngiogramFormation f;
  f.scatter_to_primary = json_number(j, "scatter_to_primary", where);
  f.scatter_sigma_mm = json_number(j, "scatter_sigma_mm", where);
  f.focal_spot_blur_px = json_number(j, "focal_spot_blur_px", where);
  f.detector_blur_px = json_number(j, "detector_blur_px", where);
  f.detector_photons = json_number(j, "detector_photons", where);
  f.electronic_noise = json_number(j, "electronic_noise", where);
  f.range_compression = json_number(j, "range_compression", where);
  f.range_compression_sigma_px = json_number(j, "range_compression_sigma_px", where);
  f.edge_gain = json_number(j, "edge_gain", where);
  f.edge_radius_px = json_number(j, "edge_radius_px", where);
  try {
    f.window = parse_window_mode(json_string(j, "window", where));
  } catch (const FormatError&) {
    throw;
  } catch (const Error& e) {
    throw FormatError(std::string(e.what()) + " (" + where + ")");
  }
  f.window_low_percentile = json_number(j, "window_low_percentile", where);
  f.window_high_percentile = json_number(j, "window_high_percentile", where);
  f.window_min_width = json_number(j, "window_min_width", where);
  f.window_width = json_number(j, "window_width", where);
  f.gamma = json_number(j, "gamma", where);
  f.display_black = json_number(j, "display_black", where);
  f.display_white = json_number(j, "display_white", where);
  f.bits = json_int(j, "bits", where);
  f.shutter = shutter_from_json(json_field(j, "shutter", where), where + ": shutter");
  try {
    f.validate();
  } catch (const FormatError&) {
    throw;
  } catch (const Error& e) {
    throw FormatError(std::string(e.what()) + " (" + where + ")");
  }
  return f;
}

inline nlohmann::json to_json(const IodineContrast& c) {
  return {{"iodine_mg_per_ml", c.iodine_mg_per_ml}, {"effective_kev", c.effective_kev}};
}

inline IodineContrast iodine_contrast_from_json(const nlohmann::json& j, const std::string& where) {
  detail::check_known_keys(j, to_json(IodineContrast{}), where);
  IodineContrast c;
  c.iodine_mg_per_ml = json_number(j, "iodine_mg_per_ml", where);
  c.effective_kev = json_number(j, "effective_kev", where);
  try {
    c.validate();
  } catch (const Error& e) {
    throw FormatError(std::string(e.what()) + " (" + where + ")");
  }
  return c;
}

/// The randomisation ranges as a record (the dataset manifest's parameters): each interval as
/// [lo, hi], the shape weights by name.
inline nlohmann::json to_json(const AngiogramFormationRanges& r) {
  const auto iv = [](Interval i) { return nlohmann::json::array({i.lo, i.hi}); };
  return {{"scatter_to_primary", iv(r.scatter_to_primary)},
          {"scatter_sigma_mm", iv(r.scatter_sigma_mm)},
          {"focal_spot_blur_px", iv(r.focal_spot_blur_px)},
          {"detector_blur_px", iv(r.detector_blur_px)},
          {"detector_photons", iv(r.detector_photons)},
          {"electronic_noise", iv(r.electronic_noise)},
          {"range_compression", iv(r.range_compression)},
          {"range_compression_sigma_px", iv(r.range_compression_sigma_px)},
          {"edge_gain", iv(r.edge_gain)},
          {"edge_radius_px", iv(r.edge_radius_px)},
          {"window_min_width", iv(r.window_min_width)},
          {"gamma", iv(r.gamma)},
          {"bits", r.bits},
          {"shutter_weights",
           {{"none", r.weight_none},
            {"rectangular", r.weight_rectangular},
            {"octagonal", r.weight_octagonal},
            {"circular", r.weight_circular}}},
          {"shutter_half_size", iv(r.shutter_half_size)},
          {"shutter_corner_cut", iv(r.shutter_corner_cut)},
          {"shutter_radius", iv(r.shutter_radius)},
          {"shutter_center", iv(r.shutter_center)},
          {"shutter_penumbra_px", iv(r.shutter_penumbra_px)},
          {"shutter_frame_level", iv(r.shutter_frame_level)},
          {"display_black", iv(r.display_black)},
          {"display_white", iv(r.display_white)}};
}

}  // namespace gimm
