// gimm-match's picture of a pair: A and B side by side with the matches drawn
// (examples/match/methods.hpp).
#include <algorithm>
#include <cmath>
#include <vector>

#include "gimm/io/png.hpp"
#include "methods.hpp"

namespace gimm_match {

namespace {

void draw_line(gimm::Image<gimm::Rgb8>& canvas, Eigen::Vector2d a, Eigen::Vector2d b,
               gimm::Rgb8 colour) {
  const int steps = std::max(1, int(std::ceil((b - a).cwiseAbs().maxCoeff())));
  for (int s = 0; s <= steps; ++s) {
    const Eigen::Vector2d p = a + (b - a) * (double(s) / steps);
    const int r = int(std::lround(p.y())), c = int(std::lround(p.x()));
    if (r >= 0 && r < canvas.rows() && c >= 0 && c < canvas.cols()) canvas(r, c) = colour;
  }
}

/// The line l (l1 u + l2 v + l3 = 0) across an image of `cols` x `rows`, shifted by `offset`.
void draw_epipolar_line(gimm::Image<gimm::Rgb8>& canvas, const Eigen::Vector3d& l, int rows,
                        int cols, double offset, gimm::Rgb8 colour) {
  std::vector<Eigen::Vector2d> ends;  // where the line meets the image's border
  if (std::abs(l.y()) > 1e-12)
    for (double u : {-0.5, cols - 0.5}) {
      const double v = -(l.x() * u + l.z()) / l.y();
      if (v >= -0.5 && v <= rows - 0.5) ends.emplace_back(u, v);
    }
  if (std::abs(l.x()) > 1e-12)
    for (double v : {-0.5, rows - 0.5}) {
      const double u = -(l.y() * v + l.z()) / l.x();
      if (u >= -0.5 && u <= cols - 0.5) ends.emplace_back(u, v);
    }
  if (ends.size() >= 2)
    draw_line(canvas, ends[0] + Eigen::Vector2d(offset, 0), ends[1] + Eigen::Vector2d(offset, 0),
              colour);
}

}  // namespace

/// A and B side by side, each match a line from A to B, green (confident) to red; with an F,
/// the epipolar lines in B of the five most confident matches, in blue.
void write_picture(const std::string& path, const gimm::Image<float>& a,
                   const gimm::Image<float>& b, const gimm::PairMatches& matches) {
  gimm::Image<gimm::Rgb8> canvas(std::max(a.rows(), b.rows()), a.cols() + b.cols());
  for (int r = 0; r < canvas.rows(); ++r)
    for (int c = 0; c < canvas.cols(); ++c) {
      const bool in_a = c < a.cols();
      const gimm::Image<float>& img = in_a ? a : b;
      const int col = in_a ? c : c - a.cols();
      const float v = r < img.rows() ? img(r, col) : 0.0f;
      const auto g = static_cast<std::uint8_t>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f);
      canvas(r, c) = {g, g, g};
    }
  if (matches.F)
    for (std::size_t k : gimm::rank_by_confidence(matches.confidence, 5))
      draw_epipolar_line(canvas, *matches.F * matches.points_a[k].homogeneous(), b.rows(), b.cols(),
                         double(a.cols()), {60, 120, 255});
  double top = 0;
  for (double c : matches.confidence) top = std::max(top, c);
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const double t = top > 0 ? matches.confidence[k] / top : 0.0;
    const gimm::Rgb8 colour{static_cast<std::uint8_t>(255 * (1 - t)),
                            static_cast<std::uint8_t>(255 * t), 40};
    draw_line(canvas, matches.points_a[k],
              matches.points_b[k] + Eigen::Vector2d(double(a.cols()), 0.0), colour);
  }
  gimm::write_png(path, canvas);
}

}  // namespace gimm_match
