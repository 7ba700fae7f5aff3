// Measurement files: CSV with unit-carrying column names (see csv.hpp).
#include "postproc/calibration/csv.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "postproc/io/input_file.hpp"
#include "src/gcode/text.hpp"
#include "src/machine/toml_fields.hpp"

namespace postproc::cal {
namespace {

using gcode::text::iequals;
using gcode::text::trim;

/// Splits one line into trimmed cells with their 1-based columns. False on an unterminated quote.
bool split(std::string_view line, std::vector<std::string>& cells, std::vector<std::uint32_t>& at) {
  cells.clear();
  at.clear();
  std::size_t i = 0;
  while (true) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    std::string cell;
    if (i < line.size() && line[i] == '"') {
      ++i;
      bool closed = false;
      while (i < line.size()) {
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            cell += '"';
            i += 2;
            continue;
          }
          closed = true;
          ++i;
          break;
        }
        cell += line[i++];
      }
      if (!closed) return false;
      while (i < line.size() && line[i] != ',') ++i;
    } else {
      const std::size_t comma = line.find(',', i);
      const std::size_t end = comma == std::string_view::npos ? line.size() : comma;
      cell = std::string(trim(line.substr(i, end - i)));
      i = end;
    }
    cells.push_back(std::move(cell));
    at.push_back(static_cast<std::uint32_t>(start + 1));
    if (i >= line.size()) break;
    ++i;  // the comma
  }
  return true;
}

CsvTable::Column column_of(std::string_view name, std::uint32_t at) {
  CsvTable::Column c;
  c.name = std::string(name);
  c.at = at;
  const auto open = name.find_first_of("[(");
  if (open != std::string_view::npos && (name.back() == ']' || name.back() == ')')) {
    c.base = std::string(trim(name.substr(0, open)));
    c.unit = std::string(trim(name.substr(open + 1, name.size() - open - 2)));
    return c;
  }
  const auto us = name.rfind('_');
  if (us != std::string_view::npos && us > 0 && unit_factor(name.substr(us + 1), Quantity::length).has_value()) {
    c.base = std::string(name.substr(0, us));
    c.unit = std::string(name.substr(us + 1));
  } else if (us != std::string_view::npos && us > 0 && unit_factor(name.substr(us + 1), Quantity::angle).has_value()) {
    c.base = std::string(name.substr(0, us));
    c.unit = std::string(name.substr(us + 1));
  } else {
    c.base = std::string(name);
  }
  return c;
}

std::string_view quantity_name(Quantity q) {
  switch (q) {
    case Quantity::length: return "length (mm, um, nm, m, in)";
    case Quantity::angle: return "angle (deg, rad, mrad, urad, arcsec, arcmin, um/m)";
    case Quantity::ratio: return "plain number (no unit)";
  }
  return "?";
}

std::string_view example_unit(Quantity q) { return q == Quantity::length ? "mm" : q == Quantity::angle ? "deg" : ""; }

}  // namespace

std::optional<double> unit_factor(std::string_view unit, Quantity q) {
  switch (q) {
    case Quantity::length: return machine::convert_unit(1.0, unit, machine::Dim::length);
    case Quantity::angle: return machine::convert_unit(1.0, unit, machine::Dim::angle);
    case Quantity::ratio: return unit.empty() ? std::optional<double>(1.0) : std::nullopt;
  }
  return std::nullopt;
}

