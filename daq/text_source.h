#pragma once
// The private header of the CSV and LVM sources (csv_source.cpp,
// lvm_source.cpp).
//
// CSV and LabVIEW .lvm sources: one line-oriented reader, two header parsers.
// The lines come from a detail::LineInput: a file read to its end, a file
// followed as it grows (--follow) or a TCP stream (tcp://). A live input may
// have nothing yet (Next returns kIdle) or start over (a replaced file, a
// reconnection): the header is read again and the time continues. A line
// is a view into the input's block buffer (line_input.h), split into views
// (fields_) and parsed in place with std::from_chars: nothing is copied or
// allocated per row.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "daq/line_input.h"
#include "daq/source.h"
#include "common/cancel.h"
#include "common/text.h"
#include "common/units.h"

namespace rocklab::daq {
namespace text_detail {

using common::ParseNumber;
using common::Quote;
using common::Split;
using common::Trim;

using common::kNaN;
// A line longer than this is skipped (a row) or refused (a header): a
// corrupt file with no line ends must not take the memory of the host.
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;
// Times beyond +-1e12 s (31 700 years) are corrupt: they would overflow the
// int64 microseconds every message carries and the sample numbering.
inline constexpr double kMaxAbsTimeS = 1e12;
// UTF-8 byte order mark (EF BB BF), ignored before the first line.
inline constexpr std::string_view kByteOrderMark{"\xEF\xBB\xBF"};
// Sample rates a file's time base may give, Hz.
inline constexpr double kMinRateHz = 1e-6;
inline constexpr double kMaxRateHz = 1e6;

// A given rate and the file's own (its time column or time base) agree
// when within this fraction: at 0.1 % the sample numbers drift by one
// every 1000 samples, which a seq gap count would already show.
inline constexpr double kRateAgreement = 1e-3;
// Data rows a file's time column is read ahead for its rate.
inline constexpr std::size_t kRateProbeRows = 256;

// The sample rate of a run of times (in file order, NaN skipped), Hz: the
// median positive step, refined over the whole span (span / its number of
// steps at the median, so that dropped samples and times printed to few
// digits do not bias it). nullopt without two increasing times.
inline std::optional<double> RateOfTimes(const std::vector<double>& times) {
  std::vector<double> steps;
  std::optional<double> first;
  std::optional<double> last;
  for (double t : times) {
    if (!std::isfinite(t)) continue;
    if (last && t > *last) steps.push_back(t - *last);
    if (!first) first = t;
    last = t;
  }
  if (steps.empty() || !(*last > *first)) return std::nullopt;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  const double median = steps[steps.size() / 2];
  const double span = *last - *first;
  const double n = std::round(span / median);
  return n >= 1 ? n / span : 1.0 / median;
}

// 10^k, k in [0, 22]: exact doubles.
inline constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

// The common field, "[+-]DIGITS[.DIGITS]" (no blanks, no exponent, at most
// 19 digits), read to the same double as std::from_chars (ParseNumber)
// reads it: the digits as an integer w <= 2^53 and w / 10^k with k <= 22
// are exact doubles, and one IEEE division rounds their quotient correctly,
// as from_chars must (Clinger's fast path). False for anything else, which
// goes to ParseNumber: a false here decides nothing.
inline bool ParsePlainDecimal(std::string_view field, double& out) {
  const char* p = field.data();
  const char* const end = p + field.size();
  bool negative = false;
  if (p != end && (*p == '-' || *p == '+')) negative = *p++ == '-';
  uint64_t w = 0;
  int digits = 0;
  int before_point = -1;  // digits before the '.', -1 without one
  for (; p != end; ++p) {
    const auto d = static_cast<unsigned>(*p - '0');
    if (d < 10) {
      if (++digits > 19) return false;
      w = w * 10 + d;
    } else if (*p == '.' && before_point < 0) {
      before_point = digits;
    } else {
      return false;
    }
  }
  const int k = before_point < 0 ? 0 : digits - before_point;
  if (digits == 0 || before_point == 0 || (before_point > 0 && k == 0)) return false;  // "", ".5", "5."
  if (w > (uint64_t{1} << 53) || k > 22) return false;
  const double v = static_cast<double>(w) / kPow10[k];
  out = negative ? -v : v;
  return true;
}

// common::Split for data rows: a byte loop, which beats a memchr call per
// field on fields of a few bytes. Same fields: `line` cut at every `sep`.
inline void SplitRow(std::string_view line, char sep, std::vector<std::string_view>& fields) {
  fields.clear();
  const char* start = line.data();
  const char* const end = start + line.size();
  for (const char* p = start; p != end; ++p) {
    if (*p == sep) {
      fields.emplace_back(start, static_cast<std::size_t>(p - start));
      start = p + 1;
    }
  }
  fields.emplace_back(start, static_cast<std::size_t>(end - start));
}

// State shared by the text formats: the file, the current line, the column
// layout of the current block of rows and the time base.
class TextSource : public Source {
 public:
  TextSource(std::unique_ptr<detail::LineInput> input, const std::string& path, const SourceOptions& options)
      : path_(path),
        input_(std::move(input)),
        on_problem_(options.on_problem),
        on_wait_(options.on_wait),
        given_rate_hz_(options.sample_rate_hz),
        rate_origin_(options.rate_origin) {
    if (!(given_rate_hz_ == 0 || (given_rate_hz_ >= kMinRateHz && given_rate_hz_ <= kMaxRateHz))) {
      std::ostringstream msg;
      msg << path << ": " << rate_origin_ << " " << given_rate_hz_
          << " Hz: a sample rate must be in [1e-6, 1e6] Hz (or 0: from the file's time column)";
      throw std::invalid_argument(msg.str());
    }
  }
  bool live() const override { return input_->live(); }

