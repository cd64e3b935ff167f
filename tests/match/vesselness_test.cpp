// The fast paths of the vessel segmentation against their slow references: the float,
// vectorised vesselness (half resolution for wide scales) against the double-precision kernels,
// the vectorised Hessian eigenvalues against the 2x2 rule, the table-driven thinning against the
// plain Zhang-Suen rule, the two-thread geometric matcher against one thread, and working memory
// kept between calls against fresh memory.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>

#include "gimm/geometry/carm.hpp"
#include "gimm/match/geometric.hpp"

namespace {

/// A bright, shaded background with dark bars of radius 1.5, 2.5 and 4 px (horizontal, vertical,
/// diagonal), and mild noise from a fixed seed: the scales of coronary vessels at 256-512 px.
gimm::Image<float> bars_scene(int size) {
  gimm::Image<float> im(size, size);
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c) {
      float v = 0.8f + 0.1f * float(c) / float(size);
      if (std::abs(r - 30) <= 1.5) v -= 0.3f;                       // horizontal, radius 1.5
      if (std::abs(c - 90) <= 2.5) v -= 0.3f;                       // vertical, radius 2.5
      if (std::abs((r - c) / std::sqrt(2.0f)) <= 4.0f) v -= 0.25f;  // diagonal, radius 4
      im(r, c) = v + noise(rng);
    }
  return im;
}

double iou(const gimm::Image<std::uint8_t>& a, const gimm::Image<std::uint8_t>& b) {
  std::size_t both = 0, either = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    both += a.data()[i] && b.data()[i];
    either += a.data()[i] || b.data()[i];
  }
  return either ? double(both) / double(either) : 1.0;
}

/// The ridge of V across a bar: the row (or column) of the largest response on a line.
int ridge_row(const gimm::Image<float>& v, int col, int from, int to) {
  int best = from;
  for (int r = from; r <= to; ++r)
    if (v(r, col) > v(best, col)) best = r;
  return best;
}

/// Zhang-Suen as the rule reads, with bounds checks: the reference for the table-driven thin_mask.
gimm::Image<std::uint8_t> thin_reference(gimm::Image<std::uint8_t> m) {
  const auto lit = [&](int r, int c) { return m.contains(r, c) && m(r, c) != 0; };
  const std::array<std::array<int, 2>, 8> ring = {
      {{-1, 0}, {-1, 1}, {0, 1}, {1, 1}, {1, 0}, {1, -1}, {0, -1}, {-1, -1}}};
  for (bool changed = true; changed;) {
    changed = false;
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<std::array<int, 2>> remove;
      for (int r = 0; r < m.rows(); ++r)
        for (int c = 0; c < m.cols(); ++c) {
          if (!m(r, c)) continue;
          int count = 0, transitions = 0;
          for (int k = 0; k < 8; ++k) {
            const bool here = lit(r + ring[k][0], c + ring[k][1]);
            const bool next = lit(r + ring[(k + 1) % 8][0], c + ring[(k + 1) % 8][1]);
            count += here;
            transitions += !here && next;
          }
          if (count < 2 || count > 6 || transitions != 1) continue;
          const bool n = lit(r - 1, c), e = lit(r, c + 1), s = lit(r + 1, c), w = lit(r, c - 1);
          if (pass == 0 ? !(n && e && s) && !(e && s && w) : !(n && e && w) && !(n && s && w))
            remove.push_back({r, c});
        }
      for (const auto& p : remove) m(p[0], p[1]) = 0;
      changed = changed || !remove.empty();
    }
  }
  return m;
}

}  // namespace

