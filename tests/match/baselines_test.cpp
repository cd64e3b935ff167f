// The predictions file format, the dataset reader, and the baselines: the oracle behaves as
// theory says (sigma = 0 is exact; with 2D Gaussian noise the fraction of A->B errors within
// r px is 1 - exp(-r^2 / (2 sigma^2))); the exact-epipolar baseline on a hand-made crossing.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <memory>

#include "gimm/match/baselines.hpp"
#include "gimm/metrics/summary.hpp"

namespace fs = std::filesystem;

namespace {

fs::path tmp_dir(const std::string& name) {
  const fs::path p = fs::path(GIMM_TEST_TMP) / "metrics" / name;
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

/// `nx` x `ny` labels on a grid with `spacing` px, the same layout shifted by (7, 3) in B;
/// 3D positions 1 mm apart per grid step. Masks (optional) mark the label pixels.
gimm::PairTruth grid_truth(int nx, int ny, double spacing, bool masks) {
  gimm::PairTruth t;
  t.id = "grid/LCA_00-01";
  t.view_a = "LCA_00";
  t.view_b = "LCA_01";
  const int size = static_cast<int>(std::max(nx, ny) * spacing + 20);
  gimm::Image<std::uint8_t> ma(size, size), mb(size, size);
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      gimm::Correspondence c;
      c.a = {5 + i * spacing, 5 + j * spacing};
      c.b = c.a + Eigen::Vector2d(7, 3);
      c.world = {double(i), double(j), 0};
      ma(static_cast<int>(c.a.y()), static_cast<int>(c.a.x())) = 255;
      mb(static_cast<int>(c.b.y()), static_cast<int>(c.b.x())) = 255;
      t.dense.push_back(c);
    }
  if (masks) {
    t.mask_a = std::make_shared<const gimm::Image<std::uint8_t>>(ma);
    t.mask_b = std::make_shared<const gimm::Image<std::uint8_t>>(mb);
  }
  t.F << 0, 0, 0, 0, 0, -1, 0, 1, 3;  // v_b = v_a + 3
  return t;
}

}  // namespace

TEST_CASE("Predictions files: write, read, defaults and errors", "[metrics]") {
  const fs::path dir = tmp_dir("format");
  gimm::PairMatches m;
  m.pair = "phantom-0000/LCA_00-01";
  m.add({1.25, 2.5}, {3, 4}, 0.75);
  m.add({-1, 1e3}, {0.1, 0.2}, 0.5);
  const fs::path file = gimm::matches_path(dir, m.pair);
  CHECK(file == dir / "phantom-0000" / "LCA_00-01.json");
  gimm::write_matches(file, m);
  const auto back = gimm::read_matches(file);
  CHECK(back.pair == m.pair);
  REQUIRE(back.size() == 2);
  CHECK(back.points_a[0] == m.points_a[0]);
  CHECK(back.points_b[1] == m.points_b[1]);
  CHECK(back.confidence == m.confidence);

  // Written from Python: no format, no pair, no confidence.
  const fs::path py = dir / "phantom-0000" / "RCA_00-01.json";
  gimm::write_file_atomic(py, std::string(R"({"points_a": [[1, 2]], "points_b": [[3, 4]]})"));
  const auto loose = gimm::read_matches(py);
  CHECK(loose.pair == "phantom-0000/RCA_00-01");
  CHECK(loose.confidence == std::vector<double>{1.0});

  const auto bad = [&](const std::string& text) {
    gimm::write_file_atomic(py, text);
    CHECK_THROWS_AS(gimm::read_matches(py), gimm::FormatError);
  };
  bad(R"({"points_a": [[1, 2]], "points_b": []})");
  bad(R"({"points_a": [[1, 2]], "points_b": [[3, 4]], "confidence": [1, 2]})");
  bad(R"({"points_a": [[1, 2, 3]], "points_b": [[3, 4]]})");
  bad(R"({"points_a": [[1, "x"]], "points_b": [[3, 4]]})");
  bad(R"({"pair": "other/RCA_00-01", "points_a": [], "points_b": []})");
  bad(R"({"format": "something/2", "points_a": [], "points_b": []})");
  bad(R"([1, 2])");
  bad(R"({"points_a": [], "points_b": [], "F": [[1, 2, 3], [4, 5, 6]]})");
  bad(R"({"points_a": [], "points_b": [], "F": [[1, 2, 3], [4, 5, 6], [7, 8, "x"]]})");
  bad(R"({"points_a": [], "points_b": [], "F": [[1, 2, 3], [4, 5, 6], [7, 8, 9]], "F_source": 3})");

  // The F the matches were gated with travels with them.
  m.F = Eigen::Matrix3d::Identity() * 0.5;
  m.F->coeffRef(0, 2) = -1.25e-3;
  m.F_source = "cameras";
  gimm::write_matches(file, m);
  const auto with_f = gimm::read_matches(file);
  REQUIRE(with_f.F);
  CHECK(*with_f.F == *m.F);
  CHECK(with_f.F_source == "cameras");
  CHECK_FALSE(back.F);  // written without one: none read

  gimm::PairMatches inf;
  inf.add({1, 2}, {3, std::nan("")}, 1);
  CHECK_THROWS_AS(gimm::write_matches(py, inf), gimm::FormatError);
}

