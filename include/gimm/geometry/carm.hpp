#pragma once
/// The C-arm: clinical angles and distances -> Camera.
///
/// Conventions (DICOM X-ray angiography; tests/geometry/carm_test.cpp flips each one):
/// - World: patient LPS mm (+x patient left, +y posterior, +z head); isocentre at `isocenter`.
/// - primary_deg > 0 is LAO, < 0 RAO: a rotation about the head-foot (z) axis that moves the
///   source towards the patient's right. secondary_deg > 0 is cranial, < 0 caudal: the detector
///   tilts towards the head, the source towards the feet.
/// - Source direction from the isocentre, for primary a and secondary b:
///     s(a, b) = (-sin a cos b, cos a cos b, -sin b);  source = iso + SOD s;  view dir = -s.
///   At 0/0 (AP) the source is posterior, the detector anterior, and the image shows the
///   patient's left on the image's right and the head at the top (as viewed from the detector).
/// - Camera axes: M = Rz(a) Rx(-b) applied to the AP axes (x_cam = +x, y_cam = +z, z_cam = -y).
///
/// Defaults: SID 1000 mm, SOD 750 mm (magnification 4/3), 512 x 512 detector of 0.5 mm pixels:
/// a 256 mm detector, so the field of view at the isocentre is 192 mm (0.375 mm per pixel,
/// close to a CCTA voxel): an adult heart (about 120-140 mm across) fits with a margin for
/// its motion and for an off-centre isocentre. Principal point: the detector centre,
/// ((cols - 1) / 2, (rows - 1) / 2).
/// The orthographic model images the same isocentre field of view: its pixel size is
/// pixel_mm * SOD / SID, so both models agree at the isocentre plane.
///
/// The table (docs/conventions.md, "Table position"): the C-arm's isocentre is fixed in the
/// room and the table carries the patient, so moving the table by d moves the patient by d and
/// the isocentre, in patient coordinates, by -d. `table_mm` is this view's table position as the
/// system reports it (lateral, vertical, longitudinal) and `reference_table_mm` that of the
/// reference view, the one whose isocentre is `isocenter`. For a head-first supine patient the
/// table axes are the patient's
///   x <- lateral, y <- vertical, z <- longitudinal,
/// so view isocentre = isocenter - (d_lat, d_vert, d_long); feet-first supine turns x and z
/// round. Both the axes and the minus sign were fitted on eight real GE views of one phantom
/// (one rigid pose at 1.4-2.4 px with the minus, 33-181 px with a plus).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <optional>

#include "gimm/core/constants.hpp"
#include "gimm/core/error.hpp"
#include "gimm/geometry/camera.hpp"

namespace gimm {

/// How the patient lies on the table (DICOM PatientPosition, 0018,5100), for the table axes.
enum class PatientPosition { HFS, FFS };

inline const char* to_string(PatientPosition p) {
  return p == PatientPosition::HFS ? "HFS" : "FFS";
}

struct CArm {
  static constexpr double kMaxDistanceMm = 1e4;  ///< SID, SOD, pixel pitch: at most 10 m
  static constexpr double kMinPixelMm = 1e-3;    ///< 1 um
  static constexpr double kMaxPositionMm = 1e5;  ///< isocentre, table: within 100 m
  static constexpr double kMaxPrincipalPointPx = 1e6;
  double primary_deg = 0.0;    ///< +LAO / -RAO, degrees
  double secondary_deg = 0.0;  ///< +cranial / -caudal, degrees
  double sid_mm = 1000.0;      ///< source to detector
  double sod_mm = 750.0;       ///< source to isocentre
  int rows = 512;
  int cols = 512;
  double pixel_mm = 0.5;      ///< detector pixel pitch across columns (horizontal), mm
  double pixel_row_mm = 0.0;  ///< pitch down the rows when pixels are not square; 0: pixel_mm
  /// Principal point in pixels; the detector centre when unset.
  std::optional<Eigen::Vector2d> principal_point;
  Eigen::Vector3d isocenter = Eigen::Vector3d::Zero();  ///< world mm, at the reference table
  Eigen::Vector3d table_mm = Eigen::Vector3d::Zero();   ///< (lateral, vertical, longitudinal)
  Eigen::Vector3d reference_table_mm = Eigen::Vector3d::Zero();
  PatientPosition patient_position = PatientPosition::HFS;
  ProjectionModel model = ProjectionModel::perspective;

