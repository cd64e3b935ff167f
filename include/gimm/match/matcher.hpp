#pragma once
/// Every matcher behind one interface: one view pair in, gimm-matches/1 predictions out.
///
///   learned   the GIMM network (nn/), gated by epipolar distance (learned.hpp)
///   epipolar  vessel pixels of A to the nearest vessel crossing of the exact epipolar line in B
///             (baselines.hpp); needs both vessel masks and F
///   oracle    the ground-truth labels with Gaussian noise (baselines.hpp); needs the truth
///
/// What a matcher may use is what a real user has: the two images and their view classes,
/// and, when known, the cameras, the vessel masks and (for the oracle only) the labels.
#include <memory>
#include <optional>
#include <string>

#include "gimm/core/image.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/match/matches.hpp"

namespace gimm {

struct PairInput {
  std::string id;  ///< written into the predictions ("<patient>/<pair>" in a dataset)
  const Image<float>* image_a = nullptr;  ///< intensities in [0, 1]
  const Image<float>* image_b = nullptr;
  int class_a = kUnknownViewClass, class_b = kUnknownViewClass;
  std::optional<Camerad> camera_a, camera_b;  ///< both or neither
  const PairTruth* truth = nullptr;           ///< dataset mode: labels, exact F, masks
  /// The exposed fields (1 where the collimator let X-rays through; match/field_of_view.hpp),
  /// each the size of its image; null: the whole image. Matches are made inside them only.
  const Image<std::uint8_t>* field_a = nullptr;
  const Image<std::uint8_t>* field_b = nullptr;
};

class PairMatcher {
 public:
  virtual ~PairMatcher() = default;
  /// The method's name in tables and messages ("learned", "epipolar", "oracle").
  virtual std::string name() const = 0;
  /// Whether match() reads the images (the baselines read masks and labels only).
  virtual bool needs_images() const { return true; }
  virtual PairMatches match(const PairInput& pair) const = 0;
};

}  // namespace gimm
