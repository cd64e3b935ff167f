// The matcher interface: each adapter gives what its function gives, names itself, and refuses
// a pair it cannot match with the pair named.
#include <catch2/catch.hpp>
#include <memory>
#include <utility>

#include "gimm/geometry/carm.hpp"
#include "gimm/match/baselines.hpp"
#include "gimm/match/field_of_view.hpp"
#include "gimm/match/learned.hpp"
#include "gimm/match/reconstruct.hpp"
#include "gimm/nn/matcher_file.hpp"

namespace {
gimm::PairTruth crossing_truth() {
  gimm::PairTruth t;
  t.id = "p/LCA_00-01";
  t.view_a = "LCA_00";
  t.view_b = "LCA_01";
  gimm::Image<std::uint8_t> ma(32, 32), mb(32, 32);
  for (int k = 2; k < 30; ++k) {
    ma(k, 10) = 255;  // a vertical vessel in A
    mb(12, k) = 255;  // a horizontal one in B
    gimm::Correspondence c;
    c.a = {10.0, double(k)};
    c.b = {double(k), 12.0};
    c.world = {double(k), 0, 0};
    t.dense.push_back(c);
  }
  t.mask_a = std::make_shared<const gimm::Image<std::uint8_t>>(ma);
  t.mask_b = std::make_shared<const gimm::Image<std::uint8_t>>(mb);
  t.F << 0, 0, 0, 0, 0, -1, 0, 1, 0;  // v_b = v_a: the epipolar lines are rows
  return t;
}

bool same(const gimm::PairMatches& x, const gimm::PairMatches& y) {
  return x.pair == y.pair && x.points_a == y.points_a && x.points_b == y.points_b &&
         x.confidence == y.confidence;
}

/// A pair of images as the matchers take it: view classes 3 and 7, cameras if given.
gimm::PairInput pair_of(const gimm::Image<float>& a, const gimm::Image<float>& b,
                        std::optional<gimm::Camerad> camera_a = std::nullopt,
                        std::optional<gimm::Camerad> camera_b = std::nullopt) {
  gimm::PairInput p;
  p.image_a = &a;
  p.image_b = &b;
  p.class_a = 3;
  p.class_b = 7;
  p.camera_a = std::move(camera_a);
  p.camera_b = std::move(camera_b);
  return p;
}

/// The two images of a parity fixture as gimm images.
std::pair<gimm::Image<float>, gimm::Image<float>> fixture_images(const std::string& file) {
  const auto expected = gimm::nn::SafetensorsFile::load(file);
  const gimm::nn::Tensor i0 = expected.tensor("image0"), i1 = expected.tensor("image1");
  gimm::Image<float> a(int(i0.dim(0)), int(i0.dim(1))), b(a.rows(), a.cols());
  for (std::int64_t n = 0; n < i0.numel(); ++n) {
    a.data()[n] = i0[n];
    b.data()[n] = i1[n];
  }
  return {a, b};
}
}  // namespace

TEST_CASE("Matcher interface: the baselines' adapters equal their functions", "[match]") {
  const gimm::PairTruth t = crossing_truth();
  gimm::PairInput input;
  input.id = t.id;
  input.truth = &t;
  const gimm::OracleMatcher oracle(1.5, 7);
  gimm::Rng rng = gimm::baseline_stream(7, "oracle", t.id);
  CHECK(oracle.name() == "oracle");
  CHECK_FALSE(oracle.needs_images());
  CHECK(same(oracle.match(input), gimm::oracle_matches(t, 1.5, rng)));
  const gimm::EpipolarMatcher epipolar({}, 7);
  rng = gimm::baseline_stream(7, "epipolar", t.id);
  const gimm::PairMatches e = epipolar.match(input);
  CHECK(same(e, gimm::epipolar_matches(t, {}, rng)));
  CHECK(e.size() > 0);
  gimm::PairInput none;
  none.id = "p/x";
  CHECK_THROWS_WITH(oracle.match(none), Catch::Contains("'p/x'"));
  CHECK_THROWS_WITH(epipolar.match(none), Catch::Contains("'p/x'"));
}

