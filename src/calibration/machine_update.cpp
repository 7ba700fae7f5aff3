// Writing calibrated machine files (see machine_update.hpp).
#include "postproc/calibration/machine_update.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "src/gcode/text.hpp"

namespace postproc::cal {
namespace {

constexpr double kArcsecPerRad = 180.0 / kin::kPi * 3600.0;

std::string key(std::string_view name) {
  const bool bare = std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
  return bare ? std::string(name) : fmt::format("\"{}\"", name);
}

std::vector<std::string_view> lines_of(std::string_view text) {
  std::vector<std::string_view> out;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    out.push_back(text.substr(0, nl == std::string_view::npos ? text.size() : nl + 1));
    if (nl == std::string_view::npos) break;
    text.remove_prefix(nl + 1);
  }
  return out;
}

/// The table a header line opens ("errors" of "[errors]  # …", "axes.X" of "[axes.X]",
/// "serial.tool_side" of "[[serial.tool_side]]"), empty if the line is no table header. A line of
/// an array value ("  [-0.40, 2.03, 7.10],") is not: a header's name starts with a letter or a
/// quote and holds only key characters, and only a comment may follow it.
std::string_view header_name(std::string_view line) {
  line = gcode::text::trim(line);
  if (line.size() < 3 || line.front() != '[') return {};
  const bool array = line[1] == '[';
  const std::size_t open = array ? 2 : 1;
  const auto close = line.find(']', open);
  if (close == std::string_view::npos) return {};
  const std::string_view name = gcode::text::trim(line.substr(open, close - open));
  if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name.front())) || name.front() == '"')) return {};
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == '"' || c == ' ')) return {};
  std::string_view rest = line.substr(close + 1);
  if (array) {
    if (rest.empty() || rest.front() != ']') return {};
    rest.remove_prefix(1);
  }
  rest = gcode::text::trim(rest);
  if (!rest.empty() && rest.front() != '#') return {};
  return name;
}

bool is_header(std::string_view line) { return !header_name(line).empty(); }

}  // namespace

std::string errors_table_toml(const ErrorsTable& t) {
  const kin::Model& m = *t.model;
  std::string s = "[errors]\n";
  auto is_identified = [&](int k) { return std::find(t.identified.begin(), t.identified.end(), k) != t.identified.end(); };
  for (std::size_t k = 0; k < m.parameters().size(); ++k) {
    const kin::Parameter& p = m.parameters()[k];
    const double v = t.values[k];
    const bool ident = is_identified(static_cast<int>(k));
    if (!p.error && !ident) continue;
    const double dev = p.error ? v - p.nominal : v;
    if (p.error && dev == 0 && !ident) continue;
    const bool angle = p.unit == "rad";
    const bool ratio = p.unit == "ratio";
    if (p.error && ((angle && std::abs(dev) > 0.1) || (ratio && std::abs(dev) > 0.01) ||
                    (!angle && !ratio && std::abs(dev) > 50.0)))
      throw Error(ExitCode::refused,
                  fmt::format("{} came out as {:g} {} — beyond what a machine file accepts as an error ({}); the "
                              "measurements do not fit this machine (check units, joint columns, the nominal file)",
                              p.name, dev, p.unit, angle ? "0.1 rad" : ratio ? "0.01" : "50 mm"));
    std::string value;
    if (!p.error) value = fmt::format("\"{:.6f} {}\"", dev, angle ? "rad" : "mm");
    else if (angle) value = fmt::format("\"{:.4f} arcsec\"", dev * kArcsecPerRad);
    else if (ratio) value = fmt::format("\"{:.4f} um/m\"", dev * 1e6);
    else value = fmt::format("\"{:.4f} um\"", dev * 1000.0);
    std::string comment;
    const double sd = k < t.stddev.size() ? t.stddev[k] : std::nan("");
    if (ident && std::isfinite(sd))
      comment = angle   ? fmt::format("  # identified, ±{:.3g} arcsec (1σ)", sd * kArcsecPerRad)
                : ratio ? fmt::format("  # identified, ±{:.3g} um/m (1σ)", sd * 1e6)
                        : fmt::format("  # identified, ±{:.3g} um (1σ)", sd * 1000.0);
    else if (!ident)
      comment = "  # not identified: kept from the nominal file";
    s += fmt::format("{} = {}{}\n", key(p.name), value, comment);
  }
  for (const auto& [k, why] : t.held)
    s += fmt::format("# {}: not identifiable from these measurements, kept at its start value ({})\n",
                     m.parameters()[static_cast<std::size_t>(k)].name, why);
  return s;
}

