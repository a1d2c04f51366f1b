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

template <class S>
double FlagValue(const S& s, int32_t flag) {
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
  if (rig.multi_body()) {
    for (int k = 0; k < rig.body_count(); ++k) {
      body_labels_.push_back("body " + rig.bodies[static_cast<std::size_t>(k)].name + " (interface " +
                             std::to_string(k + 1) + ")");
      if (k == 0) continue;
      theta_.upper.emplace_back(rig.HalfWindow(rig.theta_dot), rig.theta_dot.order, 1.0 / rig.sample_rate_hz,
                                rig.HalfWindow(rig.theta_dot));
      theta_.upper.back().SetOutputs(false, true, false);
    }
    theta_.upper_last.assign(theta_.upper.size(), 0.0);
  }
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
  for (std::size_t k = 0; k < upper.size(); ++k) {
    upper_last[k] = state.bodies[k + 1].theta;
    upper[k].Push(upper_last[k]);
  }
  started = true;
}

void Processor::Stream::Gap(int64_t missing, double next_value, const BlockState& next) {
  if (!started) return;
  if (missing > sg.half_window()) {
    sg.Finish();  // never differentiate across a long gap
    for (SavitzkyGolay& u : upper) u.Finish();
    return;
  }
  auto bridge = [missing](double from, double to, int64_t i) {
    return from + (to - from) * static_cast<double>(i) / static_cast<double>(missing + 1);
  };
  for (int64_t i = 1; i <= missing; ++i) {
    real[sg.next_index() % real.size()] = 0;
    sg.Push(bridge(last, next_value, i));
    for (std::size_t k = 0; k < upper.size(); ++k) upper[k].Push(bridge(upper_last[k], next.bodies[k + 1].theta, i));
  }
}

void Processor::Stream::Restart(bool drop_last) {
  if (!started) return;
  if (drop_last && sg.next_index() > 0) real[(sg.next_index() - 1) % real.size()] = 0;
  sg.Finish();
  for (SavitzkyGolay& u : upper) u.Finish();
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
  bool flagged = (current_.flags & kCheckFlags) != 0;
  for (int k = 1; k < current_.body_count; ++k) flagged = flagged || (current_.bodies[static_cast<std::size_t>(k)].flags & kCheckFlags) != 0;
  if (flagged) ++counts_.flagged;

  if (status == SequenceStatus::kGap) {
    theta_.Gap(sequence_.missing(), current_.theta, current_);
    if (has_table_) table_.Gap(sequence_.missing(), current_.table_displacement, current_);
    Drain();
  }
  theta_.Push(current_, current_.theta);
  if (has_table_) table_.Push(current_, current_.table_displacement);
  Drain();
}

void Processor::CheckEdges(const BlockState& state) {
  if (state.body_count == 0) {
    FlagEdges(state, state.utime, held_flags_, std::string());
    return;
  }
  for (int k = 0; k < state.body_count; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    FlagEdges(state.bodies[kk], state.utime, held_body_flags_[kk], body_labels_[kk]);
  }
}

template <class S>
void Processor::FlagEdges(const S& state, int64_t utime, int32_t& held, const std::string& body_label) {
  for (const FlagEvent& f : kFlagEvents) {
    if (!(state.checked & f.flag)) continue;  // unmeasured: hold the last known state
    const bool now = (state.flags & f.flag) != 0;
    const bool before = (held & f.flag) != 0;
    if (now == before) continue;
    const std::string what = body_label.empty() ? std::string(f.name) : body_label + ": " + f.name;
    if (now) {
      held |= f.flag;
      Event(utime, f.kind, FlagValue(state, f.flag), what + " above tolerance");
    } else {
      held &= ~f.flag;
      Event(utime, rocklab::event_t::RECOVERED, 0, what + " back within tolerance");
    }
  }
}

void Processor::Drain() {
  SgOutput out;
  while (theta_.sg.Pop(out)) {
    const size_t slot = out.index % theta_.pending.size();
    BlockState& state = theta_.pending[slot];
    // The upper bodies' differentiators give the same index (in step),
    // bridged samples too.
    for (std::size_t k = 0; k < theta_.upper.size(); ++k) {
      SgOutput body_out;
      theta_.upper[k].Pop(body_out);
      state.bodies[k + 1].theta_dot = body_out.d1;
    }
    if (!theta_.real[slot]) continue;
    state.theta_dot = out.d1;
    if (state.body_count > 0) state.bodies[0].theta_dot = out.d1;
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
  for (SavitzkyGolay& u : theta_.upper) u.Finish();
  table_.sg.Finish();
  Drain();
  Pair(true);
}

}  // namespace rocklab::daq
