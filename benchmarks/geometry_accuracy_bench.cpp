// Fundamental-matrix accuracy and stability tables (Markdown on stdout), gimm against OpenCV
// findFundamentalMat on the same seeded scenes (benchmarks/geometry_scenes.hpp).
//
//   gimm_geometry_accuracy_bench [accuracy|stability|all] [--trials N]
//
// accuracy: noise 0, 0.5, 1, 2 px x N = 16, 64, 256, 1024, routine C-arm pairs, without and
//   with 20% outliers. Cell: mean over trials of the mean sqrt(symmetric_epipolar_distance_sq)
//   of the N noise-free correspondences under the estimated F (px).
// stability: sweeps of noise, N, slab thickness (near-planar points), angular separation, and
//   orthographic pairs (perspective 8-point against fundamental_affine). Cell: median over
//   trials of (1) the mean sqrt(symmetric_epipolar_distance_sq) of 1000 held-out noise-free
//   correspondences in the full 120 mm cube and (2) the mean deviation of their estimated
//   epipolar lines from the true ones across detector B (px), and the share of trials that
//   failed (no F, or (1) or (2) above kFailPx).
// RANSAC threshold (gimm and OpenCV alike): max(1, 3 sigma) px; confidence 0.999; at most
// 10000 iterations. OpenCV's RANSAC draws from cv::theRNG(), reseeded before each call.
// Not a Google Benchmark program: it prints tables and exits.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "geometry_scenes.hpp"

