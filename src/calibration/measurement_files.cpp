// Reading one calibration's measurement files (measurement_files.hpp).
#include "postproc/calibration/measurement_files.hpp"

#include "postproc/calibration/csv.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cal {

void add_measurement_file(const std::string& path, bool validate, const kin::Model& model, MeasurementFiles& into,
                          gcode::DiagnosticSink& sink) {
  std::string text = io::read_file(path, "measurement file");
  std::optional<CsvTable> table = CsvTable::parse(path, text, sink);
  if (!table) return;
  const std::optional<std::string> kind = measurement_file_kind(*table);
  if (!kind || kind->empty()) return;
  InputFile in{path, machine::sha256_hex(text), *kind, 0};
  // The table holds its own copy of every row: the text is not needed past here but for a gauge.
  if (*kind != "step-gauge" && *kind != "step-gauge-edge") std::string().swap(text);
  if (*kind == "step-gauge" || *kind == "step-gauge-edge") {
    if (validate) {
      table->error(CsvTable::kHeader, -1, codes::kCsvColumns,
                   "step-gauge files build the map; they cannot be held out with --validate");
      return;
    }
    into.have_gauge = add_step_gauge_file(*table, into.gauge, text) || into.have_gauge;
    in.measurements = table->rows().size();
  } else {
    const std::size_t before = into.data.size();
    if (!read_measurements(*table, model, into.data)) return;
    for (std::size_t i = before; i < into.data.size(); ++i) into.data[i].validate = into.data[i].validate || validate;
    in.measurements = into.data.size() - before;
  }
  into.inputs.push_back(std::move(in));
}

}  // namespace postproc::cal