std::optional<CsvTable> CsvTable::parse(std::string file, std::string_view text, gcode::DiagnosticSink& sink) {
  CsvTable t;
  t.file_ = std::move(file);
  t.sink_ = &sink;
  bool header = false, ok = true;
  std::uint64_t line_no = 0;
  std::string_view rest = text;
  if (rest.substr(0, 3) == "\xEF\xBB\xBF") rest.remove_prefix(3);
  // At most one row per line end (LF, or CR in CR-only files): one allocation for the rows.
  t.rows_.reserve(static_cast<std::size_t>(
      std::max(std::count(rest.begin(), rest.end(), '\n'), std::count(rest.begin(), rest.end(), '\r')) + 1));
  while (!rest.empty()) {
    // A line ends in LF, CR LF or a CR alone (old Mac files, some instrument exports).
    const auto eol = rest.find_first_of("\r\n");
    std::string_view line = rest.substr(0, eol);
    std::size_t next = eol == std::string_view::npos ? rest.size() : eol + 1;
    if (eol != std::string_view::npos && rest[eol] == '\r' && next < rest.size() && rest[next] == '\n') ++next;
    rest = rest.substr(next);
    ++line_no;
    const std::string_view content = trim(line);
    if (content.empty()) continue;
    if (content.front() == '#') {
      if (!header) t.comments_.emplace_back(trim(content.substr(1)));
      t.comment_lines_.push_back({line_no, std::string(line), std::string(trim(content.substr(1))), header});
      continue;
    }
    Row row;
    row.line = line_no;
    row.raw = std::string(line);
    // Every row has the header's cells: reserved exactly (a doubling growth holds 16 of 9).
    row.cells.reserve(t.columns_.size());
    row.at.reserve(t.columns_.size());
    if (!split(line, row.cells, row.at)) {
      t.header_ = row;
      gcode::Diagnostic d;
      d.code = std::string(codes::kCsvSyntax);
      d.file = t.file_;
      d.where = {line_no, 1};
      d.source_line = row.raw;
      d.message = "a quoted field is not closed; close it with '\"' (write \"\" for a quote inside a field)";
      sink.report(std::move(d));
      ok = false;
      continue;
    }
    if (!header) {
      header = true;
      t.header_ = row;
      for (std::size_t i = 0; i < row.cells.size(); ++i) {
        t.columns_.push_back(column_of(row.cells[i], row.at[i]));
        if (row.cells[i].empty()) {
          t.error(kHeader, static_cast<int>(i), codes::kCsvSyntax, "empty column name in the header; name every column, e.g. x_mm");
          ok = false;
        }
        for (std::size_t j = 0; j < i; ++j)
          if (t.columns_[j].base == t.columns_[i].base && !t.columns_[i].base.empty()) {
            t.error(kHeader, static_cast<int>(i), codes::kCsvColumns,
                    fmt::format("column '{}' repeats column {} ('{}'); remove one of them", row.cells[i], j + 1,
                                t.columns_[j].name));
            ok = false;
          }
      }
      continue;
    }
    t.rows_.push_back(std::move(row));
    const Row& r = t.rows_.back();
    if (r.cells.size() != t.columns_.size()) {
      t.error(t.rows_.size() - 1, -1, codes::kCsvSyntax,
              fmt::format("{} fields, but the header has {} columns; give every row one value per column",
                          r.cells.size(), t.columns_.size()));
      ok = false;
    }
  }
  if (!header) {
    gcode::Diagnostic d;
    d.code = std::string(codes::kCsvSyntax);
    d.file = t.file_;
    d.where = {std::max<std::uint64_t>(line_no, 1), 1};
    d.message = "no header line: a measurement file starts with column names such as X_mm,Y_mm,Z_mm,x_mm,y_mm,z_mm";
    sink.report(std::move(d));
    return std::nullopt;
  }
  t.used_.assign(t.columns_.size(), false);
  if (!ok) return std::nullopt;
  return t;
}

std::optional<CsvTable> CsvTable::load(const std::string& path, gcode::DiagnosticSink& sink) {
  return parse(path, io::read_file(path, "measurement file"), sink);
}

std::optional<std::string> CsvTable::meta(std::string_view key) const {
  for (const std::string& c : comments_) {
    const auto colon = c.find(':');
    if (colon == std::string::npos) continue;
    if (iequals(trim(std::string_view(c).substr(0, colon)), key)) return std::string(trim(std::string_view(c).substr(colon + 1)));
  }
  return std::nullopt;
}

namespace {

/// The key of a "key: value" comment: one word of letters, digits and '_' before the first ':';
/// empty for free text.
std::string_view header_key(std::string_view text) {
  const auto colon = text.find(':');
  if (colon == std::string_view::npos) return {};
  const std::string_view key = trim(text.substr(0, colon));
  if (key.empty() || !std::isalpha(static_cast<unsigned char>(key.front()))) return {};
  for (char c : key)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return {};
  return key;
}

}  // namespace

