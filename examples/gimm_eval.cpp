// gimm-eval: scores predicted matches against a gimm-dataset with the reference protocol
// (docs/evaluation.md, include/gimm/metrics/).
//   gimm-eval --dataset DIR --predictions PRED_DIR [--top-k 20] [--out DIR] [--name NAME]
//             [--split all|train|val|test] [--worst 10]
//   gimm-eval --compare RUN1 RUN2 ... [--out DIR]      RUNs: --out directories of earlier runs
//   gimm-eval --truth T.json... --matches P.json... [--radius 3] [--top-k 20] [--out DIR]
//             a user's own sparse truth (gimm-truth/1, metrics/user_truth.hpp), no dataset
//   gimm-eval --tree R.json... --centerlines C.json...   3D error of triangulated points against
//             the true centerlines (gimm-tree/1 from gimm-match --tree; one C.json, or one each)
// Prints a Markdown table (Prec@1/3/5 px, 2D and 3D errors, coverage, exact-geometry check);
// with --out writes summary.json, table.md, worst_pairs.md and topk.tsv (compare: compare.md),
// all or nothing: a failed run (a full disk) leaves DIR as it was.
// A pair without a predictions file counts as a pair with no matches (coverage 0).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "cli_common.hpp"
#include "gimm/dataset/centerlines_json.hpp"
#include "gimm/match/tree_file.hpp"
#include "gimm/metrics/report.hpp"
#include "gimm/metrics/tree_error.hpp"
#include "gimm/metrics/user_truth.hpp"
#include "gimm/pipeline/eval_run.hpp"

namespace fs = std::filesystem;

namespace {

/// How a gnuplot script run in `folder` names `file`: by its name when it lies there (the script
/// keeps working after the folder is moved into place), else by its absolute path.
std::string gnuplot_path(const fs::path& file, const fs::path& folder) {
  return file.parent_path() == folder ? file.filename().string() : fs::absolute(file).string();
}

/// Runs gnuplot on `script` in the script's folder and returns the PNG it prints. gnuplot writes
/// no file itself: it ignores a failed write (on a full disk its chart came out truncated,
/// without an error), so gimm writes the bytes and reports a failure.
std::string run_gnuplot(const fs::path& script) {
  const fs::path folder = script.has_parent_path() ? script.parent_path() : fs::path(".");
  const std::string command =
      "cd \"" + folder.string() + "\" && gnuplot \"" + script.filename().string() + "\"";
  std::FILE* pipe = ::popen(command.c_str(), "r");
  GIMM_CHECK(pipe != nullptr, "gimm-eval: cannot run gnuplot: " << std::strerror(errno));
  std::string png;
  char chunk[1 << 16];
  for (std::size_t n; (n = std::fread(chunk, 1, sizeof chunk, pipe)) > 0;) png.append(chunk, n);
  const int status = ::pclose(pipe);
  GIMM_CHECK(status == 0 && !png.empty(), "gimm-eval: gnuplot failed on " << script.string());
  return png;
}

/// Top-K curves (2D mean error and Prec@3px against K) of one or more runs as a PNG, through
/// gnuplot (gnuplot-nox, installed by scripts/install-deps.sh); the script stays beside it as
/// "<png>.gp" (`gnuplot topk.png.gp > topk.png` in that folder draws it again). Without gnuplot,
/// a warning and no chart.
void plot_topk(const std::vector<std::pair<fs::path, std::string>>& runs, const fs::path& png) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    std::fprintf(stderr, "gimm-eval: warning: gnuplot not found, no %s\n", png.c_str());
    return;
  }
  std::string left, right;
  for (const auto& [tsv, name] : runs) {
    std::string clean = name;
    clean.erase(std::remove(clean.begin(), clean.end(), '"'), clean.end());
    const std::string sep = left.empty() ? "" : ", ";
    const std::string data = "\"" + gnuplot_path(tsv, png.parent_path()) + "\"";
    left += sep + data + " using 1:5 with linespoints title \"" + clean + "\"";
    right += sep + data + " using 1:3 with linespoints title \"" + clean + "\"";
  }
  const fs::path script = png.string() + ".gp";
  const std::string gp =
      "set terminal png size 1100,420 noenhanced\n"
      "set datafile missing \"-\"\nset multiplot layout 1,2\nset logscale x\nset grid\n"
      "set key top left\nset xlabel \"K (most confident matches per pair)\"\n"
      "set ylabel \"2D mean error (px)\"\nplot " +
      left + "\nset ylabel \"Prec@3px\"\nset yrange [0:1]\nset key bottom left\nplot " + right +
      "\nunset multiplot\n";
  gimm::write_file_atomic(script, gp);
  gimm::write_file_atomic(png, run_gnuplot(script));
}

