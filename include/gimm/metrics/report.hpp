#pragma once
/// gimm-eval/1: a dataset's scored predictions as gimm-eval reports them. One writer
/// (make_eval_report, write_eval_report) and one reader (read_eval_summary).
///
///   summary.json    {"format": "gimm-eval/1", "method", "top_k" (0: all), "pooled": Summary,
///                    and for a dataset: "dataset", "predictions", "split", "by_system",
///                    "by_class_pair", "topk_curve" (Summary and "k" per K), "worst_pairs" and
///                    "pairs" (Summary and "pair" per pair)}
///   table.md        the pooled row, by system, by view-class pair, the top-K curve, the worst
///                   pairs (Markdown)
///   worst_pairs.md  the worst pairs: nothing scored first, then by descending mean 2D error
///   topk.tsv        k, prec_1px, prec_3px, prec_5px, mean_px, mean_mm, coverage per K (charts)
/// Summaries are those of summary.hpp, undefined figures null / "-".
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/io/files.hpp"
#include "gimm/metrics/protocol.hpp"
#include "gimm/metrics/summary.hpp"

namespace gimm {

/// gimm-eval/1: the summary.json gimm-eval writes (its "pooled" Summary, the method name and
/// top-K; per-system, per-class-pair and per-pair tables beside them).
constexpr const char* kEvalFormat = "gimm-eval/1";

struct EvalSummaryFile {
  std::string method;
  long top_k = 0;  ///< 0: all matches
  Summary pooled;
};

/// Reads an earlier run's summary.json (gimm-eval --compare), checking the format and the types
/// of what it uses; a malformed file is a FormatError naming it and the key.
inline EvalSummaryFile read_eval_summary(const std::filesystem::path& file,
                                         const std::string& default_method = "") {
  const nlohmann::json j = read_json_file(file);
  const std::string where = file.string();
  GIMM_CHECK_AS(
      FormatError, j.is_object() && j.contains("format") && j.at("format") == kEvalFormat,
      where << ": not a " << kEvalFormat << " summary (the summary.json an evaluation writes)");
  GIMM_CHECK_AS(FormatError,
                j.contains("top_k") && j.at("top_k").is_number_integer() &&
                    j.at("top_k").get<std::int64_t>() >= 0,
                where << ": 'top_k' must be a count (0: all), got "
                      << (j.contains("top_k") ? j.at("top_k").dump() : std::string("nothing")));
  GIMM_CHECK_AS(FormatError, j.contains("pooled") && j.at("pooled").is_object(),
                where << ": 'pooled' must be an object");
  EvalSummaryFile out;
  out.top_k = static_cast<long>(j.at("top_k").get<std::int64_t>());
  out.method = default_method;
  if (j.contains("method")) {
    GIMM_CHECK_AS(FormatError, j.at("method").is_string(),
                  where << ": 'method' must be a string, got " << j.at("method").dump());
    out.method = j.at("method").get<std::string>();
  }
  for (const auto& [key, value] : j.at("pooled").items())
    GIMM_CHECK_AS(FormatError, value.is_number() || value.is_null(),
                  where << ": pooled." << key << " must be a number, got " << value.dump());
  for (const char* count :
       {"pairs", "missing_pairs", "matches", "kept", "slots", "scored", "epipolar_count"})
    GIMM_CHECK_AS(FormatError,
                  !j.at("pooled").contains(count) || j.at("pooled").at(count).is_number_unsigned(),
                  where << ": pooled." << count << " must be a count, got "
                        << j.at("pooled").at(count).dump());
  out.pooled = summary_from_json(j.at("pooled"));
  return out;
}

/// What a report says of the run it scores.
struct EvalRun {
  std::string method;      ///< the name in tables
  long top_k = 20;         ///< the most confident matches kept per pair (0: all)
  std::size_t worst = 10;  ///< worst pairs listed
  std::string dataset, predictions, split = "all";  ///< a dataset's run (else empty)
};

/// One run's report: what gimm-eval prints and the files it writes.
struct EvalReport {
  nlohmann::json summary;   ///< summary.json
  std::string headline_md;  ///< the pooled row and the breakdowns (what gimm-eval prints)
  std::string table_md;     ///< table.md: the headline, the top-K curve, the worst pairs
  std::string worst_md;     ///< worst_pairs.md
  std::string topk_tsv;     ///< topk.tsv
};

/// "20", or "all" for K = 0.
inline std::string k_label(long k) {
  return k > 0 ? std::to_string(k) : "all";
}

/// The core of every gimm-eval/1 summary: format, method, top-K and the pooled figures.
inline nlohmann::json eval_summary_json(const std::string& method, long top_k,
                                        const std::vector<PairScore>& pairs) {
  return {{"format", kEvalFormat},
          {"method", method},
          {"top_k", top_k},
          {"pooled", to_json(summarize(pairs, top_k))}};
}

/// Each pair's own summary at `top_k`, with its id under "pair" (summary.json's "pairs").
inline nlohmann::json pair_summaries_json(const std::vector<PairScore>& pairs, long top_k) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& p : pairs) {
    SummaryBuilder b(top_k);
    b.add(p);
    nlohmann::json j = to_json(b.summary());
    j["pair"] = p.id;
    out.push_back(j);
  }
  return out;
}