std::uint64_t CsvTable::meta_line(std::string_view key) const {
  for (const CommentLine& c : comment_lines_)
    if (!c.after_header && iequals(header_key(c.text), key)) return c.line;
  return 0;
}

void CsvTable::meta_error(std::string_view key, std::string_view code, std::string message) {
  for (const CommentLine& c : comment_lines_) {
    if (!iequals(header_key(c.text), key)) continue;
    gcode::Diagnostic d;
    d.code = std::string(code);
    d.file = file_;
    const auto hash = c.raw.find('#');
    d.where = {c.line, static_cast<std::uint32_t>(hash == std::string::npos ? 1 : hash + 1)};
    d.source_line = c.raw;
    d.length = static_cast<std::uint32_t>(std::max<std::size_t>(trim(c.raw).size(), 1));
    d.message = std::move(message);
    sink_->report(std::move(d));
    return;
  }
  error(kHeader, -1, code, std::move(message));
}

bool CsvTable::check_header_keys(std::span<const std::string_view> settings,
                                 std::span<const std::string_view> informational) {
  bool ok = true;
  std::string list;
  for (std::string_view k : settings) list += (list.empty() ? "" : ", ") + std::string(k);
  for (std::string_view k : informational) list += (list.empty() ? "" : ", ") + std::string(k);
  std::vector<std::string> seen;
  auto matches = [](std::string_view key, std::span<const std::string_view> keys) {
    return std::any_of(keys.begin(), keys.end(), [&](std::string_view k) {
      return k.ends_with('*') ? key.size() >= k.size() - 1 && iequals(key.substr(0, k.size() - 1), k.substr(0, k.size() - 1))
                              : iequals(key, k);
    });
  };
  for (const CommentLine& c : comment_lines_) {
    const std::string_view key = header_key(c.text);
    if (key.empty()) continue;
    const bool setting = matches(key, settings);
    const bool is_known = setting || matches(key, informational);
    auto report = [&](std::string message) {
      gcode::Diagnostic d;
      d.code = std::string(codes::kCsvHeaderKey);
      d.file = file_;
      const auto at = c.raw.find(key);
      d.where = {c.line, static_cast<std::uint32_t>(at == std::string::npos ? 1 : at + 1)};
      d.source_line = c.raw;
      d.length = static_cast<std::uint32_t>(key.size());
      d.message = std::move(message);
      sink_->report(std::move(d));
      ok = false;
    };
    if (!is_known) {
      report(fmt::format("'# {}:' is not a header key of this kind of file (known: {}); a setting postproc does "
                         "not know is never ignored: fix the key, or write free text without 'word:' at its start",
                         key, list));
      continue;
    }
    if (c.after_header) {
      report(fmt::format("'# {}:' comes after the column header line, where it is not read; move it above the header",
                         key));
      continue;
    }
    if (!setting) continue;
    std::string lower(key);
    for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (std::find(seen.begin(), seen.end(), lower) != seen.end()) {
      report(fmt::format("'# {}:' is given twice; keep one", key));
      continue;
    }
    seen.push_back(lower);
  }
  return ok;
}

int CsvTable::find(std::string_view base) const {
  for (std::size_t i = 0; i < columns_.size(); ++i)
    if (columns_[i].base == base) return static_cast<int>(i);
  return -1;
}

int CsvTable::quantity_column(std::string_view base, Quantity q, bool required, double& scale) {
  const int c = find(base);
  if (c < 0) {
    if (required) {
      gcode::Diagnostic d;
      d.code = std::string(codes::kCsvMissing);
      d.file = file_;
      d.where = {header_.line, 1};
      d.source_line = header_.raw;
      d.length = static_cast<std::uint32_t>(std::max<std::size_t>(header_.raw.size(), 1));
      d.message = fmt::format("no column '{}{}{}'; add it to the header (a {})", base,
                              q == Quantity::ratio ? "" : "_", example_unit(q), quantity_name(q));
      sink_->report(std::move(d));
    }
    return -1;
  }
  use(c);
  const Column& col = columns_[static_cast<std::size_t>(c)];
  const auto f = unit_factor(col.unit, q);
  if (!f) {
    error(kHeader, c, codes::kCsvUnit,
          col.unit.empty()
              ? fmt::format("column '{}' has no unit; name it {}_{} (a {})", col.name, col.base, example_unit(q), quantity_name(q))
              : fmt::format("column '{}': '{}' is not a unit of {}; rename it, e.g. {}_{}", col.name, col.unit,
                            quantity_name(q), col.base, example_unit(q)));
    return -1;
  }
  scale = *f;
  columns_[static_cast<std::size_t>(c)].quantity = q;
  columns_[static_cast<std::size_t>(c)].to_base = *f;
  return c;
}

