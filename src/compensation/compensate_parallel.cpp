// The geometric stage on several threads with the one-thread result (CompensateOptions::jobs).
//
// Speculation with validation: the reader (this thread) reads, lexes and interprets the program in
// order and cuts it into chunks of blocks; it tracks exactly what the compensation takes from the
// text (modal state, header, line ends). Workers correct the chunks in parallel. What a chunk's
// first block needs from the corrections before it (the joints, the corrected end point the
// controller holds, the map's context, an arc mode to restore) is guessed by correcting the last
// `warmup_blocks` blocks of the chunk before it. The chunks are written in order; a chunk is kept
// only when its guessed start state equals the state its predecessor ended with — then every
// block of it is corrected exactly as the one-thread run corrects it — and is corrected again,
// from the true state, when not. On axis programs the state after one corrected motion no longer
// depends on what came before, so guesses hold except where a chunk starts at an unknown position.
#include <condition_variable>
#include <deque>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>

#include "src/compensation/compensator.hpp"

namespace postproc::comp {
namespace detail {

bool Compensator::Carry::operator==(const Carry& o) const {
  return track == o.track && vector == o.vector && eol == o.eol && recompensation_checked == o.recompensation_checked &&
         header_done == o.header_done && joints.size() == o.joints.size() && joints == o.joints &&
         written == o.written && written_known == o.written_known && mask == o.mask && prev_vector == o.prev_vector &&
         prev_written_vector == o.prev_written_vector && arc_mode_broken == o.arc_mode_broken &&
         arc_word == o.arc_word && turning_limit_warned == o.turning_limit_warned &&
         unnumbered_warned == o.unnumbered_warned && map_held == o.map_held &&
         (!map_held || map_key == o.map_key);
}

namespace {

/// One block as the reader handed it over, with its motions and the reader's diagnostics that
/// came before it, owned by its chunk.
struct StoredBlock {
  gcode::Block block;
  std::size_t raw_at = 0, eol_at = 0;  ///< offsets of raw / eol in Chunk::text
  std::uint32_t motions_begin = 0, motions_end = 0;
  std::uint32_t diags_begin = 0, diags_end = 0;
  bool lexed_ok = true;
};

struct Chunk {
  std::uint64_t index = 0;
  std::size_t warm = 0;  ///< blocks[0, warm): the last blocks of the chunk before (warm-up only)
  std::vector<StoredBlock> blocks;
  std::vector<gcode::Motion> motions;
  std::vector<gcode::Diagnostic> diags;
  std::string text;
  std::optional<Compensator::Carry> start;  ///< the state the warm-up starts from
  // Filled by the worker.
  std::optional<Compensator::Carry> guess;  ///< after the warm-up: the guessed start state
  std::optional<Compensator::Carry> end;    ///< after the chunk's last block
  std::string output;
  std::vector<std::uint64_t> line_map;
  std::vector<gcode::Diagnostic> reported;
  CompensateResult r;
  std::exception_ptr error;
  bool done = false;

