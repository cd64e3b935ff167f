#pragma once
/// The whole chest around the procedural heart, for C-arm views (PhantomSize::chest): what a
/// cardiac CT's crop leaves out and every angiogram shows (docs/phantom.md, "The chest").
///
///   spine    thoracic vertebrae T1-T12 and L1 at one level per 27 mm (Panjabi et al. 1991:
///            T1-T12 bodies 15-23 mm tall, discs 4-6 mm), each a body of cortex (1.2 mm) around
///            trabecular bone, widening downwards (radius 14 -> 19 mm), a disc below it, an
///            arch around the canal, a spinous process sloping down and two transverse
///            processes;
///   ribs     twelve pairs, each leaving its vertebra's transverse process and following the
///            chest wall, its posterior end highest and its anterior end about 2.5 levels lower
///            (the frontal radiograph's descending posterior arcs and rising anterior ones),
///            flat in section (8-13 mm tall, 6 mm thick, cortex 1.2 mm around marrow), ending
///            at the costal cartilage short of the sternum; ribs 11-12 float (posterior only);
///   sternum  manubrium, body and xiphoid, narrowing downwards; clavicles from the manubrium
///            to the shoulders;
///   lungs    down to the diaphragm's domes (the right dome higher, the heart resting on the
///            left), with a two-octave texture of 60 HU (vessels and airways below the voxel);
///   abdomen  liver under the right dome, a gastric air bubble under the left.
///
/// Everything is analytic in world mm (LPS), seeded by a stream of its own so that the heart
/// and the coronary tree of a seed are the same at every phantom size.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "gimm/anatomy/centerlines.hpp"
#include "gimm/core/rng.hpp"

namespace gimm {

/// The bone HU a chest is made of (the phantom's TissueHu draws them).
struct BoneHu {
  double cortex, trabecular, marrow;
};

namespace detail {

/// Smooth value noise in [-1, 1]: hashed values on a cubic lattice of `cell` mm, blended with
/// smoothstep weights; the same at a point on any thread.
inline double value_noise(const Eigen::Vector3d& p, double cell, std::uint64_t seed) {
  auto lattice = [seed](std::int64_t i, std::int64_t j, std::int64_t k) {
    std::uint64_t z = seed ^ (static_cast<std::uint64_t>(i) * 0x9e3779b97f4a7c15ull) ^
                      (static_cast<std::uint64_t>(j) * 0xc2b2ae3d27d4eb4full) ^
                      (static_cast<std::uint64_t>(k) * 0x165667b19e3779f9ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-52 - 1.0;
  };
  const Eigen::Vector3d q = p / cell;
  const Eigen::Vector3d f = q.array().floor();
  const Eigen::Vector3d t = q - f;
  const Eigen::Vector3d w = t.array() * t.array() * (3.0 - 2.0 * t.array());
  const auto i = static_cast<std::int64_t>(f.x()), j = static_cast<std::int64_t>(f.y()),
             k = static_cast<std::int64_t>(f.z());
  double v = 0;
  for (int c = 0; c < 8; ++c) {
    const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
    const double weight =
        (di ? w.x() : 1 - w.x()) * (dj ? w.y() : 1 - w.y()) * (dk ? w.z() : 1 - w.z());
    v += weight * lattice(i + di, j + dj, k + dk);
  }
  return v;
}

}  // namespace detail

/// The chest of one patient: the body's elliptic outline (shared with the phantom's heart
/// placement) and the seeded choices of the skeleton, lungs and abdomen.
class ChestModel {
 public:
  static constexpr double kLevelMm = 27.0;  ///< one vertebra and its disc
  static constexpr int kLevels = 13;        ///< T1-T12 and L1

  /// `centre`: x, y of the body axis; `body_a`, `body_b`: the outline's semi-axes (mm);
  /// `heart_bottom_z`: the lowest z of the ventricles (the left dome meets it).
  ChestModel(Eigen::Vector2d centre, double body_a, double body_b, double heart_bottom_z,
             BoneHu bone, Rng rng)
      : c_(centre), a_(body_a), b_(body_b), bone_(bone) {
    left_dome_ = heart_bottom_z + rng.uniform(-6, 2);
    right_dome_ = left_dome_ + rng.uniform(10, 22);
    t1_z_ = left_dome_ + rng.uniform(190, 215);  // T1's top: ~8 levels above the dome
    rib_drop_ = rng.uniform(28, 40);
    noise_seed_ = rng.next_u64();
  }

  double left_dome_z() const { return left_dome_; }
  double right_dome_z() const { return right_dome_; }
  double t1_top_z() const { return t1_z_; }

