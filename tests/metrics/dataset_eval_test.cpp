// The protocol on a real gimm-dataset patient (one small phantom, 128 x 128 views): the oracle
// is exact at sigma = 0 and Rayleigh in the A->B direction at sigma > 0 (its sources are exact
// labels); the epipolar baseline's matches all lie on their exact epipolar lines and on A's
// mask; matches written to files and read back score the same.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>

#include "gimm/match/baselines.hpp"
#include "gimm/metrics/report.hpp"
#include "gimm/metrics/summary.hpp"
#include "gimm/pipeline/patient.hpp"

namespace fs = std::filesystem;

namespace {

const fs::path& small_dataset() {
  static const fs::path root = [] {
    const fs::path dir = fs::path(GIMM_TEST_TMP) / "metrics" / "phantom_dataset";
    fs::remove_all(dir);
    fs::create_directories(dir);
    gimm::DatasetOptions o;
    o.carm.rows = o.carm.cols = 128;
    o.carm.pixel_mm = 2.0;
    gimm::PatientSource src;
    src.id = "phantom-0000";
    src.phantom_seed = 7;
    gimm::generate_patient(src, o, dir);
    return dir;
  }();
  return root;
}

}  // namespace

TEST_CASE("Oracle on a phantom patient: exact at sigma 0, Rayleigh A->B", "[metrics]") {
  gimm::DatasetReader reader(small_dataset());
  const auto ids = reader.pair_ids();
  REQUIRE(ids.size() == 27);  // 6 RCA + 21 LCA pairs
  std::vector<gimm::PairScore> exact;
  std::vector<double> ab;
  const double sigma = 1.5;
  for (const auto& id : ids) {
    const auto truth = reader.pair(id);
    gimm::Rng rng = gimm::Rng(1).fork(gimm::stable_hash(id));
    exact.push_back(gimm::score_pair(truth, gimm::oracle_matches(truth, 0.0, rng)));
    const auto noisy = gimm::score_pair(truth, gimm::oracle_matches(truth, sigma, rng));
    for (const auto& r : noisy.ranked) {
      REQUIRE(r.ab.scored);  // the A side is an exact label, on A's mask
      ab.push_back(r.ab.error_px);
    }
  }
  for (long k : {20L, 0L}) {
    const auto s = gimm::summarize(exact, k);
    CHECK(s.prec[0] == 1.0);
    CHECK(s.coverage == 1.0);
    CHECK(s.mean_px == Approx(0.0).margin(1e-9));
    CHECK(s.mean_mm == Approx(0.0).margin(1e-9));
    CHECK(s.epipolar_mean_px < 1e-6);
  }
  const auto by_system =
      gimm::summarize_by(exact, 20, [](const gimm::PairScore& p) { return p.system; });
  REQUIRE(by_system.size() == 2);
  CHECK(by_system.at("RCA").pairs == 6);
  CHECK(by_system.at("LCA").pairs == 21);

  REQUIRE(ab.size() > 1000);
  for (double radius : {1.0, 2.0, 3.0}) {
    const double within = static_cast<double>(std::count_if(
                              ab.begin(), ab.end(), [&](double e) { return e <= radius; })) /
                          static_cast<double>(ab.size());
    CHECK(within == Approx(1 - std::exp(-radius * radius / (2 * sigma * sigma))).margin(0.03));
  }
}

