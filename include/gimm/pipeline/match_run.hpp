#pragma once
/// Matching a whole dataset from C++ (or Python, gimm.match_dataset): every pair of a split of a
/// gimm-dataset matched by one matcher (match/pair_matcher.hpp) into OUT/<patient>/<pair>.json, the
/// gimm-matches/1 predictions gimm-eval scores. gimm-match --dataset and gimm-baseline are flag
/// parsing around match_dataset.
///
/// What each pair's input holds: its view classes, labels (the baselines read them) and vessel
/// masks, the cameras unless `use_cameras` is off (the learned matcher then estimates F from its
/// matches), and, when the matcher reads images, the views rendered (<view>.png) or as a C-arm
/// forms them (<view>.formed.png, matched inside the exposed field <view>.field.png).
/// For stability sweeps the matcher's cameras may be moved (camera_error) and its images
/// degraded (degradation), the labels not; each pair's random stream depends on the seed and
/// the pair only, so a pair's matches do not depend on the other pairs.
///
/// All or nothing: the predictions are written under a staging folder and moved into OUT at
/// the end, so a failure (a full disk, a bad pair) leaves OUT as it was.
///
///   gimm::GeometricMatcher matcher(options);
///   gimm::MatchRunOptions run;
///   run.images = gimm::DatasetImages::formed;
///   const auto summary = gimm::match_dataset(matcher, "ds/", "pred/", run);
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/geometry/camera_error.hpp"
#include "gimm/geometry/two_rays.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/match/baselines.hpp"
#include "gimm/match/pair_matcher.hpp"
#include "gimm/pipeline/run_report.hpp"
#include "gimm/render/image_degradation.hpp"

namespace gimm {

/// Which of a dataset's images the matcher sees.
enum class DatasetImages {
  automatic,  ///< formed where the dataset has them (a clinical-style dataset), else rendered
  rendered,   ///< <view>.png, the whole image
  formed,     ///< <view>.formed.png inside <view>.field.png (gimm-dataset --formation)
};

struct MatchRunOptions {
  std::string split = "all";  ///< all | train | val | test
  /// Give the matcher the views' cameras; off: it has none (the learned matcher's F then comes
  /// from its matches, as the reference estimates it).
  bool use_cameras = true;
  DatasetImages images = DatasetImages::automatic;
  CameraError camera_error;  ///< moves the matcher's cameras (needs use_cameras)
  ImageDegradation
      degradation;         ///< degrades the matcher's images (needs a matcher that reads them)
  std::uint64_t seed = 0;  ///< the camera errors' and degradations' random streams
  RunReporter report;      ///< the run's state ("n/N pairs, s/pair, ETA"); empty: silent

