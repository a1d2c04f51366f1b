#include "daq/processor.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "rocklab/event_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::daq {
namespace {

constexpr int32_t kCheckFlags =
    kFlagSliding | kFlagJump | kFlagTwist | kFlagOutOfPlane | kFlagDisagree;

struct FlagEvent {
  int32_t flag;
  int8_t kind;
  const char* name;
};
constexpr FlagEvent kFlagEvents[] = {
    {kFlagSliding, rocklab::event_t::SLIDING, "sliding"},
    {kFlagJump, rocklab::event_t::JUMP, "jump"},
    {kFlagTwist, rocklab::event_t::TWIST, "twist"},
    {kFlagOutOfPlane, rocklab::event_t::OUT_OF_PLANE, "out-of-plane"},
    {kFlagDisagree, rocklab::event_t::DISAGREE, "mirror-camera disagreement"},
};

double FlagValue(const BlockState& s, int32_t flag) {
  switch (flag) {
    case kFlagSliding: return s.sliding;
    case kFlagJump: return s.jump;
    case kFlagTwist: return s.twist;
    case kFlagOutOfPlane: return std::isfinite(s.out_of_plane) ? s.out_of_plane : s.tilt;
    case kFlagDisagree: return s.theta_mirror - s.theta_camera;
    default: return 0;
  }
}

int TableLagSamples(const RigConfig& rig, bool has_accelerometer) {
  if (rig.table.lag_s) return rig.LagSamples(rig.table);
  // The model needs only the measured acceleration: the velocity need not
  // hold the pair back beyond theta_dot's delay.
  if (has_accelerometer) return std::min(rig.HalfWindow(rig.table), rig.HalfWindow(rig.theta_dot));
  return rig.HalfWindow(rig.table);
}

}  // namespace

Processor::Processor(const RigConfig& rig, const std::vector<std::string>& source_channels,
                     const std::string& source_path, ProcessorSink& sink)
    : source_path_(source_path),
      sink_(sink),
      reconstructor_(rig, source_channels, source_path),
      has_table_(reconstructor_.has_table_displacement() || reconstructor_.has_accelerometer()),
      has_accelerometer_(reconstructor_.has_accelerometer()),
      theta_(rig.HalfWindow(rig.theta_dot), rig.theta_dot.order, 1.0 / rig.sample_rate_hz,
             rig.HalfWindow(rig.theta_dot)),
      table_(rig.HalfWindow(rig.table), rig.table.order, 1.0 / rig.sample_rate_hz,
             TableLagSamples(rig, has_accelerometer_)),
      ready_theta_(2 * static_cast<std::size_t>(std::max(theta_.sg.half_window(), table_.sg.half_window())) + 2),
      ready_table_(ready_theta_.capacity()) {
  // Only the derivatives in use: theta_dot; the table velocity, and the
  // acceleration where no accelerometer measures it.
  theta_.sg.SetOutputs(false, true, false);
  table_.sg.SetOutputs(false, true, !has_accelerometer_);
}

Processor::Stream::Stream(int half_window, int order, double dt_s, int lag)
    : sg(half_window, order, dt_s, lag),
      // At most 2m+1 inputs wait for their output (the last m after Finish).
      pending(2 * half_window + 1),
      real(2 * half_window + 1, 0) {}

void Processor::Stream::Push(const BlockState& state, double value) {
  const size_t slot = sg.next_index() % pending.size();
  pending[slot] = state;
  real[slot] = 1;
  sg.Push(value);
  last = value;
  started = true;
}

void Processor::Stream::Gap(int64_t missing, double next_value) {
  if (!started) return;
  if (missing > sg.half_window()) {
    sg.Finish();  // never differentiate across a long gap
    return;
  }
  for (int64_t i = 1; i <= missing; ++i) {
    real[sg.next_index() % real.size()] = 0;
    sg.Push(last + (next_value - last) * static_cast<double>(i) / static_cast<double>(missing + 1));
  }
}

void Processor::Stream::Restart(bool drop_last) {
  if (!started) return;
  if (drop_last && sg.next_index() > 0) real[(sg.next_index() - 1) % real.size()] = 0;
  sg.Finish();
  started = false;
}

void Processor::Event(int64_t utime, int8_t kind, double value, std::string detail) {
  ++counts_.events;
  sink_.OnEvent(DaqEvent{utime, kind, value, std::move(detail)});
}

