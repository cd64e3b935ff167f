#pragma once
/// The GIMM matcher: tools/train/gimm_model.py (the source of truth) on the gimm engine.
///
///   ResNet-FPN (coarse 1/8, fine 1/2) -> + sine encoding -> FiLM (1 + gamma) F + beta
///   -> coarse linear-attention transformer -> dual softmax, threshold, border, mutual NN
///   -> 5x5 fine windows -> fine transformer -> soft-argmax.
/// Points are in network-input pixels, pixel centres at integers: coarse cell (r, c) is pixel
/// (8c, 8r), one fine pixel is 2 image pixels. Epipolar gating is applied by the caller
/// (match/learned.hpp), as it is geometry, not network.
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/nn/attention.hpp"
#include "gimm/nn/coarse_matching.hpp"
#include "gimm/nn/conv2d.hpp"
#include "gimm/nn/linear.hpp"
#include "gimm/nn/positional_encoding.hpp"
#include "gimm/nn/resample.hpp"
#include "gimm/nn/softmax.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

enum class LayerKind { self_attention, cross_attention };

/// Mirrors DEFAULT_CONFIG of gimm_model.py; stored as JSON in the weights' __metadata__.
struct MatcherConfig {
  std::array<std::int64_t, 3> widths{24, 48, 96};  ///< stages at 1/2, 1/4, 1/8
  int coarse_heads = 4;
  std::vector<LayerKind> coarse_layers{LayerKind::self_attention, LayerKind::cross_attention,
                                       LayerKind::self_attention, LayerKind::cross_attention};
  int fine_heads = 4;
  std::vector<LayerKind> fine_layers{LayerKind::self_attention, LayerKind::cross_attention};
  bool film = true;
  int film_classes = 12;  ///< 0 = unknown view, 1..11 = the clinical view classes
  int film_dim = 64;
  float temperature = 0.1f;
  float threshold = 0.2f;
  int border = 1;
  int window = 5;
  /// The A point refined inside its window (a learned score per window pixel, soft-argmax;
  /// its score-weighted feature queries image 1's window) instead of the coarse cell centre.
  /// Absent in weights files written before it existed: false.
  bool anchor = false;
  /// The longer image side (pixels) the weights were trained at; gimm-match resizes to it
  /// unless told otherwise. 0: not recorded (run at the image's own size).
  int input_size = 0;
  /// The epipolar gate the weights were tuned with (chosen on a tuning split, weights/README.md);
  /// gimm-match uses it unless --gate/--delta/--snap say otherwise. Empty: not recorded.
  std::string gate_mode;
  double gate_delta_px = 0;  ///< hard gate threshold, px
  bool gate_snap = false;    ///< B points moved onto their epipolar lines
  /// What the network sees of an image (match/network_input.hpp): "intensity", the image as it
  /// is, or "vesselness", its vessels enhanced. Absent in files written before it existed:
  /// intensity.
  std::string input = "intensity";

  std::int64_t coarse_dim() const { return widths[2]; }
  std::int64_t fine_dim() const { return widths[0]; }

  void validate() const {
    for (std::int64_t w : widths) GIMM_CHECK(w > 0, "matcher config: width " << w << " <= 0");
    GIMM_CHECK(coarse_heads > 0 && coarse_dim() % coarse_heads == 0,
               "matcher config: coarse dim " << coarse_dim() << " not divisible by " << coarse_heads
                                             << " heads");
    GIMM_CHECK(fine_heads > 0 && fine_dim() % fine_heads == 0,
               "matcher config: fine dim " << fine_dim() << " not divisible by " << fine_heads
                                           << " heads");
    GIMM_CHECK(coarse_dim() % 4 == 0,
               "matcher config: coarse dim " << coarse_dim() << " must be a multiple of 4");
    GIMM_CHECK(film_classes > 0 && film_dim > 0,
               "matcher config: bad film_classes " << film_classes << " or film_dim " << film_dim);
    GIMM_CHECK(std::isfinite(temperature) && temperature > 0,
               "matcher config: temperature must be > 0, got " << temperature);
    GIMM_CHECK(std::isfinite(threshold) && threshold >= 0 && threshold < 1,
               "matcher config: threshold must be in [0, 1), got " << threshold);
    GIMM_CHECK(border >= 0, "matcher config: border must be >= 0, got " << border);
    GIMM_CHECK(window >= 1 && window % 2 == 1,
               "matcher config: window must be odd, got " << window);
    GIMM_CHECK(
        input_size >= 0 && input_size % 8 == 0 && input_size <= 8192,
        "matcher config: input_size must be 0 or a multiple of 8 up to 8192, got " << input_size);
    GIMM_CHECK(gate_mode.empty() || gate_mode == "hard" || gate_mode == "soft" ||
                   gate_mode == "logit" || gate_mode == "none",
               "matcher config: gate mode must be hard|soft|logit|none, got '" << gate_mode << "'");
    GIMM_CHECK(gate_mode != "hard" || (std::isfinite(gate_delta_px) && gate_delta_px > 0),
               "matcher config: gate delta_px must be > 0, got " << gate_delta_px);
    GIMM_CHECK(input == "intensity" || input == "vesselness",
               "matcher config: input must be intensity|vesselness, got '" << input << "'");
  }
};