int evaluate(const std::string& dataset, const std::string& predictions, const gimm::EvalRun& run,
             const std::string& out) {
  const gimm::DatasetEvaluation e = gimm::evaluate_dataset(dataset, predictions, run);
  if (!e.missing.empty())
    std::fprintf(stderr, "gimm-eval: warning: %zu of %zu pairs have no predictions file in %s\n",
                 e.missing.size(), e.pairs.size(), predictions.c_str());
  std::cout << e.report.headline_md;
  if (out.empty()) return 0;
  // All or nothing: written under a staging folder and moved into `out` at the end, so a failure
  // (a full disk) leaves `out` as it was.
  gimm::write_folder_all_or_nothing(out, [&](const fs::path& dir) {
    gimm::write_eval_report(dir, e.report);
    plot_topk({{dir / "topk.tsv", e.report.summary.at("method").get<std::string>()}},
              dir / "topk.png");
  });
  std::fprintf(stderr,
               "gimm-eval: wrote %s/{summary.json,table.md,worst_pairs.md,topk.tsv,topk.png}\n",
               out.c_str());
  return 0;
}

int compare(const std::vector<std::string>& runs, const std::string& out) {
  std::string md;
  long top_k = -1;
  std::string rows;
  std::vector<std::string> methods;
  for (const auto& run : runs) {
    const fs::path file = fs::path(run) / "summary.json";
    GIMM_CHECK_AS(gimm::IoError, fs::exists(file),
                  "'" << run << "' is not a gimm-eval output directory (no summary.json)");
    const gimm::EvalSummaryFile summary = gimm::read_eval_summary(file, run);
    if (top_k >= 0 && summary.top_k != top_k)
      std::fprintf(stderr, "gimm-eval: warning: %s was scored with top-K %ld, the first with %ld\n",
                   run.c_str(), summary.top_k, top_k);
    if (top_k < 0) top_k = summary.top_k;
    rows += gimm::markdown_row(summary.method, summary.pooled);
    methods.push_back(summary.method);
  }
  md = "## Comparison (top-K = " + gimm::k_label(top_k) + ")\n\n" + gimm::markdown_header() + rows;
  std::cout << md;
  if (out.empty()) return 0;
  std::vector<std::pair<fs::path, std::string>> curves;
  for (std::size_t n = 0; n < runs.size(); ++n)
    curves.push_back({fs::path(runs[n]) / "topk.tsv", methods[n]});
  gimm::write_folder_all_or_nothing(out, [&](const fs::path& dir) {  // as in evaluate
    gimm::write_file_atomic(dir / "compare.md", md);
    plot_topk(curves, dir / "compare.png");
  });
  return 0;
}

