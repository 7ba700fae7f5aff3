#pragma once
/// @file
/// Measurement files: CSV with a header whose column names carry their unit ("x_mm", "B_deg",
/// "travel_um"), '#' comment lines, blank lines ignored. Every problem is a located diagnostic
/// (file:line:column, the offending text, what to do), codes PP-C001…PP-C006 (docs/measurements.md).

#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/diagnostic.hpp"

namespace postproc::cal {

/// Diagnostic codes of measurement files.
namespace codes {
inline constexpr std::string_view kCsvSyntax = "PP-C001";     ///< malformed CSV: field count, quotes, empty file
inline constexpr std::string_view kCsvMissing = "PP-C002";    ///< a required column is missing
inline constexpr std::string_view kCsvNumber = "PP-C003";     ///< a cell is not a finite number
inline constexpr std::string_view kCsvUnit = "PP-C004";       ///< a column's unit is missing, unknown or of another dimension
inline constexpr std::string_view kCsvRange = "PP-C005";      ///< non-physical value (zero vector, stem shorter than travel…)
inline constexpr std::string_view kCsvColumns = "PP-C006";    ///< unknown or duplicate column, columns that do not fit the machine
inline constexpr std::string_view kCsvHeaderKey = "PP-C007";  ///< unknown, misplaced or malformed '# key: value' header line
}  // namespace codes

/// Header keys every measurement file may carry as recorded text (never read as settings).
inline constexpr std::array<std::string_view, 9> kInformationalKeys = {
    "note", "comment", "description", "date", "operator", "instrument", "temperature", "noise", "source"};

/// Physical dimension of a column (the unit a value is returned in).
enum class Quantity {
  length,  ///< mm  (nm, um, µm, mm, cm, m, in)
  angle,   ///< rad (rad, mrad, urad, deg, arcmin, arcsec, um/m, mm/m)
  ratio,   ///< plain number (no unit suffix)
};

/// One parsed CSV file.
class CsvTable {
 public:
  struct Column {
    std::string name;   ///< as written in the header (trimmed)
    std::string base;   ///< name without the unit suffix ("x" of "x_mm")
    std::string unit;   ///< the suffix after the last '_' or inside [ ] / ( ); empty if none
    std::uint32_t at = 1;  ///< 1-based byte column in the header line
    /// Set once quantity_column() has read the column: its dimension and the factor of its unit
    /// to mm / rad, for the physical envelope number() checks.
    std::optional<Quantity> quantity;
    double to_base = 1;
  };
  struct Row {
    std::uint64_t line = 0;             ///< 1-based line in the file
    std::string raw;                    ///< the line as written (for caret display)
    std::vector<std::string> cells;     ///< trimmed, unquoted
    std::vector<std::uint32_t> at;      ///< 1-based byte column of each cell
  };

  /// Parses CSV text (lines end in LF, CR LF or CR alone). Reports PP-C001 for an empty file (no header), a row with another number of
  /// fields than the header, an unterminated quote; nullopt when any error was reported.
  [[nodiscard]] static std::optional<CsvTable> parse(std::string file, std::string_view text,
                                                     gcode::DiagnosticSink& sink);
  /// Reads and parses a file. Throws postproc::Error (no_input) when it cannot be read.
  [[nodiscard]] static std::optional<CsvTable> load(const std::string& path, gcode::DiagnosticSink& sink);

  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] const std::vector<Column>& columns() const { return columns_; }
  [[nodiscard]] const std::vector<Row>& rows() const { return rows_; }
  /// '#' comment lines before the header, without the '#', trimmed (e.g. "kind: poses").
  [[nodiscard]] const std::vector<std::string>& comments() const { return comments_; }
  /// Value of a "# key: value" header comment, if present.
  [[nodiscard]] std::optional<std::string> meta(std::string_view key) const;
  /// The 1-based line of the "# key: value" header comment, 0 when absent.
  [[nodiscard]] std::uint64_t meta_line(std::string_view key) const;

  /// Header keys: a '#' line "key: value" whose key is one word (letters, digits, '_') is a
  /// setting; any other '#' line is free text. Reports PP-C007, located, for a key that is not in
  /// `known` (a setting the reader does not know must not be ignored: "# frame: instrument" read
  /// as a comment fits misregistered data as if registered), for a key given twice and for a key
  /// after the column header. `settings` are read (each at most once); `informational` keys are
  /// recorded text (may repeat). Keys ending in '*' match by prefix. False on any error.
  bool check_header_keys(std::span<const std::string_view> settings, std::span<const std::string_view> informational);
  /// Reports an error at a header key's line (the whole line).
  void meta_error(std::string_view key, std::string_view code, std::string message);

  /// Index of the column whose base name equals `base` (case-sensitive: joint X, measured x), -1 if none.
  [[nodiscard]] int find(std::string_view base) const;
  /// A quantity column: finds `base`, checks its unit is one of q's (PP-C004) and returns the
  /// factor to mm / rad in `scale`. Missing and required: PP-C002. Returns -1 when absent/bad.
  int quantity_column(std::string_view base, Quantity q, bool required, double& scale);
  /// The number in a cell (times scale); PP-C003 at the cell when it is not a finite number, PP-C005
  /// when a quantity column's value is beyond anything a machine or an instrument could give (a
  /// length above 1e6 mm, an angle above 1e4°, a plain number above 1e6).
  std::optional<double> number(std::size_t row, int column, double scale = 1.0);
  /// Marks a column as read; report_unused() names the others (PP-C006).
  void use(int column);
  void report_unused();

  /// Reports an error at a cell (column -1: the whole row) or, with row = npos, at a header column.
  void error(std::size_t row, int column, std::string_view code, std::string message);
  static constexpr std::size_t kHeader = static_cast<std::size_t>(-1);
  [[nodiscard]] gcode::DiagnosticSink& sink() { return *sink_; }

 private:
  std::string file_;
  std::vector<Column> columns_;
  Row header_;
  std::vector<Row> rows_;
  std::vector<std::string> comments_;
  struct CommentLine {
    std::uint64_t line = 0;
    std::string raw;   ///< the line as written
    std::string text;  ///< without '#', trimmed
    bool after_header = false;
  };
  std::vector<CommentLine> comment_lines_;
  std::vector<bool> used_;
  gcode::DiagnosticSink* sink_ = nullptr;
};

/// Converts value·unit of quantity q to mm / rad; nullopt when the unit is not one of q's.
[[nodiscard]] std::optional<double> unit_factor(std::string_view unit, Quantity q);

}  // namespace postproc::cal