  const std::vector<std::string>& channel_names() const override { return names_; }
  std::vector<std::string> channel_units() const override { return units_; }
  bool has_comments() const override { return comments_column_; }
  double sample_rate_hz() const override { return rate_hz_; }
  const SourceStats& stats() const override { return stats_; }
  const std::string& path() const override { return path_; }

  // The streaming path never throws (source.h): what would stop the read is
  // kError, reported and kept in error_.
  ReadStatus Next(Frame& frame) final {
    if (!error_.empty()) return ReadStatus::kError;
    try {
      return ReadNext(frame);
    } catch (const Idle&) {
      return ReadStatus::kIdle;
    } catch (const std::exception& e) {
      error_ = e.what();
      if (error_.empty()) error_ = path_ + ": the read cannot go on";
      if (on_problem_) {
        // The location is the problem's: the message without its "path: " prefix.
        std::string what = error_;
        if (what.rfind(path_ + ": ", 0) == 0) what.erase(0, path_.size() + 2);
        on_problem_(Problem{{&path_, line_no_}, what});
      }
      return ReadStatus::kError;
    }
  }

 protected:
  // The format's reader: may throw std::runtime_error naming the file when
  // the read cannot go on; Next turns that into kError.
  virtual ReadStatus ReadNext(Frame& frame) = 0;

  // The file's own rate (`what` says from what) against the one given, if
  // any: a disagreement stops the read, naming both.
  void CheckGivenRate(double file_rate_hz, const std::string& what) const {
    if (given_rate_hz_ == 0 || std::abs(given_rate_hz_ - file_rate_hz) <= kRateAgreement * file_rate_hz) return;
    std::ostringstream msg;
    msg.precision(10);
    msg << what << " gives a sample rate of " << file_rate_hz << " Hz, but " << rate_origin_ << " is "
        << given_rate_hz_ << " Hz (they must agree within 0.1 %)";
    Fail(msg.str());
  }

  [[noreturn]] void Fail(const std::string& what) const {
    std::ostringstream msg;
    msg << path_ << ":" << line_no_ << ": " << what;
    throw std::runtime_error(msg.str());
  }