  void add(const gcode::Block& b, std::span<const gcode::Motion> ms, std::span<const gcode::Diagnostic> before,
           bool lexed_ok) {
    StoredBlock s;
    s.block = b;
    s.raw_at = text.size();
    text.append(b.raw);
    s.eol_at = text.size();
    text.append(b.eol);
    s.motions_begin = static_cast<std::uint32_t>(motions.size());
    motions.insert(motions.end(), ms.begin(), ms.end());
    s.motions_end = static_cast<std::uint32_t>(motions.size());
    s.diags_begin = static_cast<std::uint32_t>(diags.size());
    diags.insert(diags.end(), before.begin(), before.end());
    s.diags_end = static_cast<std::uint32_t>(diags.size());
    s.lexed_ok = lexed_ok;
    blocks.push_back(std::move(s));
  }
  /// Points the blocks at the chunk's own text (after the last add).
  void seal() {
    for (StoredBlock& s : blocks) {
      s.block.raw = std::string_view(text).substr(s.raw_at, s.eol_at - s.raw_at);
      s.block.eol = std::string_view(text).substr(s.eol_at, s.block.eol.size());
    }
  }
  void replay(Compensator& c, std::size_t i) const {
    const StoredBlock& s = blocks[i];
    for (std::uint32_t d = s.diags_begin; d < s.diags_end; ++d) c.collector().report(diags[d]);
    c.block(s.block, std::span<const gcode::Motion>(motions).subspan(s.motions_begin, s.motions_end - s.motions_begin),
            s.lexed_ok);
  }
};

/// The figures of a chunk added to those of the chunks before it (in program order).
void add_result(CompensateResult& t, const CompensateResult& c) {
  t.blocks += c.blocks;
  t.motions += c.motions;
  t.changed_blocks += c.changed_blocks;
  t.words_changed += c.words_changed;
  t.words_inserted += c.words_inserted;
  t.subdivided_blocks += c.subdivided_blocks;
  t.segments_added += c.segments_added;
  t.arcs_kept += c.arcs_kept;
  t.arcs_linearized += c.arcs_linearized;
  t.moves_split += c.moves_split;
  t.reference_moves += c.reference_moves;
  t.rapids_as_written += c.rapids_as_written;
  t.axis_limited_blocks += c.axis_limited_blocks;
  t.axis_limited_max_rad = std::max(t.axis_limited_max_rad, c.axis_limited_max_rad);
  for (const AxisLimitedBlock& a : c.axis_limited)
    if (t.axis_limited.size() < kMaxAxisLimitedListed) t.axis_limited.push_back(a);
  t.max_correction_mm = std::max(t.max_correction_mm, c.max_correction_mm);
  t.max_correction_deg = std::max(t.max_correction_deg, c.max_correction_deg);
  t.max_axis_correction_rad = std::max(t.max_axis_correction_rad, c.max_axis_correction_rad);
  if (c.max_error_before_mm > t.max_error_before_mm) {  // the first line of the largest, as one thread finds it
    t.max_error_before_mm = c.max_error_before_mm;
    t.worst_line = c.worst_line;
  }
  t.max_error_before_rad = std::max(t.max_error_before_rad, c.max_error_before_rad);
  t.max_residual_mm = std::max(t.max_residual_mm, c.max_residual_mm);
  t.max_residual_rad = std::max(t.max_residual_rad, c.max_residual_rad);
}

/// The options for the threads' own compensators: no progress reports, no line map.
CompensateOptions without_outputs(const CompensateOptions& opt) {
  CompensateOptions o = opt;
  o.progress = nullptr;
  o.line_map = nullptr;
  return o;
}

class ParallelRun final : public gcode::BlockVisitor {
 public:
  ParallelRun(std::string_view file, const gcode::Dialect& d, const machine::Machine& m, const CompensateOptions& opt,
              io::OutputFile& out, gcode::DiagnosticSink& sink, CompensateResult& r)
      : file_(file), d_(d), m_(m), opt_(opt), worker_opt_(without_outputs(opt)), out_(out), sink_(sink), r_(r),
        chunk_(std::max<std::size_t>(opt.chunk_blocks, 1)),
        warm_(std::min(opt.warmup_blocks, chunk_)), tracker_(file, d, m, worker_opt_, nullptr, discard_, scratch_) {
    tracker_.set_text_only(true);
    reader_sink_.on_report = [this](const gcode::Diagnostic& diag) {
      pending_.push_back(diag);
      tracker_.collector().report(diag);
    };
    // jobs − 1 workers: this thread reads the program and, while it waits for the oldest chunk,
    // corrects queued chunks itself.
    const unsigned n = std::max(1u, opt.jobs - 1);
    for (unsigned i = 0; i < n; ++i) threads_.emplace_back([this] { work(); });
  }
  ~ParallelRun() override {
    {
      std::lock_guard lock(mu_);
      stopping_ = true;
    }
    job_cv_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  ParallelRun(const ParallelRun&) = delete;
  ParallelRun& operator=(const ParallelRun&) = delete;

  gcode::DiagnosticSink& collector() { return reader_sink_; }
  void set_reader(const gcode::LineReader* in) { reader_ = in; }

  void block(const gcode::Block& b, std::span<const gcode::Motion> motions, bool lexed_ok) override {
    const std::uint64_t i = count_++;
    if (opt_.progress && reader_ != nullptr && (i & 8191) == 8191)
      opt_.progress("compensate", static_cast<double>(reader_->bytes_read()), static_cast<double>(opt_.input_bytes));
    // The next chunk's warm-up starts here: its start state is the text-derived state now.
    if (i + warm_ >= chunk_ && (i + warm_) % chunk_ == 0) {
      next_ = std::make_unique<Chunk>();
      next_->index = (i + warm_) / chunk_;
      next_->start.emplace(tracker_.carry());
    }
    if (i % chunk_ == 0) {
      if (current_) submit(std::move(current_));
      if (i == 0) {
        current_ = std::make_unique<Chunk>();
        current_->start.emplace(tracker_.carry());  // the program start: exact
      } else {
        current_ = std::move(next_);
        current_->warm = current_->blocks.size();
      }
    }
    current_->add(b, motions, pending_, lexed_ok);
    if (next_) next_->add(b, motions, pending_, lexed_ok);
    pending_.clear();
    tracker_.block(b, motions, lexed_ok);
  }

  void finish() {
    if (current_) submit(std::move(current_));
    while (!in_flight_.empty()) merge_front(true);
    for (gcode::Diagnostic& d : pending_) sink_.report(std::move(d));  // after the last block
    pending_.clear();
    r_.parallel_chunks = chunks_;
    r_.parallel_recomputed = recomputed_;
  }

 private:
  void submit(std::unique_ptr<Chunk> c) {
    c->seal();
    ++chunks_;
    Chunk* raw = c.get();
    {
      std::lock_guard lock(mu_);
      in_flight_.push_back(std::move(c));
      jobs_.push_back(raw);
    }
    job_cv_.notify_one();
    // Write what is done; hold the reader while too many chunks wait (bounded memory).
    while (!in_flight_.empty() && merge_front(in_flight_.size() >= std::max(1u, opt_.jobs) + 2)) {
    }
  }

  /// Writes the first chunk in flight if it is done (or, with `wait`, once it is). True if written.
  bool merge_front(bool wait) {
    Chunk* c = nullptr;
    {
      std::unique_lock lock(mu_);
      if (in_flight_.empty()) return false;
      c = in_flight_.front().get();
      if (!c->done && !wait) return false;
      while (!c->done) {
        if (!jobs_.empty()) {  // help: correct a queued chunk here instead of waiting idle
          Chunk* job = jobs_.front();
          jobs_.pop_front();
          lock.unlock();
          run_job(*job);
          lock.lock();
          continue;
        }
        done_cv_.wait(lock, [&] { return c->done || !jobs_.empty(); });
      }
    }
    if (c->error) std::rethrow_exception(c->error);
    if (previous_end_ && !(*c->guess == *previous_end_)) {
      ++recomputed_;
      correct(*c, *previous_end_);
      if (c->error) std::rethrow_exception(c->error);
    }
    out_.write(c->output);
    if (opt_.line_map != nullptr) opt_.line_map->insert(opt_.line_map->end(), c->line_map.begin(), c->line_map.end());
    for (gcode::Diagnostic& d : c->reported) sink_.report(std::move(d));
    add_result(r_, c->r);
    previous_end_ = std::move(c->end);
    std::lock_guard lock(mu_);
    in_flight_.pop_front();
    return true;
  }

  void work() {
    for (;;) {
      Chunk* c = nullptr;
      {
        std::unique_lock lock(mu_);
        job_cv_.wait(lock, [&] { return stopping_ || !jobs_.empty(); });
        if (jobs_.empty()) return;
        c = jobs_.front();
        jobs_.pop_front();
      }
      run_job(*c);
    }
  }

  /// A chunk's warm-up and correction, on whichever thread took it from the queue.
  void run_job(Chunk& c) {
    try {
      gcode::DiagnosticSink discard(0);
      CompensateResult scratch;
      Compensator warm(file_, d_, m_, worker_opt_, nullptr, discard, scratch);
      warm.restore(*c.start);
      for (std::size_t i = 0; i < c.warm; ++i) c.replay(warm, i);
      c.guess.emplace(warm.carry());
      correct(c, *c.guess);
    } catch (...) {
      c.error = std::current_exception();
    }
    {
      std::lock_guard lock(mu_);
      c.done = true;
    }
    done_cv_.notify_all();
  }

  /// Corrects the chunk's own blocks from state `from` into its output, report and diagnostics.
  void correct(Chunk& c, const Compensator::Carry& from) const {
    try {
      constexpr std::size_t kAll = std::numeric_limits<std::size_t>::max();
      gcode::DiagnosticSink local(kAll, kAll);
      CompensateResult r;
      c.line_map.clear();
      CompensateOptions o = worker_opt_;
      if (opt_.line_map != nullptr) o.line_map = &c.line_map;
      Compensator comp(file_, d_, m_, o, nullptr, local, r);
      comp.restore(from);
      for (std::size_t i = c.warm; i < c.blocks.size(); ++i) c.replay(comp, i);
      c.end.emplace(comp.carry());
      c.output = comp.take_output();
      c.reported = local.stored();
      c.r = r;
      c.error = nullptr;
    } catch (...) {
      c.error = std::current_exception();
    }
  }

  std::string_view file_;
  const gcode::Dialect& d_;
  const machine::Machine& m_;
  const CompensateOptions& opt_;
  CompensateOptions worker_opt_;
  io::OutputFile& out_;
  gcode::DiagnosticSink& sink_;
  CompensateResult& r_;
  const std::size_t chunk_, warm_;
  gcode::DiagnosticSink discard_{0};
  CompensateResult scratch_;
  Compensator tracker_;  ///< text-only: the text-derived state at every block
  gcode::DiagnosticSink reader_sink_{0};
  std::vector<gcode::Diagnostic> pending_;  ///< the reader's diagnostics since the last block
  const gcode::LineReader* reader_ = nullptr;
  std::uint64_t count_ = 0, chunks_ = 0, recomputed_ = 0;
  std::unique_ptr<Chunk> current_, next_;
  std::optional<Compensator::Carry> previous_end_;

  std::mutex mu_;
  std::condition_variable job_cv_, done_cv_;
  std::deque<std::unique_ptr<Chunk>> in_flight_;  ///< submitted, in program order
  std::deque<Chunk*> jobs_;                       ///< not yet taken by a worker
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace

CompensateResult compensate_parallel(gcode::LineReader& in, std::string_view file, const gcode::Dialect& dialect,
                                     const machine::Machine& m, const CompensateOptions& opt, io::OutputFile& out,
                                     gcode::DiagnosticSink& sink) {
  CompensateResult r;
  ParallelRun run(file, dialect, m, opt, out, sink, r);
  run.set_reader(&in);
  const gcode::ProgramStats st = gcode::run_program(in, dialect, file, run.collector(), run);
  run.finish();
  r.bytes_in = st.bytes;
  return r;
}

}  // namespace detail
}  // namespace postproc::comp