  /// HU at p inside the body outside the heart and great vessels.
  double hu(const Eigen::Vector3d& p) const {
    const double bx = (p.x() - c_.x()) / a_, by = (p.y() - c_.y()) / b_;
    const Bone bone = skeleton(p, bx, by);
    if (bone.cover >= 1) return bone.hu;
    const double soft = soft_tissue(p, bx * bx + by * by);
    return bone.cover <= 0 ? soft : bone.cover * bone.hu + (1 - bone.cover) * soft;
  }

 private:
  /// A bone's HU at p and how much of p's voxel it covers: 1 inside, 0 outside, a linear ramp
  /// over one voxel (1.6 mm) across its surface, so that bones thinner than a few voxels do
  /// not alias into dotted lines.
  struct Bone {
    double hu = 0, cover = 0;
  };
  static Bone bone_at(double signed_distance_mm, double hu) {
    return {hu, std::clamp(0.5 - signed_distance_mm / 1.6, 0.0, 1.0)};
  }
  static Bone nearer(Bone a, Bone b) { return a.cover >= b.cover ? a : b; }

  double soft_tissue(const Eigen::Vector3d& p, double body) const {
    const double dome = diaphragm(p);
    if (p.z() > dome && in_lung(p)) return lung(p);
    if (p.z() <= dome) {
      if (in_gastric_bubble(p)) return -900;
      if (p.x() < c_.x() + 25 && body < 0.8 * 0.8) return 65;  // liver, arterial phase
    }
    if (body > 0.86 * 0.86 && body < 0.93 * 0.93) return 45;  // chest wall muscle
    if (body > 0.93 * 0.93) return -100;                      // subcutaneous fat
    return 35;                                                // mediastinum, abdomen
  }

  /// The diaphragm under p: two domes, curvature radius 110 mm, the right one higher.
  double diaphragm(const Eigen::Vector3d& p) const {
    const bool left = p.x() > c_.x();
    const double top = left ? left_dome_ : right_dome_;
    const double dx = p.x() - (c_.x() + (left ? 70 : -70)), dy = p.y() - (c_.y() - 5);
    return top - (dx * dx + dy * dy) / 220.0;
  }

  bool in_lung(const Eigen::Vector3d& p) const {
    const double side = p.x() > c_.x() ? 1 : -1;
    const double lx = (p.x() - (c_.x() + side * 76)) / 60, ly = (p.y() - (c_.y() + 8)) / 84;
    const double top = t1_z_ + 15, bottom = std::min(left_dome_, right_dome_) - 60;
    const double mid = 0.5 * (top + bottom), half = 0.5 * (top - bottom);
    const double lz = (p.z() - mid) / half;
    // Apices narrow: the lung's cross-section shrinks towards the top.
    const double narrowing = lz > 0.4 ? 1 + 1.5 * (lz - 0.4) : 1.0;
    return (lx * lx + ly * ly) * narrowing * narrowing + (lz > 0 ? lz * lz : 0) < 1;
  }

  double lung(const Eigen::Vector3d& p) const {
    return -845 + 45 * detail::value_noise(p, 11.0, noise_seed_) +
           25 * detail::value_noise(p, 4.5, noise_seed_ + 1);
  }

  bool in_gastric_bubble(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q(p.x() - (c_.x() + 62), p.y() - (c_.y() + 5), p.z() - (left_dome_ - 30));
    return (q.x() / 34) * (q.x() / 34) + (q.y() / 28) * (q.y() / 28) + (q.z() / 22) * (q.z() / 22) <
           1;
  }

  double bone_hu(double depth_below_surface) const {
    return depth_below_surface < 1.2 ? bone_.cortex : bone_.trabecular;
  }

  Bone skeleton(const Eigen::Vector3d& p, double bx, double by) const {
    return nearer(nearer(spine(p), sternum(p)), nearer(clavicles(p), ribs(p, bx, by)));
  }

