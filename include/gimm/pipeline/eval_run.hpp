#pragma once
/// Scoring a dataset's predictions from C++ (or Python, gimm.evaluate_dataset): every pair of a
/// split of a gimm-dataset scored against its labels (metrics/protocol.hpp) from
/// PRED/<patient>/<pair>.json, and the gimm-eval/1 report of them (metrics/report.hpp).
/// gimm-eval --dataset is flag parsing around evaluate_dataset. A pair without a predictions
/// file counts as a pair with no matches (coverage 0) and is listed in `missing`.
///
///   gimm::EvalRun run;
///   run.top_k = 20;
///   const gimm::DatasetEvaluation e = gimm::evaluate_dataset("ds/", "pred/", run);
///   gimm::write_eval_report("eval/", e.report);
#include <filesystem>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/metrics/protocol.hpp"
#include "gimm/metrics/report.hpp"

namespace gimm {

struct DatasetEvaluation {
  std::vector<PairScore> pairs;      ///< in the dataset's pair order
  std::vector<std::string> missing;  ///< pair ids with no predictions file
  EvalReport report;
};

/// The method's name when none is given: the predictions folder's name ("pred/" -> "pred").
inline std::string method_name_of(const std::filesystem::path& predictions) {
  const std::filesystem::path p = predictions.lexically_normal();
  std::string name = p.filename().string();
  if (name.empty()) name = p.parent_path().filename().string();
  return name;
}

/// Scores every pair of `run.split` of the dataset at `dataset` with the predictions under
/// `predictions`; the report's method is `run.method`, else the predictions folder's name.
inline DatasetEvaluation evaluate_dataset(const std::filesystem::path& dataset,
                                          const std::filesystem::path& predictions, EvalRun run) {
  GIMM_CHECK(std::filesystem::is_directory(predictions),
             "predictions directory '" << predictions.string() << "' does not exist");
  GIMM_CHECK(run.top_k >= 0, "EvalRun::top_k must be >= 0 (0: all), got " << run.top_k);
  DatasetReader reader(dataset);
  const std::vector<std::string> ids = reader.pair_ids(run.split);
  GIMM_CHECK(!ids.empty(), "no pairs in '" << dataset.string() << "' (split " << run.split << ")");
  DatasetEvaluation out;
  for (const std::string& id : ids) {
    const PairTruth truth = reader.pair(id);
    const std::filesystem::path file = matches_path(predictions, id);
    if (!std::filesystem::exists(file)) {
      out.missing.push_back(id);
      out.pairs.push_back(missing_pair(truth));
      continue;
    }
    out.pairs.push_back(score_pair(truth, read_matches(file)));
  }
  if (run.method.empty()) run.method = method_name_of(predictions);
  run.dataset = dataset.string();
  run.predictions = predictions.string();
  out.report = make_eval_report(out.pairs, run);
  return out;
}

}  // namespace gimm