namespace {

using gimm_bench::Scene;
using gimm_bench::SceneOptions;
using OptionalF = std::optional<Eigen::Matrix3d>;

constexpr double kFailPx = 2.0;

struct Estimator {
  std::string name;
  std::function<OptionalF(const Scene&, double threshold_px)> run;
};

OptionalF gimm_8pt(const Scene& s, double) {
  return gimm::fundamental_8pt<double>(s.obs_a, s.obs_b);
}
OptionalF gimm_affine(const Scene& s, double) {
  return gimm::fundamental_affine<double>(s.obs_a, s.obs_b);
}
OptionalF gimm_ransac(const Scene& s, double threshold_px,
                      gimm::FundamentalModel model = gimm::FundamentalModel::perspective) {
  gimm::RansacOptions options;
  options.threshold_px = threshold_px;
  options.model = model;
  return gimm::estimate_fundamental_ransac<double>(s.obs_a, s.obs_b, options).F;
}

#ifdef GIMM_HAVE_OPENCV
OptionalF opencv(const Scene& s, double threshold_px, int method) {
  const auto a = gimm_bench::to_cv(s.obs_a), b = gimm_bench::to_cv(s.obs_b);
  cv::setRNGSeed(0);
  const gimm::RansacOptions defaults;
  try {
    return gimm_bench::opencv_fundamental(a, b, method, threshold_px, defaults.confidence,
                                          static_cast<int>(defaults.max_iterations));
  } catch (const cv::Exception&) {  // e.g. USAC with too few points
    return std::nullopt;
  }
}
#endif

std::vector<Estimator> estimators(bool with_8pt, bool with_usac) {
  std::vector<Estimator> out;
  if (with_8pt) out.push_back({"gimm 8pt", gimm_8pt});
#ifdef GIMM_HAVE_OPENCV
  if (with_8pt)
    out.push_back(
        {"OpenCV FM_8POINT", [](const Scene& s, double t) { return opencv(s, t, cv::FM_8POINT); }});
#endif
  out.push_back({"gimm RANSAC", [](const Scene& s, double t) { return gimm_ransac(s, t); }});
#ifdef GIMM_HAVE_OPENCV
  out.push_back(
      {"OpenCV FM_RANSAC", [](const Scene& s, double t) { return opencv(s, t, cv::FM_RANSAC); }});
  if (with_usac)
    out.push_back({"OpenCV USAC_ACCURATE",
                   [](const Scene& s, double t) { return opencv(s, t, cv::USAC_ACCURATE); }});
#endif
  (void)with_usac;
  return out;
}

double threshold_for(double noise_px) {
  return std::max(1.0, 3.0 * noise_px);
}

/// Per-estimator results of one configuration over all trials.
struct Cell {
  std::vector<double> same;      ///< mean error on the scene's own noise-free points (px)
  std::vector<double> held_out;  ///< mean error on held-out cube points (px)
  std::vector<double> line;      ///< mean epipolar line deviation across detector B (px)
  int no_result = 0;
  double seconds = 0;
};

std::vector<Cell> run_config(const SceneOptions& base, const std::vector<Estimator>& est,
                             int trials) {
  std::vector<Cell> cells(est.size());
  for (int t = 0; t < trials; ++t) {
    SceneOptions o = base;
    o.seed = 100000 * static_cast<std::uint64_t>(o.n) + static_cast<std::uint64_t>(t);
    const Scene s = gimm_bench::make_scene(o);
    for (std::size_t e = 0; e < est.size(); ++e) {
      const auto start = std::chrono::steady_clock::now();
      const OptionalF F = est[e].run(s, threshold_for(o.noise_px));
      cells[e].seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (!F) {
        ++cells[e].no_result;
        continue;
      }
      cells[e].same.push_back(gimm_bench::mean_symmetric_epipolar_px(*F, s.true_a, s.true_b));
      cells[e].held_out.push_back(gimm_bench::mean_symmetric_epipolar_px(*F, s.held_a, s.held_b));
      cells[e].line.push_back(gimm_bench::mean_line_deviation_px(*F, s.F_true, s.held_a, s.cam_b));
    }
  }
  return cells;
}

double mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? std::nan("") : sum / static_cast<double>(v.size());
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

std::string fmt(double x) {
  char buf[32];
  if (std::isnan(x)) return "-";
  if (x >= 1e4) return "&gt;1e4";
  std::snprintf(buf, sizeof buf, x < 0.001 ? "%.1e" : x < 10 ? "%.3f" : "%.1f", x);
  return buf;
}

void header(const std::string& first, const std::vector<Estimator>& est) {
  std::printf("| %s |", first.c_str());
  for (const auto& e : est) std::printf(" %s |", e.name.c_str());
  std::printf("\n|---|");
  for (std::size_t e = 0; e < est.size(); ++e) std::printf("---:|");
  std::printf("\n");
}

/// Accuracy cell: mean on the scene's own noise-free correspondences, "(k none)" on failures.
std::string accuracy_cell(const Cell& c) {
  std::string s = fmt(mean(c.same));
  if (c.no_result) s += " (" + std::to_string(c.no_result) + " none)";
  return s;
}

void accuracy(int trials) {
  const std::vector<double> noises = {0, 0.5, 1, 2};
  const std::vector<int> sizes = {16, 64, 256, 1024};
  for (const double outliers : {0.0, 0.2}) {
    const auto est = estimators(true, true);
    std::printf(
        "\n### %s\n\nMean symmetric epipolar distance (px) of the N noise-free correspondences "
        "under the estimated F; mean over %d routine C-arm pairs.\n\n",
        outliers > 0 ? "20% outliers" : "No outliers", trials);
    header("noise px, N", est);
    std::vector<double> seconds(est.size(), 0.0);
    for (const double noise : noises)
      for (const int n : sizes) {
        SceneOptions o;
        o.n = n;
        o.noise_px = noise;
        o.outlier_fraction = outliers;
        const auto cells = run_config(o, est, trials);
        std::printf("| %g, %d |", noise, n);
        for (std::size_t e = 0; e < est.size(); ++e) {
          std::printf(" %s |", accuracy_cell(cells[e]).c_str());
          seconds[e] += cells[e].seconds;
        }
        std::printf("\n");
      }
    std::printf("| total time (s) |");
    for (const double s : seconds) std::printf(" %.3f |", s);
    std::printf("\n");
  }

  // N = 16 with outliers: a few failed pairs dominate the means above; show the distribution.
  const auto est = estimators(false, true);
  std::printf(
      "\n### N = 16, 20%% outliers: distribution over pairs\n\nMedian / 90th percentile over "
      "%d pairs of the same error (px).\n\n",
      trials);
  header("noise px", est);
  for (const double noise : noises) {
    SceneOptions o;
    o.n = 16;
    o.noise_px = noise;
    o.outlier_fraction = 0.2;
    const auto cells = run_config(o, est, trials);
    std::printf("| %g |", noise);
    for (const auto& c : cells)
      std::printf(" %s / %s |", fmt(median(c.same)).c_str(), fmt(percentile(c.same, 0.9)).c_str());
    std::printf("\n");
  }
}

/// Stability cell: median held-out error / median line deviation, share of failed trials.
std::string stability_cell(const Cell& c, int trials) {
  int failed = c.no_result;
  for (std::size_t i = 0; i < c.held_out.size(); ++i)
    failed += !(c.held_out[i] <= kFailPx && c.line[i] <= kFailPx);
  std::string s = fmt(median(c.held_out)) + " / " + fmt(median(c.line));
  if (failed) s += " (" + std::to_string(100 * failed / trials) + "%)";
  if (c.no_result) s += " [" + std::to_string(c.no_result) + " no F]";
  return s;
}

void sweep(const std::string& title, const std::string& column, const std::vector<double>& values,
           const std::function<SceneOptions(double)>& config, const std::vector<Estimator>& est,
           int trials) {
  std::printf("\n### %s\n\n", title.c_str());
  header(column, est);
  for (const double v : values) {
    const auto cells = run_config(config(v), est, trials);
    std::printf("| %g |", v);
    for (const auto& c : cells) std::printf(" %s |", stability_cell(c, trials).c_str());
    std::printf("\n");
  }
}

void stability(int trials) {
  std::printf(
      "\nCell: median over %d trials of (1) the mean symmetric epipolar distance (px) of 1000 "
      "held-out noise-free correspondences in the 120 mm cube / (2) the mean deviation (px) of "
      "their estimated epipolar lines from the true ones across detector B; in brackets the "
      "share of trials that failed: no F (count in square brackets), or (1) or (2) above %g px.\n",
      trials, kFailPx);
  const auto est = estimators(true, false);
  sweep(
      "Noise (N = 64, routine pairs)", "noise px", {0, 0.5, 1, 2, 4, 8},
      [](double v) {
        SceneOptions o;
        o.n = 64;
        o.noise_px = v;
        return o;
      },
      est, trials);
  sweep(
      "Number of points (noise 1 px, routine pairs)", "N", {8, 10, 12, 16, 24, 32, 64, 128},
      [](double v) {
        SceneOptions o;
        o.n = static_cast<int>(v);
        o.noise_px = 1;
        return o;
      },
      est, trials);
  sweep(
      "Near-planar points (120 mm square slab, N = 256, noise 0.5 px)", "slab mm",
      {0, 0.1, 1, 5, 10, 20, 40, 120},
      [](double v) {
        SceneOptions o;
        o.n = 256;
        o.noise_px = 0.5;
        o.slab_mm = v;
        return o;
      },
      est, trials);
  sweep(
      "Exactly and nearly planar points without noise (N = 256)", "slab mm", {0, 0.001, 0.1, 1},
      [](double v) {
        SceneOptions o;
        o.n = 256;
        o.slab_mm = v;
        return o;
      },
      est, trials);
  sweep(
      "Angular separation between the views (N = 256, noise 0.5 px)", "separation deg",
      {1, 2, 5, 10, 20, 45, 90},
      [](double v) {
        SceneOptions o;
        o.n = 256;
        o.noise_px = 0.5;
        o.separation_deg = v;
        return o;
      },
      est, trials);

  std::vector<Estimator> ortho = {
      {"gimm 8pt (perspective)", gimm_8pt},
      {"gimm affine", gimm_affine},
      {"gimm RANSAC perspective", [](const Scene& s, double t) { return gimm_ransac(s, t); }},
      {"gimm RANSAC affine",
       [](const Scene& s, double t) { return gimm_ransac(s, t, gimm::FundamentalModel::affine); }},
  };
#ifdef GIMM_HAVE_OPENCV
  ortho.push_back(
      {"OpenCV FM_8POINT", [](const Scene& s, double t) { return opencv(s, t, cv::FM_8POINT); }});
#endif
  for (const int n : {16, 64}) {
    sweep(
        "Orthographic pairs (N = " + std::to_string(n) + ", routine pairs)", "noise px",
        {0, 0.5, 1, 2, 4},
        [n](double v) {
          SceneOptions o;
          o.n = n;
          o.noise_px = v;
          o.model = gimm::ProjectionModel::orthographic;
          return o;
        },
        ortho, trials);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string mode = "accuracy";
  int trials = 50;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--trials") == 0 && i + 1 < argc) {
      trials = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "accuracy") == 0 || std::strcmp(argv[i], "stability") == 0 ||
               std::strcmp(argv[i], "all") == 0) {
      mode = argv[i];
    } else {
      std::fprintf(stderr, "usage: %s [accuracy|stability|all] [--trials N]\n", argv[0]);
      return 2;
    }
  }
#ifndef GIMM_HAVE_OPENCV
  std::printf("(built without OpenCV: gimm columns only)\n");
#endif
  if (mode == "accuracy" || mode == "all") accuracy(trials);
  if (mode == "stability" || mode == "all") stability(trials);
  return 0;
}
