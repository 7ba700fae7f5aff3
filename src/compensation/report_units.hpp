#pragma once
// The units the compensation reports show their figures in (inside everything is mm and rad).

namespace postproc::comp {

inline constexpr double kUmPerMm = 1000.0;                   ///< µm per mm
inline constexpr double kArcsecPerRad = 206264.80624709636;  ///< arcsec per rad (180 / π × 3600)

}  // namespace postproc::comp
