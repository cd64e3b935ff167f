#pragma once
/// The ground truth of one view pair as the evaluation needs it (PairTruth, read by the dataset
/// room's DatasetReader), and the names of its breakdowns.
#include <string>
#include <utility>

#include "gimm/dataset/reader.hpp"
#include "gimm/labels/views.hpp"

namespace gimm {

/// Readable name of a view class ("LAO Cranial"), "unknown" for 0 or anything out of range.
inline std::string view_class_label(int id) {
  if (id < 1 || id > 11) return "unknown";
  return view_class(id).name;
}

/// The breakdown key of a pair's view classes, lower id first: "RCA AP Cranial / LAO".
inline std::string class_pair_key(const PairTruth& t) {
  int a = t.view_class_a, b = t.view_class_b;
  if (b < a) std::swap(a, b);
  return t.system() + " " + view_class_label(a) + " / " + view_class_label(b);
}

}  // namespace gimm