/// Weights by PyTorch state_dict name; throws (naming the tensor) when missing or misshapen.
using WeightLookup = std::function<Tensor(const std::string& name, const Shape& shape)>;

struct MatcherOutput {
  std::int64_t coarse_rows = 0, coarse_cols = 0;
  Tensor confidence;                     ///< [L0, L1] dual-softmax matrix (kept when asked for)
  std::vector<std::int64_t> i_ids;       ///< (M) coarse cell in image 0, row-major r * cols + c
  std::vector<std::int64_t> j_ids;       ///< (M) coarse cell in image 1
  std::vector<float> coarse_confidence;  ///< (M)
  std::vector<std::array<float, 2>> points0;  ///< (M) (u, v) in image 0, network pixels
  std::vector<std::array<float, 2>> points1;  ///< (M) (u, v) in image 1, refined
  std::vector<float> fine_std;                ///< (M) spread of the fine heat map
};

class Matcher {
 public:
  Matcher(MatcherConfig config, const WeightLookup& weights) : config_(std::move(config)) {
    config_.validate();
    load(weights);
  }

  const MatcherConfig& config() const { return config_; }
  /// The coarse confidence a match needs (the weights record the value they were trained with;
  /// a lower one gives the epipolar gate more candidates to keep).
  void set_threshold(float threshold) {
    GIMM_CHECK(std::isfinite(threshold) && threshold >= 0 && threshold < 1,
               "matcher: threshold must be in [0, 1), got " << threshold);
    config_.threshold = threshold;
  }
  /// Every tensor name the model read (the loader rejects files with others).
  const std::vector<std::string>& tensor_names() const { return names_; }

  /// image0, image1: [1, 1, H, W] in [0, 1], H and W positive multiples of 8.
  MatcherOutput match(const Tensor& image0, const Tensor& image1, int class0 = 0, int class1 = 0,
                      bool keep_confidence = false) const;

 private:
  struct Block {
    Conv2d conv1, conv2, shortcut;
    bool has_shortcut = false;
  };
  struct Encoder {
    Linear q, k, v, merge, mlp1, mlp2;
    Tensor norm1_w, norm1_b, norm2_w, norm2_b;
    LayerKind kind;
  };

