// gimm-match's picture of a pair: A and B side by side with the matches drawn
// (examples/match/methods.hpp).
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "gimm/core/bitmap_text.hpp"
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

/// Colours of the picture and its legend.
const gimm::Rgb8 kEpipolarBlue{60, 120, 255}, kLegendGrey{220, 220, 220};

/// The legend under the views: the match count, the colour scale, the epipolar lines; "A" and
/// "B" in the views' top-left corners. Font pixels are `scale` x `scale` (1 up to 512 px wide
/// pictures).
void draw_legend(gimm::Image<gimm::Rgb8>& canvas, int views_rows, int a_cols,
                 const gimm::PairMatches& matches, int scale) {
  const int line = gimm::text_height(scale) + 3 * scale, pad = 2 * scale;
  for (const auto& [label, col] : {std::pair{"A", 0}, std::pair{"B", a_cols}}) {
    for (int r = 0; r < line && r < views_rows; ++r)
      for (int c = col; c < col + gimm::text_width(label, scale) + 2 * pad; ++c)
        if (c < canvas.cols()) canvas(r, c) = {0, 0, 0};
    gimm::draw_text(canvas, pad, col + pad, label, kLegendGrey, scale);
  }
  int row = views_rows + pad;
  gimm::draw_text(canvas, row, pad, std::to_string(matches.size()) + " MATCHES A - B", kLegendGrey,
                  scale);
  row += line;
  int col = pad;
  for (const auto& [text, colour] : {std::pair{std::string("GREEN"), gimm::Rgb8{0, 255, 40}},
                                     std::pair{std::string(": MOST CONFIDENT, "), kLegendGrey},
                                     std::pair{std::string("RED"), gimm::Rgb8{255, 0, 40}},
                                     std::pair{std::string(": LEAST"), kLegendGrey}}) {
    gimm::draw_text(canvas, row, col, text, colour, scale);
    col += 6 * static_cast<int>(text.size()) * scale;  // the next glyph's place
  }
  if (matches.F) {
    row += line;
    gimm::draw_text(canvas, row, pad, "BLUE: EPIPOLAR LINES IN B OF THE 5 MOST CONFIDENT",
                    kEpipolarBlue, scale);
  }
}

/// Rows the legend takes under the views.
int legend_rows(const gimm::PairMatches& matches, int scale) {
  const int lines = matches.F ? 3 : 2;
  return lines * (gimm::text_height(scale) + 3 * scale) + 2 * scale;
}

}  // namespace

/// A and B side by side, each match a line from A to B, green (confident) to red; with an F,
/// the epipolar lines in B of the five most confident matches, in blue; a legend underneath.
void write_picture(const std::string& path, const gimm::Image<float>& a,
                   const gimm::Image<float>& b, const gimm::PairMatches& matches) {
  const int views_rows = std::max(a.rows(), b.rows());
  const int scale = std::max(1, (a.cols() + b.cols()) / 512);
  gimm::Image<gimm::Rgb8> canvas(views_rows + legend_rows(matches, scale), a.cols() + b.cols());
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
                         double(a.cols()), kEpipolarBlue);
  double top = 0;
  for (double c : matches.confidence) top = std::max(top, c);
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const double t = top > 0 ? matches.confidence[k] / top : 0.0;
    const gimm::Rgb8 colour{static_cast<std::uint8_t>(255 * (1 - t)),
                            static_cast<std::uint8_t>(255 * t), 40};
    draw_line(canvas, matches.points_a[k],
              matches.points_b[k] + Eigen::Vector2d(double(a.cols()), 0.0), colour);
  }
  draw_legend(canvas, views_rows, a.cols(), matches, scale);
  gimm::write_png(path, canvas);
}

}  // namespace gimm_match