TEST_CASE("Fast vesselness agrees with the exact-kernel reference", "[match][vesselness]") {
  const gimm::Image<float> im = bars_scene(128);
  gimm::SegmentationOptions fast, full_res, exact;
  fast.vesselness.scales_px = {1.0, 1.5, 2.0, 3.0};
  // The masks compare the two vesselness paths, on the image as it is and at the first
  // version's thresholds: at the default low threshold (0.002) the masks reach into this scene's
  // noise, where float rounding decides which noise pixel joins (IoU 0.56), and the background
  // removal drops most of the radius-4 bar, wider than the widest scale (IoU 0.78).
  fast.remove_background = false;
  fast.high = 0.15;
  fast.low = 0.05;
  full_res = exact = fast;
  full_res.vesselness.half_resolution_from_px = 0;
  exact.vesselness.exact_derivatives = true;
  const auto v_fast = gimm::vesselness(im, fast.vesselness);
  const auto v_full = gimm::vesselness(im, full_res.vesselness);
  const auto v_exact = gimm::vesselness(im, exact.vesselness);
  // The ridge of every bar is where the reference puts it (the half-resolution path within 1 px).
  for (int col : {20, 60, 110}) {
    const int ref = ridge_row(v_exact, col, 24, 36);
    CHECK(ref == 30);
    CHECK(ridge_row(v_full, col, 24, 36) == ref);
    CHECK(std::abs(ridge_row(v_fast, col, 24, 36) - ref) <= 1);
  }
  // The masks: measured IoU against the reference 1.0 at full resolution (the same kernels in
  // float) and 0.87 with the wide scales at half resolution.
  const auto m_exact = gimm::segment_vessels(im, exact);
  const double iou_full = iou(gimm::segment_vessels(im, full_res), m_exact);
  const double iou_fast = iou(gimm::segment_vessels(im, fast), m_exact);
  INFO("IoU full resolution " << iou_full << ", half resolution " << iou_fast);
  CHECK(iou_full >= 0.99);
  CHECK(iou_fast >= 0.85);
  // Bad settings are named.
  gimm::VesselnessOptions bad = fast.vesselness;
  bad.half_resolution_from_px = 0.6;
  CHECK_THROWS_WITH(gimm::vesselness(im, bad),
                    Catch::Contains("half_resolution_from_px") && Catch::Contains("0.6"));
}

TEST_CASE("Vectorised Hessian eigenvalues agree with the per-pixel 2x2 rule",
          "[match][vesselness]") {
  // Random Hessians, and the cases where the ordering by magnitude turns: trace +-0, a zero
  // root (isotropic), a zero off-diagonal.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  const int rows = 37, cols = 29;  // not a multiple of the packet size
  gimm::Image<float> xx(rows, cols), xy(rows, cols), yy(rows, cols);
  for (std::size_t i = 0; i < xx.size(); ++i) {
    xx.data()[i] = u(rng), xy.data()[i] = u(rng), yy.data()[i] = u(rng);
    if (i % 7 == 0) yy.data()[i] = -xx.data()[i];                    // trace 0
    if (i % 11 == 0) yy.data()[i] = xx.data()[i], xy.data()[i] = 0;  // isotropic
    if (i % 13 == 0) xx.data()[i] = -0.0f, yy.data()[i] = -0.0f, xy.data()[i] = u(rng);  // trace -0
    if (i % 17 == 0) xy.data()[i] = 0;
  }
  for (const double s : {1.0, 1.7}) {
    gimm::detail::ScaleEigen e;
    gimm::detail::scale_eigen(xx, xy, yy, s, e);
    const float n = static_cast<float>(s * s);
    int swapped = 0;
    for (std::size_t i = 0; i < xx.size(); ++i) {
      float l1 = 0, l2 = 0;
      gimm::detail::eigen_2x2(n * xx.data()[i], n * xy.data()[i], n * yy.data()[i], l1, l2);
      INFO("pixel " << i << " scale " << s);
      // Eigen's packet square root is a refined reciprocal estimate: a few ulp of the larger
      // magnitude, not bit-exact.
      const float ulps = 4 * std::numeric_limits<float>::epsilon() * std::abs(l2);
      CHECK(std::abs(e.l1.data()[i] - l1) <= ulps);
      CHECK(std::abs(e.l2.data()[i] - l2) <= ulps);
      CHECK(std::abs(e.l1.data()[i]) <= std::abs(e.l2.data()[i]));
      swapped += 0.5f * (n * xx.data()[i] + n * yy.data()[i]) < 0;
    }
    CHECK(swapped > 100);  // both orderings exercised
  }
}

