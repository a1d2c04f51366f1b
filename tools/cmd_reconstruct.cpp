// rocklab reconstruct --rig RIG.toml --input RAW --out THETA.csv: the
// acquisition pipeline offline, one CSV row per reconstructed sample.
#include <array>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "common/csv_number.h"
#include "common/field_tables.h"
#include "common/provenance.h"
#include "daq/processor.h"
#include "daq/rig_config.h"
#include "daq/source.h"
#include "pipeline/pipeline.h"
#include "pipeline/scenario.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct ReconstructOptions {
  std::string rig_path;
  std::string input;
  std::string out_csv;
  bool json{};
};

// Rows are formatted into a buffer written in blocks: the same text as
// printf's %.9f / %.12g / %d, without the format parsing and the stdio
// locking per field that were half of reconstruct's time. The numbers come
// from common/csv_number.h's exact integer path (a quarter of to_chars'
// cost with a precision, which was a third of the time after that), and
// from std::to_chars (specified as printf's conversion) where it declines.
class CsvSink : public daq::ProcessorSink {
 public:
  CsvSink() = default;
  ~CsvSink() override { Flush(); }
  /// The file the rows go to, from the header on; before it, problems only.
  /// `bodies` > 0: a multi-body rig's per-body columns (BodyColumns).
  void Start(std::FILE* out, int bodies) {
    out_ = out;
    bodies_ = bodies;
    std::string header = "time";
    if (bodies_ == 0) {
      HeaderVisitor names{header};
      common::BlockStateFields<daq::BlockState>(names);
    }
    for (int k = 1; k <= bodies_; ++k) {
      BodyHeaderVisitor names{header, "_" + std::to_string(k)};
      common::BlockStateFields<rocklab::block_state_t>(names);
    }
    header += '\n';
    std::fputs(header.c_str(), out_);
  }
  CsvSink(const CsvSink&) = delete;
  CsvSink& operator=(const CsvSink&) = delete;
  void OnBlockState(const daq::BlockState& s) override {
    if (kBuffer - used_ < kMaxRow * static_cast<std::size_t>(1 + bodies_)) Flush();
    Put(s.time_s, std::chars_format::fixed, 9);
    if (bodies_ > 0) {
      BodyColumns(s);
      return;
    }
    RowVisitor row{*this, s};
    common::BlockStateFields<daq::BlockState>(row);
    buffer_[used_++] = '\n';
    ++rows_;
  }
  /// Writes the buffered rows (before the file is closed).
  void Flush() {
    if (used_ > 0 && out_) std::fwrite(buffer_.data(), 1, used_, out_);
    used_ = 0;
    ++flushes_;
  }
  void OnProblem(const daq::Problem& p) override { Show(daq::ToString(p)); }
  void Show(const std::string& text) {
    if (++problems_ <= kShownProblems) std::fprintf(stderr, "rocklab: %s\n", text.c_str());
  }
  long rows() const { return rows_; }
  long problems() const { return problems_; }

 private:
  static constexpr std::size_t kBuffer = 1 << 16;
  // A row: 8 numbers (%.12g is at most 19 characters; %.9f of a time below
  // 1e15 s at most 26, a longer one goes through Put's fallback), an int,
  // separators.
  static constexpr std::size_t kMaxRow = 8 * 32 + 16;

  // The columns: the block state's fields that common/field_tables.h marks
  // kInReconstructCsv, in its order, after `time`.
  struct HeaderVisitor {
    std::string& header;
    template <class G>
    void Int(const char* name, const char*, G, unsigned outputs) { Add(name, outputs); }
    template <class G>
    void Real(const char* name, const char*, G, unsigned outputs) { Add(name, outputs); }
    void Add(const char* name, unsigned outputs) {
      if ((outputs & common::kInReconstructCsv) == 0) return;
      header += ',';
      header += name;
    }
  };
  // A multi-body rig's columns: per body K = 1.. bottom-up, every per-body
  // field of block_state2_t (its table: block_state_t's but utime and seq)
  // suffixed _K, as block_state2_t carries them (theta_K, ..., flags_K).
  struct BodyHeaderVisitor {
    std::string& header;
    std::string suffix;
    template <class G>
    void Int(const char* name, const char*, G, unsigned) { Add(name); }
    template <class G>
    void Real(const char* name, const char*, G, unsigned) { Add(name); }
    void Add(const char* name) {
      if (std::strcmp(name, "utime") == 0 || std::strcmp(name, "seq") == 0) return;
      header += ',';
      header += name;
      header += suffix;
    }
  };
  struct BodyRowVisitor {
    CsvSink& sink;
    std::size_t body;
    template <class G>
    void Int(const char*, const char*, G get, unsigned) {
      const auto& field = get(sink.bodies_msg_);
      if constexpr (common::kIsArray<decltype(field)>) {
        sink.buffer_[sink.used_++] = ',';
        sink.used_ = static_cast<std::size_t>(
            std::to_chars(&sink.buffer_[sink.used_], &sink.buffer_[kBuffer], field[body]).ptr - sink.buffer_.data());
      }
    }
    template <class G>
    void Real(const char*, const char*, G get, unsigned) {
      const auto& field = get(sink.bodies_msg_);
      if constexpr (common::kIsArray<decltype(field)>) {
        sink.buffer_[sink.used_++] = ',';
        sink.Put(field[body], std::chars_format::general, 12);
      }
    }
  };
  void BodyColumns(const daq::BlockState& s) {
    common::BodiesCopier<daq::BlockState, rocklab::block_state2_t> copy{s, bodies_msg_};
    common::BlockStateFields<rocklab::block_state_t>(copy);
    for (std::size_t k = 0; k < static_cast<std::size_t>(bodies_); ++k) {
      BodyRowVisitor row{*this, k};
      common::BlockStateFields<rocklab::block_state_t>(row);
    }
    buffer_[used_++] = '\n';
    ++rows_;
  }

