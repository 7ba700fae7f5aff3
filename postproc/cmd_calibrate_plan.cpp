// postproc calibrate plan: choose measuring poses (D-optimal) and write the pose list and the NC
// program that visits them. postproc calibrate simulate: synthetic measurement files from a
// machine file with known errors plus noise.
#include <cmath>
#include <limits>
#include <memory>

#include <fmt/format.h>

#include "calibrate_support.hpp"
#include "common.hpp"
#include "postproc/calibration/csv.hpp"
#include "postproc/calibration/measurement.hpp"
#include "postproc/calibration/plan.hpp"
#include "postproc/calibration/step_gauge.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/kinematics/volumetric_map.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cli {
namespace {

struct KindArg {
  cal::MeasurementKind kind;
  bool torsion;
};

KindArg parse_kind(const std::string& s) {
  if (s == "poses") return {cal::MeasurementKind::pose, true};
  if (s == "poses5") return {cal::MeasurementKind::pose, false};
  if (s == "positions") return {cal::MeasurementKind::position, false};
  if (s == "directions") return {cal::MeasurementKind::direction, false};
  if (s == "struts") return {cal::MeasurementKind::struts, true};
  throw Error(ExitCode::usage, fmt::format("--kind {}: use poses (6-DoF), poses5, positions, directions or struts", s));
}


/// The plan file: `# kind: plan`, id and one column per joint (mm / deg).
std::string plan_csv(const kin::Model& model, std::span<const kin::JointVector> joints, const std::string& comment) {
  std::string s = "# kind: plan\n# " + comment + "\nid";
  for (const kin::Joint& j : model.joints()) s += fmt::format(",{}_{}", j.name, j.type == kin::JointType::rotary ? "deg" : "mm");
  s += '\n';
  for (std::size_t i = 0; i < joints.size(); ++i) {
    s += fmt::format("p{}", i + 1);
    for (int j = 0; j < joints[i].size(); ++j) s += fmt::format(",{:.6f}", joints[i][j]);
    s += '\n';
  }
  return s;
}

std::vector<kin::JointVector> read_plan(const std::string& path, const kin::Model& model) {
  gcode::DiagnosticSink sink;
  DiagnosticPrinter printer(sink, 20);
  const std::string text = io::read_file(path, "plan file");
  auto t = cal::CsvTable::parse(path, text, sink);
  std::vector<kin::JointVector> out;
  if (t) {
    if (t->meta("kind") != "plan")
      t->error(cal::CsvTable::kHeader, -1, cal::codes::kCsvColumns, "a plan file starts with '# kind: plan' (written by calibrate plan)");
    const cal::JointColumns joints = cal::joint_columns(*t, model);
    double unused = 1;
    if (t->find("id") >= 0) (void)t->quantity_column("id", cal::Quantity::ratio, false, unused);
    t->report_unused();
    if (!sink.has_errors() && joints.ok())
      for (std::size_t r = 0; r < t->rows().size(); ++r)
        if (const auto q = cal::joints_of_row(*t, joints, r)) out.push_back(*q);
  }
  printer.finish();
  if (sink.has_errors() || out.empty()) throw Error(ExitCode::refused, fmt::format("{}: plan file refused", path));
  return out;
}

void print_identifiability(std::string_view what, const cal::Identifiability& a) {
  std::fputs(fmt::format("postproc: {}: rank {} of {}, condition {:.4g}, O1 {:.4g}, O3 {:.4g}, O4 {:.4g}\n", what, a.rank,
                         a.parameters, a.condition, a.o1, a.o3, a.o4)
                 .c_str(),
             stderr);
}

struct PlanArgs {
  std::string machine, output, program, kind = "poses";
  std::vector<std::string> free;
  int poses = 30, candidates = 2000;
  std::uint64_t seed = 1;
  double margin = 0;
  std::vector<std::string> region_from;  ///< programs whose working region the poses are drawn in
  std::vector<std::string> region;       ///< NAME=LO:HI: joints (mm / deg), x y z (tool tip, mm), tilt (deg)
};

/// --region NAME=LO:HI,…: a joint's range (its unit: mm or deg), the tool tip's x, y, z (mm,
/// parallel machines) or the largest tilt (`tilt=0:25`, deg).
void apply_region_args(const std::vector<std::string>& items, const kin::Model& model, cal::PlanOptions& o) {
  const bool parallel = model.kind().find("hexapod") != std::string::npos || model.kind().find("prs") != std::string::npos;
  for (const std::string& item : items) {
    const auto eq = item.find('='), colon = item.find(':', item.find('=') == std::string::npos ? 0 : item.find('='));
    double lo = 0, hi = 0;
    bool ok = eq != std::string::npos && colon != std::string::npos;
    if (ok) {
      try {
        std::size_t used = 0;
        lo = std::stod(item.substr(eq + 1, colon - eq - 1), &used);
        ok = used == colon - eq - 1;
        hi = std::stod(item.substr(colon + 1), &used);
        ok = ok && used == item.size() - colon - 1 && lo <= hi;
      } catch (const std::exception&) {
        ok = false;
      }
    }
    if (!ok)
      throw Error(ExitCode::usage, fmt::format("--region '{}': write NAME=LOW:HIGH with LOW ≤ HIGH, e.g. X=-200:200 or "
                                               "z=-750:-650 (tool tip, parallel machines) or tilt=0:25",
                                               item));
    const std::string name = item.substr(0, eq);
    int joint = -1;
    for (int j = 0; j < model.joint_count(); ++j)
      if (model.joints()[static_cast<std::size_t>(j)].name == name) joint = j;
    if (joint >= 0) {
      if (o.joint_region.empty())
        o.joint_region.assign(model.joints().size(), {-std::numeric_limits<double>::infinity(),
                                                     std::numeric_limits<double>::infinity()});
      o.joint_region[static_cast<std::size_t>(joint)] = {lo, hi};
    } else if (parallel && (name == "x" || name == "y" || name == "z")) {
      if (!o.tip_region) {
        const Eigen::Vector3d h = o.box_mm;
        kin::Pose home;
        if (!model.forward(kin::JointVector::Zero(model.joint_count()), home).ok())
          throw Error(ExitCode::usage, "--region: the home pose cannot be evaluated");
        o.tip_region = std::make_pair(Eigen::Vector3d(home.p - h), Eigen::Vector3d(home.p + h));
      }
      const int k = name[0] - 'x';
      o.tip_region->first[k] = lo;
      o.tip_region->second[k] = hi;
    } else if (parallel && name == "tilt") {
      o.max_tilt_deg = std::max(hi, 1e-3);
    } else {
      std::string names;
      for (const kin::Joint& j : model.joints()) names += (names.empty() ? "" : ", ") + j.name;
      throw Error(ExitCode::usage, fmt::format("--region '{}': '{}' is neither a joint of this machine ({}){}", item, name,
                                               names, parallel ? " nor x, y, z, tilt" : ""));
    }
  }
}

struct CalibrationSimulateArgs {
  std::string machine, output, plan, kind = "poses";
  int poses = 30, validate_every = 0;
  std::uint64_t seed = 1;
  double noise_um = 10, noise_arcsec = 36;
  std::vector<double> frame_offset_um, frame_rotation_arcsec;  ///< an instrument frame (empty: the workpiece frame)
};

/// Step-gauge files (document 002) for the machine's volumetric map: one plate per z level of its
/// grid and a column gauge chaining them (cal::grid_layouts), the readings of the map's field plus
/// noise, plate tilts of a few µrad.
void simulate_step_gauge_files(const CalibrationSimulateArgs& a, const machine::Machine& m) {
  const auto* vm = dynamic_cast<const kin::VolumetricModel*>(m.actual.get());
  if (vm == nullptr)
    throw Error(ExitCode::usage, fmt::format("--kind step-gauge: {} has no [volumetric_map] to take the error field from",
                                             a.machine));
  const kin::VolumetricMap& map = vm->map();
  const Eigen::Vector2d tilts[] = {{15e-6, -10e-6}, {-20e-6, 8e-6}, {5e-6, 25e-6}};
  const auto layouts = cal::grid_layouts(map.origin(), map.spacing(), map.counts(), tilts, a.seed);
  cal::StepGaugeSimulateOptions o;
  o.noise_mm = a.noise_um / 1000.0;
  o.seed = a.seed;
  o.decimals = 4;
  o.comment = fmt::format("simulated by postproc {} calibrate simulate from the [volumetric_map] of {} (sha256 {}); "
                          "uniform reading noise ±{} um, seed {}",
                          POSTPROC_VERSION, a.machine, m.sha256, a.noise_um, a.seed);
  const auto files = cal::simulate_step_gauge([&](const Eigen::Vector3d& p) { return *map.error(p); }, layouts, o);
  OutputSet outputs;
  for (std::size_t i = 0; i < files.size(); ++i) {
    const std::string base = a.output + "_" + layouts[i].name;
    outputs.add(base + ".csv", files[i].gauge_csv);
    if (!files[i].edge_csv.empty()) outputs.add(base + "_edges.csv", files[i].edge_csv);
  }
  outputs.commit();
  std::fputs(fmt::format("postproc: wrote {} simulated step-gauge placements to {}_*.csv\n", files.size(), a.output).c_str(),
             stderr);
}

}  // namespace