TEST_CASE("Dataset reader: pair ids, labels, F and masks", "[metrics]") {
  const fs::path root = tmp_dir("dataset");
  const fs::path p = root / "patients" / "p1";
  fs::create_directories(p / "pairs");
  fs::create_directories(p / "views");
  gimm::write_json_file(
      root / "manifest.json",
      {{"format", "gimm-dataset/1"},
       {"patients", {{{"id", "p1"}, {"status", "ok"}}, {{"id", "p2"}, {"status", "failed"}}}}});
  fs::create_directories(root / "splits");
  gimm::write_file_atomic(root / "splits" / "test.txt", std::string("p1\n"));
  gimm::write_file_atomic(root / "splits" / "train.txt", std::string(""));
  const nlohmann::json pair = {
      {"view_a", "RCA_00"},
      {"view_b", "RCA_01"},
      {"view_class_a", 4},
      {"view_class_b", 1},
      {"F", {{0, 0, 0}, {0, 0, -1}, {0, 1, 0}}},
      {"dense_fields",
       {"u_a", "v_a", "u_b", "v_b", "x_mm", "y_mm", "z_mm", "branch", "point", "radius_mm"}},
      {"dense", {{1, 2, 3, 4, 5, 6, 7, 0, 3, 0.5}, {2, 2, 4, 4, 5, 6, 8, 0, 4, 0.5}}}};
  gimm::write_json_file(p / "pairs" / "RCA_00-01.json", pair);
  gimm::Image<std::uint8_t> mask(8, 10);
  mask(2, 1) = 255;
  gimm::write_png(p / "views" / "RCA_00.mask.png", mask);
  gimm::write_png(p / "views" / "RCA_01.mask.png", mask);

  gimm::DatasetReader reader(root);
  CHECK(reader.pair_ids() == std::vector<std::string>{"p1/RCA_00-01"});
  CHECK(reader.pair_ids("test") == std::vector<std::string>{"p1/RCA_00-01"});
  CHECK(reader.pair_ids("train").empty());
  const auto t = reader.pair("p1/RCA_00-01");
  CHECK(t.system() == "RCA");
  CHECK(gimm::class_pair_key(t) == "RCA AP Cranial / RAO");
  REQUIRE(t.dense.size() == 2);
  CHECK(t.dense[1].a == Eigen::Vector2d(2, 2));
  CHECK(t.dense[1].b == Eigen::Vector2d(4, 4));
  CHECK(t.dense[1].world == Eigen::Vector3d(5, 6, 8));
  CHECK(t.dense[1].index == 4);
  CHECK(t.F(1, 2) == -1.0);
  REQUIRE(t.mask_a);
  CHECK(t.mask_a->rows() == 8);
  CHECK(t.mask_a->cols() == 10);
  CHECK((*t.mask_a)(2, 1) == 255);
  CHECK(gimm::on_mask(t.mask_a.get(), {1.2, 1.8}));
  CHECK_FALSE(gimm::on_mask(t.mask_a.get(), {2.0, 1.8}));
  CHECK_THROWS_AS(reader.pair("p1/RCA_00-02"), gimm::IoError);
  CHECK_THROWS(gimm::DatasetReader(root / "nothing"));
}

TEST_CASE("Oracle with sigma = 0 is exact", "[metrics]") {
  const auto truth = grid_truth(12, 10, 6.0, true);
  gimm::Rng rng(1);
  const auto m = gimm::oracle_matches(truth, 0.0, rng);
  REQUIRE(m.size() == truth.dense.size());
  const auto score = gimm::score_pair(truth, m);
  for (long k : {20L, 0L}) {
    const auto s = gimm::summarize({score}, k);
    CHECK(s.prec[0] == 1.0);
    CHECK(s.mean_px == Approx(0.0).margin(1e-12));
    CHECK(s.mean_mm == Approx(0.0).margin(1e-12));
    CHECK(s.coverage == 1.0);
    CHECK(s.epipolar_mean_px == Approx(0.0).margin(1e-9));
    CHECK(s.epipolar_ok == 1.0);
  }
}

