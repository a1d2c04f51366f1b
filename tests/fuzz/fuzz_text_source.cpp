// Fuzz target: the CSV (ROCKLAB_FUZZ_LVM undefined) or LabVIEW .lvm reader,
// and the acquisition pipeline behind it. Input: the bytes of a file. When
// the first byte is odd, the lab rig's header is put before the rest, so
// that rows reach the Processor (sequence checks, reconstruction, the
// differentiators) with the fuzzer's times and values. When its second bit
// is set no rate is given, so the rate comes from the file's time column
// (or time base); otherwise the rig's 1000 Hz, checked against it.
// Invariants: opening throws only std::runtime_error/std::invalid_argument;
// an opened source has a finite rate > 0;
// Next() never throws (source.h): a read error or no usable row is kError
// with a message in error();
// every problem message is one bounded line of printable ASCII; the counters
// add up (bad rows <= rows; frames delivered + bad rows <= rows).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <sstream>
#include <string>

#include "daq/processor.h"
#include "daq/rig_config.h"
#include "daq/source.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using namespace rocklab::daq;

// The lab rig of data/rigs/lab_rig.toml, cut to the channels the mirror and
// the table need (kept here so that the target reads no file).
const char* const kRig = R"(name = "fuzz"
sample_rate_hz = 1000.0
[block]
width_m = 0.247
height_m = 1.0
[mirror]
lever_m = 2.0
[theta_dot]
window_s = 0.01
order = 2
[table]
window_s = 0.05
order = 4
[[channel]]
name = "mirror_s"
sensor = "mirror.s"
[[channel]]
name = "mirror_n"
sensor = "mirror.n"
[[channel]]
name = "table_x"
sensor = "table.displacement"
)";

class NullSink : public ProcessorSink {
 public:
  void OnProblem(const Problem& p) override { rocklab::fuzz::CheckMessage(p.message); }
  void OnEvent(const DaqEvent& e) override { rocklab::fuzz::CheckMessage(e.detail); }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const RigConfig rig = ParseRigConfig(kRig, "fuzz_rig.toml");
  std::string text;
  if (size > 0 && (data[0] & 1) != 0) {
#ifdef ROCKLAB_FUZZ_LVM
    text = "LabVIEW Measurement\t\nSeparator\tTab\n***End_of_Header***\n\nChannels\t3\nDelta_X\t0.001\n"
           "***End_of_Header***\nX_Value\tmirror_s\tmirror_n\ttable_x\tComment\n";
#else
    text = "time,mirror_s,mirror_n,table_x\n";
#endif
  }
  if (size > 0) text.append(reinterpret_cast<const char*>(data) + 1, size - 1);
  SourceOptions options;
  options.sample_rate_hz = size > 0 && (data[0] & 2) != 0 ? 0.0 : rig.sample_rate_hz;
  options.on_problem = [](const Problem& p) { rocklab::fuzz::CheckMessage(p.message); };
  std::unique_ptr<Source> source;
  try {
#ifdef ROCKLAB_FUZZ_LVM
    source = OpenLvmStream(std::make_unique<std::istringstream>(text), "fuzz.lvm", options);
#else
    source = OpenCsvStream(std::make_unique<std::istringstream>(text), "fuzz.csv", options);
#endif
  } catch (const std::runtime_error& e) {
    rocklab::fuzz::CheckMessage(e.what(), 4096);
    return 0;
  }
  const double rate_hz = source->sample_rate_hz();
  if (!(rate_hz > 0) || !std::isfinite(rate_hz)) rocklab::fuzz::Violated("an opened source without a rate");
  NullSink sink;
  std::unique_ptr<Processor> processor;
  try {
    processor = std::make_unique<Processor>(rig, source->channel_names(), source->path(), sink);
  } catch (const std::runtime_error&) {
    // Not the rig's channels: the reader alone.
  }
  Frame frame;
  std::int64_t frames = 0;
  ReadStatus status;
  while ((status = source->Next(frame)) == ReadStatus::kFrame) {
    ++frames;
    if (frame.values.size() != source->channel_names().size()) rocklab::fuzz::Violated("frame width");
    if (processor) processor->Process(frame);
  }
  if (status == ReadStatus::kError) {
    if (source->error().empty()) rocklab::fuzz::Violated("kError without a message");
    rocklab::fuzz::CheckMessage(source->error(), 4096);
    if (source->Next(frame) != ReadStatus::kError) rocklab::fuzz::Violated("kError did not stay");
  } else if (!source->error().empty()) {
    rocklab::fuzz::Violated("an error message without kError", source->error());
  }
  if (processor) processor->Finish();
  const SourceStats& st = source->stats();
  if (st.bad_rows > st.rows || frames + st.bad_rows > st.rows) rocklab::fuzz::Violated("row counts");
  return 0;
}
