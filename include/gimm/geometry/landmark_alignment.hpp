#pragma once
/// A pair's second view moved onto landmarks the user marked in both images: the correction of
/// an unrecorded table (or patient) move between two runs, as 3D QCA systems make it from a
/// common reference point (a catheter tip, an ostium, a bifurcation).
///
/// The model: B's whole C-arm (source and detector) moved by a shift s in the world, the image
/// unchanged; that is what a table move of -s does to the patient's coordinates (docs/
/// conventions.md, "table"). A landmark pair is consistent when its two rays meet; the gap
/// between rays ray_A and ray_B + s along their common normal n = d_A x d_B is
/// n . (C_A - C_B - s), linear in s. The shift is the least-squares solution of
/// n_i . s = n_i . (C_A - C_B) over the landmarks, of least norm: one landmark fixes the
/// component along its n only (the rays' gap closed the shortest way), two fix both directions
/// across the baseline, and no number of landmarks fixes the component along the baseline
/// (moving B along it moves no epipolar plane): it stays 0.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/camera_error.hpp"
#include "gimm/geometry/epipolar.hpp"

namespace gimm {

struct LandmarkAlignment {
  Eigen::Vector3d shift_mm = Eigen::Vector3d::Zero();  ///< B's C-arm moved by this (world, mm)
  Camerad camera_b;                                    ///< B's camera so moved
  /// Each landmark's distance in B from the epipolar line of its A point, px: before and after.
  std::vector<double> distance_before_px, distance_after_px;
  int constrained_directions = 0;  ///< 1 or 2: directions of the shift the landmarks fix
};

/// B's camera moved so that each landmark pair (points_a[i] in A, points_b[i] in B, pixels)
/// lies on corresponding epipolar lines as nearly as the pairs allow (see the header comment).
/// Needs perspective cameras and at least one pair, each on the detector, not at an epipole.
inline LandmarkAlignment align_to_landmarks(const Camerad& camera_a, const Camerad& camera_b,
                                            const std::vector<Eigen::Vector2d>& points_a,
                                            const std::vector<Eigen::Vector2d>& points_b) {
  GIMM_CHECK(!camera_a.is_orthographic() && !camera_b.is_orthographic(),
             "landmark alignment: needs perspective cameras (an orthographic view has no source)");
  GIMM_CHECK(!points_a.empty() && points_a.size() == points_b.size(),
             "landmark alignment: needs one or more landmarks marked in both views, got "
                 << points_a.size() << " in A and " << points_b.size() << " in B");
  const Eigen::Vector3d gap = camera_a.center() - camera_b.center();
  const Eigen::Index n = static_cast<Eigen::Index>(points_a.size());
  // The normal equations N^T N s = N^T o, accumulated (3 x 3: no dynamic decomposition to compile).
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right_side = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector2d &a = points_a[i], &b = points_b[i];
    GIMM_CHECK(a.allFinite() && b.allFinite() && camera_a.on_detector(a) && camera_b.on_detector(b),
               "landmark alignment: landmark " << i + 1 << " (A " << a.transpose() << ", B "
                                               << b.transpose() << ") is not on both detectors");
    const Eigen::Vector3d normal =
        camera_a.ray(a.x(), a.y()).direction.cross(camera_b.ray(b.x(), b.y()).direction);
    GIMM_CHECK(normal.norm() > 1e-9, "landmark alignment: landmark "
                                         << i + 1
                                         << " lies along the baseline (its rays are parallel)");
    const Eigen::Vector3d unit = normal.normalized();
    normal_matrix += unit * unit.transpose();
    right_side += unit * unit.dot(gap);
  }
  // Least norm: directions the landmarks do not fix (eigenvalues of N^T N below 1e-6 of the
  // largest, singular values of N below 1e-3: the baseline's, and with one landmark a second)
  // stay unshifted.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(normal_matrix);
  LandmarkAlignment r;
  const double largest = eig.eigenvalues()(2);
  for (int k = 0; k < 3; ++k) {
    const double lambda = eig.eigenvalues()(k);
    if (!(lambda > 1e-6 * largest)) continue;
    const Eigen::Vector3d v = eig.eigenvectors().col(k);
    r.shift_mm += v * (v.dot(right_side) / lambda);
    ++r.constrained_directions;
  }
  r.camera_b =
      moved_camera(camera_b, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(), r.shift_mm);
  const Eigen::Matrix3d before = fundamental_from_cameras(camera_a, camera_b),
                        after = fundamental_from_cameras(camera_a, r.camera_b);
  for (Eigen::Index i = 0; i < n; ++i) {
    r.distance_before_px.push_back(
        point_line_distance(epipolar_line_b(before, points_a[i]), points_b[i]));
    r.distance_after_px.push_back(
        point_line_distance(epipolar_line_b(after, points_a[i]), points_b[i]));
  }
  return r;
}

}  // namespace gimm
