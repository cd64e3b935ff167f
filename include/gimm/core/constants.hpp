#pragma once
/// The one pi of gimm, and degree/radian conversion.

namespace gimm {

template <class Scalar>
inline constexpr Scalar kPiOf = Scalar(3.14159265358979323846L);
inline constexpr double kPi = kPiOf<double>;

constexpr double deg_to_rad(double deg) {
  return deg * kPi / 180.0;
}
constexpr double rad_to_deg(double rad) {
  return rad * 180.0 / kPi;
}

}  // namespace gimm
