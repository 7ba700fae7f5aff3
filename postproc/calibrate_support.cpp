// Shared pieces of the calibrate commands (see calibrate_support.hpp).
#include "calibrate_support.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::cli {
namespace {

bool glob(std::string_view p, std::string_view s) {
  if (p.empty()) return s.empty();
  if (p.front() == '*') return glob(p.substr(1), s) || (!s.empty() && glob(p, s.substr(1)));
  if (s.empty()) return false;
  return (p.front() == '?' || p.front() == s.front()) && glob(p.substr(1), s.substr(1));
}

}  // namespace

std::vector<int> match_parameters(const kin::Model& model, const std::vector<std::string>& patterns, std::string_view option) {
  std::vector<int> out;
  for (const std::string& pat : patterns) {
    bool any = false;
    for (std::size_t k = 0; k < model.parameters().size(); ++k)
      if (glob(pat, model.parameters()[k].name)) {
        out.push_back(static_cast<int>(k));
        any = true;
      }
    if (!any) {
      std::string names;
      for (const auto& p : model.parameters()) names += (names.empty() ? "" : " ") + p.name;
      throw Error(ExitCode::usage, fmt::format("{} {}: no parameter of this {} machine matches; its parameters are: {}", option,
                                               pat, model.kind(), names));
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace postproc::cli