  void Report(const std::string& what) {
    if (on_problem_) on_problem_(Problem{{&path_, line_no_}, what});
  }

  // Thrown by ReadDataLine when a live input has nothing yet; Next turns it
  // into kIdle. Not a std::exception: it is not an error.
  struct Idle {};

  // Reads the next line into line_ (without its '\n'); false at the end of
  // the input. A line longer than kMaxLineBytes is cut there (line_too_long_
  // says so) and the rest of it skipped. A live input's line broken off
  // before its '\n' sets line_cut_ (never a whole row). A read error is
  // never the end of the file: it throws, naming the file and the last line
  // read. A live input waits here (headers are read whole), calling
  // on_wait_ every wait slice. When the input started over, the line is the
  // first of the new stream and restarted_ is set.
  bool ReadLine(bool may_idle = false) {
    common::PollThreadCancel();  // ReadCancelled is not a std::exception: Next lets it through
    line_cut_ = false;
    // Waiting in slices lets on_wait_ run (the node's heartbeat).
    const bool in_slices = may_idle || (on_wait_ && input_->live());
    while (true) {
      detail::LineStatus got;
      try {
        got = input_->Read(line_, line_too_long_, kMaxLineBytes, in_slices);
      } catch (const std::exception& e) {
        std::ostringstream msg;
        msg << path_ << ": read error after line " << line_no_ << " (" << e.what()
            << "): the rest of the file is not read";
        throw std::runtime_error(msg.str());
      }
      if (got == detail::LineStatus::kEnd) return false;
      if (got == detail::LineStatus::kIdle) {
        if (may_idle) throw Idle{};
        on_wait_();
        continue;
      }
      line_cut_ = got == detail::LineStatus::kCut;
      if (got == detail::LineStatus::kRestart) {
        ++stats_.restarts;
        restarted_ = true;
        line_no_ = 0;
        continue;
      }
      break;
    }
    ++line_no_;
    if (line_no_ == 1 && line_.substr(0, 3) == kByteOrderMark) {
      line_.remove_prefix(3);  // a BOM must not hide the first column
    }
    return true;
  }
  // ReadLine for data rows: a live input with nothing yet ends this Next
  // with kIdle (nothing is consumed, the next call goes on from here).
  bool ReadDataLine() { return ReadLine(true); }

  bool ParseValue(std::string_view field, double& v) const {
    if (decimal_ != Decimal::kComma && ParsePlainDecimal(Trim(field), v)) return true;
    if (decimal_ == Decimal::kSniff) return ParseNumber(field, false, v) || ParseNumber(field, true, v);
    return ParseNumber(field, decimal_ == Decimal::kComma, v);
  }

  // After a restart the first row's time decides how the sample clock goes
  // on: later than the last sample, the gap is samples lost while the input
  // was away (counted); not later (the writer's clock started again), the
  // rows are moved to follow the last sample, and what was lost cannot be
  // known (reported).
  void ContinueAfterRestart(double& t) {
    rebase_pending_ = false;
    if (!last_time_) return;
    const double step = 1.0 / rate_hz_;
    if (t > *last_time_) {
      const int64_t lost = std::llround((t - *last_time_) * rate_hz_) - 1;
      if (lost > 0) stats_.restart_lost += lost;
      std::ostringstream msg;
      msg << "input restarted (" << stats_.restarts << "): " << (lost > 0 ? lost : 0)
          << " samples lost while it was away (from the time column)";
      ++stats_.warnings;
      Report(msg.str());
      return;
    }
    time_offset_s_ += *last_time_ + step - t;
    t = *last_time_ + step;
    std::ostringstream msg;
    msg << "input restarted (" << stats_.restarts << ") with its time going back: its samples follow the "
        << "last one; samples lost while it was away cannot be counted";
    ++stats_.warnings;
    Report(msg.str());
  }

