// The C++ matcher against PyTorch (tools/train/gimm_model.py) on the committed fixture
// tests/data/nn/ (regenerate with tools/train/make_parity_fixture.py): same weights, same
// images -> coarse confidence within 1e-4, the same coarse matches, fine points (A and B) within
// 1e-3 px.
#include <omp.h>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "gimm/nn/matcher_file.hpp"
#include "gimm/nn/safetensors.hpp"

namespace {

const std::string kFixtureDir = std::string(GIMM_SOURCE_DIR) + "/tests/data/nn/";

gimm::nn::Tensor as_image(const gimm::nn::Tensor& image) {
  return image.reshaped({1, 1, image.dim(0), image.dim(1)});
}

/// The C++ engine against PyTorch's outputs for one weights file.
void check_parity(const std::string& expected_file, const std::string& weights_file) {
  INFO("fixture " << expected_file << " with " << weights_file);
  const auto expected = gimm::nn::SafetensorsFile::load(expected_file);
  const gimm::nn::Matcher matcher = gimm::nn::load_matcher(weights_file);
  const int class0 = std::stoi(expected.metadata().at("class0"));
  const int class1 = std::stoi(expected.metadata().at("class1"));
  REQUIRE(class0 != class1);  // FiLM must see two different classes

  const gimm::nn::MatcherOutput out =
      matcher.match(as_image(expected.tensor("image0")), as_image(expected.tensor("image1")),
                    class0, class1, /*keep_confidence=*/true);

  const gimm::nn::Tensor conf = expected.tensor("confidence");
  REQUIRE(out.confidence.shape() == conf.shape());
  double max_diff = 0;
  for (std::int64_t i = 0; i < conf.numel(); ++i)
    max_diff = std::max(max_diff, double(std::abs(out.confidence[i] - conf[i])));
  INFO("coarse confidence max |diff| = " << max_diff);
  CHECK(max_diff <= 1e-4);

  const gimm::nn::Tensor i_ids = expected.tensor("i_ids"), j_ids = expected.tensor("j_ids");
  REQUIRE(i_ids.numel() >= 8);  // the fixture must exercise the fine stage
  REQUIRE(out.i_ids.size() == std::size_t(i_ids.numel()));
  const gimm::nn::Tensor p0 = expected.tensor("points0"), p1 = expected.tensor("points1");
  const gimm::nn::Tensor mconf = expected.tensor("mconf");
  double max_fine = 0;
  int refined = 0;
  for (std::int64_t k = 0; k < i_ids.numel(); ++k) {
    CHECK(out.i_ids[std::size_t(k)] == std::int64_t(i_ids[k]));
    CHECK(out.j_ids[std::size_t(k)] == std::int64_t(j_ids[k]));
    CHECK(out.coarse_confidence[std::size_t(k)] == Approx(mconf[k]).margin(1e-4));
    for (int a = 0; a < 2; ++a) {
      max_fine = std::max(max_fine, double(std::abs(out.points0[std::size_t(k)][a] - p0.at(k, a))));
      max_fine = std::max(max_fine, double(std::abs(out.points1[std::size_t(k)][a] - p1.at(k, a))));
      // Off the cell centre (a multiple of 8) exactly when the anchor refines A.
      refined += std::fmod(double(p0.at(k, a)), 8.0) != 0.0;
    }
  }
  CHECK((refined > 0) == matcher.config().anchor);
  INFO("fine points max |diff| = " << max_fine << " px");
  CHECK(max_fine <= 1e-3);
}

}  // namespace

TEST_CASE("matcher: parity with PyTorch on the committed fixtures", "[nn][parity]") {
  // parity_*: A points at the coarse cell centres, its config written before the anchor key
  // existed (the loader's default); parity_anchor_*: A points refined inside their windows.
  const std::string prefix = GENERATE(std::string("parity"), std::string("parity_anchor"));
  check_parity(kFixtureDir + prefix + "_expected.safetensors",
               kFixtureDir + prefix + "_weights.safetensors");
  CHECK(gimm::nn::load_matcher(kFixtureDir + prefix + "_weights.safetensors").config().anchor ==
        (prefix == "parity_anchor"));
}

