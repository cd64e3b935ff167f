// The baselines and the evaluation protocol (metrics/protocol.hpp, summary.hpp, user_truth.hpp).
// gimm.Matcher: learned.cpp; match_geometric: geometric.cpp.
#include <pybind11/stl.h>

#include <filesystem>

#include "common.hpp"
#include "gimm/match/baselines.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/metrics/protocol.hpp"
#include "gimm/metrics/report.hpp"
#include "gimm/metrics/summary.hpp"
#include "gimm/pipeline/eval_run.hpp"
#include "gimm/metrics/user_truth.hpp"

namespace gimm::python {

namespace {

py::object parse_json(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

std::vector<Eigen::Vector2d> point_list(const py::handle& obj, const std::string& name) {
  const auto m = rows_of(obj, 2, name);
  std::vector<Eigen::Vector2d> out;
  for (Eigen::Index n = 0; n < m.rows(); ++n) out.emplace_back(m(n, 0), m(n, 1));
  return out;
}

py::object item(const py::dict& d, const char* key) {
  return d.contains(key) ? py::object(d[key]) : py::object(py::none());
}

py::dict as_dict(const py::handle& obj, const std::string& name) {
  if (!py::isinstance<py::dict>(obj))
    throw py::type_error(name + ": expected a dict, got " +
                         std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  return py::reinterpret_borrow<py::dict>(obj);
}

PairTruth truth_from(const py::handle& obj, double radius_px, const std::string& name) {
  const py::dict d = as_dict(obj, name);
  for (const char* key : {"points_a", "points_b"})
    if (!d.contains(key)) throw py::value_error(name + ": missing '" + key + "' (N, 2)");
  PairTruth t;
  t.id = d.contains("id") ? d["id"].cast<std::string>() : name;
  if (d.contains("view_class_a")) t.view_class_a = d["view_class_a"].cast<int>();
  if (d.contains("view_class_b")) t.view_class_b = d["view_class_b"].cast<int>();
  const auto a = point_list(d["points_a"], name + "['points_a']");
  const auto b = point_list(d["points_b"], name + "['points_b']");
  if (a.size() != b.size())
    throw py::value_error(name + ": points_a has " + std::to_string(a.size()) +
                          " points but points_b " + std::to_string(b.size()));
  const py::object world = item(d, "world_mm");
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> w;
  if (!world.is_none()) {
    w = rows_of(world, 3, name + "['world_mm']");
    if (static_cast<std::size_t>(w.rows()) != a.size())
      throw py::value_error(name + ": world_mm has " + std::to_string(w.rows()) + " rows for " +
                            std::to_string(a.size()) + " points");
  }
  for (std::size_t k = 0; k < a.size(); ++k) {
    Correspondence c;
    c.a = a[k];
    c.b = b[k];
    c.world = world.is_none() ? Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())
                              : Eigen::Vector3d(w.row(static_cast<Eigen::Index>(k)).transpose());
    t.dense.push_back(c);
  }
  if (const py::object F = item(d, "F"); !F.is_none()) t.F = fixed<3, 3>(F, name + "['F']");
  const auto mask = [&](const char* key, const std::vector<Eigen::Vector2d>& points) {
    const py::object m = item(d, key);
    if (m.is_none()) return sparse_truth_mask(points, radius_px);
    return std::shared_ptr<const Image<std::uint8_t>>(std::make_shared<Image<std::uint8_t>>(
        image_from<std::uint8_t>(m, Accept::mask, name + "['" + key + "']")));
  };
  t.mask_a = mask("mask_a", a);
  t.mask_b = mask("mask_b", b);
  return t;
}

PairMatches matches_from(const py::handle& obj, const std::string& name) {
  const py::dict d = as_dict(obj, name);
  for (const char* key : {"points_a", "points_b"})
    if (!d.contains(key)) throw py::value_error(name + ": missing '" + key + "' (N, 2)");
  PairMatches m;
  m.points_a = point_list(d["points_a"], name + "['points_a']");
  m.points_b = point_list(d["points_b"], name + "['points_b']");
  if (const py::object c = item(d, "confidence"); !c.is_none()) {
    const Eigen::VectorXd v = vector_of(c, name + "['confidence']");
    m.confidence.assign(v.data(), v.data() + v.size());
  } else {
    m.confidence.assign(m.points_a.size(), 1.0);
  }
  if (const py::object F = item(d, "F"); !F.is_none()) m.F = fixed<3, 3>(F, name + "['F']");
  if (const py::object s = item(d, "F_source"); !s.is_none()) m.F_source = s.cast<std::string>();
  if (const py::object p = item(d, "pair"); !p.is_none()) m.pair = p.cast<std::string>();
  return m;
}


/// A list of dicts, or one dict as a list of one.
std::vector<py::object> list_of(const py::handle& obj) {
  std::vector<py::object> out;
  if (py::isinstance<py::dict>(obj) || obj.is_none()) {
    out.push_back(py::reinterpret_borrow<py::object>(obj));
    return out;
  }
  for (const py::handle& h : py::reinterpret_borrow<py::sequence>(obj))
    out.push_back(py::reinterpret_borrow<py::object>(h));
  return out;
}

}  // namespace

py::dict matches_dict(PairMatches m) {
  py::dict d;
  d["points_a"] = rows_to_numpy<2>(m.points_a);
  d["points_b"] = rows_to_numpy<2>(m.points_b);
  d["confidence"] = adopt_vector(std::move(m.confidence));
  d["F"] = m.F ? py::object(to_numpy(*m.F)) : py::object(py::none());
  d["F_source"] = m.F_source;
  d["pair"] = m.pair;
  return d;
}

py::dict result_dict(PairMatchResult r) {
  if (!r.matches.F) r.matches.F_source = "none";  // Python's dict says so explicitly
  py::dict d = matches_dict(std::move(r.matches));
  d.attr("pop")("pair");
  d["candidates"] = r.candidates;
  d["dropped_in_padding"] = r.dropped_in_padding;
  d["dropped_by_gate"] = r.dropped_by_gate;
  d["dropped_outside_field"] = r.dropped_outside_field;
  d["seconds"] = r.seconds;
  return d;
}

std::optional<Image<std::uint8_t>> optional_field(const py::object& given, const Image<float>& image,
                                                  const char* name) {
  if (given.is_none()) return std::nullopt;
  Image<std::uint8_t> f = image_from<std::uint8_t>(given, Accept::mask, name);
  if (f.rows() != image.rows() || f.cols() != image.cols())
    throw py::value_error(std::string(name) + " is " + std::to_string(f.cols()) + " x " +
                          std::to_string(f.rows()) + ", its image " + std::to_string(image.cols()) +
                          " x " + std::to_string(image.rows()));
  return f;
}

void bind_match(py::module_& m) {
  m.def(
      "match_baseline",
      [](const py::handle& truth, const std::string& method, double sigma_px,
         std::size_t max_points, std::uint64_t seed) {
        const PairTruth t = truth_from(truth, 3.0, "truth");
        if (method != "epipolar" && method != "oracle")
          throw py::value_error("method must be 'epipolar' or 'oracle', got '" + method + "'");
        EpipolarBaselineOptions o;
        o.max_points = max_points;
        const std::unique_ptr<PairMatcher> matcher = options_checked(
            "match_baseline", [&] { return baseline_matcher(method, sigma_px, o, seed); });
        PairInput input;
        input.id = t.id;
        input.truth = &t;
        PairMatches matches;
        {
          py::gil_scoped_release release;
          matches = matcher->match(input);
        }
        py::dict d = matches_dict(std::move(matches));
        d.attr("pop")("pair");
        return d;
      },
      py::arg("truth"), py::arg("method") = "epipolar", py::kw_only(), py::arg("sigma_px") = 1.0,
      py::arg("max_points") = 300, py::arg("seed") = 0, R"doc(
The training-free baselines of gimm-baseline on one pair (match/baselines.hpp).

truth: a pair's truth dict (Dataset.pair(), label_pair(); masks are needed for 'epipolar'; its
'id', e.g. 'phantom-0003/LCA_00-04', seeds the pair's random stream as gimm-baseline does).
method: 'epipolar' (epipolar-nearest: for up to max_points vessel pixels of A, the vessel crossing
of its epipolar line in B nearest in pixels, exact F from the truth) or 'oracle' (the true
partners with sigma_px Gaussian noise per axis on the B side). Returns dict(points_a, points_b,
confidence, F, F_source) as Matcher.match does.)doc");

  m.def(
      "evaluate",
      [](const py::handle& truth, const py::handle& predictions, long top_k, double radius_px) {
        if (!(std::isfinite(radius_px) && radius_px > 0))
          throw py::value_error("evaluate: radius_px must be > 0, got " +
                                std::to_string(radius_px));
        if (top_k < 0) throw py::value_error("evaluate: top_k must be >= 0 (0 = all)");
        const auto truths = list_of(truth), preds = list_of(predictions);
        if (truths.size() != preds.size())
          throw py::value_error("evaluate: " + std::to_string(truths.size()) + " truths but " +
                                std::to_string(preds.size()) + " predictions");
        std::vector<PairScore> pairs;
        for (std::size_t n = 0; n < truths.size(); ++n) {
          const std::string name =
              truths.size() == 1 ? "truth" : "truth[" + std::to_string(n) + "]";
          const PairTruth t = truth_from(truths[n], radius_px, name);
          if (preds[n].is_none()) {
            pairs.push_back(missing_pair(t));
            continue;
          }
          const PairMatches p =
              matches_from(preds[n], truths.size() == 1 ? "predictions"
                                                        : "predictions[" + std::to_string(n) + "]");
          pairs.push_back(score_pair(t, p));
        }
        const nlohmann::json out = {{"top_k", top_k},
                                    {"pooled", to_json(summarize(pairs, top_k))},
                                    {"pairs", pair_summaries_json(pairs, top_k)}};
        return parse_json(out);
      },
      py::arg("truth"), py::arg("predictions"), py::arg("top_k") = 20, py::arg("radius_px") = 3.0,
      R"doc(
Scores predicted matches with the paper's protocol (docs/evaluation.md), as gimm-eval does.

truth: a dict, or a list of dicts (one per pair), with points_a, points_b (N, 2) pixels (point i
of A <-> point i of B), optional world_mm (N, 3) (enables the 3D error), F (3, 3) (the epipolar
check), mask_a / mask_b (rows, cols) vessel masks (nonzero = vessel; without them, the discs of
radius_px around the truth points, as gimm-eval --truth), view_class_a / view_class_b, id.
label_pair's output is such a dict. predictions: a dict (or list, None for a pair without
predictions) with points_a, points_b (M, 2), optional confidence (M,) (all 1 when missing) -
Matcher.match's output is one. top_k: the most confident matches kept per pair (0 = all).
Returns dict(top_k, pooled, pairs): pooled and per-pair summaries with the keys of gimm-eval's
summary.json (prec_1px, prec_3px, prec_5px, mean_px, median_px, p90_px, mean_mm, ...,
coverage, epipolar_*); undefined figures are None.)doc");
  m.def(
      "evaluate_dataset",
      [](const std::filesystem::path& dataset, const std::filesystem::path& predictions,
         const std::string& split, long top_k, const std::string& method, std::size_t worst,
         const py::object& out) {
        if (top_k < 0) throw py::value_error("evaluate_dataset: top_k must be >= 0 (0 = all)");
        EvalRun run;
        run.split = split;
        run.top_k = top_k;
        run.method = method;
        run.worst = worst;
        const std::filesystem::path dir =
            out.is_none() ? std::filesystem::path() : std::filesystem::path(py::str(out).cast<std::string>());
        // out must not be an input (its files would land among theirs).
        check_outputs_not_inputs({{"out", dir}}, {{"dataset", dataset}, {"predictions", predictions}});
        DatasetEvaluation e;
        {
          py::gil_scoped_release release;
          e = evaluate_dataset(dataset, predictions, run);
        }
        if (!dir.empty()) {
          write_folder_all_or_nothing(
              dir, [&](const std::filesystem::path& staged) { write_eval_report(staged, e.report); });
        }
        py::dict d = parse_json(e.report.summary);
        d["missing"] = e.missing;
        return d;
      },
      py::arg("dataset"), py::arg("predictions"), py::kw_only(), py::arg("split") = "all",
      py::arg("top_k") = 20, py::arg("method") = "", py::arg("worst") = 10,
      py::arg("out") = py::none(), R"doc(
Scores a dataset's predictions (predictions/<patient>/<pair>.json) as gimm-eval --dataset does
(pipeline/eval_run.hpp): returns the gimm-eval/1 summary as a dict (format, method, top_k,
pooled, by_system, by_class_pair, topk_curve, worst_pairs, pairs; undefined figures None) and
missing (the pair ids without a predictions file, scored as pairs with no matches). split: 'all',
'train', 'val', 'test'; top_k: matches kept per pair (0 = all); method: the name in the tables
('' : the predictions folder's name); worst: worst pairs listed. out: a folder to write
summary.json, table.md, worst_pairs.md and topk.tsv into, all or nothing (gimm-eval --out,
without the chart).)doc");
  m.def(
      "read_user_truth",
      [](const std::filesystem::path& path, double radius_px) {
        return truth_dict(read_user_truth(path, radius_px));
      },
      py::arg("path"), py::arg("radius_px") = 3.0,
      "Reads a gimm-truth/1 file (docs/evaluation.md) as a truth dict for evaluate: points_a, "
      "points_b, world_mm (NaN rows when absent), F or None, and the disc masks of radius_px.");
  m.def(
      "read_matches",
      [](const std::filesystem::path& path) {
        return matches_dict(matches_from_json(read_json_file(path), path.string()));
      },
      py::arg("path"),
      "Reads a gimm-matches/1 predictions file: dict(points_a, points_b (N, 2), confidence (N,), "
      "F or None, F_source, pair).");
  m.def(
      "write_matches",
      [](const std::filesystem::path& path, const py::handle& predictions, const py::object& pair) {
        PairMatches p = matches_from(predictions, "predictions");
        if (!pair.is_none()) p.pair = pair.cast<std::string>();
        if (p.F_source == "none") {
          p.F.reset();
          p.F_source.clear();
        }
        write_matches(path, p);
      },
      py::arg("path"), py::arg("predictions"), py::arg("pair") = py::none(),
      "Writes predictions (a dict as Matcher.match returns) as a gimm-matches/1 file for "
      "gimm-eval, atomically.");
}

}  // namespace gimm::python