  Tensor fetch(const WeightLookup& weights, const std::string& name, const Shape& shape) {
    names_.push_back(name);
    return weights(name, shape);
  }
  Conv2d conv(const WeightLookup& w, const std::string& name, std::int64_t cin, std::int64_t cout,
              int k, int stride) {
    return Conv2d::from(fetch(w, name + ".weight", {cout, cin, k, k}), nullptr, stride, k / 2,
                        name);
  }
  /// conv + BatchNorm2d (PyTorch Sequential(conv, bn): names .0 and .1), folded.
  Conv2d conv_bn(const WeightLookup& w, const std::string& name, std::int64_t cin,
                 std::int64_t cout, int k, int stride) {
    Conv2d c = conv(w, name + ".0", cin, cout, k, stride);
    const std::string bn = name + ".1";
    fold_batch_norm(c, fetch(w, bn + ".weight", {cout}), fetch(w, bn + ".bias", {cout}),
                    fetch(w, bn + ".running_mean", {cout}), fetch(w, bn + ".running_var", {cout}),
                    1e-5f, bn);
    return c;
  }
  Linear linear_layer(const WeightLookup& w, const std::string& name, std::int64_t in,
                      std::int64_t out, bool bias) {
    Tensor b = bias ? fetch(w, name + ".bias", {out}) : Tensor();
    return Linear::from(fetch(w, name + ".weight", {out, in}), bias ? &b : nullptr, name);
  }
  Block block(const WeightLookup& w, const std::string& name, std::int64_t cin, std::int64_t cout,
              int stride) {
    Block b;
    b.conv1 = conv_bn(w, name + ".conv1", cin, cout, 3, stride);
    b.conv2 = conv_bn(w, name + ".conv2", cout, cout, 3, 1);
    b.has_shortcut = stride != 1 || cin != cout;
    if (b.has_shortcut) b.shortcut = conv_bn(w, name + ".shortcut", cin, cout, 1, stride);
    return b;
  }
  std::vector<Encoder> encoders(const WeightLookup& w, const std::string& name, std::int64_t dim,
                                const std::vector<LayerKind>& kinds) {
    std::vector<Encoder> layers;
    for (std::size_t i = 0; i < kinds.size(); ++i) {
      const std::string p = name + ".layers." + std::to_string(i);
      Encoder e;
      e.kind = kinds[i];
      e.q = linear_layer(w, p + ".q", dim, dim, false);
      e.k = linear_layer(w, p + ".k", dim, dim, false);
      e.v = linear_layer(w, p + ".v", dim, dim, false);
      e.merge = linear_layer(w, p + ".merge", dim, dim, false);
      e.mlp1 = linear_layer(w, p + ".mlp.0", 2 * dim, 2 * dim, false);
      e.mlp2 = linear_layer(w, p + ".mlp.2", 2 * dim, dim, false);
      e.norm1_w = fetch(w, p + ".norm1.weight", {dim});
      e.norm1_b = fetch(w, p + ".norm1.bias", {dim});
      e.norm2_w = fetch(w, p + ".norm2.weight", {dim});
      e.norm2_b = fetch(w, p + ".norm2.bias", {dim});
      layers.push_back(std::move(e));
    }
    return layers;
  }

  void load(const WeightLookup& w) {
    const auto [w1, w2, w3] = config_.widths;
    stem_ = conv_bn(w, "backbone.stem", 1, w1, 7, 2);
    const std::int64_t stages[3][2] = {{w1, w1}, {w1, w2}, {w2, w3}};
    for (int s = 0; s < 3; ++s) {
      const std::string name = "backbone.layer" + std::to_string(s + 1);
      layers_[s][0] = block(w, name + ".0", stages[s][0], stages[s][1], s == 0 ? 1 : 2);
      layers_[s][1] = block(w, name + ".1", stages[s][1], stages[s][1], 1);
    }
    out3_ = conv(w, "backbone.out3", w3, w3, 1, 1);
    out2_ = conv(w, "backbone.out2", w2, w3, 1, 1);
    out2_refine_a_ = conv_bn(w, "backbone.out2_refine.0", w3, w3, 3, 1);
    out2_refine_b_ = conv(w, "backbone.out2_refine.2", w3, w2, 3, 1);
    out1_ = conv(w, "backbone.out1", w1, w2, 1, 1);
    out1_refine_a_ = conv_bn(w, "backbone.out1_refine.0", w2, w2, 3, 1);
    out1_refine_b_ = conv(w, "backbone.out1_refine.2", w2, w1, 3, 1);
    if (config_.film) {
      film_table_ = fetch(w, "film.embedding.weight", {config_.film_classes, config_.film_dim});
      film1_ = linear_layer(w, "film.mlp.0", config_.film_dim, config_.film_dim, true);
      film2_ = linear_layer(w, "film.mlp.2", config_.film_dim, 2 * w3, true);
    }
    coarse_ = encoders(w, "coarse", w3, config_.coarse_layers);
    down_proj_ = linear_layer(w, "down_proj", w3, w1, true);
    merge_feat_ = linear_layer(w, "merge_feat", 2 * w1, w1, true);
    fine_ = encoders(w, "fine", w1, config_.fine_layers);
    if (config_.anchor) anchor_ = linear_layer(w, "anchor", w1, 1, true);
  }