namespace detail {

struct PairRow {
  std::string id;
  Summary s;
};

/// The `count` worst pairs: nothing scored first, then by descending mean 2D error; ties by
/// the pairs' order.
inline std::vector<PairRow> worst_pairs(const std::vector<PairScore>& pairs, long k,
                                        std::size_t count) {
  std::vector<PairRow> rows;
  for (const auto& p : pairs) {
    SummaryBuilder b(k);
    b.add(p);
    rows.push_back({p.id, b.summary()});
  }
  std::stable_sort(rows.begin(), rows.end(), [](const PairRow& a, const PairRow& b) {
    const bool na = std::isnan(a.s.mean_px), nb = std::isnan(b.s.mean_px);
    if (na != nb) return na;
    return !na && a.s.mean_px > b.s.mean_px;
  });
  if (rows.size() > count) rows.resize(count);
  return rows;
}

inline std::string breakdown_table(const std::string& title, const std::string& column,
                                   const std::map<std::string, Summary>& groups) {
  std::string md = "\n### " + title + "\n\n" + markdown_header(column);
  for (const auto& [key, s] : groups) md += markdown_row(key, s);
  return md;
}

inline nlohmann::json groups_json(const std::map<std::string, Summary>& groups) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [key, s] : groups) out[key] = to_json(s);
  return out;
}

/// The top-K curve: its JSON, Markdown table and TSV.
inline void add_topk_curve(const std::vector<PairScore>& pairs, long top_k, EvalReport& r) {
  std::string md = "\n### Top-K curve\n\n" + markdown_header("K");
  nlohmann::json curve = nlohmann::json::array();
  r.topk_tsv = "# k\tprec_1px\tprec_3px\tprec_5px\tmean_px\tmean_mm\tcoverage\n";
  for (long k : curve_ks(pairs, top_k)) {
    const Summary s = summarize(pairs, k);
    md += markdown_row(k_label(k), s);
    nlohmann::json j = to_json(s);
    j["k"] = k > 0 ? nlohmann::json(k) : nlohmann::json("all");
    curve.push_back(j);
    if (k > 0)
      r.topk_tsv += std::to_string(k) + "\t" + fmt(s.prec[0], 6) + "\t" + fmt(s.prec[1], 6) + "\t" +
                    fmt(s.prec[2], 6) + "\t" + fmt(s.mean_px, 6) + "\t" + fmt(s.mean_mm, 6) + "\t" +
                    fmt(s.coverage, 6) + "\n";
  }
  r.summary["topk_curve"] = curve;
  r.table_md += md;
}

}  // namespace detail

/// The report of `pairs` scored for `run` (see the file comment).
inline EvalReport make_eval_report(const std::vector<PairScore>& pairs, const EvalRun& run) {
  EvalReport r;
  const long k = run.top_k;
  const auto by_system = summarize_by(pairs, k, [](const PairScore& p) { return p.system; });
  const auto by_class = summarize_by(pairs, k, [](const PairScore& p) { return p.class_pair; });
  r.headline_md = "## " + run.method + " (top-K = " + k_label(k) + ", " +
                  std::to_string(pairs.size()) + " pairs)\n\n" + markdown_header() +
                  markdown_row(run.method, summarize(pairs, k)) +
                  detail::breakdown_table("By system", "system", by_system) +
                  detail::breakdown_table("By view-class pair", "view classes", by_class);
  r.summary = eval_summary_json(run.method, k, pairs);
  r.summary["dataset"] = run.dataset;
  r.summary["predictions"] = run.predictions;
  r.summary["split"] = run.split;
  r.summary["by_system"] = detail::groups_json(by_system);
  r.summary["by_class_pair"] = detail::groups_json(by_class);
  r.summary["pairs"] = pair_summaries_json(pairs, k);
  r.table_md = r.headline_md;
  detail::add_topk_curve(pairs, k, r);
  r.worst_md =
      "\n### Worst pairs (by mean 2D error; nothing scored first)\n\n" + markdown_header("pair");
  nlohmann::json worst = nlohmann::json::array();
  for (const auto& row : detail::worst_pairs(pairs, k, run.worst)) {
    r.worst_md += markdown_row(row.id, row.s);
    nlohmann::json j = to_json(row.s);
    j["pair"] = row.id;
    worst.push_back(j);
  }
  r.summary["worst_pairs"] = worst;
  r.table_md += r.worst_md;
  return r;
}

/// Writes summary.json, table.md, worst_pairs.md and topk.tsv into `dir` (each atomically; a
/// caller wanting all or nothing writes into a staging folder, as gimm-eval does).
inline void write_eval_report(const std::filesystem::path& dir, const EvalReport& r) {
  write_json_file(dir / "summary.json", r.summary);
  write_file_atomic(dir / "table.md", r.table_md);
  write_file_atomic(dir / "worst_pairs.md", r.worst_md.substr(1));
  write_file_atomic(dir / "topk.tsv", r.topk_tsv);
}

}  // namespace gimm