TEST_CASE("matcher: parity with PyTorch for the shipped weights on a phantom pair",
          "[nn][parity]") {
  // tools/train/make_parity_fixture.py --shipped: the trained weights of weights/ on one view
  // pair of a held-out phantom patient, at the weights' input size.
  const std::string weights =
      std::string(GIMM_SOURCE_DIR) + "/weights/gimm-phantom-128.safetensors";
  check_parity(kFixtureDir + "shipped_expected.safetensors", weights);
  CHECK(gimm::nn::load_matcher(weights).config().input_size == 128);
}

TEST_CASE("matcher: the view class changes the coarse confidences (FiLM is live)", "[nn]") {
  const auto expected =
      gimm::nn::SafetensorsFile::load(kFixtureDir + "parity_expected.safetensors");
  const gimm::nn::Matcher matcher =
      gimm::nn::load_matcher(kFixtureDir + "parity_weights.safetensors");
  const auto a = as_image(expected.tensor("image0")), b = as_image(expected.tensor("image1"));
  const auto first = matcher.match(a, b, 3, 7, true);
  const auto swapped = matcher.match(a, b, 7, 3, true);
  double diff = 0;
  for (std::int64_t i = 0; i < first.confidence.numel(); ++i)
    diff = std::max(diff, double(std::abs(first.confidence[i] - swapped.confidence[i])));
  CHECK(diff > 1e-4);
  CHECK_THROWS_WITH(matcher.match(a, b, 12, 0), Catch::Contains("view class 12"));
  CHECK_THROWS_WITH(matcher.match(a, b, -1, 0), Catch::Contains("view class -1"));
}

TEST_CASE("matcher: bad inputs are refused with the bad value named", "[nn]") {
  const gimm::nn::Matcher matcher =
      gimm::nn::load_matcher(kFixtureDir + "parity_weights.safetensors");
  const gimm::nn::Tensor good({1, 1, 64, 96});
  CHECK_THROWS_WITH(matcher.match(good, gimm::nn::Tensor({1, 1, 64, 88})),
                    Catch::Contains("image 1"));
  CHECK_THROWS_WITH(
      matcher.match(gimm::nn::Tensor({1, 1, 60, 96}), gimm::nn::Tensor({1, 1, 60, 96})),
      Catch::Contains("96x60"));
  CHECK_THROWS_WITH(
      matcher.match(gimm::nn::Tensor({1, 2, 64, 96}), gimm::nn::Tensor({1, 2, 64, 96})),
      Catch::Contains("[1, 2, 64, 96]"));
}

