#pragma once
/// A procedural CCTA patient from a seed: the embedded default input (no data to download).
///
/// Everything is defined analytically in world mm (patient LPS: +x left, +y posterior,
/// +z superior) and then sampled on an ImageCAS-like grid:
///   thorax   elliptic body with a fat layer, two lungs, vertebral bodies with a canal, ribs,
///            sternum;
///   heart    ventricles as a half prolate ellipsoid (base at the atrioventricular groove, apex
///            anterior-inferior-left), LV and RV cavities, left and right atria, an epicardial
///            fat layer, aortic root, ascending and descending aorta, pulmonary trunk;
///   coronary LCA (LM, LAD, D1, D2, LCx, OM1, OM2) and RCA (RCA, AM, PDA, PLB) as tubes on the
///            epicardium in their grooves, radii tapering from ~2 mm to ~0.7 mm, with seeded
///            tortuosity. Dominance is right (PDA and PLB from the RCA) with probability 0.8,
///            left (from the LCx) 0.1, co-dominant 0.1, unless forced.
/// Blood in the aorta, left heart and coronaries carries contrast (lumen HU from the seed,
/// 350..450); the right heart slightly less; the superior vena cava holds undiluted contrast
/// (800..1400 HU). Bones have a cortex (1000..1300 HU) around trabecular bone or marrow
/// (160..320 HU), as in real CT, so the contrast recipe meets both cases that a threshold
/// confuses. Seeds vary heart size, position and orientation,
/// branch lengths and angles, dominance and lumen HU. Scanner noise is N(0, noise_hu),
/// drawn per voxel from a counter-based hash, so the volume is the same on any thread count.
///
/// The label is 1 where a voxel centre lies inside a coronary tube, plus every voxel holding
/// a centerline sample, so each system stays one 26-connected component even where the lumen
/// is thinner than a voxel (the small grid). The aorta is not labelled (as in ImageCAS).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/anatomy/chest.hpp"
#include "gimm/anatomy/coronary_branches.hpp"
#include "gimm/anatomy/lumen.hpp"
#include "gimm/anatomy/tortuosity.hpp"
#include "gimm/core/constants.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/core/volume.hpp"