TEST_CASE("Matcher interface: the learned adapter equals match_pair", "[match]") {
  const std::string fixture = std::string(GIMM_SOURCE_DIR) + "/tests/data/nn/";
  const auto [a, b] = fixture_images(fixture + "parity_anchor_expected.safetensors");
  gimm::MatchOptions options;
  options.gate.mode = gimm::GateMode::none;
  const gimm::LearnedMatcher learned(
      gimm::nn::load_matcher(fixture + "parity_anchor_weights.safetensors"), options);
  gimm::PairInput input;
  input.id = "p/LCA_00-01";
  input.image_a = &a;
  input.image_b = &b;
  input.class_a = 3;
  input.class_b = 7;
  CHECK(learned.name() == "learned");
  const gimm::PairMatches direct =
      gimm::match_pair(gimm::nn::load_matcher(fixture + "parity_anchor_weights.safetensors"), input,
                       options)
          .matches;
  const gimm::PairMatches via = learned.match(input);
  CHECK(via.size() > 0);
  CHECK(same(via, direct));
  input.image_b = nullptr;
  CHECK_THROWS_WITH(learned.match(input), Catch::Contains("'p/LCA_00-01' has no images"));
}

TEST_CASE("Learned matcher: --snap puts every B point on its epipolar line", "[match]") {
  const Eigen::Vector3d l(3, 4, -10);  // 3u + 4v = 10
  const Eigen::Vector2d foot = gimm::foot_on_line(l, {5, 5});
  CHECK(3 * foot.x() + 4 * foot.y() == Approx(10));
  CHECK((Eigen::Vector2d(5, 5) - foot).norm() == Approx(25.0 / 5.0));  // |3*5+4*5-10| / 5

  const std::string fixture = std::string(GIMM_SOURCE_DIR) + "/tests/data/nn/";
  const auto [a, b] = fixture_images(fixture + "parity_anchor_expected.safetensors");
  gimm::CArm carm;
  carm.rows = a.rows();
  carm.cols = a.cols();
  carm.primary_deg = 30;
  const gimm::Camerad cam_a = carm.camera();
  carm.primary_deg = -20;
  carm.secondary_deg = 15;
  const gimm::Camerad cam_b = carm.camera();
  const Eigen::Matrix3d F = gimm::fundamental_from_cameras(cam_a, cam_b);
  gimm::MatchOptions options;
  options.gate.delta_px = 1e6;  // keep everything: the snap alone is tested
  const gimm::nn::Matcher network =
      gimm::nn::load_matcher(fixture + "parity_anchor_weights.safetensors");
  const auto plain = gimm::match_pair(network, pair_of(a, b, cam_a, cam_b), options).matches;
  options.snap_to_epipolar = true;
  const auto snapped = gimm::match_pair(network, pair_of(a, b, cam_a, cam_b), options).matches;
  REQUIRE(plain.size() > 0);
  REQUIRE(snapped.size() == plain.size());
  for (std::size_t k = 0; k < plain.size(); ++k) {
    const Eigen::Vector3d line = F * snapped.points_a[k].homogeneous();
    CHECK(std::abs(line.dot(snapped.points_b[k].homogeneous())) / line.head<2>().norm() < 1e-6);
    CHECK(snapped.points_a[k] == plain.points_a[k]);
    CHECK(snapped.confidence[k] == plain.confidence[k]);
  }
  options.gate.mode = gimm::GateMode::none;
  CHECK_THROWS_WITH(gimm::match_pair(network, pair_of(a, b, cam_a, cam_b), options),
                    Catch::Contains("needs an F"));
}

TEST_CASE("Learned matcher: images of different sizes map back per image", "[match]") {
  // B twice as large, each pixel a 2x2 block: resized to A's size (the exact 2x2 box filter)
  // it is the same network input, so the matches are the same, B's points scaled by 2 about
  // pixel corners: u2 = 2 (u + 0.5) - 0.5.
  const std::string fixture = std::string(GIMM_SOURCE_DIR) + "/tests/data/nn/";
  const auto [a, b] = fixture_images(fixture + "parity_anchor_expected.safetensors");
  gimm::Image<float> b2(2 * b.rows(), 2 * b.cols());
  for (int r = 0; r < b2.rows(); ++r)
    for (int c = 0; c < b2.cols(); ++c) b2(r, c) = b(r / 2, c / 2);
  const gimm::nn::Matcher network =
      gimm::nn::load_matcher(fixture + "parity_anchor_weights.safetensors");
  gimm::MatchOptions options;
  options.gate.mode = gimm::GateMode::none;
  options.input_size = std::max(a.rows(), a.cols());
  const auto same_size =
      gimm::match_pair(network, pair_of(a, b, std::nullopt, std::nullopt), options).matches;
  const auto larger =
      gimm::match_pair(network, pair_of(a, b2, std::nullopt, std::nullopt), options).matches;
  REQUIRE(same_size.size() > 0);
  REQUIRE(larger.size() == same_size.size());
  for (std::size_t k = 0; k < larger.size(); ++k) {
    CHECK((larger.points_a[k] - same_size.points_a[k]).norm() < 1e-9);
    const Eigen::Vector2d expected =
        2.0 * (same_size.points_b[k].array() + 0.5).matrix() - Eigen::Vector2d(0.5, 0.5);
    CHECK((larger.points_b[k] - expected).norm() < 1e-4);
  }
  // A camera for the wrong image size is named.
  gimm::CArm carm;
  carm.rows = a.rows();
  carm.cols = a.cols();
  const gimm::Camerad cam = carm.camera();
  CHECK_THROWS_WITH(gimm::match_pair(network, pair_of(a, b2, cam, cam), options),
                    Catch::Contains("camera B") && Catch::Contains("image B"));
}

