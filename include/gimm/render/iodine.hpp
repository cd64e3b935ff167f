#pragma once
/// Iodine contrast physics: the linear attenuation of blood holding iodinated contrast at a
/// given iodine concentration, at the effective energy of the beam.
///
/// Source: J. H. Hubbell and S. M. Seltzer, Tables of X-Ray Mass Attenuation Coefficients and
/// Mass Energy-Absorption Coefficients (NIST Standard Reference Database 126, NISTIR 5632,
/// 1996, data last updated 2004): Table 3, iodine (Z = 53); Table 4, "Water, Liquid". The
/// tables below are the total mass attenuation mu/rho (coherent scattering included, cm^2/g)
/// at the tabulated energies from 30 to 100 keV, the iodine K edge (33.1694 keV) listed twice,
/// below and above. Between tabulated energies the coefficients are interpolated linearly in
/// log(mu/rho) against log(E), as NIST recommends for their tables (away from edges mu/rho is
/// close to a power law of E).
///
/// The mixture (Bragg additivity): mu = C (mu/rho)_I + rho_blood (mu/rho)_blood, with C the
/// iodine concentration in g/cm^3 (mgI/mL / 1000) and rho_blood = 1.06 g/cm^3 (ICRU-44 whole
/// blood). Why the contrast medium's carrier is counted as blood: iohexol 350 has density
/// 1.406 g/mL with 0.350 g/mL of iodine, so 1.056 g/mL of carrier (water and an organic C, H,
/// N, O molecule) - the mass per volume of blood, of a water-like composition. Blood's mu/rho is
/// taken as liquid water's: ICRU-44 whole blood is 75% O, 10% H, 11% C by mass with traces of
/// Fe, K, Cl, and its tabulated mu/rho lies within about 2% of water's from 30 to 100 keV, far
/// inside the spread of the effective energy itself.
///
/// Worked number (tests/render/angiogram_formation_test.cpp): 350 mgI/mL contrast diluted 1:1
/// by blood in the artery, C = 175 mgI/mL, at an effective energy of 55 keV:
/// (mu/rho)_I = 9.558 cm^2/g and (mu/rho)_water = 0.2157 cm^2/g (log-log between 50 and 60 keV),
/// mu = 0.175 x 9.558 + 1.06 x 0.2157 = 1.901 cm^-1 = 0.190 mm^-1 against blood's 0.0229 mm^-1:
/// a 3 mm lumen adds 0.50 to the line integral at its centre.
#include <array>
#include <cmath>
#include <cstddef>

#include "gimm/core/error.hpp"