namespace gimm {

/// small and imagecas: a cardiac CT's crop (205 x 205 x 128 mm) at two resolutions; chest: the
/// whole chest (anatomy/chest.hpp) on the small grid's voxels, for C-arm views that see past a
/// CT's crop. The heart and tree of a seed are the same at every size; small and imagecas keep
/// the thorax the shipped weights and recorded figures were made on.
enum class PhantomSize { small, imagecas, chest };
enum class Dominance { automatic, right, left, codominant };

inline PhantomSize parse_phantom_size(const std::string& s) {
  if (s == "small") return PhantomSize::small;
  if (s == "imagecas") return PhantomSize::imagecas;
  if (s == "chest") return PhantomSize::chest;
  GIMM_FAIL("phantom size must be small|imagecas|chest, got '" << s << "'");
}
inline const char* to_string(PhantomSize s) {
  return s == PhantomSize::imagecas ? "imagecas" : s == PhantomSize::chest ? "chest" : "small";
}
inline Dominance parse_dominance(const std::string& s) {
  if (s == "auto") return Dominance::automatic;
  if (s == "right") return Dominance::right;
  if (s == "left") return Dominance::left;
  if (s == "codominant") return Dominance::codominant;
  GIMM_FAIL("dominance must be auto|right|left|codominant, got '" << s << "'");
}
inline const char* to_string(Dominance d) {
  switch (d) {
    case Dominance::right:
      return "right";
    case Dominance::left:
      return "left";
    case Dominance::codominant:
      return "codominant";
    default:
      return "auto";
  }
}

/// The grid: ImageCAS-like is 512 x 512 x 256 at 0.4 x 0.4 x 0.5 mm (205 x 205 x 128 mm, a
/// cardiac field of view); small covers the same field at 128 x 128 x 64 (1.6 x 1.6 x 2 mm).
inline VolumeGeometry phantom_grid(PhantomSize size) {
  VolumeGeometry g;
  if (size == PhantomSize::chest) {
    // The body outline (165 x 118 mm semi-axes about x = -25, y = 25, moved up to 8 mm by the
    // seed) with 6 mm to spare, and 380 mm head to foot: a 30-degree tilted view through the
    // heart stays inside at the detector's edge.
    g.dims = {224, 165, 190};
    g.spacing = {1.6, 1.6, 2.0};
    g.origin = {-204 + 0.8, -107 + 0.8, -189};
    return g;
  }
  if (size == PhantomSize::imagecas) {
    g.dims = {512, 512, 256};
    g.spacing = {0.4, 0.4, 0.5};
  } else {
    g.dims = {128, 128, 64};
    g.spacing = {1.6, 1.6, 2.0};
  }
  for (int a = 0; a < 3; ++a) g.origin[a] = -0.5 * (g.dims[a] - 1) * g.spacing[a];
  return g;
}

struct PhantomOptions {
  std::uint64_t seed = 0;
  PhantomSize size = PhantomSize::small;
  Dominance dominance = Dominance::automatic;
  double noise_hu = 15.0;                 ///< scanner noise sigma; 0 for a noise-free volume
  TreeDetail tree = TreeDetail::classic;  ///< rich: side branches and Murray's-law calibres
  LumenOptions lumen;                     ///< stenoses and an irregular calibre (none: smooth)
  TortuosityOptions tortuosity;           ///< an irregular course (none: the classic sinusoids)
  std::optional<VolumeGeometry> grid;     ///< overrides `size` (any spacing, crop or direction)
};

/// The seeded anatomy (what the seed decided), recorded with the outputs.
struct PhantomAnatomy {
  Eigen::Vector3d base_centre;  ///< centre of the atrioventricular (base) plane, mm
  Eigen::Vector3d long_axis;    ///< unit, base -> apex
  Eigen::Vector3d anterior;     ///< unit, perpendicular to long_axis, phi = 0
  Eigen::Vector3d left;         ///< unit, long_axis x anterior flipped to point left, phi = 90
  double height_mm = 90;        ///< base to apex
  double radius_mm = 45;        ///< ventricular radius at the base
  Dominance dominance = Dominance::right;
  double lumen_hu = 400;
  Eigen::Vector2d body_axis{-25, 25};  ///< x, y of the chest's axis, mm
  /// The aorta's centreline from the root over the arch down the descending aorta (a
  /// polyline, mm), and its radius there: ascending 14 mm, descending 11.5 mm.
  std::vector<Eigen::Vector3d> aorta_path;
  std::vector<double> aorta_radius_mm;
  /// The chest's landmarks (PhantomSize::chest; NaN at the other sizes): the top of the left
  /// and right diaphragm domes and of T1, mm.
  double left_dome_z = std::numeric_limits<double>::quiet_NaN();
  double right_dome_z = std::numeric_limits<double>::quiet_NaN();
  double t1_top_z = std::numeric_limits<double>::quiet_NaN();
  std::vector<Stenosis> stenoses;  ///< as drawn (PhantomOptions::lumen)
};

struct Phantom {
  Volume<std::int16_t> hu;
  Volume<std::uint8_t> label;
  CenterlineTree centerlines;
  PhantomAnatomy anatomy;
  PhantomOptions options;
};

namespace detail {

/// An ellipsoid with centre and orthonormal axes (columns) and semi-axes.
struct Ellipsoid {
  Eigen::Vector3d centre;
  Eigen::Matrix3d axes;
  Eigen::Vector3d semi;
  /// < 1 inside, 1 on the surface.
  double level(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = axes.transpose() * (p - centre);
    return q.cwiseQuotient(semi).squaredNorm();
  }
  Ellipsoid inflated(double mm) const {
    return {centre, axes, semi + Eigen::Vector3d::Constant(mm)};
  }
};

/// A tube along a polyline with a constant radius.
struct Tube {
  std::vector<Eigen::Vector3d> points;
  double radius;
  double distance(const Eigen::Vector3d& p) const {
    double d = 1e30;
    for (std::size_t n = 1; n < points.size(); ++n)
      d = std::min(d, segment_distance(p, points[n - 1], points[n]));
    return d;
  }
};

/// Counter-based standard normal: the same value for (seed, index) on any thread.
inline double hashed_normal(std::uint64_t seed, std::uint64_t index) {
  auto mix = [](std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  };
  const std::uint64_t a = mix(seed ^ mix(2 * index)), b = mix(seed ^ mix(2 * index + 1));
  const double u1 = (static_cast<double>(a >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(b >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
}

/// The heart's surface frame: (h, phi) -> world, and back.
class HeartFrame {
 public:
  explicit HeartFrame(const PhantomAnatomy& a) : a_(a) {}
  double radius_at(double h) const {
    if (h <= 0) return a_.radius_mm;
    const double x = h / a_.height_mm;
    return a_.radius_mm * std::sqrt(std::max(0.0, 1.0 - x * x));
  }
  Eigen::Vector3d radial(double phi) const {
    return std::cos(phi) * a_.anterior + std::sin(phi) * a_.left;
  }
  /// A point `offset` mm outside the ventricular surface at height h and azimuth phi.
  Eigen::Vector3d surface(double h, double phi, double offset) const {
    return a_.base_centre + h * a_.long_axis + (radius_at(h) + offset) * radial(phi);
  }
  double height(const Eigen::Vector3d& p) const { return (p - a_.base_centre).dot(a_.long_axis); }
  double azimuth(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d d = p - a_.base_centre;
    return std::atan2(d.dot(a_.left), d.dot(a_.anterior));
  }
  /// Moves p along its radial line to `offset` mm outside the surface.
  Eigen::Vector3d onto_surface(const Eigen::Vector3d& p, double offset) const {
    return surface(height(p), azimuth(p), offset);
  }
  /// Scaled distance from the ventricular surface: < 1 inside.
  double ventricle_level(const Eigen::Vector3d& p, double inflate = 0) const {
    const Eigen::Vector3d d = p - a_.base_centre;
    const double h = d.dot(a_.long_axis);
    const double rho = (d - h * a_.long_axis).norm();
    if (h < -inflate) return 2.0;  // above the base plane: atria, not ventricles
    const double hh = std::max(h, 0.0) / (a_.height_mm + inflate);
    return hh * hh + (rho / (a_.radius_mm + inflate)) * (rho / (a_.radius_mm + inflate));
  }

 private:
  PhantomAnatomy a_;
};

constexpr double kDeg = kPi / 180.0;  // degrees to radians

/// The lowest z of the ventricles' surface (where the diaphragm meets the heart).
inline double ventricles_bottom_z(const HeartFrame& frame, const PhantomAnatomy& a) {
  double z = 1e30;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j < 36; ++j)
      z = std::min(z, frame.surface(a.height_mm * i / 20.0, j * 10 * kDeg, 0).z());
  return z;
}

/// Control points of a branch on the epicardium: (h in mm, phi in degrees).
struct SurfacePath {
  std::vector<std::array<double, 2>> control;
};

/// Catmull-Rom through the control points in (h, phi), mapped to 3D and resampled every
/// `step` mm, with seeded tortuosity: two sinusoids across the path, on the surface, from `rng`;
/// or, when `wander` is given and `tortuosity` is not none, the irregular displacement drawn from
/// `wander` instead (the sinusoids' numbers are drawn all the same, so `rng` moves on alike).
inline std::vector<Eigen::Vector3d> trace_surface_path(const HeartFrame& frame,
                                                       const SurfacePath& path, double offset,
                                                       double step, Rng& rng,
                                                       const TortuosityOptions& tortuosity = {},
                                                       Rng* wander = nullptr) {
  // Unwrap azimuths so each control point is within 180 degrees of the previous one (the
  // path never takes the long way round the heart).
  auto c = path.control;
  for (std::size_t s = 1; s < c.size(); ++s) {
    while (c[s][1] - c[s - 1][1] > 180) c[s][1] -= 360;
    while (c[s][1] - c[s - 1][1] < -180) c[s][1] += 360;
  }
  std::vector<Eigen::Vector3d> dense;
  const int per_segment = 64;
  for (std::size_t s = 0; s + 1 < c.size(); ++s) {
    const auto& p0 = c[s == 0 ? 0 : s - 1];
    const auto& p1 = c[s];
    const auto& p2 = c[s + 1];
    const auto& p3 = c[std::min(s + 2, c.size() - 1)];
    for (int n = 0; n < per_segment; ++n) {
      const double t = double(n) / per_segment, t2 = t * t, t3 = t2 * t;
      double v[2];
      for (int a = 0; a < 2; ++a)
        v[a] = 0.5 * (2 * p1[a] + (-p0[a] + p2[a]) * t +
                      (2 * p0[a] - 5 * p1[a] + 4 * p2[a] - p3[a]) * t2 +
                      (-p0[a] + 3 * p1[a] - 3 * p2[a] + p3[a]) * t3);
      dense.push_back(frame.surface(v[0], v[1] * kDeg, offset));
    }
  }
  dense.push_back(frame.surface(c.back()[0], c.back()[1] * kDeg, offset));
  // Resample by arc length.
  std::vector<Eigen::Vector3d> out{dense.front()};
  double carried = 0;
  for (std::size_t n = 1; n < dense.size(); ++n) {
    const Eigen::Vector3d a = dense[n - 1], b = dense[n];
    const double len = (b - a).norm();
    double at = step - carried;
    while (at <= len) {
      out.push_back(a + (b - a) * (at / len));
      at += step;
    }
    carried = len - (at - step);
  }
  if ((out.back() - dense.back()).norm() > 0.25 * step) out.push_back(dense.back());
  // Tortuosity: lateral displacement w(s) = sum A sin(2 pi s / L + phase), zero at the start.
  const double a1 = rng.uniform(0.6, 1.8), l1 = rng.uniform(14, 26), f1 = rng.uniform(0, 6.28);
  const double a2 = rng.uniform(0.3, 1.0), l2 = rng.uniform(6, 11), f2 = rng.uniform(0, 6.28);
  std::vector<double> arc(out.size(), 0.0);
  for (std::size_t n = 1; n < out.size(); ++n) arc[n] = arc[n - 1] + (out[n] - out[n - 1]).norm();
  std::vector<double> irregular;  // when drawn, it replaces the two sinusoids (drawn all the same)
  if (wander && !tortuosity.none()) {
    irregular = smooth_process(arc, tortuosity.correlation_mm, *wander);
    for (double& v : irregular) v *= tortuosity.sigma_mm;
  }
  std::vector<Eigen::Vector3d> bent(out.size());
  for (std::size_t n = 0; n < out.size(); ++n) {
    const double s = arc[n];
    const Eigen::Vector3d tangent =
        (out[std::min(n + 1, out.size() - 1)] - out[n == 0 ? 0 : n - 1]).normalized();
    const Eigen::Vector3d normal = frame.onto_surface(out[n], 10.0) - out[n];
    const Eigen::Vector3d across = tangent.cross(normal).normalized();
    const double ramp = std::min(1.0, s / 8.0);  // keep the junction with the parent in place
    const double w = ramp * (irregular.empty() ? a1 * std::sin(6.2832 * s / l1 + f1) +
                                                     a2 * std::sin(6.2832 * s / l2 + f2)
                                               : irregular[n]);
    bent[n] = frame.onto_surface(out[n] + w * across, offset);
  }
  return bent;
}

/// Straight resampling from a to b every `step` mm (both ends included).
inline std::vector<Eigen::Vector3d> straight_path(const Eigen::Vector3d& a,
                                                  const Eigen::Vector3d& b, double step) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i <= n; ++i) out.push_back(a + (b - a) * (double(i) / n));
  return out;
}

inline std::vector<double> taper(const std::vector<Eigen::Vector3d>& points, double r0, double r1) {
  double total = 0;
  for (std::size_t n = 1; n < points.size(); ++n) total += (points[n] - points[n - 1]).norm();
  std::vector<double> r(points.size());
  double s = 0;
  for (std::size_t n = 0; n < points.size(); ++n) {
    if (n > 0) s += (points[n] - points[n - 1]).norm();
    r[n] = r0 + (r1 - r0) * (total > 0 ? s / total : 0.0);
  }
  return r;
}

struct ThoraxLayout {
  Eigen::Vector2d chest_centre;  // x, y of the body axis
  double body_a = 165, body_b = 118;
  Ellipsoid lung_left, lung_right, la, ra, lv, rv;
  Tube aorta_ascending, aorta_descending, pulmonary, svc;
  Eigen::Vector3d aortic_root;
  double aortic_radius = 14;
};

/// HU of what a contrast recipe must tell apart, drawn from a stream of their own so that the
/// anatomy of every seed is unchanged: undiluted contrast arriving in the superior vena cava
/// (CCTA injects into an arm vein: 800-1400 HU, denser than any chest bone), cortical bone
/// (1000-1300 HU) and trabecular bone and rib marrow (160-320 HU: a threshold at 700 HU calls
/// it blood).
struct TissueHu {
  double svc, cortex, trabecular, marrow;
  explicit TissueHu(Rng rng)
      : svc(rng.uniform(800, 1400)),
        cortex(rng.uniform(1000, 1300)),
        trabecular(rng.uniform(160, 320)),
        marrow(rng.uniform(160, 260)) {}
};

}  // namespace detail

/// Builds the phantom for `options` (see the file comment).
inline Phantom make_phantom(const PhantomOptions& options) {
  using Eigen::Vector3d;
  using namespace detail;
  // HU are stored as int16: a sigma past its range saturates every voxel.
  GIMM_CHECK(std::isfinite(options.noise_hu) && options.noise_hu >= 0 && options.noise_hu <= 1000,
             "make_phantom: noise_hu must be in [0, 1000] HU, got " << options.noise_hu);
  options.lumen.validate();
  options.tortuosity.validate();
  Rng rng(options.seed);
  Phantom out;
  out.options = options;
  PhantomAnatomy& A = out.anatomy;

  // --- The seed's choices, always drawn in this order.
  A.height_mm = rng.uniform(82, 100);
  A.radius_mm = rng.uniform(40, 48);
  const double azimuth = rng.uniform(35, 55) * kDeg;    // long axis from anterior towards left
  const double elevation = rng.uniform(20, 40) * kDeg;  // long axis tilt towards the feet
  const double twist = rng.uniform(-15, 15) * kDeg;
  const Vector3d shift(rng.uniform(-8, 8), rng.uniform(-8, 8), rng.uniform(-6, 6));
  A.lumen_hu = rng.uniform(350, 450);
  const double u = rng.uniform(0, 1);
  A.dominance = options.dominance != Dominance::automatic ? options.dominance
                : u < 0.8                                 ? Dominance::right
                : u < 0.9                                 ? Dominance::left
                                                          : Dominance::codominant;
  A.long_axis = Vector3d(std::sin(azimuth) * std::cos(elevation),
                         -std::cos(azimuth) * std::cos(elevation), -std::sin(elevation));
  const Vector3d anterior =
      (Vector3d(0, -1, 0) - Vector3d(0, -1, 0).dot(A.long_axis) * A.long_axis).normalized();
  Vector3d left = A.long_axis.cross(anterior);
  if (left.x() < 0) left = -left;
  A.anterior = std::cos(twist) * anterior + std::sin(twist) * left;
  A.left = std::cos(twist) * left - std::sin(twist) * anterior;
  const Vector3d ventricle_centre = Vector3d(0, 0, -12) + shift;
  A.base_centre = ventricle_centre - 0.4 * A.height_mm * A.long_axis;
  const HeartFrame frame(A);
  const double H = A.height_mm, R = A.radius_mm;

  // --- Thorax and great vessels.
  ThoraxLayout T;
  T.chest_centre = Eigen::Vector2d(-25 + shift.x(), 25 + shift.y());
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const double cx = T.chest_centre.x(), cy = T.chest_centre.y();
  A.body_axis = T.chest_centre;
  T.lung_left = {Vector3d(cx + 78, cy + 5, 10), I, Vector3d(58, 80, 150)};
  T.lung_right = {Vector3d(cx - 78, cy + 5, 10), I, Vector3d(60, 82, 150)};
  Eigen::Matrix3d heart_axes;
  heart_axes << A.long_axis, A.anterior, A.left;
  auto in_heart = [&](double h, double phi_deg, double radial) -> Vector3d {
    return A.base_centre + h * A.long_axis + radial * frame.radial(phi_deg * kDeg);
  };
  T.lv = {in_heart(0.42 * H, 120, 0.28 * R), heart_axes, Vector3d(0.55 * H, 0.45 * R, 0.45 * R)};
  T.rv = {in_heart(0.3 * H, -60, 0.55 * R), heart_axes, Vector3d(0.5 * H, 0.4 * R, 0.5 * R)};
  T.la = {in_heart(-22, 165, 0.35 * R), heart_axes, Vector3d(20, 24, 27)};
  T.ra = {in_heart(-20, -110, 0.5 * R), heart_axes, Vector3d(22, 24, 22)};
  T.aortic_root = in_heart(-14, -15, 0.12 * R);
  const Vector3d arch_top = T.aortic_root + Vector3d(-8, -5, 55);
  const Vector3d arch_back = Vector3d(cx + 22, cy + 45, arch_top.z() + 8);
  T.aorta_ascending = {{T.aortic_root, T.aortic_root + Vector3d(-6, -6, 30), arch_top,
                        Vector3d(cx + 10, cy + 25, arch_top.z() + 14), arch_back},
                       T.aortic_radius};
  T.aorta_descending = {{arch_back, Vector3d(cx + 24, cy + 48, -200)}, 11.5};
  A.aorta_path = T.aorta_ascending.points;
  A.aorta_radius_mm.assign(A.aorta_path.size(), T.aortic_radius);
  A.aorta_path.push_back(T.aorta_descending.points.back());
  A.aorta_radius_mm.push_back(11.5);
  const Vector3d rvot = frame.surface(-4, -25, -12);
  T.pulmonary = {{rvot, rvot + Vector3d(6, 4, 30), rvot + Vector3d(12, 25, 45)}, 12};
  // The SVC comes down on the patient's right of the ascending aorta into the top of the RA.
  const Vector3d svc_inlet = T.ra.centre + Vector3d(-4, 6, 14);
  T.svc = {{svc_inlet, svc_inlet + Vector3d(-6, 4, 40), svc_inlet + Vector3d(-8, 6, 260)}, 9};

  // --- Coronary tree.
  const double off = 1.6, step = 0.5;
  // The irregular course's stream of its own: without it the tree is the classic one exactly.
  Rng wander = Rng(options.seed).fork(0x70a7);
  auto surface_path = [&](const SurfacePath& path, Rng& draws) {
    return trace_surface_path(frame, path, off, step, draws, options.tortuosity, &wander);
  };
  CenterlineTree& tree = out.centerlines;
  auto add_branch = [&](const std::string& name, CoronarySystem system, int parent,
                        std::vector<Vector3d> pts, double r0, double r1) {
    CenterlineBranch b;
    b.name = name;
    b.system = system;
    b.parent = parent;
    b.radii = taper(pts, r0, r1);
    b.points = std::move(pts);
    tree.branches.push_back(std::move(b));
    return static_cast<int>(tree.branches.size()) - 1;
  };
  // A child starts on its parent at fraction f of the parent's length and runs on the surface
  // through the given (h, phi) control points.
  auto child_drawn = [&](Rng& draws, int parent, double f, SurfacePath path) {
    const auto& pp = tree.branches[parent].points;
    const Vector3d start =
        pp[std::min(pp.size() - 1, static_cast<std::size_t>(f * (pp.size() - 1)))];
    path.control.insert(path.control.begin(), {frame.height(start), frame.azimuth(start) / kDeg});
    auto pts = surface_path(path, draws);
    pts.front() = start;
    return pts;
  };
  auto child = [&](int parent, double f, SurfacePath path) {
    return child_drawn(rng, parent, f, std::move(path));
  };
  auto jitter = [&](double spread) { return rng.uniform(-spread, spread); };
  const auto LCA = CoronarySystem::LCA, RCA = CoronarySystem::RCA;
  const bool right_dom = A.dominance == Dominance::right;
  const bool left_dom = A.dominance == Dominance::left;

  // LM: from the left coronary sinus to the LAD/LCx bifurcation.
  const Vector3d lm_ostium =
      T.aortic_root + T.aortic_radius * (0.2 * -A.long_axis + frame.radial(55 * kDeg)).normalized();
  const double bif_phi = 40 + jitter(6);
  const Vector3d bifurcation = frame.surface(-3, bif_phi * kDeg, off);
  const int lm = add_branch("LM", LCA, -1, straight_path(lm_ostium, bifurcation, step),
                            2.0 + jitter(0.15), 1.9);
  auto continue_from = [&](int parent, SurfacePath path) {
    const auto& pp = tree.branches[parent].points;
    path.control.insert(path.control.begin(),
                        {frame.height(pp.back()), frame.azimuth(pp.back()) / kDeg});
    auto pts = surface_path(path, rng);
    pts.front() = pp.back();
    return pts;
  };
  const double lad_end = 0.93 + jitter(0.05);
  const int lad = add_branch(
      "LAD", LCA, lm,
      continue_from(
          lm,
          {{{0.3 * H, 22 + jitter(5)}, {0.65 * H, 18 + jitter(6)}, {lad_end * H, 8 + jitter(8)}}}),
      1.8, 0.75);
  // Draws happen in statement order: function arguments have no defined evaluation order,
  // and the stream must not depend on the compiler.
  const double d1_at = 0.22 + jitter(0.05);
  add_branch("D1", LCA, lad,
             child(lad, d1_at, {{{0.45 * H, 55 + jitter(8)}, {0.7 * H, 70 + jitter(8)}}}), 1.2,
             0.7);
  const double d2_at = 0.5 + jitter(0.06);
  add_branch("D2", LCA, lad,
             child(lad, d2_at, {{{0.7 * H, 45 + jitter(6)}, {0.85 * H, 55 + jitter(8)}}}), 1.0,
             0.7);
  SurfacePath lcx_path{{{-1, 75 + jitter(6)}, {0, 115 + jitter(6)}, {1, 150 + jitter(5)}}};
  if (left_dom) lcx_path.control.push_back({2, 200});
  if (A.dominance == Dominance::codominant) lcx_path.control.push_back({2, 178});
  const int lcx =
      add_branch("LCx", LCA, lm, continue_from(lm, lcx_path), 1.7, left_dom ? 1.1 : 0.8);
  add_branch("OM1", LCA, lcx,
             child(lcx, left_dom ? 0.25 : 0.35,
                   {{{0.45 * H, 95 + jitter(8)}, {0.72 * H, 100 + jitter(8)}}}),
             1.2, 0.7);
  add_branch("OM2", LCA, lcx,
             child(lcx, left_dom ? 0.5 : 0.75,
                   {{{0.45 * H, 135 + jitter(8)}, {0.68 * H, 140 + jitter(8)}}}),
             1.1, 0.7);
  if (left_dom)
    add_branch("PDA", LCA, lcx,
               child(lcx, 1.0, {{{0.35 * H, 205 + jitter(4)}, {0.75 * H, 210 + jitter(5)}}}), 1.1,
               0.7);

  // RCA: from the right coronary sinus around the right AV groove.
  const Vector3d rca_ostium =
      T.aortic_root +
      T.aortic_radius * (0.2 * -A.long_axis + frame.radial(-45 * kDeg)).normalized();
  const Vector3d rca_groove = frame.surface(-2, (-25 + jitter(5)) * kDeg, off);
  std::vector<Vector3d> rca_pts = straight_path(rca_ostium, rca_groove, step);
  SurfacePath rca_path{{{-2, -25}, {-3, -75 + jitter(6)}, {-1, -115 + jitter(5)}}};
  if (!left_dom) rca_path.control.push_back({1, -150 + jitter(4)});
  if (right_dom) rca_path.control.push_back({2, -158});
  auto surface_part = surface_path(rca_path, rng);
  rca_pts.insert(rca_pts.end(), surface_part.begin() + 1, surface_part.end());
  const int rca = add_branch("RCA", RCA, -1, rca_pts, 2.0 + jitter(0.15), left_dom ? 1.0 : 1.1);
  add_branch("AM", RCA, rca,
             child(rca, left_dom ? 0.6 : 0.45,
                   {{{0.4 * H, -85 + jitter(8)}, {0.65 * H, -80 + jitter(8)}}}),
             1.0, 0.7);
  if (!left_dom)
    add_branch("PDA", RCA, rca,
               child(rca, 1.0, {{{0.35 * H, -153 + jitter(4)}, {0.75 * H, -148 + jitter(5)}}}), 1.1,
               0.7);
  if (right_dom)
    add_branch("PLB", RCA, rca, child(rca, 1.0, {{{4, -175}, {0.3 * H, 165 + jitter(5)}}}), 1.1,
               0.7);
  if (options.tree == TreeDetail::rich) {  // a stream of its own: the branches above stay
    Rng branch_rng = Rng(options.seed).fork(0xb7a9c4);
    auto trace = [&](int parent, double f, std::vector<std::array<double, 2>> control) {
      return child_drawn(branch_rng, parent, f, SurfacePath{std::move(control)});
    };
    auto inward = [&](const Vector3d& p) { return (p - frame.onto_surface(p, 10.0)).normalized(); };
    auto locate = [&](const Vector3d& p) {
      return std::array<double, 2>{frame.height(p), frame.azimuth(p) / kDeg};
    };
    add_side_branches(tree, trace, inward, locate, A.long_axis, H, left_dom, right_dom, step,
                      branch_rng);
  }
  // A stream of its own: the tree's course and everything else stay as they were.
  Rng lumen_rng = Rng(options.seed).fork(0x10e3);
  A.stenoses = shape_lumen(tree, options.lumen, lumen_rng);
  tree.validate("make_phantom");

  // --- Sample the grid.
  const VolumeGeometry grid = options.grid ? *options.grid : phantom_grid(options.size);
  grid.validate("make_phantom: grid");
  out.hu = Volume<std::int16_t>(grid);
  out.label = Volume<std::uint8_t>(grid, 0);
  const double lumen = A.lumen_hu, right_blood = A.lumen_hu - 80;
  const TissueHu tissue(Rng(options.seed).fork(0x7155e));
  const double rib_spacing = 26, rib_phase = rng.uniform(0, rib_spacing);
  std::optional<ChestModel> chest;
  if (options.size == PhantomSize::chest)
    chest.emplace(T.chest_centre, T.body_a, T.body_b, ventricles_bottom_z(frame, A),
                  BoneHu{tissue.cortex, tissue.trabecular, tissue.marrow},
                  Rng(options.seed).fork(0xc4e57));
  if (chest) {
    A.left_dome_z = chest->left_dome_z();
    A.right_dome_z = chest->right_dome_z();
    A.t1_top_z = chest->t1_top_z();
  }
  auto hu_at = [&](const Vector3d& p) -> double {
    const double bx = (p.x() - cx) / T.body_a, by = (p.y() - cy) / T.body_b;
    const double body = bx * bx + by * by;
    if (body > 1) return -1000;
    // Heart and great vessels.
    if (T.aorta_ascending.distance(p) < T.aortic_radius || T.aorta_descending.distance(p) < 11.5)
      return lumen;
    if (T.pulmonary.distance(p) < T.pulmonary.radius) return right_blood;
    if (T.svc.distance(p) < T.svc.radius) return tissue.svc;
    const double v = frame.ventricle_level(p);
    if (v < 1) {
      if (T.lv.level(p) < 1) return lumen;
      if (T.rv.level(p) < 1 && frame.ventricle_level(p, -4) < 1 && T.lv.inflated(7).level(p) > 1)
        return right_blood;
      return 110;  // enhanced myocardium
    }
    if (T.la.level(p) < 1) return lumen;
    if (T.ra.level(p) < 1) return right_blood;
    if (T.la.inflated(2.5).level(p) < 1 || T.ra.inflated(2.5).level(p) < 1) return 100;
    if (frame.ventricle_level(p, 4) < 1) return -80;  // epicardial fat, where the coronaries run
    if (chest) return chest->hu(p);
    // Skeleton.
    const double sx = p.x() - cx, sy = p.y() - (cy + 80);
    const double spine = std::hypot(sx, sy);
    if (spine < 6) return 20;                                                 // spinal canal
    if (spine < 19) return spine > 16.5 ? tissue.cortex : tissue.trabecular;  // vertebral body
    const double sternum_x = 14 - std::abs(p.x() - cx);
    const double sternum_y = std::min(p.y() - (cy - T.body_b + 12), cy - T.body_b + 24 - p.y());
    if (sternum_x > 0 && sternum_y > 0)  // sternum: 2 mm of cortex around marrow
      return std::min(sternum_x, sternum_y) < 2 ? tissue.cortex : tissue.marrow;
    // Ribs: rings inside the body wall, sloping down anteriorly, interrupted at the sternum.
    const double theta = std::atan2(by, bx);
    const double ring_x = 0.86 * std::cos(theta), ring_y = 0.86 * std::sin(theta);
    const double wall = std::hypot((bx - ring_x) * T.body_a, (by - ring_y) * T.body_b);
    if (wall < 7 && std::abs(std::cos(theta)) > 0.25 - 0.5 * (std::sin(theta) > 0)) {
      const double slope_z = p.z() + 22 * (1 - std::sin(theta));  // anterior ribs lower
      const double k = std::round((slope_z - rib_phase) / rib_spacing);
      const double dz = slope_z - rib_phase - k * rib_spacing;
      const double rib = std::hypot(wall, dz);
      if (rib < 5.5) return rib > 3.5 ? tissue.cortex : tissue.marrow;
    }
    if (T.lung_left.level(p) < 1 || T.lung_right.level(p) < 1) return -850;
    if (body > 0.86 * 0.86 && body < 0.93 * 0.93) return 45;  // chest wall muscle
    if (body > 0.93 * 0.93) return -100;                      // subcutaneous fat
    return 35;                                                // mediastinal soft tissue
  };
  const int nx = grid.dims[0], ny = grid.dims[1], nz = grid.dims[2];
  parallel_for_dynamic(0, nz, 1, [&](std::int64_t k) {
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        out.hu(i, j, static_cast<int>(k)) = static_cast<std::int16_t>(
            std::lround(hu_at(grid.index_to_world(Vector3d(i, j, static_cast<double>(k))))));
  });

  // Coronary lumen: capsules between consecutive samples, soft-edged over one voxel in HU,
  // binary (voxel centre inside) in the label.
  const double edge = grid.spacing.minCoeff();
  for (const auto& br : tree.branches) {
    for (std::size_t n = 0; n < br.points.size(); ++n) {
      const Vector3d idx = grid.world_to_index(br.points[n]);
      const int ci = int(std::lround(idx.x())), cj = int(std::lround(idx.y())),
                ck = int(std::lround(idx.z()));
      if (out.label.contains(ci, cj, ck)) out.label(ci, cj, ck) = 1;
      if (n == 0) continue;
      const Vector3d a = br.points[n - 1], b = br.points[n];
      const double rmax = std::max(br.radii[n - 1], br.radii[n]) + edge;
      Vector3d lo = grid.world_to_index(a.cwiseMin(b) - Vector3d::Constant(rmax));
      Vector3d hi = grid.world_to_index(a.cwiseMax(b) + Vector3d::Constant(rmax));
      for (int k = std::max(0, int(std::floor(lo.z())));
           k <= std::min(nz - 1, int(std::ceil(hi.z()))); ++k)
        for (int j = std::max(0, int(std::floor(lo.y())));
             j <= std::min(ny - 1, int(std::ceil(hi.y()))); ++j)
          for (int i = std::max(0, int(std::floor(lo.x())));
               i <= std::min(nx - 1, int(std::ceil(hi.x()))); ++i) {
            double t = 0;
            const double d = segment_distance(grid.index_to_world(Vector3d(i, j, k)), a, b, &t);
            const double r = br.radii[n - 1] + t * (br.radii[n] - br.radii[n - 1]);
            if (d < r) out.label(i, j, k) = 1;
            const double fill = std::clamp((r - d) / edge + 0.5, 0.0, 1.0);
            if (fill <= 0) continue;
            auto& voxel = out.hu(i, j, k);
            const double mixed = (1 - fill) * voxel + fill * lumen;
            if (mixed > voxel) voxel = static_cast<std::int16_t>(std::lround(mixed));
          }
    }
  }

  if (options.noise_hu > 0) {
    const std::uint64_t noise_seed = options.seed * 0x9e3779b97f4a7c15ull + 0x5eed;
    parallel_for(0, nz, [&](std::int64_t k) {
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          auto& voxel = out.hu(i, j, static_cast<int>(k));
          if (voxel <= -1000) continue;  // air outside the body stays clean
          const double noisy =
              voxel + options.noise_hu *
                          hashed_normal(noise_seed, out.hu.linear_index(i, j, static_cast<int>(k)));
          voxel = static_cast<std::int16_t>(std::lround(std::clamp(noisy, -1024.0, 3071.0)));
        }
    });
  }
  return out;
}

}  // namespace gimm