TEST_CASE("Table-driven thinning equals the plain Zhang-Suen rule", "[match][vesselness]") {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 24; ++trial) {
    // Random thick strokes and blobs, some touching the border; the last four large and thick
    // (many sub-iterations, each changing a few pixels' neighbourhoods).
    const bool large = trial >= 20;
    const int rows = large ? 160 : 48, cols = large ? 150 : 40;
    gimm::Image<std::uint8_t> m(rows, cols, 0);
    std::uniform_int_distribution<int> row(-3, rows + 2), col(-3, cols + 2),
        half(0, large ? 12 : 4);
    for (int k = 0; k < 6; ++k) {
      const int r0 = row(rng), c0 = col(rng), r1 = row(rng), c1 = col(rng), h = half(rng);
      for (int s = 0; s <= 60; ++s) {
        const int r = r0 + (r1 - r0) * s / 60, c = c0 + (c1 - c0) * s / 60;
        for (int dr = -h; dr <= h; ++dr)
          for (int dc = -h; dc <= h; ++dc)
            if (m.contains(r + dr, c + dc)) m(r + dr, c + dc) = 1;
      }
    }
    const auto fast = gimm::thin_mask(m), ref = thin_reference(m);
    INFO("trial " << trial);
    CHECK(fast.storage() == ref.storage());
  }
}

namespace {

/// Two 3D curves drawn dark into two views of `size` px, so that the images are segmented and
/// matched; the images live in the returned struct, the pair points at them.
struct CurvesPair {
  gimm::Image<float> a, b;
  gimm::PairInput pair;
};

std::unique_ptr<CurvesPair> curves_pair(int size) {
  gimm::CArm ga, gb;
  ga.primary_deg = 30;
  gb.primary_deg = -30;
  gb.secondary_deg = 15;
  for (gimm::CArm* g : {&ga, &gb}) g->rows = g->cols = size, g->pixel_mm = 256.0 / size;
  const gimm::Camerad ca = ga.camera(), cb = gb.camera();
  const auto draw = [](const gimm::Camerad& cam) {
    gimm::Image<float> im(cam.rows(), cam.cols(), 0.9f);
    for (int k = 0; k <= 2000; ++k) {
      const double t = k / 2000.0;
      for (const Eigen::Vector3d& X :
           {Eigen::Vector3d(-40 + 80 * t, 15 * std::sin(3 * t), 10 * t - 20),
            Eigen::Vector3d(10 * std::cos(2 * t) - 20, -35 + 70 * t, 25 * t)}) {
        const Eigen::Vector2d p = cam.project(X).uv;
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc) {
            const int r = int(std::lround(p.y())) + dr, c = int(std::lround(p.x())) + dc;
            if (im.contains(r, c)) im(r, c) = 0.4f;
          }
      }
    }
    return im;
  };
  auto out = std::make_unique<CurvesPair>();
  out->a = draw(ca);
  out->b = draw(cb);
  out->pair.id = "curves-" + std::to_string(size);
  out->pair.image_a = &out->a;
  out->pair.image_b = &out->b;
  out->pair.camera_a = ca;
  out->pair.camera_b = cb;
  return out;
}

void check_same_matches(const std::vector<gimm::GeometricMatch>& m1,
                        const std::vector<gimm::GeometricMatch>& m2) {
  REQUIRE(m1.size() == m2.size());
  for (std::size_t i = 0; i < m1.size(); ++i) {
    CHECK(m1[i].a == m2[i].a);
    CHECK(m1[i].b == m2[i].b);
    CHECK(m1[i].confidence == m2[i].confidence);
  }
}

}  // namespace

TEST_CASE("Geometric matcher: two threads give the one-thread result", "[match][vesselness]") {
  const auto curves = curves_pair(128);
  gimm::GeometricOptions one, two;
  one.two_threads = false;
  two.two_threads = true;
  const auto m1 = gimm::GeometricMatcher(one).match_with_points(curves->pair);
  const auto m2 = gimm::GeometricMatcher(two).match_with_points(curves->pair);
  REQUIRE(m1.size() >= 10);
  check_same_matches(m1, m2);
}