TEST_CASE("Oracle with Gaussian noise: Rayleigh fractions within r px", "[metrics]") {
  // Labels 40 px apart, noise sigma 1.5 px: the nearest label is always the right one, so the
  // A->B error is |n| (Rayleigh), the B->A error is 0 (the A side is exact) and the 3D error 0.
  const double sigma = 1.5;
  const auto truth = grid_truth(50, 60, 40.0, false);
  gimm::Rng rng(42);
  const auto m = gimm::oracle_matches(truth, sigma, rng);
  const auto score = gimm::score_pair(truth, m);
  std::vector<double> ab;
  for (const auto& r : score.ranked) {
    REQUIRE(r.ab.scored);
    REQUIRE(r.ba.scored);
    ab.push_back(r.ab.error_px);
    CHECK(r.ba.error_px == Approx(0.0).margin(1e-12));
    CHECK(r.ab.error_mm == Approx(0.0).margin(1e-12));
  }
  REQUIRE(ab.size() == 3000);
  for (double radius : {1.0, 2.0, 3.0, 5.0}) {
    const double expected = 1 - std::exp(-radius * radius / (2 * sigma * sigma));
    const double within = static_cast<double>(std::count_if(
                              ab.begin(), ab.end(), [&](double e) { return e <= radius; })) /
                          static_cast<double>(ab.size());
    CHECK(within == Approx(expected).margin(0.03));
  }
  // Mean of a Rayleigh: sigma sqrt(pi / 2).
  CHECK(gimm::mean_of(ab) == Approx(sigma * std::sqrt(3.141592653589793 / 2)).epsilon(0.03));
  // Pooled over both directions: half the errors are 0.
  const auto s = gimm::summarize({score}, 0);
  CHECK(s.prec[0] == Approx(0.5 + 0.5 * (1 - std::exp(-1 / (2 * sigma * sigma)))).margin(0.02));
}

TEST_CASE("Oracle draws are reproducible from the seed", "[metrics]") {
  const auto truth = grid_truth(5, 5, 10.0, false);
  gimm::Rng r1(9), r2(9), r3(10);
  const auto a = gimm::oracle_matches(truth, 1.0, r1);
  const auto b = gimm::oracle_matches(truth, 1.0, r2);
  const auto c = gimm::oracle_matches(truth, 1.0, r3);
  CHECK(a.points_b == b.points_b);
  CHECK(a.confidence == b.confidence);
  CHECK(a.points_b != c.points_b);
  CHECK(gimm::stable_hash("a") != gimm::stable_hash("b"));
  // The FNV-1a 64 test vectors: the offset basis for "", and "a".
  CHECK(gimm::stable_hash("") == 14695981039346656037ull);
  CHECK(gimm::stable_hash("a") == 0xaf63dc4c8601ec8cull);
}

TEST_CASE("Epipolar baseline: nearest crossing on the exact line, 1 / crossings", "[metrics]") {
  gimm::PairTruth t;
  t.id = "x/LCA_00-01";
  t.view_a = "LCA_00";
  t.view_b = "LCA_01";
  t.F << 0, 0, 0, 0, 0, -1, 0, 1, 0;  // v_b = v_a
  gimm::Image<std::uint8_t> ma(100, 100), mb(100, 100);
  ma(40, 25) = 255;  // one A vessel pixel: u = 25, v = 40
  for (int r = 0; r < 100; ++r)
    for (int c : {20, 21, 22, 60, 61, 62}) mb(r, c) = 255;  // two vertical vessels in B
  t.mask_a = std::make_shared<const gimm::Image<std::uint8_t>>(ma);
  t.mask_b = std::make_shared<const gimm::Image<std::uint8_t>>(mb);
  gimm::Rng rng(0);
  const auto m = gimm::epipolar_matches(t, {}, rng);
  REQUIRE(m.size() == 1);
  CHECK(m.points_a[0] == Eigen::Vector2d(25, 40));
  CHECK(m.points_b[0].x() == Approx(21.0));
  CHECK(m.points_b[0].y() == Approx(40.0));
  CHECK(m.confidence[0] == Approx(0.5));

  // Crossings of the line v = 40: runs along u, split at gaps > 2 px.
  const auto runs = gimm::line_crossings({0, -1, 40}, gimm::mask_pixels(*t.mask_b), 1.0, 2.0);
  REQUIRE(runs.size() == 2);
  CHECK(runs[1].x() == Approx(61.0));
  CHECK(gimm::line_crossings({0, 0, 1}, gimm::mask_pixels(*t.mask_b), 1.0, 2.0).empty());

  // A line that misses B's vessels gives no match; max_points caps the sample.
  gimm::Image<std::uint8_t> many(100, 100, 255);
  t.mask_a = std::make_shared<const gimm::Image<std::uint8_t>>(many);
  gimm::EpipolarBaselineOptions o;
  o.max_points = 50;
  const auto capped = gimm::epipolar_matches(t, o, rng);
  CHECK(capped.size() == 50);
  for (std::size_t i = 0; i < capped.size(); ++i) {
    CHECK(std::abs(capped.points_b[i].y() - capped.points_a[i].y()) < 1e-9);
    CHECK(capped.confidence[i] == Approx(0.5));
  }
}
