#pragma once
/// Every matcher behind one interface: one view pair in (PairInput), one result out
/// (PairMatchResult: the gimm-matches/1 predictions with the F they were made with, counts and
/// time).
///
///   learned    the GIMM network (nn/), gated by epipolar distance (learned.hpp)
///   geometric  2D centerlines matched along epipolar lines by dynamic programming
///              (geometric.hpp); needs the cameras
///   epipolar   vessel pixels of A to the nearest vessel crossing of the exact epipolar line in B
///              (baselines.hpp); needs the pair's labels (masks and F)
///   oracle     the ground-truth labels with Gaussian noise (baselines.hpp); needs the labels
///
/// What a matcher may use is what a real user has: the two images and their view classes,
/// and, when known, the cameras, vessel masks and exposed fields; the labels (`truth`) only in
/// a dataset, for the baselines.
#include <chrono>
#include <optional>
#include <string>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/match/field_of_view.hpp"
#include "gimm/match/matches.hpp"

namespace gimm {

struct PairInput {
  std::string id;  ///< written into the predictions ("<patient>/<pair>" in a dataset)
  const Image<float>* image_a = nullptr;  ///< intensities in [0, 1], dark vessels
  const Image<float>* image_b = nullptr;
  int class_a = kUnknownViewClass, class_b = kUnknownViewClass;
  std::optional<Camerad> camera_a, camera_b;  ///< both or neither
  /// Vessel masks (nonzero = vessel), each the size of its image, both or neither: a user's
  /// segmentation or a dataset's masks. The geometric matcher follows them instead of segmenting
  /// the images (GeometricOptions::use_masks).
  const Image<std::uint8_t>* mask_a = nullptr;
  const Image<std::uint8_t>* mask_b = nullptr;
  /// The exposed fields (1 where the collimator let X-rays through; match/field_of_view.hpp),
  /// each the size of its image; null: the whole image. Matches are made inside them only.
  const Image<std::uint8_t>* field_a = nullptr;
  const Image<std::uint8_t>* field_b = nullptr;
  const PairTruth* truth = nullptr;  ///< a dataset's labels, exact F and masks (the baselines)

  /// How messages name the pair: "pair '<id>'", or "the pair" without an id.
  std::string name() const { return id.empty() ? "the pair" : "pair '" + id + "'"; }

  /// Fails naming the pair and the part when the parts do not fit together: cameras or masks
  /// given for one view only, a camera, mask or field of another size than its image.
  void validate() const {
    GIMM_CHECK(camera_a.has_value() == camera_b.has_value(),
               name() << ": give both cameras or neither (only camera " << (camera_a ? "A" : "B")
                      << " given)");
    GIMM_CHECK((mask_a == nullptr) == (mask_b == nullptr),
               name() << ": give both vessel masks or neither (only mask " << (mask_a ? "A" : "B")
                      << " given)");
    for (const char view : {'A', 'B'}) {
      const Image<float>* image = view == 'A' ? image_a : image_b;
      const auto& camera = view == 'A' ? camera_a : camera_b;
      const Image<std::uint8_t>* mask = view == 'A' ? mask_a : mask_b;
      const Image<std::uint8_t>* field = view == 'A' ? field_a : field_b;
      // Without the image, the mask sets the size (a matcher reading masks only).
      const int rows = image ? image->rows() : mask ? mask->rows() : -1;
      const int cols = image ? image->cols() : mask ? mask->cols() : -1;
      if (rows < 0) continue;
      const auto fits = [&](const char* what, int r, int c) {
        GIMM_CHECK(r == rows && c == cols, name() << ": " << what << " " << view << " is " << c
                                                  << "x" << r << " px, image " << view << " "
                                                  << cols << "x" << rows);
      };
      if (camera) fits("camera", camera->rows(), camera->cols());
      if (mask) fits("mask", mask->rows(), mask->cols());
      if (field) fits("field", field->rows(), field->cols());
    }
  }
};

/// What every matcher returns for one pair.
struct PairMatchResult {
  /// The matches in image pixels with their confidences (the ranking), and the F they were
  /// made or gated with and its source (matches.F, matches.F_source: "cameras" or "matches";
  /// no F: unset and "").
  PairMatches matches;
  int candidates = 0;             ///< what the method proposed before the drops below
  int dropped_in_padding = 0;     ///< learned: a point in the network input's padding
  int dropped_by_gate = 0;        ///< learned: off the epipolar line (hard gate)
  int dropped_outside_field = 0;  ///< an end outside its view's exposed field
  double seconds = 0;             ///< wall time of the matching itself (no file reading)

  /// "cameras", "matches", or "none" when the matches carry no F.
  std::string fundamental_source() const { return matches.F ? matches.F_source : "none"; }
};

class PairMatcher {
 public:
  virtual ~PairMatcher() = default;
  /// The method's name in tables and messages ("learned", "geometric", "epipolar", "oracle").
  virtual std::string name() const = 0;
  /// Whether run() reads the images (the baselines read the labels only; the geometric matcher
  /// with masks reads the masks).
  virtual bool needs_images() const { return true; }
  /// The pair matched: the method's matches, none with an end outside its view's exposed field
  /// (a point the detector did not see cannot be matched, whichever method proposes it; the
  /// drops are counted in dropped_outside_field).
  PairMatchResult run(const PairInput& pair) const {
    PairMatchResult r = run_method(pair);
    r.dropped_outside_field +=
        static_cast<int>(drop_outside_fields(r.matches, pair.field_a, pair.field_b));
    return r;
  }
  PairMatches match(const PairInput& pair) const { return run(pair).matches; }

 protected:
  /// The method itself, before the exposed-field rule of run().
  virtual PairMatchResult run_method(const PairInput& pair) const = 0;
};

namespace detail {
/// Seconds since `start`, for PairMatchResult::seconds.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace detail

}  // namespace gimm