  /// Throws gimm::Error naming the bad field and value.
  void validate() const {
    GIMM_CHECK(std::isfinite(primary_deg) && std::abs(primary_deg) <= 180,
               "CArm: primary angle must be in [-180, 180] degrees, got " << primary_deg);
    GIMM_CHECK(std::isfinite(secondary_deg) && std::abs(secondary_deg) < 90,
               "CArm: secondary angle must be in (-90, 90) degrees, got " << secondary_deg);
    // Bounds far beyond any C-arm (10 m, 1 um pixels, 100 m of table) that keep the camera's K
    // and t within Camera's 1e9, so a mistyped value is refused here, naming it.
    GIMM_CHECK(std::isfinite(sod_mm) && sod_mm > 0 && sod_mm <= kMaxDistanceMm,
               "CArm: SOD must be in (0, " << kMaxDistanceMm << "] mm, got " << sod_mm);
    GIMM_CHECK(std::isfinite(sid_mm) && sid_mm > sod_mm && sid_mm <= kMaxDistanceMm,
               "CArm: SID must exceed SOD (" << sod_mm << " mm) and be at most " << kMaxDistanceMm
                                             << " mm, got " << sid_mm);
    GIMM_CHECK(rows > 0 && rows <= 16384 && cols > 0 && cols <= 16384,
               "CArm: detector size must be in [1, 16384], got " << rows << " x " << cols);
    GIMM_CHECK(std::isfinite(pixel_mm) && pixel_mm >= kMinPixelMm && pixel_mm <= kMaxDistanceMm,
               "CArm: pixel size must be in [" << kMinPixelMm << ", " << kMaxDistanceMm
                                               << "] mm, got " << pixel_mm);
    GIMM_CHECK(
        std::isfinite(pixel_row_mm) &&
            (pixel_row_mm == 0 || (pixel_row_mm >= kMinPixelMm && pixel_row_mm <= kMaxDistanceMm)),
        "CArm: row pixel size must be in [" << kMinPixelMm << ", " << kMaxDistanceMm
                                            << "] mm (0: square pixels), got " << pixel_row_mm);
    GIMM_CHECK(isocenter.allFinite() && isocenter.cwiseAbs().maxCoeff() <= kMaxPositionMm,
               "CArm: isocentre must be finite and within +-" << kMaxPositionMm << " mm, got "
                                                              << isocenter.transpose());
    GIMM_CHECK(table_mm.allFinite() && reference_table_mm.allFinite() &&
                   table_mm.cwiseAbs().maxCoeff() <= kMaxPositionMm &&
                   reference_table_mm.cwiseAbs().maxCoeff() <= kMaxPositionMm,
               "CArm: table positions must be finite and within +-"
                   << kMaxPositionMm << " mm, got " << table_mm.transpose() << " (reference "
                   << reference_table_mm.transpose() << ")");
    if (principal_point)
      GIMM_CHECK(principal_point->allFinite() &&
                     principal_point->cwiseAbs().maxCoeff() <= kMaxPrincipalPointPx,
                 "CArm: principal point must be finite and within +-"
                     << kMaxPrincipalPointPx << " px, got " << principal_point->transpose());
  }

  Eigen::Vector2d principal_point_or_centre() const {
    return principal_point.value_or(Eigen::Vector2d((cols - 1) / 2.0, (rows - 1) / 2.0));
  }

  /// World-to-camera rotation (rows: x_cam, y_cam, z_cam in world coordinates).
  Eigen::Matrix3d rotation() const {
    const Eigen::Matrix3d M =
        (Eigen::AngleAxisd(deg_to_rad(primary_deg), Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(-deg_to_rad(secondary_deg), Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    Eigen::Matrix3d ap_axes;  // columns: x_cam, y_cam, z_cam at AP
    ap_axes << 1, 0, 0,       //
        0, 0, -1,             //
        0, 1, 0;
    return (M * ap_axes).transpose();
  }

  double row_pixel_mm() const { return pixel_row_mm > 0 ? pixel_row_mm : pixel_mm; }

  /// The patient's move in patient mm caused by the table's move from the reference view (the
  /// patient rides on the table): the table's change with its axes turned into patient axes.
  Eigen::Vector3d table_shift() const {
    const Eigen::Vector3d d = table_mm - reference_table_mm;  // lateral, vertical, longitudinal
    const double turn = patient_position == PatientPosition::HFS ? 1.0 : -1.0;
    return {turn * d.x(), d.y(), turn * d.z()};
  }
  /// This view's isocentre in patient coordinates: the room's isocentre stays, the patient moved
  /// by table_shift(), so in the patient's frame the isocentre moved the other way.
  Eigen::Vector3d view_isocenter() const { return isocenter - table_shift(); }

  /// Unit vector from the isocentre to the source.
  Eigen::Vector3d source_direction() const { return -rotation().row(2).transpose(); }
  Eigen::Vector3d source_position() const { return view_isocenter() + sod_mm * source_direction(); }

  /// The camera of this C-arm pose.
  Camerad camera() const {
    validate();
    const Eigen::Matrix3d R = rotation();
    const Eigen::Vector2d c = principal_point_or_centre();
    // Pixels per unit tan (perspective) or per mm at the isocentre (orthographic), per axis.
    const auto focal = [&](double pitch) {
      return model == ProjectionModel::perspective ? sid_mm / pitch : sid_mm / (pitch * sod_mm);
    };
    Eigen::Matrix3d K;
    K << focal(pixel_mm), 0, c.x(),        //
        0, -focal(row_pixel_mm()), c.y(),  //
        0, 0, 1;
    const Eigen::Vector3d t = -R * source_position();
    return Camerad(model, K, R, t, rows, cols);
  }
};

}  // namespace gimm