void setup_calibrate_plan(CLI::App& calibrate, int& rc) {
  auto a = std::make_shared<PlanArgs>();
  auto* cmd = calibrate.add_subcommand("plan", "choose measuring poses that make the errors best identifiable (D-optimal "
                                               "within the axis limits); write the pose list and an NC program visiting them");
  cmd->add_option("-m,--machine", a->machine, "machine file")->required();
  cmd->add_option("--poses", a->poses, "number of poses")->capture_default_str();
  cmd->add_option("--kind", a->kind, "what will be measured: poses, poses5, positions, directions, struts")->capture_default_str();
  cmd->add_option("--candidates", a->candidates, "random candidates to choose from")->capture_default_str();
  cmd->add_option("--seed", a->seed, "random seed")->capture_default_str();
  cmd->add_option("--margin", a->margin, "keep this far inside the travel (mm / deg)")->capture_default_str();
  cmd->add_option("--free", a->free, "plan for these parameters only (patterns, comma separated)")->delimiter(',');
  cmd->add_option("-o,--output", a->output, "pose list (CSV, '# kind: plan')")->required();
  cmd->add_option("--program", a->program, "also write the NC program that visits the poses");
  cmd->add_option("--region-from", a->region_from,
                  "draw the poses in the working region of these NC programs (joint ranges; parallel machines: the "
                  "tool-tip box and tilt)");
  cmd->add_option("--region", a->region,
                  "an explicit region, NAME=LOW:HIGH,…: joints (mm / deg), and for parallel machines the tool tip x, "
                  "y, z (mm, workpiece frame) and tilt (deg)")
      ->delimiter(',');
  cmd->callback([a, &rc] {
    const machine::Machine m = load_or_refuse(a->machine);
    const KindArg k = parse_kind(a->kind);
    cal::PlanOptions opt;
    opt.poses = a->poses;
    opt.kind = k.kind;
    opt.has_torsion = k.torsion;
    opt.candidates = a->candidates;
    opt.seed = a->seed;
    opt.margin = a->margin;
    if (!a->free.empty()) opt.parameters = match_parameters(*m.nominal, a->free, "--free");
    if (!a->region_from.empty()) {
      gcode::DiagnosticSink sink;
      DiagnosticPrinter printer(sink, 20);
      const cal::WorkingRegion region = cal::program_region(m, a->region_from, sink);
      printer.finish();
      if (sink.has_errors())
        throw Error(ExitCode::refused, "--region-from: a program was refused; its working region is not known");
      cal::plan_in(region, *m.nominal, opt);
      std::string joints;
      for (int j = 0; j < m.nominal->joint_count(); ++j)
        joints += fmt::format("{}{} {:.3f} … {:.3f}", j == 0 ? "" : ", ", m.nominal->joints()[static_cast<std::size_t>(j)].name,
                              region.joint_min[static_cast<std::size_t>(j)], region.joint_max[static_cast<std::size_t>(j)]);
      std::fputs(fmt::format("postproc: working region of {} motions: {}; tool tip x {:.3f} … {:.3f}, y {:.3f} … {:.3f}, "
                             "z {:.3f} … {:.3f} mm; tilt up to {:.2f}°\n",
                             region.motions, joints, region.tip_min.x(), region.tip_max.x(), region.tip_min.y(),
                             region.tip_max.y(), region.tip_min.z(), region.tip_max.z(), region.max_tilt_deg)
                     .c_str(),
                 stderr);
    }
    apply_region_args(a->region, *m.nominal, opt);
    const cal::PlanResult r = cal::plan_poses(*m.nominal, opt);
    print_identifiability("planned poses", r.planned);
    print_identifiability("as many random poses in the same region", r.random);
    {
      std::string ranges;
      for (int j = 0; j < m.nominal->joint_count(); ++j) {
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (const kin::JointVector& q : r.joints) {
          lo = std::min(lo, q[j]);
          hi = std::max(hi, q[j]);
        }
        ranges += fmt::format("{}{} {:.3f} … {:.3f}", j == 0 ? "" : ", ", m.nominal->joints()[static_cast<std::size_t>(j)].name, lo, hi);
      }
      std::fputs(fmt::format("postproc: the planned poses span {}\n", ranges).c_str(), stderr);
    }
    for (const std::string& c : r.planned.combinations)
      std::fputs(fmt::format("postproc: not identifiable with any pose of this kind: {}\n", c).c_str(), stderr);
    io::OutputFile out(a->output, a->machine, false);
    out.write(plan_csv(*m.nominal, r.joints,
                       fmt::format("{} poses for {} measurements of {} (sha256 {}), seed {}, {:.2f} s", r.joints.size(), a->kind,
                                   a->machine, m.sha256, a->seed, r.seconds)));
    OutputSet outputs;
    if (!a->program.empty())
      outputs.add(a->program, cal::plan_program(m, r.joints, fmt::format("calibration poses for {}", m.name)));
    outputs.commit(&out);
    std::fputs(fmt::format("postproc: wrote {} poses to {}{}\n", r.joints.size(), a->output,
                           a->program.empty() ? "" : " and the program " + a->program)
                   .c_str(),
               stderr);
    rc = 0;
  });
}