TEST_CASE("matcher weights: missing, extra and misshapen tensors are named", "[nn][io]") {
  const auto weights = gimm::nn::SafetensorsFile::load(kFixtureDir + "parity_weights.safetensors");
  std::vector<gimm::nn::Tensor> tensors;
  std::vector<std::string> names = weights.names();
  for (const auto& n : names) tensors.push_back(weights.tensor(n));
  const std::string dir = std::string(GIMM_TEST_TMP) + "/nn_weights";
  std::filesystem::create_directories(dir);

  auto write_variant = [&](const std::string& file, const std::string& drop,
                           const std::string& extra, const std::string& reshape) {
    std::vector<std::pair<std::string, const gimm::nn::Tensor*>> list;
    std::vector<gimm::nn::Tensor> reshaped;
    reshaped.reserve(names.size());
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (names[i] == drop) continue;
      if (names[i] == reshape) {
        reshaped.push_back(tensors[i].reshaped({tensors[i].numel()}));
        list.emplace_back(names[i], &reshaped.back());
      } else {
        list.emplace_back(names[i], &tensors[i]);
      }
    }
    if (!extra.empty()) list.emplace_back(extra, &tensors[0]);
    gimm::nn::write_safetensors(dir + "/" + file, list, weights.metadata());
    return dir + "/" + file;
  };
  CHECK_THROWS_WITH(gimm::nn::load_matcher(
                        write_variant("missing.safetensors", "coarse.layers.1.k.weight", "", "")),
                    Catch::Contains("coarse.layers.1.k.weight"));
  CHECK_THROWS_WITH(
      gimm::nn::load_matcher(write_variant("extra.safetensors", "", "backbone.unused.weight", "")),
      Catch::Contains("backbone.unused.weight"));
  CHECK_THROWS_WITH(
      gimm::nn::load_matcher(write_variant("shape.safetensors", "", "", "down_proj.weight")),
      Catch::Contains("down_proj.weight"));

  // A NaN or inf weight is refused at load, naming the tensor, the value and its index.
  for (const float bad :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    std::vector<gimm::nn::Tensor> poisoned = tensors;
    poisoned[1].data()[2] = bad;
    std::vector<std::pair<std::string, const gimm::nn::Tensor*>> list;
    for (std::size_t i = 0; i < names.size(); ++i) list.emplace_back(names[i], &poisoned[i]);
    gimm::nn::write_safetensors(dir + "/nonfinite.safetensors", list, weights.metadata());
    CHECK_THROWS_WITH(gimm::nn::load_matcher(dir + "/nonfinite.safetensors"),
                      Catch::Contains(names[1]) && Catch::Contains("non-finite") &&
                          Catch::Contains("at index 2"));
  }

  // A config that disagrees with the tensors (wider coarse stage) fails on the first tensor.
  auto meta = weights.metadata();
  const std::string config = meta.at("gimm_config");
  meta["gimm_config"] = std::string(config).replace(config.find("\"widths\": [8, 16, 32]"),
                                                    std::string("\"widths\": [8, 16, 32]").size(),
                                                    "\"widths\": [8, 16, 64]");
  std::vector<std::pair<std::string, const gimm::nn::Tensor*>> all;
  for (std::size_t i = 0; i < names.size(); ++i) all.emplace_back(names[i], &tensors[i]);
  gimm::nn::write_safetensors(dir + "/config.safetensors", all, meta);
  CHECK_THROWS_WITH(gimm::nn::load_matcher(dir + "/config.safetensors"),
                    Catch::Contains("backbone.layer3.0.conv1.0.weight"));

  meta["gimm_config"] = std::string(config).replace(config.find("\"coarse_heads\": 4"),
                                                    std::string("\"coarse_heads\": 4").size(),
                                                    "\"coarse_heads\": 4.9");
  gimm::nn::write_safetensors(dir + "/heads.safetensors", all, meta);
  CHECK_THROWS_WITH(gimm::nn::load_matcher(dir + "/heads.safetensors"),
                    Catch::Contains("'coarse_heads' must be an integer, got 4.9"));

  // The recorded gate: read back, and refused when malformed, naming the key or value.
  const auto with_gate = [&](const std::string& gate) {
    const auto at = config.rfind('}');
    meta["gimm_config"] = config.substr(0, at) + ", \"gate\": " + gate + "}";
    gimm::nn::write_safetensors(dir + "/gate.safetensors", all, meta);
    return gimm::nn::load_matcher(dir + "/gate.safetensors");
  };
  meta["gimm_config"] = config;  // written before the gate existed: none recorded
  gimm::nn::write_safetensors(dir + "/nogate.safetensors", all, meta);
  CHECK(gimm::nn::load_matcher(dir + "/nogate.safetensors").config().gate_mode.empty());
  const auto gated = with_gate(R"({"mode": "hard", "delta_px": 4, "snap": true})").config();
  CHECK(gated.gate_mode == "hard");
  CHECK(gated.gate_delta_px == 4.0);
  CHECK(gated.gate_snap);
  CHECK_THROWS_WITH(with_gate(R"({"mode": "tight"})"),
                    Catch::Contains("gate mode must be hard|soft|logit|none, got 'tight'"));
  CHECK_THROWS_WITH(with_gate(R"({"mode": "hard", "delta_px": -1})"),
                    Catch::Contains("delta_px must be > 0, got -1"));
  CHECK_THROWS_WITH(with_gate(R"({"mode": "hard", "delta_px": 4, "snap": "yes"})"),
                    Catch::Contains("'snap' has the wrong type"));
  CHECK_THROWS_WITH(with_gate(R"("hard")"), Catch::Contains("'gate' must be an object"));
  CHECK_THROWS_WITH(with_gate(R"({"mode": "hard", "delta": 4})"),
                    Catch::Contains("unknown key 'gate.delta'"));
  // What the network sees: intensity when not recorded (files written before it existed),
  // vesselness when recorded; anything else refused, naming it.
  CHECK(gimm::nn::load_matcher(dir + "/nogate.safetensors").config().input == "intensity");
  const auto with_input = [&](const std::string& input) {
    meta["gimm_config"] = config.substr(0, config.rfind('}')) + ", \"input\": " + input + "}";
    gimm::nn::write_safetensors(dir + "/input.safetensors", all, meta);
    return gimm::nn::load_matcher(dir + "/input.safetensors");
  };
  CHECK(with_input(R"("vesselness")").config().input == "vesselness");
  CHECK_THROWS_WITH(with_input(R"("edges")"),
                    Catch::Contains("input must be intensity|vesselness, got 'edges'"));
  CHECK_THROWS_WITH(with_input("3"), Catch::Contains("'input' has the wrong type"));
  // A key the reader does not know (a typo, a newer writer's setting) is refused, not ignored.
  meta["gimm_config"] = config.substr(0, config.rfind('}')) + ", \"treshold\": 0.3}";
  gimm::nn::write_safetensors(dir + "/typo.safetensors", all, meta);
  CHECK_THROWS_WITH(gimm::nn::load_matcher(dir + "/typo.safetensors"),
                    Catch::Contains("unknown key 'treshold'"));

  meta["gimm_config"] = "{not json";
  gimm::nn::write_safetensors(dir + "/badjson.safetensors", all, meta);
  CHECK_THROWS_WITH(gimm::nn::load_matcher(dir + "/badjson.safetensors"),
                    Catch::Contains("gimm_config"));

  meta.erase("gimm_config");
  gimm::nn::write_safetensors(dir + "/noconfig.safetensors", all, meta);
  CHECK_THROWS_WITH(gimm::nn::load_matcher(dir + "/noconfig.safetensors"),
                    Catch::Contains("gimm_config"));
}