namespace gimm {

/// The energies the tables cover (keV): effective energies outside are refused, not extrapolated.
constexpr double kIodineTableMinKev = 30.0;
constexpr double kIodineTableMaxKev = 100.0;
/// The iodine K edge (keV), NIST Table 3.
constexpr double kIodineKEdgeKev = 33.1694;
/// Whole blood (ICRU-44), g/cm^3.
constexpr double kBloodDensity = 1.06;

namespace detail {

struct MassAttenuationPoint {
  double kev;     ///< photon energy, keV
  double mu_rho;  ///< total mass attenuation coefficient, cm^2/g
};

/// NIST SRD 126, Table 3, iodine (Z = 53), 30-100 keV, the K edge twice (below, above).
constexpr std::array<MassAttenuationPoint, 8> kIodineMuRho = {{
    {30.0, 8.561},
    {33.1694, 6.553},  // K edge, below
    {33.1694, 35.82},  // K edge, above
    {40.0, 22.10},
    {50.0, 12.32},
    {60.0, 7.579},
    {80.0, 3.510},
    {100.0, 1.942},
}};

/// NIST SRD 126, Table 4, "Water, Liquid", 30-100 keV.
constexpr std::array<MassAttenuationPoint, 6> kWaterMuRho = {{
    {30.0, 0.3756},
    {40.0, 0.2683},
    {50.0, 0.2269},
    {60.0, 0.2059},
    {80.0, 0.1837},
    {100.0, 0.1707},
}};

/// Log-log interpolation in a table sorted by energy; a repeated energy is an absorption edge,
/// and an energy exactly on it takes the value above the edge.
template <std::size_t N>
double log_log_interpolate(const std::array<MassAttenuationPoint, N>& table, double kev,
                           const char* what) {
  GIMM_CHECK(std::isfinite(kev) && kev >= table.front().kev && kev <= table.back().kev,
             what << ": energy must be in [" << table.front().kev << ", " << table.back().kev
                  << "] keV (the tabulated range), got " << kev);
  for (std::size_t i = 0; i + 1 < N; ++i) {
    const MassAttenuationPoint a = table[i], b = table[i + 1];
    if (b.kev <= a.kev) continue;             // an edge: no width
    if (kev >= b.kev && i + 2 < N) continue;  // beyond this segment (the last one ends it)
    const double t = std::log(kev / a.kev) / std::log(b.kev / a.kev);
    return std::exp(std::log(a.mu_rho) + t * std::log(b.mu_rho / a.mu_rho));
  }
  return table.back().mu_rho;  // unreachable: the range was checked
}

}  // namespace detail

/// Mass attenuation coefficient of iodine, cm^2/g, at `kev` in [30, 100] keV.
inline double iodine_mass_attenuation(double kev) {
  return detail::log_log_interpolate(detail::kIodineMuRho, kev, "iodine mass attenuation");
}

/// Mass attenuation coefficient of liquid water (and of blood, see above), cm^2/g, at `kev`.
inline double water_mass_attenuation(double kev) {
  return detail::log_log_interpolate(detail::kWaterMuRho, kev, "water mass attenuation");
}

/// Linear attenuation of water (1 g/cm^3), mm^-1, at `kev`.
inline double water_mu_per_mm(double kev) {
  return water_mass_attenuation(kev) / 10.0;
}

/// Linear attenuation (mm^-1) of blood holding `iodine_mg_per_ml` mgI/mL (0 = native blood;
/// at most 400, above every marketed contrast medium) at the effective energy `kev`.
inline double iodinated_blood_mu_per_mm(double iodine_mg_per_ml, double kev) {
  GIMM_CHECK(
      std::isfinite(iodine_mg_per_ml) && iodine_mg_per_ml >= 0 && iodine_mg_per_ml <= 400,
      "iodinated blood: iodine concentration must be in [0, 400] mgI/mL, got " << iodine_mg_per_ml);
  const double per_cm = iodine_mg_per_ml / 1000.0 * iodine_mass_attenuation(kev) +
                        kBloodDensity * water_mass_attenuation(kev);
  return per_cm / 10.0;
}

/// Native blood, mm^-1, at `kev`.
inline double blood_mu_per_mm(double kev) {
  return iodinated_blood_mu_per_mm(0.0, kev);
}

/// The Hounsfield value that attenuation `mu_per_mm` has at `kev` (1000 (mu / mu_water - 1)):
/// how a contrast recipe written in HU (anatomy/attenuation.hpp, lumen_hu) can take an iodine
/// concentration. Note that gimm's HU -> mu uses the fixed mu_water 0.02 mm^-1.
inline double hu_equivalent(double mu_per_mm, double kev) {
  GIMM_CHECK(std::isfinite(mu_per_mm) && mu_per_mm >= 0,
             "hu_equivalent: attenuation must be finite and >= 0 mm^-1, got " << mu_per_mm);
  return 1000.0 * (mu_per_mm / water_mu_per_mm(kev) - 1.0);
}

/// The contrast of a selective injection: what the attenuation of the injected lumen is made
/// from. Defaults: 350 mgI/mL contrast (iohexol 350, iopamidol 370 are the usual cardiac
/// media) diluted about 1:1 by blood in the artery during the injection, at the effective
/// energy of a 70-90 kVp cardiac beam behind the patient.
struct IodineContrast {
  double iodine_mg_per_ml = 175;  ///< iodine in the lumen, mgI/mL, [0, 400]
  double effective_kev = 55;      ///< effective beam energy, keV, [30, 100] (the table's range)

  void validate() const {
    GIMM_CHECK(
        std::isfinite(iodine_mg_per_ml) && iodine_mg_per_ml >= 0 && iodine_mg_per_ml <= 400,
        "iodine contrast: iodine_mg_per_ml must be in [0, 400] mgI/mL, got " << iodine_mg_per_ml);
    GIMM_CHECK(std::isfinite(effective_kev) && effective_kev >= kIodineTableMinKev &&
                   effective_kev <= kIodineTableMaxKev,
               "iodine contrast: effective_kev must be in [" << kIodineTableMinKev << ", "
                                                             << kIodineTableMaxKev << "] keV, got "
                                                             << effective_kev);
  }
  /// The injected lumen, mm^-1.
  double lumen_mu_per_mm() const {
    validate();
    return iodinated_blood_mu_per_mm(iodine_mg_per_ml, effective_kev);
  }
  /// Native blood at this energy, mm^-1.
  double blood_mu_per_mm() const { return gimm::blood_mu_per_mm(effective_kev); }
  /// The lumen in HU at this energy: ContrastRecipe::lumen_hu for this injection (gimm's
  /// HU -> mu keeps the lumen-to-water ratio of this energy).
  double lumen_hu() const { return hu_equivalent(lumen_mu_per_mm(), effective_kev); }
};

}  // namespace gimm