  Tensor run_block(const Tensor& x, const Block& b) const {
    const Tensor y = conv2d(x, b.conv1, Activation::relu);
    if (!b.has_shortcut) return conv2d(y, b.conv2, Activation::relu, &x);
    const Tensor shortcut = conv2d(x, b.shortcut);
    return conv2d(y, b.conv2, Activation::relu, &shortcut);
  }

  /// images [2, 1, H, W] -> coarse [2, C3, H/8, W/8] and fine [2, C1, H/2, W/2].
  void backbone(const Tensor& images, Tensor& coarse, Tensor& fine) const {
    const Tensor stem = conv2d(images, stem_, Activation::relu);
    const Tensor x1 = run_block(run_block(stem, layers_[0][0]), layers_[0][1]);
    const Tensor x2 = run_block(run_block(x1, layers_[1][0]), layers_[1][1]);
    const Tensor x3 = run_block(run_block(x2, layers_[2][0]), layers_[2][1]);
    coarse = conv2d(x3, out3_);
    Tensor up = upsample_bilinear(coarse, x2.dim(2), x2.dim(3));
    Tensor f2 = conv2d(conv2d(x2, out2_, Activation::none, &up), out2_refine_a_, Activation::relu);
    f2 = conv2d(f2, out2_refine_b_);
    up = upsample_bilinear(f2, x1.dim(2), x1.dim(3));
    fine = conv2d(conv2d(x1, out1_, Activation::none, &up), out1_refine_a_, Activation::relu);
    fine = conv2d(fine, out1_refine_b_);
  }

  /// Adds the sine encoding, applies FiLM, and returns tokens [1, L, C] of image `n`.
  Tensor coarse_tokens(const Tensor& coarse, std::int64_t n, int view_class,
                       const Tensor& encoding) const {
    const std::int64_t c = coarse.dim(1), l = coarse.dim(2) * coarse.dim(3);
    std::vector<float> gamma(static_cast<std::size_t>(c), 0.0f), beta(gamma);
    if (config_.film) {
      const Tensor e =
          embedding(film_table_, view_class, "view class").reshaped({1, config_.film_dim});
      const Tensor gb = linear(linear(e, film1_, true), film2_);
      for (std::int64_t i = 0; i < c; ++i) {
        gamma[static_cast<std::size_t>(i)] = gb[i];
        beta[static_cast<std::size_t>(i)] = gb[c + i];
      }
    }
    Tensor tokens({1, l, c});
    const float* src = coarse.data() + n * c * l;
    for (std::int64_t ch = 0; ch < c; ++ch) {
      const float scale = 1.0f + gamma[static_cast<std::size_t>(ch)];
      const float shift = beta[static_cast<std::size_t>(ch)];
      for (std::int64_t p = 0; p < l; ++p) {
        const float f = src[ch * l + p] + encoding[ch * l + p];
        tokens[p * c + ch] = config_.film ? scale * f + shift : f;
      }
    }
    return tokens;
  }

  Tensor encode(const Encoder& e, const Tensor& x, const Tensor& source, int heads) const {
    Tensor message =
        linear_attention(linear(x, e.q), linear(source, e.k), linear(source, e.v), heads);
    message = linear(message, e.merge);
    layer_norm_inplace(message, e.norm1_w, e.norm1_b);
    // mlp(cat[x, message]) without the concatenation: the first layer's weight [2C, 2C] is
    // [W_x | W_m], so h = x W_x^T + message W_m^T.
    const std::int64_t c = x.dim(-1), rows = x.numel() / c, c2 = 2 * c;
    Shape hidden_shape = x.shape();
    hidden_shape.back() = c2;
    Tensor hidden(hidden_shape);
    parallel_for(0, (rows + 255) / 256, [&](std::int64_t task) {
      const std::int64_t r0 = task * 256, n = std::min<std::int64_t>(256, rows - r0);
      float* h = hidden.data() + r0 * c2;
      gemm(x.data() + r0 * c, c, e.mlp1.weight.data(), c2, h, c2, n, c2, c, true, false);
      gemm(message.data() + r0 * c, c, e.mlp1.weight.data() + c, c2, h, c2, n, c2, c, true, true);
      relu_inplace(h, n * c2);
    });
    Tensor out = linear(hidden, e.mlp2);
    layer_norm_inplace(out, e.norm2_w, e.norm2_b);
    add_inplace(out, x);
    return out;
  }

