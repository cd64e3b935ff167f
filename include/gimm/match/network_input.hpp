#pragma once
/// An angiogram as the learned matcher's network sees it: resized, optionally vessel-enhanced,
/// zero-padded. Training (tools/train, through gimm.network_image) and inference run this same
/// code, so the network sees the same thing in both.
///
/// Size. The network needs sides that are multiples of 8, so by default an image runs at its
/// own size, zero-padded on the right and bottom to the next multiple of 8. With `input_size`
/// N > 0 the image is first resized (bilinear, pixel centres aligned, which is the exact 2x2 box
/// filter at a factor of 2) so that its longer side is N. Two images of different sizes are
/// padded to the larger rows and columns (to_network_input's pad_rows/pad_cols).
///
/// Content (nn::MatcherConfig::input, recorded in the weights):
/// - intensity: the image as it is, [0, 1], vessels dark;
/// - vesselness: what the segmenting geometric matcher sees, at the network's resolution: the
///   background removed (log intensity, black top-hat) and Frangi's vesselness V in [0, 1]
///   (match/vesselness.hpp), shown as 1 - sqrt(V). Vessels stay dark on a bright ground as in an
///   intensity image (weights trained on intensities are a fair start), and the square root
///   lifts the faint distal vessels that V's peaked distribution leaves near 0. Heart shadow,
///   ribs, lungs and shutter edges, where synthetic and real frames differ most, are much
///   reduced; a real frame's fine background texture stays (docs/images/network_input.png).
///   Trained once, it did worse than intensities (weights/README.md, "The vessel-enhanced input").
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/match/vesselness.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm {

enum class NetworkImage { intensity, vesselness };

inline NetworkImage network_image_kind(const std::string& name) {
  if (name == "intensity") return NetworkImage::intensity;
  if (name == "vesselness") return NetworkImage::vesselness;
  GIMM_FAIL("network input must be intensity|vesselness, got '" << name << "'");
}

/// Vesselness scales at the network's resolution, pixels: lumen radii of about 1-4 px, which at
/// 256 px covers clinical frames (512 px vessels of ~8 px, ~2 px radius after halving) and the
/// synthetic views (a 3 mm proximal vessel at 0.6 mm pixels is ~3.3 px in radius).
inline const std::vector<double>& network_vesselness_scales() {
  static const std::vector<double> scales = {1.0, 1.5, 2.0, 3.0, 4.0};
  return scales;
}

/// The network's view of `image` (already at the network's size): the image itself, or
/// 1 - sqrt(vesselness) of its background-free log (see the header comment).
inline Image<float> network_image(const Image<float>& image, NetworkImage kind) {
  GIMM_CHECK(!image.empty(), "network_image: the image is empty");
  if (kind == NetworkImage::intensity) return image;
  VesselnessOptions o;
  o.scales_px = network_vesselness_scales();
  const double widest = o.scales_px.back();
  Image<float> v = vesselness(vessel_contrast(image, background_width_px(widest)), o);
  for (float& x : v.storage()) x = 1.0f - std::sqrt(std::max(0.0f, x));
  return v;
}

/// One image as the network sees it.
struct NetworkInput {
  Image<float> content;                    ///< resized and turned into the input kind
  nn::Tensor tensor;                       ///< [1, 1, rows, cols], rows and cols multiples of 8
  int content_rows = 0, content_cols = 0;  ///< the resized image inside the padding
  double scale_u = 1, scale_v = 1;         ///< image pixels per network pixel
  std::int64_t padded_rows() const { return (content_rows + 7) / 8 * 8; }
  std::int64_t padded_cols() const { return (content_cols + 7) / 8 * 8; }
};

/// Bilinear resampling with pixel centres aligned (PyTorch align_corners=False).
inline Image<float> resize_bilinear(const Image<float>& image, int rows, int cols) {
  GIMM_CHECK(rows > 0 && cols > 0, "resize_bilinear: bad size " << cols << "x" << rows);
  Image<float> out(rows, cols);
  const double sv = double(image.rows()) / rows, su = double(image.cols()) / cols;
  for (int r = 0; r < rows; ++r) {
    const double y = std::clamp((r + 0.5) * sv - 0.5, 0.0, double(image.rows() - 1));
    const int y0 = int(y), y1 = std::min(y0 + 1, image.rows() - 1);
    const double wy = y - y0;
    for (int c = 0; c < cols; ++c) {
      const double x = std::clamp((c + 0.5) * su - 0.5, 0.0, double(image.cols() - 1));
      const int x0 = int(x), x1 = std::min(x0 + 1, image.cols() - 1);
      const double wx = x - x0;
      const double top = (1 - wx) * image(y0, x0) + wx * image(y0, x1);
      const double bottom = (1 - wx) * image(y1, x0) + wx * image(y1, x1);
      out(r, c) = float((1 - wy) * top + wy * bottom);
    }
  }
  return out;
}

/// `image` resized to `input_size` (0: its own size) and turned into `kind`; not padded yet
/// (pad_network_input). Checks every pixel is finite, naming `name` and the pixel.
inline NetworkInput prepare_network_input(const Image<float>& image, int input_size,
                                          NetworkImage kind, const std::string& name) {
  GIMM_CHECK(image.rows() > 0 && image.cols() > 0, name << ": the image is empty");
  GIMM_CHECK(input_size >= 0, "input_size must be >= 0, got " << input_size);
  for (int r = 0; r < image.rows(); ++r)  // before resizing spreads a NaN over its neighbours
    for (int c = 0; c < image.cols(); ++c)
      GIMM_CHECK(std::isfinite(image(r, c)),
                 name << ": pixel (" << r << ", " << c << ") is " << image(r, c));
  NetworkInput in;
  in.content = image;
  if (input_size > 0) {
    const double scale = double(input_size) / std::max(image.rows(), image.cols());
    const int rows = std::max(1, int(std::lround(image.rows() * scale)));
    const int cols = std::max(1, int(std::lround(image.cols() * scale)));
    if (rows != image.rows() || cols != image.cols())
      in.content = resize_bilinear(image, rows, cols);
  }
  in.content_rows = in.content.rows();
  in.content_cols = in.content.cols();
  GIMM_CHECK(in.content_rows >= 8 && in.content_cols >= 8,
             name << ": " << image.cols() << "x" << image.rows() << " px resized to "
                  << in.content_cols << "x" << in.content_rows << " (input size " << input_size
                  << ") is too small for the matcher (at least 8x8 pixels; a very long, thin "
                     "image?)");
  if (kind != NetworkImage::intensity) in.content = network_image(in.content, kind);
  in.scale_u = double(image.cols()) / in.content_cols;
  in.scale_v = double(image.rows()) / in.content_rows;
  return in;
}

/// The tensor of a prepared input, zero-padded to `rows` x `cols` (multiples of 8, at least the
/// content's padded size).
inline void pad_network_input(NetworkInput& in, std::int64_t rows, std::int64_t cols) {
  GIMM_CHECK(rows % 8 == 0 && cols % 8 == 0 && rows >= in.padded_rows() && cols >= in.padded_cols(),
             "network input: cannot pad " << in.content_cols << "x" << in.content_rows << " to "
                                          << cols << "x" << rows);
  in.tensor = nn::Tensor({1, 1, rows, cols});
  for (int r = 0; r < in.content_rows; ++r)
    for (int c = 0; c < in.content_cols; ++c) in.tensor[r * cols + c] = in.content(r, c);
}

/// prepare_network_input, then padded to the content's own size rounded up to 8.
inline NetworkInput to_network_input(const Image<float>& image, int input_size, NetworkImage kind,
                                     const std::string& name) {
  NetworkInput in = prepare_network_input(image, input_size, kind, name);
  pad_network_input(in, in.padded_rows(), in.padded_cols());
  return in;
}

}  // namespace gimm