  // A row a live input broke off before its line end (a dropped
  // connection, a replaced file, the stop or the idle timeout): its last
  // field may be cut short, so it is no sample. Reported, counted as bad.
  bool SkipCutRow() {
    if (!line_cut_ || Trim(line_).empty()) return false;  // a blank one is skipped as any blank line
    ++stats_.rows;
    ++stats_.bad_rows;
    Report("row cut before its line end (the input broke off or ended): " + Quote(line_) + " (row skipped)");
    return true;
  }

  // A header line a live input broke off before its line end: the read
  // cannot go on with a header cut short (its last name would be wrong).
  void FailIfHeaderCut() const {
    if (!line_cut_) return;
    Fail("incomplete header: " + std::to_string(line_.size()) + " bytes of a header line (" + Quote(line_) +
         ") without its line end when the input " + (live() ? "broke off or ended" : "ended"));
  }

  // A line cut by ReadLine: reported, counted as a bad row.
  bool SkipLongRow() {
    if (!line_too_long_) return false;
    ++stats_.rows;
    ++stats_.bad_rows;
    Report("row longer than " + std::to_string(kMaxLineBytes) + " bytes (row skipped)");
    return true;
  }

  // End of the data: a file whose every data row was bad is an error, not
  // an empty record that looks like a success.
  ReadStatus End() {
    if (stats_.rows > 0 && frames_ == 0) {
      std::ostringstream msg;
      msg << path_ << ": none of the " << stats_.rows << " data rows could be used (each is reported above)";
      throw std::runtime_error(msg.str());
    }
    return ReadStatus::kEnd;
  }

  // Parses line_ (already split into fields_) as a data row. `k` is the row's
  // index in its block (used when there is no time column). Returns false for
  // a row that was skipped (reported and counted).
  bool ParseRow(int64_t k, Frame& frame) {
    ++stats_.rows;
    size_t n = fields_.size();
    frame.comment.clear();
    if (has_comment_) {
      // LVM's Comment column: the text after the data columns (a tab in it
      // splits it: joined back).
      if (n > columns_) {
        const char* begin = fields_[columns_].data();
        const char* end = fields_.back().data() + fields_.back().size();
        const std::string_view text = Trim(std::string_view(begin, static_cast<size_t>(end - begin)));
        if (!text.empty()) {
          frame.comment = common::ToUtf8(text);
          ++stats_.comments;
        }
        n = columns_;
      }
    } else if (n == columns_ + 1 && Trim(fields_.back()).empty()) {
      --n;  // a trailing separator
    }
    if (n != columns_) {
      ++stats_.bad_rows;
      std::ostringstream msg;
      msg << "row has " << n << " fields, the header has " << columns_ << " (row skipped)";
      Report(msg.str());
      return false;
    }
    double t = 0;
    if (time_col_ >= 0) {
      if (!ParseValue(fields_[time_col_], t) || !std::isfinite(t)) {
        ++stats_.bad_rows;
        Report("time " + Quote(Trim(fields_[time_col_])) + " is not a finite number (row skipped)");
        return false;
      }
      CheckOtherXColumns(t);
    } else {
      t = x0_s_ + static_cast<double>(k) / rate_hz_;
    }
    t += time_offset_s_;
    if (rebase_pending_) ContinueAfterRestart(t);
    if (!(std::abs(t) <= kMaxAbsTimeS)) {
      ++stats_.bad_rows;
      std::ostringstream msg;
      msg << "time " << t << " s is outside [-1e12, 1e12] s (row skipped)";
      Report(msg.str());
      return false;
    }
    if (!first_time_) first_time_ = t;
    last_time_ = t;
    frame.time_s = t;
    frame.seq = std::llround((t - *first_time_) * rate_hz_);
    frame.line = line_no_;
    frame.values.resize(names_.size());
    for (size_t i = 0; i < value_cols_.size(); ++i) {
      double v = kNaN;
      const std::string_view field = fields_[value_cols_[i]];
      if (Trim(field).empty()) {
        // A channel with no data in this row: NaN, counted; reported once per column.
        ++stats_.empty_values;
        if (empty_reported_.size() != names_.size()) empty_reported_.assign(names_.size(), false);
        if (!empty_reported_[i]) {
          empty_reported_[i] = true;
          Report("column " + Quote(names_[i]) +
                 " has an empty field (NaN; later empty fields of this column are counted, not reported)");
        }
      } else if (!ParseValue(field, v)) {
        v = kNaN;
        ++stats_.bad_values;
        Report("column " + Quote(names_[i]) + ": " + Quote(Trim(field)) +
               " is not a number (sample set to NaN)");
      }
      frame.values[i] = v;
    }
    ++frames_;
    return true;
  }