  void transform(const std::vector<Encoder>& layers, int heads, Tensor& f0, Tensor& f1) const {
    for (const Encoder& e : layers) {
      if (e.kind == LayerKind::self_attention) {
        Tensor a = encode(e, f0, f0, heads);
        f1 = encode(e, f1, f1, heads);
        f0 = std::move(a);
      } else {  // image 0 first, then image 1 against the updated image 0 (as LoFTR)
        f0 = encode(e, f0, f1, heads);
        f1 = encode(e, f1, f0, heads);
      }
    }
  }

  MatcherConfig config_;
  std::vector<std::string> names_;
  Conv2d stem_;
  Block layers_[3][2];
  Conv2d out3_, out2_, out2_refine_a_, out2_refine_b_, out1_, out1_refine_a_, out1_refine_b_;
  Tensor film_table_;
  Linear film1_, film2_, down_proj_, merge_feat_, anchor_;
  std::vector<Encoder> coarse_, fine_;
};

inline MatcherOutput Matcher::match(const Tensor& image0, const Tensor& image1, int class0,
                                    int class1, bool keep_confidence) const {
  image0.expect_rank(4, "matcher image 0");
  GIMM_CHECK(image0.dim(0) == 1 && image0.dim(1) == 1,
             "matcher: image 0 must be [1, 1, H, W], got " << shape_string(image0.shape()));
  image1.expect_shape(image0.shape(), "matcher image 1 (must match image 0)");
  const std::int64_t h = image0.dim(2), w = image0.dim(3);
  GIMM_CHECK(h >= 8 && w >= 8 && h % 8 == 0 && w % 8 == 0,
             "matcher: image size " << w << "x" << h << " must be positive multiples of 8");
  for (int cls : {class0, class1})
    GIMM_CHECK(cls >= 0 && cls < config_.film_classes,
               "matcher: view class " << cls << " outside [0, " << config_.film_classes << ")");

  Tensor images({2, 1, h, w});
  std::copy(image0.data(), image0.data() + h * w, images.data());
  std::copy(image1.data(), image1.data() + h * w, images.data() + h * w);
  Tensor coarse, fine;
  backbone(images, coarse, fine);

  MatcherOutput out;
  const std::int64_t hc = coarse.dim(2), wc = coarse.dim(3), c = coarse.dim(1), l = hc * wc;
  out.coarse_rows = hc;
  out.coarse_cols = wc;
  const Tensor encoding = sine_encoding(c, hc, wc);
  Tensor f0 = coarse_tokens(coarse, 0, class0, encoding);
  Tensor f1 = coarse_tokens(coarse, 1, class1, encoding);
  transform(coarse_, config_.coarse_heads, f0, f1);

  // Dual-softmax confidence, computed as the model does: each side scaled by 1/sqrt(C).
  const float sqrt_c = std::sqrt(float(c));
  Tensor s0 = f0, s1 = f1;
  for (float& v : s0.values()) v /= sqrt_c;
  for (float& v : s1.values()) v /= sqrt_c;
  Tensor conf({l, l});
  gemm_rows_parallel(s0.data(), c, s1.data(), c, conf.data(), l, l, l, c, true);
  dual_softmax_inplace(conf, config_.temperature);

  // Threshold, border removal, mutual nearest neighbours (row-major order, as torch.nonzero).
  const std::vector<char> keep = inside_border(hc, wc, config_.border);
  CoarseMatches coarse_matches = mutual_matches(conf, config_.threshold, keep, keep);
  out.i_ids = std::move(coarse_matches.i_ids);
  out.j_ids = std::move(coarse_matches.j_ids);
  out.coarse_confidence = std::move(coarse_matches.confidence);
  if (keep_confidence) out.confidence = std::move(conf);

  const std::int64_t m = static_cast<std::int64_t>(out.i_ids.size());
  if (m == 0) return out;

  // Fine windows centred on fine pixel (4r, 4c) of each matched coarse cell.
  const std::int64_t cf = fine.dim(1), hf = fine.dim(2), wf = fine.dim(3);
  const int win = config_.window, ww = win * win;
  std::vector<std::int64_t> r0(m), c0(m), r1(m), c1(m);
  for (std::int64_t k = 0; k < m; ++k) {
    r0[k] = out.i_ids[k] / wc * 4;
    c0[k] = out.i_ids[k] % wc * 4;
    r1[k] = out.j_ids[k] / wc * 4;
    c1[k] = out.j_ids[k] % wc * 4;
  }
  const Tensor win0 = extract_windows(fine.data(), cf, hf, wf, r0, c0, win);
  const Tensor win1 = extract_windows(fine.data() + cf * hf * wf, cf, hf, wf, r1, c1, win);

  // Coarse context: down_proj of the matched coarse tokens, concatenated to every window pixel.
  Tensor picked({2 * m, c});
  for (std::int64_t k = 0; k < m; ++k) {
    std::copy_n(f0.data() + out.i_ids[k] * c, c, picked.data() + k * c);
    std::copy_n(f1.data() + out.j_ids[k] * c, c, picked.data() + (m + k) * c);
  }
  const Tensor context = linear(picked, down_proj_);  // [2M, Cf]
  Tensor cat({2 * m, ww, 2 * cf});
  for (std::int64_t k = 0; k < 2 * m; ++k) {
    const Tensor& windows = k < m ? win0 : win1;
    const std::int64_t src = k < m ? k : k - m;
    for (int p = 0; p < ww; ++p) {
      float* dst = cat.data() + (k * ww + p) * 2 * cf;
      std::copy_n(windows.data() + (src * ww + p) * cf, cf, dst);
      std::copy_n(context.data() + k * cf, cf, dst + cf);
    }
  }
  const Tensor merged = linear(cat, merge_feat_);  // [2M, WW, Cf]
  Tensor g0({m, ww, cf}, std::vector<float>(merged.data(), merged.data() + m * ww * cf));
  Tensor g1({m, ww, cf},
            std::vector<float>(merged.data() + m * ww * cf, merged.data() + 2 * m * ww * cf));
  transform(fine_, config_.fine_heads, g0, g1);

  // The A point: the cell centre, or with the anchor the soft-argmax of its window scores, whose
  // score-weighted feature is the query; then the expectation of the query's similarity heat
  // map over image 1's window.
  const float sqrt_cf = std::sqrt(float(cf));
  const float reach = float(win / 2) * 2.0f;  // window half-width in image pixels
  std::vector<float> heat(static_cast<std::size_t>(ww));
  std::vector<float> query(static_cast<std::size_t>(cf));
  const Tensor scores = config_.anchor ? linear(g0, anchor_) : Tensor();  // [M, WW, 1]
  for (std::int64_t k = 0; k < m; ++k) {
    const float* window0 = g0.data() + k * ww * cf;
    Expectation e0;  // zero offset: the cell centre
    if (config_.anchor) {
      std::copy_n(scores.data() + k * ww, ww, heat.data());
      softmax_rows_inplace(heat.data(), 1, ww);
      e0 = soft_argmax(heat.data(), win);
      std::fill(query.begin(), query.end(), 0.0f);
      for (int p = 0; p < ww; ++p)
        for (std::int64_t ch = 0; ch < cf; ++ch)
          query[static_cast<std::size_t>(ch)] +=
              heat[static_cast<std::size_t>(p)] * window0[p * cf + ch];
    } else {
      std::copy_n(window0 + (ww / 2) * cf, cf, query.data());
    }
    for (int p = 0; p < ww; ++p) {
      const float* other = g1.data() + (k * ww + p) * cf;
      float dot = 0.0f;
      for (std::int64_t ch = 0; ch < cf; ++ch)
        dot += query[static_cast<std::size_t>(ch)] * other[ch];
      heat[static_cast<std::size_t>(p)] = dot / sqrt_cf;
    }
    softmax_rows_inplace(heat.data(), 1, ww);
    const Expectation e = soft_argmax(heat.data(), win);
    const float u0 = float(out.i_ids[k] % wc * 8), v0 = float(out.i_ids[k] / wc * 8);
    const float u1 = float(out.j_ids[k] % wc * 8), v1 = float(out.j_ids[k] / wc * 8);
    out.points0.push_back({u0 + e0.x * reach, v0 + e0.y * reach});
    out.points1.push_back({u1 + e.x * reach, v1 + e.y * reach});
    out.fine_std.push_back(e.std);
  }
  return out;
}

}  // namespace gimm::nn