TEST_CASE("matcher: the result does not depend on the thread count", "[nn]") {
  const auto expected =
      gimm::nn::SafetensorsFile::load(kFixtureDir + "parity_expected.safetensors");
  const gimm::nn::Matcher matcher =
      gimm::nn::load_matcher(kFixtureDir + "parity_weights.safetensors");
  // 256 x 256 as well, so that the large products (the 1024 x 1024 similarity) are split
  // across threads by Eigen.
  gimm::nn::Tensor big_a({1, 1, 256, 256}), big_b({1, 1, 256, 256});
  for (int r = 0; r < 256; ++r)
    for (int c = 0; c < 256; ++c) {
      big_a.at(0, 0, r, c) = float(0.5 + 0.4 * std::sin(r / 9.0) * std::cos(c / 13.0));
      big_b.at(0, 0, r, c) = float(0.5 + 0.4 * std::sin((r + 8) / 9.0) * std::cos((c + 16) / 13.0));
    }
  for (const auto& [a, b] :
       {std::pair{as_image(expected.tensor("image0")), as_image(expected.tensor("image1"))},
        std::pair{big_a, big_b}}) {
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    const auto one = matcher.match(a, b, 3, 7, true);
    omp_set_num_threads(std::max(2, threads));
    const auto many = matcher.match(a, b, 3, 7, true);
    omp_set_num_threads(threads);
    CHECK(one.confidence.values() == many.confidence.values());
    CHECK(one.i_ids == many.i_ids);
    CHECK(one.j_ids == many.j_ids);
    CHECK(one.points1 == many.points1);
  }
}