  // One row's fields after `time`: %.12g, an integer in decimal.
  struct RowVisitor {
    CsvSink& sink;
    const daq::BlockState& s;
    std::size_t theta_at{}, theta_end{};
    int64_t flushes{-1};
    template <class G>
    void Int(const char*, const char*, G get, unsigned outputs) {
      if ((outputs & common::kInReconstructCsv) == 0) return;
      sink.buffer_[sink.used_++] = ',';
      sink.used_ = static_cast<std::size_t>(
          std::to_chars(&sink.buffer_[sink.used_], &sink.buffer_[kBuffer], get(s)).ptr - sink.buffer_.data());
    }
    template <class G>
    void Real(const char*, const char*, G get, unsigned outputs) {
      if ((outputs & common::kInReconstructCsv) == 0) return;
      sink.buffer_[sink.used_++] = ',';
      const double& v = get(s);
      if (&v == &s.theta) {
        theta_at = sink.used_;
        flushes = sink.flushes_;
        sink.Put(v, std::chars_format::general, 12);
        theta_end = sink.used_;
        return;
      }
      if (std::memcmp(&v, &s.theta, sizeof v) == 0 && flushes == sink.flushes_) {
        // theta is theta_mirror (or theta_camera) whenever that is valid: its text again.
        std::memcpy(&sink.buffer_[sink.used_], &sink.buffer_[theta_at], theta_end - theta_at);
        sink.used_ += theta_end - theta_at;
        return;
      }
      sink.Put(v, std::chars_format::general, 12);
    }
  };

  void Put(double v, std::chars_format format, int precision) {
    // The exact integer path (common/csv_number.h) where it applies, else to_chars.
    char* const at = &buffer_[used_];
    char* const fast = format == std::chars_format::fixed ? common::csv_number::Fixed9(v, at) : common::csv_number::General12(v, at);
    if (fast != nullptr) {
      used_ = static_cast<std::size_t>(fast - buffer_.data());
      return;
    }
    const auto r = std::to_chars(&buffer_[used_], &buffer_[kBuffer - 16], v, format, precision);
    if (r.ec == std::errc{}) {
      used_ = static_cast<std::size_t>(r.ptr - buffer_.data());
      return;
    }
    // Longer than a row's share (a fixed-point time beyond 1e15 s): printf it.
    Flush();
    std::fprintf(out_, format == std::chars_format::fixed ? "%.*f" : "%.*g", precision, v);
  }
  std::FILE* out_{};
  int bodies_{0};
  rocklab::block_state2_t bodies_msg_;  // a multi-body row, copied by the field table
  std::array<char, kBuffer> buffer_{};
  std::size_t used_{0};
  int64_t flushes_{0};  // a flush moves the row's text: nothing before it may be copied
  long rows_{0};
  long problems_{0};
};

