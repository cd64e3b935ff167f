#pragma once
/// Loads a GIMM matcher from safetensors: the config from __metadata__["gimm_config"] (the
/// JSON that tools/train/gimm_model.py writes), then every tensor the model needs, checked for
/// shape; a file with a missing or an extra tensor is refused, naming it.
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <type_traits>

#include "gimm/core/error.hpp"
#include "gimm/nn/matcher.hpp"
#include "gimm/nn/safetensors.hpp"

namespace gimm::nn {

namespace detail {
inline nn::LayerKind layer_kind(const nlohmann::json& j, const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.is_string() && (j == "self" || j == "cross"),
                where << ": layer kind must be \"self\" or \"cross\", got " << j.dump());
  return j == "self" ? nn::LayerKind::self_attention : nn::LayerKind::cross_attention;
}

template <class T>
T config_value(const nlohmann::json& j, const char* key, const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.contains(key), where << ": missing key '" << key << "'");
  if constexpr (std::is_same_v<T, int>) {
    const auto& v = j.at(key);
    GIMM_CHECK_AS(FormatError,
                  v.is_number_integer() && v.template get<std::int64_t>() >= -(1LL << 30) &&
                      v.template get<std::int64_t>() <= (1LL << 30),
                  where << ": key '" << key << "' must be an integer, got " << v.dump());
  }
  try {
    return j.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    GIMM_FAIL(where << ": key '" << key << "' has the wrong type: " << j.at(key).dump());
  }
}
}  // namespace detail

constexpr const char* kMatcherFormat = "gimm-matcher/1";

/// Parses the model config JSON; `where` names the source in messages.
inline nn::MatcherConfig matcher_config_from_json(const nlohmann::json& j,
                                                  const std::string& where) {
  using detail::config_value;
  GIMM_CHECK_AS(FormatError, j.is_object(), where << ": the matcher config must be an object");
  const auto format = config_value<std::string>(j, "format", where);
  GIMM_CHECK_AS(FormatError, format == kMatcherFormat,
                where << ": config format is '" << format << "', expected " << kMatcherFormat);
  // A key this reader does not know would be ignored: a newer writer's setting, or a typo.
  static const std::set<std::string> known = {
      "format", "widths",       "coarse_heads", "fine_heads",  "coarse_layers", "fine_layers",
      "film",   "film_classes", "film_dim",     "temperature", "threshold",     "border",
      "window", "anchor",       "input_size",   "gate",        "input"};
  for (const auto& [key, value] : j.items())
    GIMM_CHECK_AS(FormatError, known.count(key),
                  where << ": unknown key '" << key << "' (this reader knows " << kMatcherFormat
                        << "'s keys only)");
  nn::MatcherConfig c;
  const auto widths = config_value<std::vector<std::int64_t>>(j, "widths", where);
  GIMM_CHECK_AS(FormatError, widths.size() == 3,
                where << ": 'widths' must have 3 entries, got " << widths.size());
  for (int i = 0; i < 3; ++i)
    c.widths[static_cast<std::size_t>(i)] = widths[static_cast<std::size_t>(i)];
  c.coarse_heads = config_value<int>(j, "coarse_heads", where);
  c.fine_heads = config_value<int>(j, "fine_heads", where);
  c.coarse_layers.clear();
  c.fine_layers.clear();
  for (const auto& k : config_value<nlohmann::json>(j, "coarse_layers", where))
    c.coarse_layers.push_back(detail::layer_kind(k, where + " coarse_layers"));
  for (const auto& k : config_value<nlohmann::json>(j, "fine_layers", where))
    c.fine_layers.push_back(detail::layer_kind(k, where + " fine_layers"));
  c.film = config_value<bool>(j, "film", where);
  c.film_classes = config_value<int>(j, "film_classes", where);
  c.film_dim = config_value<int>(j, "film_dim", where);
  c.temperature = config_value<float>(j, "temperature", where);
  c.threshold = config_value<float>(j, "threshold", where);
  c.border = config_value<int>(j, "border", where);
  c.window = config_value<int>(j, "window", where);
  if (j.contains("anchor")) c.anchor = config_value<bool>(j, "anchor", where);
  if (j.contains("input_size")) c.input_size = config_value<int>(j, "input_size", where);
  if (j.contains("input")) c.input = config_value<std::string>(j, "input", where);
  if (j.contains("gate")) {  // {"mode": "hard", "delta_px": 4, "snap": true}; absent in older files
    const auto gate = config_value<nlohmann::json>(j, "gate", where);
    GIMM_CHECK_AS(FormatError, gate.is_object(),
                  where << ": 'gate' must be an object, got " << gate.dump());
    for (const auto& [key, value] : gate.items())
      GIMM_CHECK_AS(FormatError, key == "mode" || key == "delta_px" || key == "snap",
                    where << ": unknown key 'gate." << key << "' (mode, delta_px, snap)");
    c.gate_mode = config_value<std::string>(gate, "mode", where + " gate");
    if (gate.contains("delta_px"))
      c.gate_delta_px = config_value<double>(gate, "delta_px", where + " gate");
    if (gate.contains("snap")) c.gate_snap = config_value<bool>(gate, "snap", where + " gate");
  }
  try {
    c.validate();
  } catch (const Error& e) {
    GIMM_FAIL(where << ": " << e.what());
  }
  return c;
}

inline nn::Matcher load_matcher(const SafetensorsFile& file, const std::string& where) {
  const auto& meta = file.metadata();
  const auto found = meta.find("gimm_config");
  GIMM_CHECK_AS(FormatError, found != meta.end(),
                where << ": no 'gimm_config' in __metadata__; not a gimm matcher file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(found->second);
  } catch (const nlohmann::json::exception& e) {
    GIMM_FAIL(where << ": __metadata__ gimm_config is not JSON: " << e.what());
  }
  nn::Matcher matcher(matcher_config_from_json(j, where + " gimm_config"),
                      [&](const std::string& name, const nn::Shape& shape) {
                        GIMM_CHECK_AS(FormatError, file.contains(name),
                                      where << ": missing tensor '" << name << "'");
                        nn::Tensor t = file.tensor(name, shape);
                        // A NaN or inf weight poisons every match (and the fast exp's bit
                        // tricks): refused at load, naming the first one.
                        for (std::int64_t i = 0; i < t.numel(); ++i)
                          GIMM_CHECK_AS(FormatError, std::isfinite(t.data()[i]),
                                        where << ": tensor '" << name << "' has a non-finite "
                                              << "weight " << t.data()[i] << " at index " << i);
                        return t;
                      });
  file.expect_names(matcher.tensor_names());
  return matcher;
}

inline nn::Matcher load_matcher(const std::string& path) {
  return load_matcher(SafetensorsFile::load(path), path);
}

}  // namespace gimm::nn