void setup_calibrate_simulate(CLI::App& calibrate, int& rc) {
  auto a = std::make_shared<CalibrationSimulateArgs>();
  auto* cmd = calibrate.add_subcommand("simulate", "write synthetic measurements of a machine file's (known) errors plus "
                                                   "noise, at planned poses");
  cmd->add_option("-m,--machine", a->machine, "machine file with the true errors")->required();
  cmd->add_option("--plan", a->plan, "pose list from calibrate plan (default: plan --poses N here)");
  cmd->add_option("--poses", a->poses, "poses to plan when no --plan is given")->capture_default_str();
  cmd->add_option("--kind", a->kind, "poses, poses5, positions, directions, struts, step-gauge")->capture_default_str();
  cmd->add_option("--noise", a->noise_um, "uniform noise ± per position component / strut reading, µm")->capture_default_str();
  cmd->add_option("--angle-noise", a->noise_arcsec, "uniform noise ± per rotation component, arcsec")->capture_default_str();
  cmd->add_option("--validate-every", a->validate_every, "mark every k-th measurement as held out (0 = none)")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "random seed")->capture_default_str();
  cmd->add_option("--frame-offset", a->frame_offset_um,
                  "write the values in an instrument frame moved by X,Y,Z µm from the workpiece frame ('# frame: instrument')")
      ->delimiter(',')
      ->expected(3);
  cmd->add_option("--frame-rotation", a->frame_rotation_arcsec,
                  "… and turned by the rotation vector RX,RY,RZ arcsec")
      ->delimiter(',')
      ->expected(3);
  cmd->add_option("-o,--output", a->output,
                  "measurement file to write (step-gauge: a path prefix; PREFIX_<gauge>.csv and PREFIX_<gauge>_edges.csv)")
      ->required();
  cmd->callback([a, &rc] {
    const machine::Machine m = load_or_refuse(a->machine);
    if (a->kind == "step-gauge") {
      simulate_step_gauge_files(*a, m);
      rc = 0;
      return;
    }
    const KindArg k = parse_kind(a->kind);
    std::vector<kin::JointVector> joints;
    if (!a->plan.empty()) {
      joints = read_plan(a->plan, *m.nominal);
    } else {
      cal::PlanOptions p;
      p.poses = a->poses;
      p.kind = k.kind;
      p.has_torsion = k.torsion;
      p.seed = a->seed;
      joints = cal::plan_poses(*m.nominal, p).joints;
    }
    cal::SimulateOptions opt;
    opt.kind = k.kind;
    opt.has_torsion = k.torsion;
    opt.noise_mm = a->noise_um / 1000.0;
    opt.noise_deg = a->noise_arcsec / 3600.0;
    opt.validate_every = a->validate_every;
    opt.seed = a->seed;
    auto data = cal::simulate_measurements(*m.actual, *m.nominal, joints, opt);
    std::vector<std::string> header{
        fmt::format("simulated by postproc {} calibrate simulate from {} (sha256 {})", POSTPROC_VERSION, a->machine, m.sha256),
        fmt::format("noise: uniform ±{} um per position component, ±{} arcsec per rotation component; seed {}", a->noise_um,
                    a->noise_arcsec, a->seed)};
    // The standard uncertainty of uniform noise ±a is a/√3.
    if (a->noise_um > 0) header.push_back(fmt::format("sigma: {:.6g} um", a->noise_um / std::sqrt(3.0)));
    if (a->noise_arcsec > 0 && k.kind != cal::MeasurementKind::position && k.kind != cal::MeasurementKind::struts)
      header.push_back(fmt::format("sigma_angle: {:.6g} arcsec", a->noise_arcsec / std::sqrt(3.0)));
    if (!a->frame_offset_um.empty() || !a->frame_rotation_arcsec.empty()) {
      if (k.kind == cal::MeasurementKind::struts)
        throw Error(ExitCode::usage, "--frame-offset/--frame-rotation: strut readings are taken at poses in the workpiece frame");
      for (double v : a->frame_offset_um)
        if (!std::isfinite(v) || std::abs(v) > 1e9)
          throw Error(ExitCode::usage, fmt::format("--frame-offset: {} µm is not a placement an instrument could have "
                                                   "(finite, at most 1e9 µm = 1 km)",
                                                   v));
      for (double v : a->frame_rotation_arcsec)
        if (!std::isfinite(v) || std::abs(v) > 648000)
          throw Error(ExitCode::usage, fmt::format("--frame-rotation: {} arcsec is not a rotation vector component "
                                                   "(finite, at most 648000 arcsec = 180°)",
                                                   v));
      // The instrument frame is the workpiece frame moved by (r, t): P_i = rᵀ·(P_w − t), R_i = rᵀ·R_w.
      Eigen::Vector3d t = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
      for (std::size_t i = 0; i < a->frame_offset_um.size(); ++i) t[static_cast<Eigen::Index>(i)] = a->frame_offset_um[i] / 1000;
      for (std::size_t i = 0; i < a->frame_rotation_arcsec.size(); ++i)
        w[static_cast<Eigen::Index>(i)] = a->frame_rotation_arcsec[i] / 3600 * kin::kDeg;
      const Eigen::Matrix3d r = w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                                             : Eigen::Matrix3d::Identity();
      for (cal::Measurement& d : data) {
        d.measured.p = r.transpose() * (d.measured.p - t);
        d.measured.r = r.transpose() * d.measured.r;
      }
      header.push_back("frame: instrument");
      header.push_back(fmt::format("note: the instrument frame is the workpiece frame moved by ({:g}, {:g}, {:g}) um and "
                                   "turned by ({:g}, {:g}, {:g}) arcsec (rotation vector)",
                                   t.x() * 1000, t.y() * 1000, t.z() * 1000, w.x() / kin::kDeg * 3600,
                                   w.y() / kin::kDeg * 3600, w.z() / kin::kDeg * 3600));
    }
    io::OutputFile out(a->output, a->machine, false);
    out.write(cal::write_measurements(data, *m.actual, header));
    out.commit();
    std::fputs(fmt::format("postproc: wrote {} simulated {} measurements to {}\n", data.size(), a->kind, a->output).c_str(),
               stderr);
    rc = 0;
  });
}

}  // namespace postproc::cli