TEST_CASE("Epipolar baseline on a phantom patient, through files", "[metrics]") {
  gimm::DatasetReader reader(small_dataset());
  const fs::path pred = fs::path(GIMM_TEST_TMP) / "metrics" / "phantom_epipolar";
  fs::remove_all(pred);
  std::vector<gimm::PairScore> direct, from_files;
  for (const auto& id : reader.pair_ids()) {
    const auto truth = reader.pair(id);
    gimm::Rng rng(5);
    gimm::EpipolarBaselineOptions o;
    o.max_points = 60;
    const auto m = gimm::epipolar_matches(truth, o, rng);
    REQUIRE(m.size() > 0);
    for (std::size_t i = 0; i < m.size(); ++i) {
      CHECK(gimm::on_mask(truth.mask_a.get(), m.points_a[i]));
      CHECK(m.confidence[i] > 0);
      CHECK(m.confidence[i] <= 1);
    }
    gimm::write_matches(gimm::matches_path(pred, id), m);
    direct.push_back(gimm::score_pair(truth, m));
    from_files.push_back(gimm::score_pair(truth, gimm::read_matches(gimm::matches_path(pred, id))));
  }
  const auto s = gimm::summarize(direct, 20);
  CHECK(s.epipolar_mean_px < 1e-6);
  CHECK(s.epipolar_ok == 1.0);
  CHECK(s.scored >= s.kept);  // every A->B direction is scored
  CHECK(s.prec[2] > 0.2);     // far better than chance on a 128 x 128 image
  const auto f = gimm::summarize(from_files, 20);
  CHECK(f.scored == s.scored);
  CHECK(f.mean_px == Approx(s.mean_px).epsilon(1e-12));
  CHECK(f.mean_mm == Approx(s.mean_mm).epsilon(1e-12));
}

TEST_CASE("gimm-eval/1 report: pooled, groups and worst pairs from the scores; read back",
          "[metrics]") {
  // Exact oracle matches on every pair but one pair with none: the report's pooled row and its
  // per-system and per-pair entries are the summaries of those scores, the empty pair is the
  // worst, and the summary reads back through the one reader.
  gimm::DatasetReader reader(small_dataset());
  const auto ids = reader.pair_ids();
  std::vector<gimm::PairScore> pairs;
  for (const auto& id : ids) {
    const auto truth = reader.pair(id);
    gimm::Rng rng(3);
    pairs.push_back(id == ids[4] ? gimm::missing_pair(truth)
                                 : gimm::score_pair(truth, gimm::oracle_matches(truth, 0.0, rng)));
  }
  gimm::EvalRun run;
  run.method = "oracle0";
  run.top_k = 20;
  run.worst = 3;
  const gimm::EvalReport r = gimm::make_eval_report(pairs, run);
  const nlohmann::json& s = r.summary;
  CHECK(s.at("format") == "gimm-eval/1");
  CHECK(s.at("pooled") == gimm::to_json(gimm::summarize(pairs, 20)));
  CHECK(s.at("pooled").at("coverage").get<double>() == Approx(26.0 / 27.0));
  CHECK(s.at("by_system").size() == 2);
  CHECK(s.at("by_system").at("RCA").at("pairs") == 6);
  REQUIRE(s.at("pairs").size() == ids.size());
  CHECK(s.at("pairs")[4].at("pair") == ids[4]);
  CHECK(s.at("pairs")[4].at("coverage") == 0.0);
  REQUIRE(s.at("worst_pairs").size() == 3);
  CHECK(s.at("worst_pairs")[0].at("pair") == ids[4]);  // nothing scored: listed first
  CHECK(r.table_md.rfind(r.headline_md, 0) == 0);
  CHECK(r.headline_md.find("| oracle0 | 1.000 |") != std::string::npos);
  CHECK(r.worst_md.find("| " + ids[4] + " |") != std::string::npos);
  CHECK(r.topk_tsv.rfind("# k\tprec_1px", 0) == 0);
  const fs::path dir = fs::path(GIMM_TEST_TMP) / "metrics" / "report";
  fs::remove_all(dir);
  fs::create_directories(dir);
  gimm::write_eval_report(dir, r);
  const gimm::EvalSummaryFile back = gimm::read_eval_summary(dir / "summary.json");
  CHECK(back.method == "oracle0");
  CHECK(back.top_k == 20);
  CHECK(gimm::to_json(back.pooled) == s.at("pooled"));
}