  /// Fails naming the option when these options do not fit `matcher` and the dataset.
  void validate(const PairMatcher& matcher, const DatasetReader& dataset) const {
    GIMM_CHECK(split == "all" || split == "train" || split == "val" || split == "test",
               "MatchRunOptions::split must be all, train, val or test, got '" << split << "'");
    camera_error.validate();
    degradation.validate();
    GIMM_CHECK(camera_error.none() || use_cameras,
               "MatchRunOptions::camera_error moves the cameras: it needs "
               "MatchRunOptions::use_cameras");
    GIMM_CHECK(degradation.none() || matcher.needs_images(),
               "MatchRunOptions::degradation degrades the images, and the "
                   << matcher.name() << " matcher does not look at them");
    GIMM_CHECK(images != DatasetImages::formed || dataset.has_formed_views(),
               "MatchRunOptions::images formed: "
                   << dataset.root().string()
                   << " has no formed views (made without a formation stage: gimm-dataset "
                      "--style drr or --no-formation)");
  }
};

struct MatchRunSummary {
  std::size_t pairs = 0, matches = 0;
  std::size_t without_F = 0;  ///< pairs written with no F (none from the cameras or the matches)
  bool formed = false;        ///< the formed views were matched
  double seconds = 0;
};

namespace detail {

/// The images and fields one pair's matcher sees, kept alive while it runs.
struct PairViews {
  Image<float> a, b;
  Image<std::uint8_t> field_a, field_b;
};

/// Fills `input` (and `views`, which it points into) for pair `id` of the dataset.
inline void load_pair_input(const PairMatcher& matcher, const DatasetReader& reader,
                            const std::string& id, const PairTruth& truth, bool formed,
                            const MatchRunOptions& options, PairViews& views, PairInput& input) {
  const std::string patient = split_pair_id(id).first;
  const DatasetLayout& layout = reader.layout();
  input.id = id;
  input.class_a = truth.view_class_a;
  input.class_b = truth.view_class_b;
  input.truth = &truth;
  input.mask_a = truth.mask_a.get();
  input.mask_b = truth.mask_b.get();
  if (formed) {  // the views as a C-arm forms them, matched inside their exposed fields
    views.field_a = read_png8(layout.view_field(patient, truth.view_a));
    views.field_b = read_png8(layout.view_field(patient, truth.view_b));
    input.field_a = &views.field_a;
    input.field_b = &views.field_b;
  }
  if (matcher.needs_images()) {
    const auto image = [&](const std::string& view) {
      return formed ? layout.view_formed(patient, view) : layout.view_image(patient, view);
    };
    views.a = read_png_unit(image(truth.view_a));
    views.b = read_png_unit(image(truth.view_b));
    if (!options.degradation.none()) {  // what the matcher sees is degraded, the truth is not
      Rng rng = baseline_stream(options.seed, "image-degradation", id);
      views.a = degrade_image(views.a, options.degradation, rng);
      views.b = degrade_image(views.b, options.degradation, rng);
    }
    input.image_a = &views.a;
    input.image_b = &views.b;
  }
  if (options.use_cameras) {
    input.camera_a = reader.camera(patient, truth.view_a);
    input.camera_b = reader.camera(patient, truth.view_b);
    if (!options.camera_error.none()) {  // the matcher's cameras are off, the images are not
      Rng rng = baseline_stream(options.seed, "camera-error", id);
      const Eigen::Vector3d pivot = pair_isocenter(*input.camera_a, *input.camera_b);
      input.camera_a = perturbed_camera(*input.camera_a, pivot, options.camera_error, rng);
      input.camera_b = perturbed_camera(*input.camera_b, pivot, options.camera_error, rng);
    }
  }
}

/// "n/N pairs, s/pair, ETA" for the progress report.
inline std::string match_progress(std::size_t done, std::size_t total, double seconds) {
  char line[120];
  std::snprintf(line, sizeof line, "%zu/%zu pairs, %.2f s/pair, ETA %.0f s   ", done, total,
                seconds / double(done), seconds / double(done) * double(total - done));
  return line;
}

}  // namespace detail

/// Matches every pair of `options.split` of the gimm-dataset at `dataset` into
/// `out`/<patient>/<pair>.json (see the file comment).
inline MatchRunSummary match_dataset(const PairMatcher& matcher,
                                     const std::filesystem::path& dataset,
                                     const std::filesystem::path& out,
                                     const MatchRunOptions& options) {
  DatasetReader reader(dataset);
  options.validate(matcher, reader);
  MatchRunSummary summary;
  summary.formed = options.images == DatasetImages::formed ||
                   (options.images == DatasetImages::automatic && reader.has_formed_views());
  const std::vector<std::string> ids = reader.pair_ids(options.split);
  GIMM_CHECK(!ids.empty(),
             "no pairs in '" << dataset.string() << "' (split " << options.split << ")");
  const auto start = std::chrono::steady_clock::now();
  const auto report = [&](RunMessage kind, const std::string& text) {
    if (options.report) options.report(kind, text);
  };
  try {
    write_folder_all_or_nothing(out, [&](const std::filesystem::path& staged) {
      for (std::size_t n = 0; n < ids.size(); ++n) {
        const PairTruth truth = reader.pair(ids[n]);
        detail::PairViews views;
        PairInput input;
        detail::load_pair_input(matcher, reader, ids[n], truth, summary.formed, options, views,
                                input);
        const PairMatches matches = matcher.match(input);
        write_matches(matches_path(staged, ids[n]), matches);
        summary.matches += matches.size();
        summary.without_F += !matches.F;
        report(RunMessage::progress,
               detail::match_progress(n + 1, ids.size(), detail::seconds_since(start)));
      }
    });
  } catch (...) {
    report(RunMessage::end, "");  // the progress line ends before the error is shown
    throw;
  }
  report(RunMessage::end, "");
  summary.pairs = ids.size();
  summary.seconds = detail::seconds_since(start);
  return summary;
}

}  // namespace gimm