  Bone spine(const Eigen::Vector3d& p) const {
    const double below_t1 = t1_z_ - p.z();
    if (below_t1 < -2 || below_t1 > kLevels * kLevelMm) return {};
    const int level = std::clamp(static_cast<int>(below_t1 / kLevelMm), 0, kLevels - 1);
    const double in_level = below_t1 - level * kLevelMm;  // 0 at the level's top
    const double level_top = t1_z_ - level * kLevelMm;
    const double radius = 14 + 5.0 * (level + in_level / kLevelMm) / kLevels;
    // The body's centre: far enough behind the descending aorta to leave a fat plane (fused,
    // bone and contrast would form one component and the recipe could not tell them apart).
    const double body_y = c_.y() + b_ - 30 - radius;
    const double r = std::hypot(p.x() - c_.x(), (p.y() - body_y) * 1.15);
    const double disc = 5.0;
    Bone body;
    if (in_level > kLevelMm - disc)
      body = bone_at(r - radius, 90);  // the disc below the body
    else {
      const double depth = std::min({radius - r, in_level, kLevelMm - disc - in_level});
      body = bone_at(-depth, bone_hu(depth));
    }
    // The arch around the canal, behind the body, and its processes (capsules).
    const Eigen::Vector3d canal(c_.x(), body_y + radius / 1.15 + 7, level_top - 10);
    const double dx = p.x() - canal.x(), dy = p.y() - canal.y(), dz = p.z() - canal.z();
    const double ring = std::hypot(dx, dy);
    if (ring < 6.5) return body;  // the spinal canal
    const double arch = std::max(ring - 13, std::abs(dz) - 7);
    const Eigen::Vector3d spinous_tip = canal + Eigen::Vector3d(0, 26, -24);
    const Eigen::Vector3d left_tip = canal + Eigen::Vector3d(30, 6, 2),
                          right_tip = canal + Eigen::Vector3d(-30, 6, 2);
    const double process = std::min({arch, detail::segment_distance(p, canal, spinous_tip) - 4.5,
                                     detail::segment_distance(p, canal, left_tip) - 5.5,
                                     detail::segment_distance(p, canal, right_tip) - 5.5});
    return nearer(body, bone_at(process, bone_hu(-process)));
  }

  Bone ribs(const Eigen::Vector3d& p, double bx, double by) const {
    const double theta = std::atan2(by, bx);  // +pi/2 posterior, -pi/2 anterior
    const double s = std::sin(theta), c = std::cos(theta);
    const double wall = std::hypot(bx - 0.86 * c, by - 0.86 * s) * std::min(a_, b_);
    if (wall > 6) return {};
    if (std::abs(c) < 0.28 && s < 0) return {};  // costal cartilage and sternum
    if (std::abs(c) < 0.2 && s > 0) return {};   // the spine's own column
    // The rib through p: posterior end at its level, the rest dropping along the wall.
    const double posterior_z = p.z() + rib_drop_ * (1 - s);
    const double k = std::round((t1_z_ - 16 - posterior_z) / kLevelMm);
    if (k < 0 || k > 11) return {};
    if (k >= 10 && s < 0.25) return {};  // ribs 11 and 12 float
    const double dz = posterior_z - (t1_z_ - 16 - k * kLevelMm);
    const double half_height = 4.0 + 2.5 * (1 - s) / 2;  // wider towards the front
    const double e = std::hypot(wall / 3.0, dz / half_height);
    const double inner = std::hypot(wall / 1.8, dz / (half_height - 1.2));
    return bone_at((e - 1) * 3.0, inner < 1 ? bone_.marrow : bone_.cortex);
  }

  Bone sternum(const Eigen::Vector3d& p) const {
    const double front = c_.y() - b_ * 0.93;  // behind the subcutaneous fat
    const double depth = p.y() - front;
    const double z = p.z() - (t1_z_ - 1.6 * kLevelMm);  // the jugular notch at T2-T3
    if (depth < -2 || depth > 15 || z > 2 || z < -192) return {};
    const double half_width = z > -50    ? 26 + 0.2 * z            // manubrium
                              : z > -165 ? 14                      // body
                                         : 14 - 0.4 * (-165 - z);  // xiphoid
    const double inside =
        std::min({half_width - std::abs(p.x() - c_.x()), depth, 13 - depth, -z, 190 + z});
    return bone_at(-inside, inside < 1.6 ? bone_.cortex : bone_.marrow);
  }

  Bone clavicles(const Eigen::Vector3d& p) const {
    const double side = p.x() > c_.x() ? 1 : -1;
    const double front = c_.y() - b_ * 0.8;
    const Eigen::Vector3d medial(c_.x() + side * 22, front, t1_z_ - 20);
    const Eigen::Vector3d middle(c_.x() + side * 80, front - 4, t1_z_ - 8);
    const Eigen::Vector3d lateral(c_.x() + side * 140, front + 40, t1_z_ + 4);
    const double d = std::min(detail::segment_distance(p, medial, middle),
                              detail::segment_distance(p, middle, lateral)) -
                     7;
    return bone_at(d, -d < 1.8 ? bone_.cortex : bone_.marrow);
  }

  Eigen::Vector2d c_;
  double a_, b_;
  BoneHu bone_;
  double left_dome_ = 0, right_dome_ = 0, t1_z_ = 0, rib_drop_ = 0;
  std::uint64_t noise_seed_ = 0;
};

}  // namespace gimm