std::string uncertainty_table_toml(const kin::Model& model, std::span<const int> identified,
                                   const Eigen::MatrixXd& covariance, std::span<const kin::JointVector> fitted_joints) {
  std::string s = "[uncertainty]\n# written by postproc calibrate: the covariance of the identified parameters (mm, rad) "
                  "and the joint range\n# of the fitted measurements (mm, deg); compensate --bounds-csv turns them into a "
                  "95 % bound per block\nparameters = [";
  for (std::size_t i = 0; i < identified.size(); ++i)
    s += fmt::format("{}\"{}\"", i == 0 ? "" : ", ", model.parameters()[static_cast<std::size_t>(identified[i])].name);
  s += "]\ncovariance = [\n";
  for (Eigen::Index i = 0; i < covariance.rows(); ++i) {
    s += "  [";
    for (Eigen::Index j = 0; j < covariance.cols(); ++j)
      s += fmt::format("{}{:.17g}", j == 0 ? "" : ", ", 0.5 * (covariance(i, j) + covariance(j, i)));
    s += "],\n";
  }
  s += "]\n";
  if (!fitted_joints.empty()) {
    s += "region = { ";
    for (int j = 0; j < model.joint_count(); ++j) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const kin::JointVector& q : fitted_joints) {
        lo = std::min(lo, q[j]);
        hi = std::max(hi, q[j]);
      }
      s += fmt::format("{}{} = [{:.6f}, {:.6f}]", j == 0 ? "" : ", ", key(model.joints()[static_cast<std::size_t>(j)].name), lo, hi);
    }
    s += " }\n";
  }
  return s;
}

std::string replace_toml_table(std::string_view text, std::string_view name, std::string_view section) {
  const auto lines = lines_of(text);
  std::string out;
  std::size_t i = 0;
  bool replaced = false;
  std::string sec(section);
  if (!sec.empty() && sec.back() != '\n') sec += '\n';
  while (i < lines.size()) {
    if (!replaced && header_name(lines[i]) == name) {
      out += sec;
      ++i;
      // The table runs to the next header; comment lines right before that header belong to it.
      std::size_t end = i;
      while (end < lines.size() && !is_header(lines[end])) ++end;
      std::size_t keep = end;
      while (keep > i && (gcode::text::trim(lines[keep - 1]).empty() || gcode::text::trim(lines[keep - 1]).front() == '#')) --keep;
      for (std::size_t k = keep; k < end; ++k) out += lines[k];
      i = end;
      replaced = true;
      continue;
    }
    out += lines[i++];
  }
  if (replaced) return out;
  // Insert before the first [axes.*] table, else at the end.
  out.clear();
  bool inserted = false;
  for (std::string_view l : lines) {
    if (!inserted && header_name(l).substr(0, 5) == "axes.") {
      out += sec + "\n";
      inserted = true;
    }
    out += l;
  }
  if (!inserted) {
    if (!out.empty() && out.back() != '\n') out += '\n';
    out += "\n" + sec;
  }
  return out;
}

std::string add_header_comment(std::string_view text, std::span<const std::string> lines) {
  const auto in = lines_of(text);
  std::string out, block;
  for (const std::string& l : lines) block += l.empty() ? std::string("#\n") : "# " + l + "\n";
  std::size_t i = 0;
  // Keep the file's own leading comment block, minus an earlier calibration block.
  bool skipping = false;
  while (i < in.size() && !gcode::text::trim(in[i]).empty() && gcode::text::trim(in[i]).front() == '#') {
    const std::string_view t = gcode::text::trim(in[i]);
    if (t.rfind("# calibrated by postproc", 0) == 0) skipping = true;
    else if (skipping && t.rfind("#   ", 0) != 0 && t != "#") skipping = false;
    if (!skipping) out += in[i];
    ++i;
  }
  out += block;
  for (; i < in.size(); ++i) out += in[i];
  return out;
}

}  // namespace postproc::cal