std::optional<double> CsvTable::number(std::size_t row, int column, double scale) {
  const Row& r = rows_.at(row);
  const std::string& s = r.cells.at(static_cast<std::size_t>(column));
  double v = 0;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (b != e && *b == '+') ++b;
  const auto [ptr, ec] = std::from_chars(b, e, v);
  if (s.empty() || ec != std::errc() || ptr != e || !std::isfinite(v)) {
    error(row, column, codes::kCsvNumber,
          fmt::format("'{}' in column '{}' is not a number; write a decimal number such as 12.5", s,
                      columns_[static_cast<std::size_t>(column)].name));
    return std::nullopt;
  }
  const Column& col = columns_[static_cast<std::size_t>(column)];
  if (col.quantity) {
    // The envelope of anything a machine or an instrument could give; beyond it a value is a typo,
    // a unit mistake or a corrupted export, and a solver fed with it diverges without saying why.
    const double base = std::abs(v * col.to_base);
    const double limit = *col.quantity == Quantity::length  ? 1e6
                         : *col.quantity == Quantity::angle ? 1e4 * std::numbers::pi / 180
                                                            : 1e6;
    if (base > limit) {
      error(row, column, codes::kCsvRange,
            fmt::format("'{}' in column '{}' is beyond anything a machine or instrument could give (at most {}); "
                        "check the value and the column's unit",
                        s, col.name,
                        *col.quantity == Quantity::length  ? "1e6 mm"
                        : *col.quantity == Quantity::angle ? "1e4 deg"
                                                           : "1e6"));
      return std::nullopt;
    }
  }
  return v * scale;
}

void CsvTable::use(int column) {
  if (column >= 0 && static_cast<std::size_t>(column) < used_.size()) used_[static_cast<std::size_t>(column)] = true;
}

void CsvTable::report_unused() {
  std::string read;
  for (std::size_t i = 0; i < columns_.size(); ++i)
    if (used_[i]) read += (read.empty() ? "" : ", ") + columns_[i].name;
  for (std::size_t i = 0; i < columns_.size(); ++i)
    if (!used_[i])
      error(kHeader, static_cast<int>(i), codes::kCsvColumns,
            fmt::format("column '{}' is not read for this kind of measurement (read: {}); remove or rename it — "
                        "data is never ignored silently",
                        columns_[i].name, read.empty() ? "none" : read));
}

void CsvTable::error(std::size_t row, int column, std::string_view code, std::string message) {
  const Row& r = row == kHeader ? header_ : rows_.at(row);
  gcode::Diagnostic d;
  d.code = std::string(code);
  d.file = file_;
  d.source_line = r.raw;
  d.message = std::move(message);
  if (column >= 0 && static_cast<std::size_t>(column) < r.at.size()) {
    const std::size_t c = static_cast<std::size_t>(column);
    d.where = {r.line, r.at[c]};
    const std::string_view raw = r.raw;
    std::size_t end = raw.find(',', r.at[c] - 1);
    if (end == std::string_view::npos) end = raw.size();
    d.length = static_cast<std::uint32_t>(std::max<std::size_t>(1, trim(raw.substr(r.at[c] - 1, end - (r.at[c] - 1))).size()));
  } else {
    d.where = {r.line, 1};
    d.length = static_cast<std::uint32_t>(std::max<std::size_t>(r.raw.size(), 1));
  }
  sink_->report(std::move(d));
}

}  // namespace postproc::cal