TEST_CASE("Learned matcher: each gate setting left unset is what the weights record", "[match]") {
  const auto resolved = [](const gimm::nn::MatcherConfig& weights, const gimm::GateChoice& c) {
    gimm::MatchOptions o;
    gimm::apply_gate_choice(weights, c, o);
    return o;
  };
  gimm::nn::MatcherConfig none_recorded;
  const gimm::MatchOptions plain = resolved(none_recorded, {});
  CHECK(plain.gate.mode == gimm::GateMode::hard);
  CHECK(plain.gate.delta_px == gimm::MatchOptions{}.gate.delta_px);
  CHECK_FALSE(plain.snap_to_epipolar);

  gimm::nn::MatcherConfig tuned;
  tuned.gate_mode = "soft";
  tuned.gate_delta_px = 4.0;
  tuned.gate_snap = true;
  const gimm::MatchOptions recorded = resolved(tuned, {});
  CHECK(recorded.gate.mode == gimm::GateMode::soft);
  CHECK(recorded.gate.delta_px == 4.0);
  CHECK(recorded.snap_to_epipolar);

  gimm::GateChoice chosen;
  chosen.delta_px = 7.0;
  chosen.snap = false;
  const gimm::MatchOptions mixed = resolved(tuned, chosen);
  CHECK(mixed.gate.mode == gimm::GateMode::soft);  // still the record
  CHECK(mixed.gate.delta_px == 7.0);
  CHECK_FALSE(mixed.snap_to_epipolar);
  // No gate, no F to snap onto: the recorded snap does not apply; an explicit one is kept.
  gimm::GateChoice off;
  off.mode = gimm::GateMode::none;
  CHECK_FALSE(resolved(tuned, off).snap_to_epipolar);
  off.snap = true;
  CHECK(resolved(tuned, off).snap_to_epipolar);
}

TEST_CASE("Reconstruction: exact matches triangulate to their points; off ones are dropped",
          "[match]") {
  gimm::CArm carm;
  carm.rows = carm.cols = 256;
  carm.pixel_mm = 1.0;
  carm.primary_deg = 35;
  carm.secondary_deg = 20;
  const gimm::Camerad a = carm.camera();
  carm.primary_deg = -30;
  carm.secondary_deg = -15;
  const gimm::Camerad b = carm.camera();
  gimm::PairMatches matches;
  const std::vector<Eigen::Vector3d> points{{0, 0, 0}, {20, -10, 30}, {-35, 15, -5}};
  for (const auto& X : points) matches.add(a.project(X).uv, b.project(X).uv, 0.9);
  matches.add(a.project(points[1]).uv, b.project(points[1]).uv + Eigen::Vector2d(0, 12), 0.5);
  const gimm::Reconstruction rec = gimm::reconstruct_matches(matches, a, b, 3.0);
  REQUIRE(rec.points.size() == 3);
  CHECK(rec.dropped_reprojection == 1);
  for (std::size_t k = 0; k < 3; ++k) {
    CHECK((rec.points[k].world - points[k]).norm() < 1e-6);
    CHECK(rec.points[k].reprojection_a < 1e-6);
    CHECK(rec.points[k].reprojection_b < 1e-6);
  }
  CHECK_THROWS_WITH(gimm::reconstruct_matches(matches, a, b, std::nan("")),
                    Catch::Contains("reprojection limit"));
}