TEST_CASE("Kept buffers give what fresh ones give, image after image", "[match][vesselness]") {
  // One set of buffers through images of other sizes and content, a flat one (no structure),
  // options that drop the half-resolution scales and the exact path: whatever an earlier call
  // left in them must not show in a later result.
  gimm::SegmentationBuffers seg;
  gimm::CenterlineBuffers lines;
  gimm::TopHatBuffers top_hat;
  gimm::SegmentationOptions halved, full_res, exact;
  full_res.vesselness.half_resolution_from_px = 0;
  exact.vesselness.exact_derivatives = true;
  halved.vesselness.scales_px = full_res.vesselness.scales_px =
      exact.vesselness.scales_px = {1.0, 2.0, 3.0};
  const gimm::Image<float> flat(40, 40, 0.5f);
  struct Step {
    const gimm::Image<float>* image;
    const gimm::SegmentationOptions* options;
  };
  const gimm::Image<float> big = bars_scene(160), small = bars_scene(96);
  std::size_t lit_steps = 0;
  for (const Step& step : {Step{&big, &halved}, Step{&small, &full_res}, Step{&flat, &halved},
                           Step{&big, &exact}, Step{&small, &halved}, Step{&big, &halved}}) {
    const gimm::Image<float>& im = *step.image;
    INFO(im.rows() << " px, exact " << step.options->vesselness.exact_derivatives << ", halving "
                   << step.options->vesselness.half_resolution_from_px);
    gimm::Image<std::uint8_t> mask(3, 3, 7);  // an output with stale pixels of another size
    gimm::segment_vessels(im, *step.options, mask, seg);
    const gimm::Image<std::uint8_t> fresh = gimm::segment_vessels(im, *step.options);
    REQUIRE(mask.rows() == fresh.rows());
    REQUIRE(mask.cols() == fresh.cols());
    CHECK(mask.storage() == fresh.storage());
    lit_steps += std::count(mask.storage().begin(), mask.storage().end(), 1) > 100;
    gimm::Image<float> v;
    gimm::vesselness(im, step.options->vesselness, v, seg.vesselness);
    CHECK(v.storage() == gimm::vesselness(im, step.options->vesselness).storage());
    gimm::Image<float> hat;
    gimm::black_top_hat(im, 7, hat, top_hat);
    CHECK(hat.storage() == gimm::black_top_hat(im, 7).storage());
    const gimm::CenterlineGraph2d kept = gimm::centerline_graph(fresh, 5, lines),
                                  again = gimm::centerline_graph(fresh);
    REQUIRE(kept.branches.size() == again.branches.size());
    for (std::size_t k = 0; k < kept.branches.size(); ++k) {
      CHECK(kept.branches[k].points == again.branches[k].points);
      CHECK(kept.branches[k].radius_px == again.branches[k].radius_px);
    }
  }
  CHECK(lit_steps == 5);  // all but the flat image found their bars
  // An output that is the input would be overwritten while it is read: refused.
  gimm::Image<float> same = small;
  CHECK_THROWS_WITH(gimm::vesselness(same, halved.vesselness, same, seg.vesselness),
                    Catch::Contains("must not be the input"));
  CHECK_THROWS_WITH(gimm::vessel_contrast(same, 7, same, seg.log_image, seg.top_hat),
                    Catch::Contains("must not be the input"));
  CHECK_THROWS_WITH(gimm::black_top_hat(same, 7, same, top_hat),
                    Catch::Contains("must not be the input"));
}