void Processor::Process(const Frame& frame) {
  ++counts_.frames_in;
  const SequenceStatus status = sequence_.Check(frame.seq, frame.utime());
  if (status == SequenceStatus::kDuplicate || status == SequenceStatus::kOutOfOrder) {
    ++counts_.rejected;
    std::ostringstream msg;
    msg << "frame seq " << frame.seq << " at t = " << frame.time_s << " s is "
        << ToString(status) << " (published raw, not reconstructed)";
    sink_.OnProblem(Problem{{&source_path_, frame.line}, msg.str()});
    Event(frame.utime(), rocklab::event_t::BAD_SAMPLE, 1, msg.str());
    return;
  }
  if (status == SequenceStatus::kReanchored) {
    // A bad timestamp (sequence_checker.h): the segment ends here, and what
    // was made of an isolated bad frame is withdrawn.
    std::ostringstream msg;
    if (sequence_.last_was_bad()) {
      msg << "the frame before (t = " << last_time_s_ << " s) had a bad timestamp: its gap is withdrawn, "
          << "its sample not reconstructed";
      --counts_.reconstructed;
      ++counts_.rejected;
    } else {
      msg << SequenceChecker::kReanchorRun << " frames in a row behind the reference: the sample clock "
          << "is re-anchored at seq " << frame.seq << ", t = " << frame.time_s << " s";
    }
    sink_.OnProblem(Problem{{&source_path_, frame.line}, msg.str()});
    Event(frame.utime(), rocklab::event_t::BAD_SAMPLE, 1, msg.str());
    theta_.Restart(sequence_.last_was_bad());
    table_.Restart(sequence_.last_was_bad());
    Drain();
  }
  if (sequence_.missing() > 0) {
    std::ostringstream msg;
    msg << sequence_.missing() << " samples missing before seq " << frame.seq;
    sink_.OnProblem(Problem{{&source_path_, frame.line}, msg.str()});
    Event(frame.utime(), rocklab::event_t::GAP, static_cast<double>(sequence_.missing()), msg.str());
  }

  reconstructor_.Reconstruct(frame, current_);
  ++counts_.reconstructed;
  last_time_s_ = frame.time_s;
  CheckEdges(current_);
  if (current_.flags & kCheckFlags) ++counts_.flagged;

  if (status == SequenceStatus::kGap) {
    theta_.Gap(sequence_.missing(), current_.theta);
    if (has_table_) table_.Gap(sequence_.missing(), current_.table_displacement);
    Drain();
  }
  theta_.Push(current_, current_.theta);
  if (has_table_) table_.Push(current_, current_.table_displacement);
  Drain();
}

void Processor::CheckEdges(const BlockState& state) {
  for (const FlagEvent& f : kFlagEvents) {
    if (!(state.checked & f.flag)) continue;  // unmeasured: hold the last known state
    const bool now = (state.flags & f.flag) != 0;
    const bool before = (held_flags_ & f.flag) != 0;
    if (now == before) continue;
    if (now) {
      held_flags_ |= f.flag;
      Event(state.utime, f.kind, FlagValue(state, f.flag), std::string(f.name) + " above tolerance");
    } else {
      held_flags_ &= ~f.flag;
      Event(state.utime, rocklab::event_t::RECOVERED, 0, std::string(f.name) + " back within tolerance");
    }
  }
}

void Processor::Drain() {
  SgOutput out;
  while (theta_.sg.Pop(out)) {
    const size_t slot = out.index % theta_.pending.size();
    if (!theta_.real[slot]) continue;
    BlockState& state = theta_.pending[slot];
    state.theta_dot = out.d1;
    if (!has_table_) {
      sink_.OnBlockState(state);
      continue;
    }
    if (ready_theta_.full()) {  // Pair left the table ring empty: nothing to wait for
      sink_.OnBlockState(ready_theta_.front());
      ready_theta_.pop_front();
    }
    ready_theta_.push_back(state);
    Pair(false);
  }
  while (table_.sg.Pop(out)) {
    const size_t slot = out.index % table_.pending.size();
    if (!table_.real[slot]) continue;
    const BlockState& s = table_.pending[slot];
    TableState t;
    t.seq = s.seq;
    t.utime = s.utime;
    t.time_s = s.time_s;
    t.displacement = s.table_displacement;
    t.velocity = out.d1;
    if (has_accelerometer_) {
      t.acceleration = s.table_acceleration;
      t.accel_source = rocklab::table_state_t::ACCEL_ACCELEROMETER;
    } else {
      t.acceleration = out.d2;
      t.accel_source = rocklab::table_state_t::ACCEL_DIFFERENTIATED;
    }
    if (ready_table_.full()) {  // Pair left the theta ring empty
      sink_.OnTableState(ready_table_.front());
      ready_table_.pop_front();
    }
    ready_table_.push_back(t);
    Pair(false);
  }
}

void Processor::Pair(bool flush) {
  // Both rings are in sample order: the lower seq at the fronts goes first;
  // one without its partner (the other stream skipped that sample) goes alone.
  while (!ready_theta_.empty() && !ready_table_.empty()) {
    const int64_t a = ready_theta_.front().seq;
    const int64_t b = ready_table_.front().seq;
    if (a <= b) {
      sink_.OnBlockState(ready_theta_.front());
      ready_theta_.pop_front();
    }
    if (b <= a) {
      sink_.OnTableState(ready_table_.front());
      ready_table_.pop_front();
    }
  }
  if (!flush) return;
  for (; !ready_theta_.empty(); ready_theta_.pop_front()) sink_.OnBlockState(ready_theta_.front());
  for (; !ready_table_.empty(); ready_table_.pop_front()) sink_.OnTableState(ready_table_.front());
}

void Processor::Finish() {
  theta_.sg.Finish();
  table_.sg.Finish();
  Drain();
  Pair(true);
}

}  // namespace rocklab::daq
