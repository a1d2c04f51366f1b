#pragma once
/// @file
/// The acquisition pipeline of one source, as plain calls: sequence
/// accounting -> calibration and reconstruction -> checks and events ->
/// smoothing differentiators (theta_dot; table velocity and acceleration).
/// The DAQ node, `rocklab reconstruct` and the tests all drive this class, so
/// the same frames give the same outputs at any replay speed.

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/ring.h"
#include "daq/reconstruction.h"
#include "daq/rig_config.h"
#include "daq/savitzky_golay.h"
#include "daq/sequence_checker.h"
#include "daq/source.h"

namespace rocklab::daq {

/// Table motion at one sample (the table_state_t fields).
struct TableState {
  int64_t seq{};
  int64_t utime{};         ///< sample clock, us
  double time_s{};         ///< s
  double displacement{};   ///< m
  double velocity{};       ///< m/s
  double acceleration{};   ///< table acceleration u_g'', m/s^2
  int8_t accel_source{};   ///< table_state_t::ACCEL_ACCELEROMETER or ACCEL_DIFFERENTIATED
};

/// An event_t without the source name: kind is an event_t constant.
struct DaqEvent {
  int64_t utime{};
  int8_t kind{};
  double value{};
  std::string detail;
};

/// Receives the pipeline's outputs, in sample order. Block and table states
/// come together: the block state of a sample, then its table state (a
/// sample that has only one of them, e.g. a rig without a table channel,
/// gives that one alone), delayed by the longer of the two differentiators'
/// delays (Processor::output_delay_samples). Events are immediate.
/// Implementations must not throw.
class ProcessorSink {
 public:
  virtual ~ProcessorSink() = default;
  virtual void OnBlockState(const BlockState& /*state*/) {}
  virtual void OnTableState(const TableState& /*state*/) {}
  virtual void OnEvent(const DaqEvent& /*event*/) {}
  virtual void OnProblem(const Problem& /*problem*/) {}
};

struct ProcessorCounts {
  int64_t frames_in{};       ///< frames given to Process
  int64_t reconstructed{};   ///< frames reconstructed (in order, after gaps)
  int64_t rejected{};        ///< duplicate or out-of-order frames, reported and not reconstructed
  int64_t flagged{};         ///< block states with a check flag (sliding .. disagree)
  int64_t events{};
};

class Processor {
 public:
  /// `sink` is retained (non-owning) and must outlive the Processor;
  /// `source_path` names the source in problems.
  /// @throws std::runtime_error when a rig channel is missing from the source,
  ///         std::invalid_argument for unusable differentiator settings.
  Processor(const RigConfig& rig, const std::vector<std::string>& source_channels,
            const std::string& source_path, ProcessorSink& sink);

  /// One frame, in arrival order. Never throws.
  void Process(const Frame& frame);
  /// End of data: the delayed outputs still held are emitted.
  void Finish();

  const ProcessorCounts& counts() const { return counts_; }
  const SequenceCounts& sequence() const { return sequence_.counts(); }
  const ReconstructionCounts& reconstruction() const { return reconstructor_.counts(); }
  /// theta_dot's delay, samples: its half window (centred).
  int theta_delay_samples() const { return theta_.sg.delay_samples(); }
  /// The table differentiator's delay (its lag), samples: the rig's
  /// [table] lag_s when set; else theta_dot's delay (at most the table's
  /// half window) when an accelerometer measures the acceleration; else the
  /// table's half window (centred).
  int table_delay_samples() const { return table_.sg.delay_samples(); }
  /// Delay of the block and table states behind the newest frame, samples:
  /// the longer of the two (theta_dot's alone without a table channel).
  int output_delay_samples() const {
    return has_table_ ? std::max(theta_delay_samples(), table_delay_samples()) : theta_delay_samples();
  }

 private:
  // A differentiator and the states waiting for its output. A gap of at most
  // m samples (the half window, whatever the lag) is bridged by linear
  // interpolation of the input (those samples give no output); a longer gap
  // ends the segment.
  struct Stream {
    Stream(int half_window, int order, double dt_s, int lag);
    SavitzkyGolay sg;
    // A multi-body rig's theta stream: the bodies above the bottom one,
    // differentiated in step with sg (same inputs, gaps and ends, so the
    // same output indices).
    std::vector<SavitzkyGolay> upper;
    std::vector<double> upper_last;
    std::vector<BlockState> pending;  // ring indexed by SG input index
    std::vector<char> real;           // 0 for a bridged (interpolated) sample
    double last{};                    // last input value
    bool started{false};
    void Push(const BlockState& state, double value);
    void Gap(int64_t missing, double next_value, const BlockState& next);
    // Ends the segment; with drop_last the last input gives no output.
    void Restart(bool drop_last);
  };
  void Drain();
  // Sends the ready block and table states of the same samples together
  // (all that are ready when `flush`).
  void Pair(bool flush);
  void Event(int64_t utime, int8_t kind, double value, std::string detail);
  void CheckEdges(const BlockState& state);
  // The flag edges of one state (the block's, or body k's with `body_label`
  // naming it in the events' detail).
  template <class S>
  void FlagEdges(const S& state, int64_t utime, int32_t& held, const std::string& body_label);

  std::string source_path_;
  ProcessorSink& sink_;
  SequenceChecker sequence_;
  Reconstructor reconstructor_;
  bool has_table_;
  bool has_accelerometer_;
  Stream theta_;
  Stream table_;
  // Outputs waiting for the other stream's output of their sample; each
  // holds at most the difference of the two delays (sized for the larger half
  // window).
  common::Ring<BlockState> ready_theta_;
  common::Ring<TableState> ready_table_;
  BlockState current_;
  int32_t held_flags_{0};  // check flags as last measured (for event edges)
  std::array<int32_t, kMaxRigBodies> held_body_flags_{};  // the same per body (multi-body rig)
  std::vector<std::string> body_labels_;  // per body: "body 'NAME' (interface K)" 
  double last_time_s_{};   // time of the last reconstructed frame, s
  ProcessorCounts counts_;
};

}  // namespace rocklab::daq