  // X_Columns Multi: the first X column is the time; the others should agree
  // within 1% of a sample step (they are the same clock printed again; a
  // whole sample off is a real misalignment). Disagreeing rows are counted,
  // the first of each segment reported.
  void CheckOtherXColumns(double t) {
    for (size_t c : other_x_cols_) {
      double x = 0;
      if (Trim(fields_[c]).empty() || !ParseValue(fields_[c], x)) continue;
      if (std::abs(x - t) > 0.01 / rate_hz_) {
        ++stats_.x_disagreements;
        if (!x_disagreement_reported_) {
          x_disagreement_reported_ = true;
          ++stats_.warnings;
          std::ostringstream msg;
          msg << "X column " << (c + 1) << " says " << x << " s where the first X column says " << t
              << " s (the first is used; further disagreements of this segment are counted)";
          Report(msg.str());
        }
        return;
      }
    }
  }

  std::string path_;
  std::unique_ptr<detail::LineInput> input_;
  ProblemCallback on_problem_;
  std::function<void()> on_wait_;  // may be empty
  std::string_view line_;  // the current line, in the input's buffer: valid until the next ReadLine
  bool line_too_long_{false};
  bool line_cut_{false};  // line_ was broken off before its '\n' (live inputs)
  int64_t frames_{0};  // rows delivered
  std::vector<std::string_view> fields_;
  int64_t line_no_{0};
  SourceStats stats_;

  std::vector<std::string> names_;  // channel names, frame order
  std::vector<std::string> units_;  // LVM: Y_Unit_Label of segment 1 per channel ("" none); CSV: empty
  bool comments_column_{false};     // LVM: segment 1's column row ends with Comment
  std::vector<size_t> value_cols_;  // column of each channel
  size_t columns_{};                // fields per row
  int time_col_{-1};
  std::vector<size_t> other_x_cols_;  // LVM X_Columns Multi: X columns after the first
  bool x_disagreement_reported_{false};
  bool has_comment_{false};           // LVM: the column row ends with Comment
  std::vector<bool> empty_reported_;  // per channel
  char sep_{','};
  enum class Decimal { kPoint, kComma, kSniff };  // kSniff: '.' or ',' per field
  Decimal decimal_{Decimal::kPoint};
  bool restarted_{false};       // the input started over: a header is the current line
  bool rebase_pending_{false};  // the next row decides how time goes on (ContinueAfterRestart)
  double time_offset_s_{0};     // added to every time after a restart whose clock went back
  std::optional<double> last_time_;
  double rate_hz_{};
  double given_rate_hz_{};  // SourceOptions::sample_rate_hz: 0 = none given
  std::string rate_origin_;  // where given_rate_hz_ came from (messages)
  double x0_s_{};                   // time of row 0 of the block without a time column
  std::optional<double> first_time_;
};

inline std::unique_ptr<detail::LineInput> StreamOrFail(std::unique_ptr<std::istream> in, const std::string& name) {
  if (!in || !*in) throw std::runtime_error(name + ": cannot open the input file");
  return detail::StreamLines(std::move(in));
}

inline detail::LiveOptions Live(const SourceOptions& options) {
  detail::LiveOptions live;
  live.stop = options.stop;
  live.idle_timeout_s = options.idle_timeout_s;
  return live;
}

}  // namespace text_detail
}  // namespace rocklab::daq