int RunReconstruct(const ReconstructOptions& o) {
  const daq::RigConfig rig = pipeline::LoadRig(o.rig_path);
  // The input is opened before the output exists: a bad --input leaves a
  // previous --out as it was (and the output is renamed only when complete).
  std::unique_ptr<pipeline::OutputFile> out;  // declared before the sink: outlives its last Flush
  CsvSink sink;
  daq::SourceOptions options;
  options.sample_rate_hz = rig.sample_rate_hz;
  options.rig = &rig;
  for (const auto& c : rig.channels) options.fallback_channel_names.push_back(c.name);
  options.on_problem = [&sink](const daq::Problem& p) { sink.Show(daq::ToString(p)); };
  std::unique_ptr<daq::Source> source;
  std::unique_ptr<daq::Processor> processor;
  try {
    source = daq::OpenSource(InputFile("RAW", o.input), options);
    // The units the file states against the rig's (as the DAQ node does).
    for (const std::string& w :
         daq::CheckFileUnits(rig, source->channel_names(), source->channel_units(), source->path())) {
      sink.Show(w);
    }
  } catch (const std::exception& e) {
    throw UsageError(std::string("--input: ") + e.what());
  }
  out = std::make_unique<pipeline::OutputFile>(o.out_csv);
  sink.Start(out->get(), rig.multi_body() ? rig.body_count() : 0);
  try {
    processor = std::make_unique<daq::Processor>(rig, source->channel_names(), source->path(), sink);
  } catch (const std::exception& e) {
    throw UsageError(std::string("--input: ") + e.what());
  }
  daq::Frame frame;
  daq::ReadStatus status;
  while ((status = source->Next(frame)) == daq::ReadStatus::kFrame) processor->Process(frame);
  processor->Finish();
  sink.Flush();
  out->Close();
  common::WriteProvenanceSidecar(o.out_csv, {o.input, o.rig_path});  // beside it: the CSV stays as readers expect

  const daq::SourceStats& src = source->stats();
  const daq::SequenceCounts& seq = processor->sequence();
  const daq::ReconstructionCounts& rec = processor->reconstruction();
  if (sink.problems() > kShownProblems) {
    std::fprintf(stderr, "rocklab: %ld more problems not shown\n", sink.problems() - kShownProblems);
  }
  const nlohmann::json result = {
      {"input", o.input},
      {"out", o.out_csv},
      {"rows_written", sink.rows()},
      {"rows_read", src.rows},
      {"bad_rows", src.bad_rows},
      {"bad_values", src.bad_values},
      {"gaps", seq.gaps},
      {"samples_missing", seq.missing},
      {"duplicates", seq.duplicates},
      {"out_of_order", seq.out_of_order},
      {"invalid_led_samples", rec.invalid_led_samples},
      {"flagged", processor->counts().flagged},
      {"problems", sink.problems()},
      {"damaged_regions", src.damaged_regions},
      {"read_error", status == daq::ReadStatus::kError ? nlohmann::json(source->error()) : nlohmann::json(nullptr)}};
  if (o.json) WriteResult(result, true, "", o.out_csv == "-");
  std::fprintf(stderr,
               "%ld rows written to %s; %lld rows read, %lld bad rows, %lld bad values, "
               "%lld gaps (%lld samples missing), %lld duplicate, %lld out of order, "
               "%lld invalid LED samples, %lld flagged\n",
               sink.rows(), o.out_csv.c_str(), static_cast<long long>(src.rows),
               static_cast<long long>(src.bad_rows), static_cast<long long>(src.bad_values),
               static_cast<long long>(seq.gaps), static_cast<long long>(seq.missing),
               static_cast<long long>(seq.duplicates), static_cast<long long>(seq.out_of_order),
               static_cast<long long>(rec.invalid_led_samples),
               static_cast<long long>(processor->counts().flagged));
  // A source's own counts (a video's: frames, drops, LED samples missing, merged, ...).
  if (const std::string more = source->summary(); !more.empty()) std::fprintf(stderr, "%s\n", more.c_str());
  if (status == daq::ReadStatus::kError) {
    // The rows before it were reconstructed and written; the exit code says
    // the input was not read to its end.
    std::fprintf(stderr, "rocklab: %s\n", source->error().c_str());
    return kFailureExit;
  }
  // Every readable frame was reconstructed; the exit code says the log is damaged.
  return pipeline::ReportDamage(src.damaged_regions, src.damaged_bytes, src.damaged_events, o.input,
                                "rocklab", "; the rest was read") == 0
             ? 0
             : kFailureExit;
}

}  // namespace

void RegisterReconstruct(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<ReconstructOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("reconstruct", "reconstruct theta and the checks from a raw file");
  cmd->add_option("--rig", opts->rig_path, "rig configuration (TOML)")->required();
  cmd->add_option("input,--input", opts->input, "raw file: .csv, .lvm, an LCM log, or video:FILE (docs/video.md)")->required();
  cmd->add_option("--out", opts->out_csv,
                  "output CSV: time,theta,theta_dot,theta_mirror,theta_camera,sliding,twist,"
                  "out_of_plane,flags (s, rad, rad/s, rad, rad, m, rad, m, bitmask); a rig of several "
                  "[[body]] tables: time, then per body K theta_K,theta_dot_K,theta_mirror_K,theta_camera_K,"
                  "sliding_K,jump_K,twist_K,out_of_plane_K,leds_used_K,flags_K")
      ->required();
  AddJsonFlag(*cmd, opts->json);
  cmd->callback([opts, &run] { run = [opts] { return RunReconstruct(*opts); }; });
}

}  // namespace rocklab::tools