TEST_CASE("Geometric matcher: one matcher, pair after pair, gives a fresh matcher's result",
          "[match][vesselness]") {
  // The matcher keeps its views' buffers between pairs (ViewBufferPool): pairs of two sizes in
  // turn, each against a new matcher's answer; and copies of the matcher share the pool.
  const auto p128 = curves_pair(128), p96 = curves_pair(96);
  const gimm::GeometricMatcher kept;
  const gimm::GeometricMatcher copy = kept;
  // A pool outliving the matchers made on it, one per pair (as the Python binding does).
  const auto pool = std::make_shared<gimm::ViewBufferPool>();
  for (const CurvesPair* p : {p128.get(), p96.get(), p128.get(), p96.get()}) {
    INFO(p->pair.id);
    const auto fresh = gimm::GeometricMatcher().match_with_points(p->pair);
    REQUIRE(fresh.size() >= 5);
    check_same_matches(kept.match_with_points(p->pair), fresh);
    check_same_matches(copy.match_with_points(p->pair), fresh);
    check_same_matches(gimm::GeometricMatcher({}, pool).match_with_points(p->pair), fresh);
  }
  CHECK_THROWS_WITH(gimm::GeometricMatcher({}, nullptr), Catch::Contains("no buffer pool"));
}

TEST_CASE("Geometric matcher: run() is every matcher's result, with the cameras' F",
          "[match][vesselness]") {
  const auto curves = curves_pair(128);
  const gimm::GeometricMatcher matcher;
  const gimm::GeometricPairResult r = matcher.run_with_points(curves->pair);
  const auto points = matcher.match_with_points(curves->pair);
  check_same_matches(r.points, points);
  REQUIRE(r.matches.size() == points.size());
  CHECK(r.matches.pair == curves->pair.id);
  CHECK(r.candidates == static_cast<int>(points.size()));
  for (std::size_t k = 0; k < points.size(); ++k) {
    CHECK(r.matches.points_a[k] == points[k].a);
    CHECK(r.matches.points_b[k] == points[k].b);
    CHECK(r.matches.confidence[k] == points[k].confidence);
  }
  REQUIRE(r.matches.F);
  CHECK(r.fundamental_source() == "cameras");
  CHECK(r.matches.F->isApprox(
      gimm::fundamental_from_cameras(*curves->pair.camera_a, *curves->pair.camera_b)));
  // Through the interface: the same matches, the same F.
  const gimm::PairMatches via = static_cast<const gimm::PairMatcher&>(matcher).match(curves->pair);
  CHECK(via.points_b == r.matches.points_b);
  CHECK(via.F == r.matches.F);
}

TEST_CASE("Geometric matcher: a user's masks are followed instead of the images",
          "[match][vesselness]") {
  // Masks of the images' dark pixels give the segmented answer's neighbourhood; an empty mask
  // gives nothing although the images hold both curves; masks are ignored with use_masks off.
  auto curves = curves_pair(128);
  gimm::Image<std::uint8_t> ma(128, 128), mb(128, 128), empty(128, 128);
  for (int r = 0; r < 128; ++r)
    for (int c = 0; c < 128; ++c)
      ma(r, c) = curves->a(r, c) < 0.5f, mb(r, c) = curves->b(r, c) < 0.5f;
  gimm::PairInput with = curves->pair;
  with.mask_a = &ma;
  with.mask_b = &mb;
  CHECK(gimm::GeometricMatcher().match(with).size() >= 10);
  with.mask_a = &empty;
  with.mask_b = &empty;
  CHECK(gimm::GeometricMatcher().match(with).size() == 0);
  gimm::GeometricOptions segment;
  segment.use_masks = false;
  CHECK(gimm::GeometricMatcher(segment).match(with).size() ==
        gimm::GeometricMatcher(segment).match(curves->pair).size());
  // Masks only (no images) are enough when the matcher follows them.
  gimm::PairInput masks_only = with;
  masks_only.mask_a = &ma;
  masks_only.mask_b = &mb;
  masks_only.image_a = masks_only.image_b = nullptr;
  CHECK(gimm::GeometricMatcher().match(masks_only).size() >= 10);
  masks_only.mask_b = nullptr;
  CHECK_THROWS_WITH(gimm::GeometricMatcher().match(masks_only),
                    Catch::Contains("both vessel masks or neither"));
}
