// Python bindings (pybind11): read a program into NumPy arrays, compensate a program, calibrate a
// machine from measurement files — the library's own calls, for calibration studies in Python
// (docs/python.md). A thin layer like the CLI: every refusal raises postproc.Refused with the
// located diagnostics; nothing here decides anything the library does not.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "postproc/calibration/csv.hpp"
#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/measurement.hpp"
#include "postproc/calibration/measurement_files.hpp"
#include "postproc/calibration/report.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/compensation/result_json.hpp"
#include "postproc/error.hpp"
#include "postproc/gcode/detect.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"

namespace py = pybind11;
using namespace postproc;

namespace {

/// Raised for a refused input; `args[0]` is the message, `.diagnostics` the located lines.
py::object refused_type;

[[noreturn]] void refuse(const std::string& what, const gcode::DiagnosticSink& sink) {
  std::vector<std::string> lines;
  for (const gcode::Diagnostic& d : sink.stored())
    if (d.severity == gcode::Severity::error) lines.push_back(gcode::format(d, false));
  std::string message = what;
  if (!lines.empty()) message += ": " + lines.front();
  py::object e = refused_type(message);
  e.attr("diagnostics") = lines;
  PyErr_SetObject(refused_type.ptr(), e.ptr());
  throw py::error_already_set();
}

std::vector<std::string> all_diagnostics(const gcode::DiagnosticSink& sink) {
  std::vector<std::string> out;
  for (const gcode::Diagnostic& d : sink.stored()) out.push_back(gcode::format(d, false));
  return out;
}

py::object to_python(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

gcode::Dialect dialect_for(const std::string& name, const std::string& text, bool lathe) {
  gcode::DialectOptions o;
  o.lathe = lathe;
  if (!name.empty()) {
    auto d = gcode::make_dialect(name, o);
    if (!d) throw py::value_error(fmt::format("unknown dialect '{}'; use {}", name, gcode::dialect_names()));
    return *d;
  }
  const auto g = gcode::guess_dialect(text);
  if (!g)
    throw py::value_error(fmt::format("nothing in the program identifies its dialect; pass dialect= ({})",
                                      gcode::dialect_names()));
  return gcode::make_dialect(g->id, o);
}

/// Collects the resolved motions column by column.
class Columns final : public gcode::BlockVisitor {
 public:
  void block(const gcode::Block&, std::span<const gcode::Motion> motions, bool) override {
    for (const gcode::Motion& m : motions) {
      line.push_back(static_cast<std::int64_t>(m.line));
      type.push_back(std::string(gcode::to_string(m.type)));
      for (int a = 0; a < gcode::kAxisCount; ++a)
        axes[static_cast<std::size_t>(a)].push_back(((m.known >> a) & 1u) ? m.end[a]
                                                                           : std::numeric_limits<double>::quiet_NaN());
      feed.push_back(m.feed_known ? m.feed : std::numeric_limits<double>::quiet_NaN());
    }
  }
  std::vector<std::int64_t> line;
  std::vector<std::string> type;
  std::array<std::vector<double>, gcode::kAxisCount> axes;
  std::vector<double> feed;
};

template <class T>
py::array_t<T> array_of(const std::vector<T>& v) {
  py::array_t<T> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::dict read_program(const std::string& path, const std::string& dialect, bool lathe) {
  const std::string text = io::read_file(path, "NC program");
  const gcode::Dialect d = dialect_for(dialect, text, lathe);
  gcode::DiagnosticSink sink;
  Columns c;
  gcode::run_program_file(path, d, path, sink, c, gcode::ResolveOptions{});
  if (sink.has_errors()) refuse(fmt::format("{}: the program cannot be read as {}", path, d.name), sink);
  py::dict out;
  out["dialect"] = d.name;
  out["line"] = array_of(c.line);
  out["type"] = c.type;
  for (int a = 0; a < gcode::kAxisCount; ++a)
    out[py::str(std::string(1, static_cast<char>(gcode::kAxisLetters[static_cast<std::size_t>(a)] + ('a' - 'A'))))] =
        array_of(c.axes[static_cast<std::size_t>(a)]);
  out["feed"] = array_of(c.feed);
  out["diagnostics"] = all_diagnostics(sink);
  return out;
}

std::optional<machine::Machine> machine_of(const std::string& path) {
  gcode::DiagnosticSink sink;
  auto m = machine::load_machine(path, sink);
  if (!m) refuse(fmt::format("{}: machine file refused", path), sink);
  return m;
}

py::dict compensate_program(const std::string& path, const std::string& machine_path, const std::string& mode,
                    const std::string& dialect, double max_deviation_um) {
  const auto m = machine_of(machine_path);
  const std::optional<comp::Mode> md = comp::parse_mode(mode);
  if (!md) throw py::value_error(fmt::format("unknown mode '{}'; use geometric, contour or all", mode));
  if (!(max_deviation_um > 0) || !std::isfinite(max_deviation_um))
    throw py::value_error("max_deviation_um must be a positive number of µm");
  const std::string text = io::read_file(path, "NC program");
  auto dd = gcode::make_dialect(dialect.empty() ? m->dialect_name : dialect, m->dialect_options);
  if (!dd) throw py::value_error(fmt::format("unknown dialect '{}'; use {}", dialect, gcode::dialect_names()));
  comp::CompensateOptions opt;
  opt.mode = *md;
  opt.max_deviation_mm = max_deviation_um / 1000.0;
  opt.tool_version = POSTPROC_VERSION;
  gcode::DiagnosticSink sink;
  auto out = io::OutputFile::memory();
  comp::ContourDetails details;
  const comp::CompensateResult got =
      comp::compensate_program({text, path, *dd, *m}, opt, out, sink,
                               opt.mode == comp::Mode::geometric ? nullptr : &details);
  if (sink.has_errors()) refuse(fmt::format("{}: refused", path), sink);
  py::dict res;
  res["program"] = out.take();
  res["figures"] = to_python(comp::result_json(got, opt.mode, opt.mode == comp::Mode::geometric ? nullptr : &details));
  res["diagnostics"] = all_diagnostics(sink);
  res["machine_sha256"] = m->sha256;
  return res;
}

py::dict calibrate_machine(const std::vector<std::string>& data_paths, const std::string& machine_path,
                   const std::vector<std::string>& validate_paths) {
  const auto m = machine_of(machine_path);
  const kin::Model& start = *m->actual;
  gcode::DiagnosticSink sink;
  cal::MeasurementFiles files;
  for (const std::string& p : data_paths) cal::add_measurement_file(p, false, start, files, sink);
  for (const std::string& p : validate_paths) cal::add_measurement_file(p, true, start, files, sink);
  if (files.have_gauge)
    throw py::value_error("step-gauge files build a volumetric map: use postproc calibrate for them");
  const std::vector<cal::Measurement>& data = files.data;
  if (sink.has_errors() || data.empty()) refuse("measurement files refused", sink);
  cal::CalibrationRun run;
  run.tool_version = POSTPROC_VERSION;
  run.machine_file = machine_path;
  run.machine_sha256 = m->sha256;
  run.machine_name = m->name;
  run.inputs = files.inputs;
  run.result = cal::identify(start, data, run.options);
  const kin::ModelPtr solved = start.with_values(run.result.values);
  run.start = &start;
  run.solved = solved.get();
  const std::vector<cal::Measurement> registered = cal::registered(data, run.result);
  run.data = registered;
  py::dict res = to_python(nlohmann::json::parse(cal::report_json(run)));
  res["diagnostics"] = all_diagnostics(sink);
  return res;
}

}  // namespace

PYBIND11_MODULE(postproc, mod) {
  mod.doc() = "postproc: NC programs read as their controllers run them, compensated through calibrated "
              "machine models; machines calibrated from measurements (docs/python.md)";
  mod.attr("__version__") = POSTPROC_VERSION;
  py::register_exception<Error>(mod, "Refused", PyExc_RuntimeError);
  refused_type = mod.attr("Refused");
  mod.def("read", &read_program, py::arg("path"), py::arg("dialect") = std::string(), py::arg("lathe") = false,
          "Reads a program (parameters, subprograms and loops resolved) into one row per motion: 'line' "
          "(int64), 'type' (list of str), 'x' … 'w' (float64, mm / deg, absolute; NaN where the position is not "
          "known), 'feed' (float64, NaN when not set), 'dialect', 'diagnostics'. dialect: fanuc, siemens, "
          "linuxcnc, heidenhain-iso, heidenhain; guessed from the program when omitted. Raises Refused with "
          "the located diagnostics when the program cannot be read exactly.");
  mod.def("compensate", &compensate_program, py::arg("path"), py::arg("machine"), py::arg("mode") = "geometric",
          py::arg("dialect") = std::string(), py::arg("max_deviation_um") = 1.0,
          "Compensates a program for the calibrated machine in the machine file. Returns 'program' (the "
          "written text, as postproc compensate -o writes it), 'figures' (as its --json report), "
          "'diagnostics' and 'machine_sha256'. Raises Refused when the program or machine is refused.");
  mod.def("calibrate", &calibrate_machine, py::arg("data"), py::arg("machine"), py::arg("validate") = std::vector<std::string>(),
          "Identifies the machine file's error parameters from measurement files (CSV, docs/measurements.md; "
          "least squares, the command's defaults). Returns the JSON report of postproc calibrate as a dict "
          "(parameters with status, value and stddev; identifiability; figures before/after).");
}