TEST_CASE("Matcher interface: a pair whose parts do not fit is refused, naming the part",
          "[match]") {
  const gimm::Image<float> a(32, 32, 0.5f), b(32, 32, 0.5f);
  const gimm::Image<std::uint8_t> mask(32, 32), small(16, 32);
  gimm::CArm carm;
  carm.rows = carm.cols = 32;
  gimm::PairInput p = pair_of(a, b);
  p.id = "p/x";
  CHECK_NOTHROW(p.validate());
  p.mask_a = &mask;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("'p/x'") &&
                                      Catch::Contains("both vessel masks or neither") &&
                                      Catch::Contains("only mask A"));
  p.mask_b = &small;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("mask B is 32x16 px, image B 32x32"));
  p.mask_a = p.mask_b = nullptr;
  p.field_a = &small;
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("field A is 32x16 px"));
  p.field_a = nullptr;
  p.camera_b = carm.camera();
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("only camera B given"));
  carm.rows = 64;
  p.camera_a = carm.camera();
  CHECK_THROWS_WITH(p.validate(), Catch::Contains("camera A is 32x64 px, image A 32x32"));
}

TEST_CASE("Learned matcher: matches with an end outside its exposed field are dropped", "[match]") {
  const std::string fixture = std::string(GIMM_SOURCE_DIR) + "/tests/data/nn/";
  const auto [a, b] = fixture_images(fixture + "parity_anchor_expected.safetensors");
  const gimm::nn::Matcher network =
      gimm::nn::load_matcher(fixture + "parity_anchor_weights.safetensors");
  gimm::MatchOptions options;
  options.gate.mode = gimm::GateMode::none;
  gimm::PairInput pair = pair_of(a, b);
  const gimm::PairMatchResult whole = gimm::match_pair(network, pair, options);
  REQUIRE(whole.matches.size() >= 4);
  CHECK(whole.dropped_outside_field == 0);
  CHECK(whole.fundamental_source() == "none");
  CHECK(whole.candidates == static_cast<int>(whole.matches.size()) + whole.dropped_in_padding);
  // A's field: its left half only; B's: all of it.
  gimm::Image<std::uint8_t> left(a.rows(), a.cols()), all(b.rows(), b.cols(), 1);
  for (int r = 0; r < a.rows(); ++r)
    for (int c = 0; c < a.cols() / 2; ++c) left(r, c) = 1;
  pair.field_a = &left;
  pair.field_b = &all;
  const gimm::PairMatchResult inside = gimm::match_pair(network, pair, options);
  std::size_t expected = 0;
  for (const auto& p : whole.matches.points_a) expected += gimm::in_field(&left, p);
  REQUIRE(expected > 0);
  REQUIRE(expected < whole.matches.size());
  CHECK(inside.matches.size() == expected);
  CHECK(inside.dropped_outside_field == static_cast<int>(whole.matches.size() - expected));
  for (const auto& p : inside.matches.points_a) CHECK(std::lround(p.x()) < a.cols() / 2);
}

TEST_CASE("Matcher interface: no method's match ends outside an exposed field", "[match]") {
  // The baselines read the labels, which span the whole image; run() drops what the detector did
  // not see, for every method, and counts it.
  const gimm::PairTruth t = crossing_truth();  // A: column 10, rows 2-29; B: row 12
  gimm::PairInput input;
  input.id = t.id;
  input.truth = &t;
  const gimm::OracleMatcher oracle(0.0, 7);
  const gimm::PairMatchResult whole = oracle.run(input);
  REQUIRE(whole.matches.size() == t.dense.size());
  CHECK(whole.dropped_outside_field == 0);
  gimm::Image<std::uint8_t> top(32, 32), all(32, 32, 1);  // A's field: rows 0-15
  for (int r = 0; r < 16; ++r)
    for (int c = 0; c < 32; ++c) top(r, c) = 1;
  input.field_a = &top;
  input.field_b = &all;
  gimm::PairInput open = input;
  open.field_a = open.field_b = nullptr;
  const gimm::EpipolarMatcher epipolar({}, 7);
  for (const gimm::PairMatcher* m : {static_cast<const gimm::PairMatcher*>(&oracle),
                                     static_cast<const gimm::PairMatcher*>(&epipolar)}) {
    INFO(m->name());
    const gimm::PairMatchResult r = m->run(input);
    REQUIRE(r.matches.size() > 0);
    for (const auto& p : r.matches.points_a) CHECK(p.y() < 15.5);
    CHECK(r.matches.size() + r.dropped_outside_field == m->run(open).matches.size());
    if (m == &oracle) CHECK(r.dropped_outside_field == 14);  // rows 16-29 of A's vessel
  }
}
