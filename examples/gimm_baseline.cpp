// gimm-baseline: training-free matchers written in the predictions format of gimm-eval (the same
// as gimm-match --dataset DIR --method oracle|epipolar).
//   gimm-baseline --dataset DIR --method oracle|epipolar --out PRED_DIR [--sigma PX] [--seed S]
//                 [--split all|train|val|test] [--max-points N]
// oracle: the dense GT labels with N(0, sigma^2) pixel noise on the B side; epipolar: vessel
// pixels of A matched to the nearest vessel crossing of the exact epipolar line in B
// (include/gimm/match/baselines.hpp). One file per pair: PRED_DIR/<patient>/<pair>.json, all or
// nothing: a failed run (a full disk) leaves PRED_DIR as it was (pipeline/match_run.hpp).
#include <cstdio>
#include <memory>

#include "cli_common.hpp"
#include "gimm/match/baselines.hpp"
#include "gimm/pipeline/match_run.hpp"

int main(int argc, char** argv) {
  CLI::App app{"gimm-baseline: oracle and exact-epipolar baseline matches for gimm-eval",
               "gimm-baseline"};
  std::string dataset, method, out, split = "all";
  double sigma = 1.0;
  std::uint64_t seed = 0;
  gimm::EpipolarBaselineOptions epi;
  app.add_option("--dataset", dataset, "gimm-dataset directory")->required();
  app.add_option("--method", method, "oracle|epipolar")
      ->required()
      ->check(CLI::IsMember({"oracle", "epipolar"}));
  app.add_option("--out", out, "predictions directory")->required();
  app.add_option("--sigma", sigma, "oracle: Gaussian noise on the B side, px per axis")
      ->capture_default_str()
      ->check(gimm::cli::at_least(0));
  app.add_option("--seed", seed, "random seed")->capture_default_str();
  app.add_option("--split", split, "all|train|val|test")
      ->check(CLI::IsMember({"all", "train", "val", "test"}))
      ->capture_default_str();
  app.add_option("--max-points", epi.max_points, "epipolar: A vessel pixels sampled per pair")
      ->capture_default_str();
  return gimm::cli::run(app, argc, argv, [&] {
    GIMM_USAGE_CHECK(std::isfinite(sigma) && sigma >= 0, "--sigma must be >= 0, got " << sigma);
    // A flag of the other method would be ignored: refuse it, as gimm-match does.
    GIMM_USAGE_CHECK(app.count("--sigma") == 0 || method == "oracle",
                     "--sigma is for --method oracle, not " << method);
    GIMM_USAGE_CHECK(app.count("--max-points") == 0 || method == "epipolar",
                     "--max-points is for --method epipolar, not " << method);
    // PRED_DIR must not be the dataset (the predictions would land among its files).
    gimm::cli::refuse_outputs_over_inputs({{"--out", out}}, {{"--dataset", dataset}});
    const std::unique_ptr<gimm::PairMatcher> matcher =
        gimm::baseline_matcher(method, sigma, epi, seed);
    // The baselines read the labels only: no cameras, no images or fields.
    gimm::MatchRunOptions run;
    run.split = split;
    run.use_cameras = false;
    run.images = gimm::DatasetImages::rendered;
    const gimm::MatchRunSummary done = gimm::match_dataset(*matcher, dataset, out, run);
    std::printf("gimm-baseline %s: %zu pairs, %zu matches -> %s\n", method.c_str(), done.pairs,
                done.matches, out.c_str());
    return 0;
  });
}
