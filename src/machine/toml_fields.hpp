#pragma once
// Reading machine files: typed, unit-checked access to the keys of one TOML table, with every
// problem reported as a located diagnostic (file:line:column, the offending text, what to do),
// and unknown keys reported when the table is finished.
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <toml++/toml.h>

#include "postproc/gcode/diagnostic.hpp"

namespace postproc::machine {

/// Physical dimension of a quantity and the unit its value is returned in.
enum class Dim : std::uint8_t {
  length,        ///< returned in mm       (nm, um, µm, mm, cm, m, in)
  angle,         ///< returned in rad      (rad, mrad, urad, µrad, deg, arcmin, arcsec, um/m, mm/m)
  inverse_time,  ///< returned in 1/s      (1/s, 1/min, (m/min)/mm — the Kv unit of Heidenhain and Siemens)
  time,          ///< returned in s        (s, ms, us, µs, min)
  velocity,      ///< returned in mm/min   (mm/min, m/min, mm/s, m/s, in/min)
  acceleration,  ///< returned in mm/s^2   (mm/s^2, m/s^2, g)
  jerk,          ///< returned in mm/s^3   (mm/s^3, m/s^3)
  ratio,         ///< dimensionless        (plain number, %)
};
[[nodiscard]] std::string_view to_string(Dim d);

/// Converts `value unit` to the returned unit of `d`; nullopt when the unit is not one of d's.
[[nodiscard]] std::optional<double> convert_unit(double value, std::string_view unit, Dim d);

/// Diagnostic codes of machine files (README "Machine files").
namespace codes {
inline constexpr std::string_view kSyntax = "PP-M001";       ///< not valid TOML
inline constexpr std::string_view kUnknownKey = "PP-M002";   ///< a key the schema does not have
inline constexpr std::string_view kMissing = "PP-M003";      ///< a required key is missing
inline constexpr std::string_view kType = "PP-M004";         ///< wrong TOML type
inline constexpr std::string_view kUnit = "PP-M005";         ///< unit missing, unknown or of another dimension
inline constexpr std::string_view kRange = "PP-M006";        ///< non-physical or out-of-range value
inline constexpr std::string_view kInconsistent = "PP-M007"; ///< values that contradict each other
}  // namespace codes

/// One parsed machine file: its text (for caret lines), root table and the sink.
class TomlDoc {
 public:
  /// Parses `text`; a syntax error is reported (PP-M001) and ok() is false.
  TomlDoc(std::string file, std::string text, gcode::DiagnosticSink& sink);
  [[nodiscard]] bool ok() const { return ok_; }
  [[nodiscard]] const toml::table& root() const { return root_; }
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] const std::string& text() const { return text_; }
  /// Reports an error at `where` (the region of a key's value, or of a table).
  void error(const toml::source_region& where, std::string_view code, std::string message);
  [[nodiscard]] gcode::DiagnosticSink& sink() { return sink_; }

 private:
  std::string file_;
  std::string text_;
  std::vector<std::string_view> lines_;
  gcode::DiagnosticSink& sink_;
  toml::table root_;
  bool ok_ = false;
};

/// Allowed values of a quantity, in the returned unit of its dimension.
struct QuantityRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;  ///< lo itself not allowed (e.g. a gain must be > 0)
};

/// Typed access to the keys of one table. Every accessor marks its key as known; finish()
/// reports the keys of the table nobody asked for (PP-M002), naming the known ones.
class Fields {
 public:
  Fields(TomlDoc& doc, const toml::table& t, std::string path);
  Fields(const Fields&) = delete;
  Fields& operator=(const Fields&) = delete;

  using Range = QuantityRange;
  /// A quantity: a number (in `default_unit`, which must be one of `d`'s units) or a string
  /// "<number> <unit>". Returned in d's unit. Range checked in d's unit.
  std::optional<double> quantity(std::string_view key, Dim d, std::string_view default_unit, bool required,
                                 QuantityRange range = QuantityRange{});
  /// Three quantities [x, y, z] (numbers or strings as above).
  std::optional<Eigen::Vector3d> vector3(std::string_view key, Dim d, std::string_view default_unit, bool required);
  /// A unit direction [x, y, z] (normalised; zero vectors are refused).
  std::optional<Eigen::Vector3d> direction(std::string_view key, bool required);
  /// A list of quantities of any length (≥ min_size).
  std::optional<std::vector<double>> quantities(std::string_view key, Dim d, std::string_view default_unit,
                                                bool required, std::size_t min_size = 0);
  std::optional<std::string> text(std::string_view key, bool required, std::span<const std::string_view> allowed = {});
  std::optional<bool> boolean(std::string_view key, bool required);
  std::optional<std::int64_t> integer(std::string_view key, bool required, std::int64_t lo, std::int64_t hi);
  const toml::table* table(std::string_view key, bool required);
  const toml::array* array(std::string_view key, bool required);
  /// Marks a key as known without reading it.
  void known(std::string_view key) { known_.insert(std::string(key)); }
  [[nodiscard]] bool has(std::string_view key) const { return t_.contains(key); }
  /// Reports unknown keys. Call once, after every accessor.
  void finish();

  [[nodiscard]] const toml::table& table_ref() const { return t_; }
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] TomlDoc& doc() { return doc_; }
  /// Reports an error at the value of `key` (or at the table when the key is absent).
  void error_at(std::string_view key, std::string_view code, std::string message);
  /// Parses one quantity node (number or "<number> <unit>"); reports at the node. Values beyond a
  /// machine's physical envelope (e.g. lengths above 1e6 mm, non-finite results) are refused (PP-M006).
  std::optional<double> quantity_node(const toml::node& n, std::string_view what, Dim d, std::string_view default_unit);

 private:
  const toml::node* get(std::string_view key, bool required, std::string_view expected);
  /// quantity_node without the physical envelope check.
  std::optional<double> parse_quantity(const toml::node& n, std::string_view what, Dim d, std::string_view default_unit);
  TomlDoc& doc_;
  const toml::table& t_;
  std::string path_;
  std::set<std::string, std::less<>> known_;
};

}  // namespace postproc::machine