/// Pairs of a user's own truth files and prediction files, scored and tabled.
int evaluate_user_truth(const std::vector<std::string>& truths,
                        const std::vector<std::string>& predictions, double radius, long top_k,
                        const std::string& out) {
  GIMM_USAGE_CHECK(truths.size() == predictions.size(),
                   "--truth and --matches pair up: got " << truths.size() << " truth files and "
                                                         << predictions.size() << " matches files");
  std::vector<gimm::PairScore> pairs;
  std::string rows;
  for (std::size_t n = 0; n < truths.size(); ++n) {
    const gimm::PairTruth truth = gimm::read_user_truth(truths[n], radius);
    const gimm::PairMatches matches =
        gimm::matches_from_json(gimm::read_json_file(predictions[n]), predictions[n]);
    gimm::check_same_pair(truth, truths[n], matches, predictions[n]);
    pairs.push_back(gimm::score_pair(truth, matches));
    gimm::SummaryBuilder one(top_k);
    one.add(pairs.back());
    rows += gimm::markdown_row(truth.id, one.summary());
  }
  const std::string md = "## Own truth (top-K = " + gimm::k_label(top_k) + ", " +
                         std::to_string(pairs.size()) + " pairs, truth radius " +
                         gimm::fmt(radius, 1) + " px)\n\n" + gimm::markdown_header("pair") + rows +
                         gimm::markdown_row("pooled", gimm::summarize(pairs, top_k));
  std::cout << md;
  if (out.empty()) return 0;
  gimm::write_folder_all_or_nothing(out, [&](const fs::path& dir) {  // as in evaluate
    gimm::write_json_file(dir / "summary.json", gimm::eval_summary_json("own truth", top_k, pairs));
    gimm::write_file_atomic(dir / "table.md", md);
  });
  return 0;
}

