#pragma once
/// @file
/// Writing a calibrated machine file: the nominal file's text with its `[errors]` table (and,
/// from a step gauge, its `[volumetric_map]` table) replaced and a header comment naming what
/// produced it. Everything else — comments, layout, other tables — is kept byte for byte, so the
/// result is a machine file every command takes as it is.

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/kinematics/model.hpp"

namespace postproc::cal {

struct ErrorsTable {
  const kin::Model* model = nullptr;  ///< parameter names, units, nominal values
  std::vector<double> values;         ///< every parameter (the identified model's values)
  std::vector<double> stddev;         ///< per parameter, NaN where not estimated (written as a comment)
  std::vector<int> identified;        ///< indices estimated (marked in the comments)
  /// Not identifiable from the data: index and the reason (the combination), written as comments.
  std::vector<std::pair<int, std::string>> held;
};

/// The `[errors]` table text: every error parameter whose value differs from its nominal one, as
/// a deviation ("12.3456 um", "1.2345 arcsec"), plus any non-error (geometry) parameter that was
/// identified, as an absolute value in mm / rad; comments give ±1σ and the held parameters.
/// Throws postproc::Error (refused) when an error is beyond what a machine file accepts
/// (50 mm, 0.1 rad), naming it.
[[nodiscard]] std::string errors_table_toml(const ErrorsTable& t);

/// The `[uncertainty]` table: the identified parameters' names, their covariance (mm, rad; full
/// precision) and the joint range the fitted measurements covered (`region`, mm / deg), which
/// `compensate --bounds-csv` turns into a 95 % bound per block.
[[nodiscard]] std::string uncertainty_table_toml(const kin::Model& model, std::span<const int> identified,
                                                 const Eigen::MatrixXd& covariance,
                                                 std::span<const kin::JointVector> fitted_joints);

/// Replaces the table `[name]` (its header line to the line before the next table header) in a
/// TOML text by `section` (which starts with its own header line); appends it before the first
/// `[axes.` table, or at the end, when the text has no such table.
[[nodiscard]] std::string replace_toml_table(std::string_view text, std::string_view name, std::string_view section);

/// Puts `lines` (each written as "# line") at the top of the text, after a leading '#' comment
/// block, and removes an earlier "# calibrated by postproc" block so re-calibration does not stack them.
[[nodiscard]] std::string add_header_comment(std::string_view text, std::span<const std::string> lines);

}  // namespace postproc::cal
