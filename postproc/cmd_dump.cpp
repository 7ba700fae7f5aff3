// postproc dump FILE --format csv|jsonl: one row per resolved motion.
#include <memory>
#include <numbers>

#include <fmt/format.h>

#include "common.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/machine/machine.hpp"
#include "postproc/io/output_file.hpp"

namespace postproc::cli {
namespace {

struct DumpOptions {
  std::string file;
  std::string output = "-";
  std::string format = "csv";
  DialectArgs dialect;
  ResolveArgs resolve;
  std::size_t max_per_code = 20;
};

// Column names; units: positions mm/deg, feed mm/min | mm/rev | 1/min, sweep deg.
constexpr const char* kColumns[] = {
    "line", "motion", "x", "y", "z", "a", "b", "c", "u", "v", "w", "feed", "feed_mode", "plane",
    "centre_x", "centre_y", "centre_z", "radius", "sweep_deg", "turns", "cycle", "cycle_r", "cycle_bottom",
    "frame", "work_offset", "g52_x", "g52_y", "g52_z", "g92_x", "g92_y", "g92_z", "tool_length_h", "tcp",
    "tilted_plane", "diameter_mode", "tool_i", "tool_j", "tool_k", "orientation_frame"};
constexpr std::size_t kColumnCount = std::size(kColumns);

class Dumper final : public gcode::BlockVisitor {
 public:
  Dumper(io::OutputFile& out, bool jsonl) : out_(out), jsonl_(jsonl) {
    if (!jsonl_) {
      for (std::size_t i = 0; i < kColumnCount; ++i) {
        buf_ += kColumns[i];
        buf_ += i + 1 < kColumnCount ? ',' : '\n';
      }
    }
  }
  void block(const gcode::Block&, std::span<const gcode::Motion> motions, bool) override {
    for (const auto& m : motions) row(m);
    if (buf_.size() > (1u << 20)) flush();
  }
  void flush() {
    out_.write(buf_);
    buf_.clear();
  }

 private:
  void row(const gcode::Motion& m) {
    using gcode::MotionType;
    field_ = 0;
    if (jsonl_) buf_ += '{';
    num(static_cast<double>(m.line));
    str(gcode::to_string(m.type));
    for (int a = 0; a < gcode::kAxisCount; ++a) {
      if ((m.known >> a) & 1u) num(m.end[a]);
      else empty();
    }
    if (m.feed_known) num(m.feed);
    else empty();
    str(gcode::to_string(m.feed_mode));
    str(gcode::to_string(m.plane));
    const bool arc = m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw;
    for (int i = 0; i < 3; ++i) {
      // The centre's coordinate along the plane normal is the start height: empty when unknown.
      if (arc && ((m.known >> i) & 1u)) num(m.arc.centre[i]);
      else empty();
    }
    arc ? num(m.arc.radius) : empty();
    arc ? num(m.arc.sweep * 180.0 / std::numbers::pi) : empty();
    arc ? num(m.arc.turns) : empty();
    if (m.type == MotionType::drill_cycle) {
      str(fmt::format("G{}", m.cycle_code10 / 10));
      num(m.cycle_r);
      num(m.cycle_bottom);
    } else {
      empty();
      empty();
      empty();
    }
    str(m.frame == gcode::Frame::machine ? "machine" : "work");
    str(machine::work_offset_name(m.work_offset));
    for (int i = 0; i < 3; ++i) num(m.local_offset[i]);
    for (int i = 0; i < 3; ++i) num(m.position_offset[i]);
    m.tool_length_active ? num(m.tool_length_h) : empty();
    str(gcode::to_string(m.tcp));
    boolean(m.tilted_plane);
    boolean(m.diameter_mode);
    for (int i = 0; i < 3; ++i) m.tool_vector_known ? num(m.tool_vector[i]) : empty();
    str(m.orientation_machine_frame ? "machine" : "work");
    buf_ += jsonl_ ? "}\n" : "\n";
  }
  void sep() {
    if (field_ > 0) buf_ += ',';
    if (jsonl_) fmt::format_to(std::back_inserter(buf_), "\"{}\":", kColumns[field_]);
    ++field_;
  }
  void num(double v) {
    sep();
    if (v == 0) v = 0;  // no "-0"
    fmt::format_to(std::back_inserter(buf_), "{}", v);
  }
  void empty() {
    sep();
    if (jsonl_) buf_ += "null";
  }
  void str(std::string_view s) {
    sep();
    if (jsonl_) buf_ += '"';
    buf_ += s;
    if (jsonl_) buf_ += '"';
  }
  void boolean(bool b) {
    sep();
    buf_ += jsonl_ ? (b ? "true" : "false") : (b ? "1" : "0");
  }
  io::OutputFile& out_;
  bool jsonl_;
  std::string buf_;
  std::size_t field_ = 0;
};

}  // namespace

void setup_dump(CLI::App& app, int& rc) {
  auto o = std::make_shared<DumpOptions>();
  auto* cmd = app.add_subcommand("dump", "write one row per resolved motion (absolute mm / degrees)");
  cmd->add_option("file", o->file, "NC program ('-' = stdin)")->required();
  cmd->add_option("-o,--output", o->output, "output file ('-' = stdout)")->capture_default_str();
  cmd->add_option("--format", o->format, "csv or jsonl")->check(CLI::IsMember({"csv", "jsonl"}))->capture_default_str();
  add_dialect_options(*cmd, o->dialect, true);
  add_resolve_options(*cmd, o->resolve);
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")
      ->capture_default_str();
  cmd->callback([o, &rc] {
    const gcode::Dialect d = make_dialect(o->dialect);
    gcode::DiagnosticSink sink;
    DiagnosticPrinter printer(sink, o->max_per_code);
    io::OutputFile out(o->output, o->file);
    Dumper dumper(out, o->format == "jsonl");
    gcode::run_program_file(o->file, d, o->file, sink, dumper, make_resolve_options(o->resolve));
    printer.finish();
    dumper.flush();
    // Rows of a refused program would be wrong or incomplete: write nothing.
    if (!sink.has_errors()) out.commit();
    rc = static_cast<int>(exit_code_for(sink));
  });
}

}  // namespace postproc::cli