/// Distances of triangulated points (gimm-tree/1) to the true centerlines.
int evaluate_trees(const std::vector<std::string>& trees,
                   const std::vector<std::string>& centerlines, const std::string& out) {
  GIMM_USAGE_CHECK(centerlines.size() == 1 || centerlines.size() == trees.size(),
                   "--centerlines: give one file, or one per --tree (" << trees.size() << "), got "
                                                                       << centerlines.size());
  std::vector<double> all;
  std::string rows;
  const auto stats_row = [](const std::string& name, const std::vector<double>& d) {
    return "| " + name + " | " + std::to_string(d.size()) + " | " + gimm::fmt(gimm::mean_of(d), 2) +
           " | " + gimm::fmt(gimm::percentile(d, 0.5), 2) + " | " +
           gimm::fmt(gimm::percentile(d, 0.9), 2) + " |\n";
  };
  for (std::size_t n = 0; n < trees.size(); ++n) {
    const gimm::CenterlineTree truth =
        gimm::read_centerlines(centerlines[centerlines.size() == 1 ? 0 : n]);
    std::vector<double> d;
    for (const gimm::TreePoint& p : gimm::read_tree_file(trees[n]).points)
      d.push_back(gimm::distance_to_centerlines(p.world, truth));
    rows += stats_row(trees[n], d);
    all.insert(all.end(), d.begin(), d.end());
  }
  const std::string md =
      "## 3D error of the triangulated points against the true centerlines (mm)\n\n"
      "| tree | points | mean | median | p90 |\n| --- | --- | --- | --- | --- |\n" +
      rows + stats_row("pooled", all);
  std::cout << md;
  if (out.empty()) return 0;
  gimm::write_folder_all_or_nothing(out, [&](const fs::path& dir) {  // as in evaluate
    gimm::write_file_atomic(dir / "tree_error.md", md);
  });
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gimm-eval: score predicted matches with the reference protocol", "gimm-eval"};
  std::string dataset, predictions, out, name, split = "all";
  std::vector<std::string> runs;
  long top_k = 20;
  std::size_t worst = 10;
  app.add_option("--dataset", dataset, "gimm-dataset directory");
  app.add_option("--predictions", predictions, "predictions directory (<patient>/<pair>.json)");
  app.add_option("--top-k", top_k, "most confident matches kept per pair (0 = all)")
      ->check(gimm::cli::at_least(0))
      ->capture_default_str();
  app.add_option("--out", out, "output directory");
  app.add_option("--name", name, "method name in the tables (default: predictions folder)");
  app.add_option("--split", split, "all|train|val|test")
      ->check(CLI::IsMember({"all", "train", "val", "test"}))
      ->capture_default_str();
  app.add_option("--worst", worst, "worst pairs listed")->capture_default_str();
  app.add_option("--compare", runs, "compare earlier runs (their --out directories)");
  std::vector<std::string> truths, matches, trees, centerlines;
  double radius = 3.0;
  app.add_option("--truth", truths, "own sparse truth files (gimm-truth/1), one per pair")
      ->check(CLI::ExistingFile);
  app.add_option("--matches", matches, "with --truth: the matches files, in the same order")
      ->check(CLI::ExistingFile);
  app.add_option("--radius", radius,
                 "with --truth: a match is scored when its source point is within this many px "
                 "of a truth point")
      ->check(gimm::cli::Positive)
      ->check(CLI::Range(0.0, gimm::kMaxTruthRadius))
      ->capture_default_str();
  app.add_option("--tree", trees, "triangulated points (gimm-tree/1) to score in 3D")
      ->check(CLI::ExistingFile);
  app.add_option("--centerlines", centerlines, "with --tree: the true centerlines JSON")
      ->check(CLI::ExistingFile);
  return gimm::cli::run(app, argc, argv, [&] {
    // --out must not be one of the inputs (its files would land among theirs).
    std::vector<gimm::NamedPath> inputs{{"--dataset", dataset}, {"--predictions", predictions}};
    for (const auto& [flag, files] : {std::pair{"--compare", &runs},
                                      {"--truth", &truths},
                                      {"--matches", &matches},
                                      {"--tree", &trees},
                                      {"--centerlines", &centerlines}})
      for (const auto& f : *files) inputs.push_back({flag, f});
    gimm::cli::refuse_outputs_over_inputs({{"--out", out}}, inputs);
    const bool dataset_mode = !dataset.empty() || !predictions.empty();
    const int modes = int(!runs.empty()) + int(!truths.empty() || !matches.empty()) +
                      int(!trees.empty() || !centerlines.empty()) + int(dataset_mode);
    GIMM_USAGE_CHECK(modes <= 1,
                     "give one of --dataset/--predictions, --compare, --truth/--matches or "
                     "--tree/--centerlines");
    // The name goes into tables and gnuplot scripts: one line of printable text.
    const auto control = std::find_if(name.begin(), name.end(), [](char c) {
      return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
    });
    GIMM_USAGE_CHECK(control == name.end(),
                     "--name must be one line of printable text, got a control character at "
                     "position "
                         << (control - name.begin()));
    // Flags another mode owns would be ignored: refuse them.
    GIMM_USAGE_CHECK(!(modes == 1 && !dataset_mode) || app.count("--split") == 0,
                     "--split chooses a dataset's pairs: it goes with --dataset/--predictions");
    GIMM_USAGE_CHECK((trees.empty() && centerlines.empty()) || app.count("--top-k") == 0,
                     "--top-k chooses matches: --tree/--centerlines score every point");
    if (!truths.empty() || !matches.empty())
      return evaluate_user_truth(truths, matches, radius, top_k, out);
    if (!trees.empty() || !centerlines.empty()) {
      GIMM_USAGE_CHECK(!trees.empty() && !centerlines.empty(),
                       "--tree and --centerlines go together");
      return evaluate_trees(trees, centerlines, out);
    }
    if (!runs.empty()) {
      GIMM_USAGE_CHECK(dataset.empty() && predictions.empty(),
                       "--compare takes run directories only, not --dataset/--predictions");
      return compare(runs, out);
    }
    GIMM_USAGE_CHECK(!dataset.empty() && !predictions.empty(),
                     "give --dataset and --predictions (or --compare RUN...)");
    gimm::EvalRun run;
    run.method = name;
    run.top_k = top_k;
    run.worst = worst;
    run.split = split;
    return evaluate(dataset, predictions, run, out);
  });
}
