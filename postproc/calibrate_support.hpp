#pragma once
// Shared pieces of the calibrate commands.
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "postproc/kinematics/model.hpp"

namespace postproc::cli {

/// Parameter indices whose names match any of `patterns` (* and ? wildcards). Throws
/// postproc::Error (usage) for a pattern that matches nothing, listing the parameters.
std::vector<int> match_parameters(const kin::Model& model, const std::vector<std::string>& patterns, std::string_view option);

void setup_calibrate_plan(CLI::App& calibrate, int& rc);
void setup_calibrate_simulate(CLI::App& calibrate, int& rc);

}  // namespace postproc::cli
