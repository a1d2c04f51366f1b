// CSV and LabVIEW .lvm sources: one line-oriented reader, two header parsers.
// The lines come from a detail::LineInput: a file read to its end, a file
// followed as it grows (--follow) or a TCP stream (tcp://). A live input may
// have nothing yet (Next returns kIdle) or start over (a replaced file, a
// reconnection): the header is read again and the time continues. A line
// is a view into the input's block buffer (line_input.h), split into views
// (fields_) and parsed in place with std::from_chars: nothing is copied or
// allocated per row.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "daq/line_input.h"
#include "daq/source.h"
#include "common/text.h"

namespace rocklab::daq {
namespace {

using common::ParseNumber;
using common::Quote;
using common::Split;
using common::Trim;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A line longer than this is skipped (a row) or refused (a header): a
// corrupt file with no line ends must not take the memory of the host.
constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;
// Times beyond +-1e12 s (31 700 years) are corrupt: they would overflow the
// int64 microseconds every message carries and the sample numbering.
constexpr double kMaxAbsTimeS = 1e12;
// UTF-8 byte order mark (EF BB BF), ignored before the first line.
constexpr std::string_view kByteOrderMark{"\xEF\xBB\xBF"};
// Sample rates a file's time base may give, Hz.
constexpr double kMinRateHz = 1e-6;
constexpr double kMaxRateHz = 1e6;

// 10^k, k in [0, 22]: exact doubles.
constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                             1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

// The common field, "[+-]DIGITS[.DIGITS]" (no blanks, no exponent, at most
// 19 digits), read to the same double as std::from_chars (ParseNumber)
// reads it: the digits as an integer w <= 2^53 and w / 10^k with k <= 22
// are exact doubles, and one IEEE division rounds their quotient correctly,
// as from_chars must (Clinger's fast path). False for anything else, which
// goes to ParseNumber: a false here decides nothing.
bool ParsePlainDecimal(std::string_view field, double& out) {
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
void SplitRow(std::string_view line, char sep, std::vector<std::string_view>& fields) {
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
      : path_(path), input_(std::move(input)), on_problem_(options.on_problem), on_wait_(options.on_wait) {}
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
  double x0_s_{};                   // time of row 0 of the block without a time column
  std::optional<double> first_time_;
};

class CsvSource final : public TextSource {
 public:
  CsvSource(std::unique_ptr<detail::LineInput> input, const std::string& path, const SourceOptions& options)
      : TextSource(std::move(input), path, options) {
    rate_hz_ = options.sample_rate_hz;
    if (!(rate_hz_ >= kMinRateHz && rate_hz_ <= kMaxRateHz)) {
      throw std::invalid_argument("CSV source: sample_rate_hz must be in [1e-6, 1e6] Hz");
    }
    if (options.delimiter != 0 && options.delimiter != ',' && options.delimiter != ';' &&
        options.delimiter != '\t') {
      throw std::invalid_argument("CSV source: the delimiter must be ',', ';' or tab");
    }
    // Header: the first non-blank line. One broken off by a dropped
    // connection is skipped (the reconnection sends it again); one the
    // input ended on is an incomplete header.
    bool got = false;
    std::string cut;  // the last header line broken off, quoted
    while ((got = ReadLine())) {
      if (line_cut_) {
        if (Trim(line_).empty()) continue;
        cut = Quote(line_);
        ++stats_.warnings;
        Report("header line " + cut + " broken off before its line end (skipped)");
        continue;
      }
      if (!Trim(line_).empty()) break;
    }
    if (!got && !cut.empty()) {
      Fail("incomplete header: the input ended (stopped, or idle timeout) after a header line broken off "
           "before its line end: " + cut);
    }
    if (!got && live()) Fail("no header line arrived (stopped, or idle timeout)");
    if (line_too_long_) Fail("header row longer than " + std::to_string(kMaxLineBytes) + " bytes");
    if (Trim(line_).empty()) Fail("empty file: expected a header row");
    restarted_ = false;
    sep_ = options.delimiter != 0 ? options.delimiter : common::SniffDelimiter(line_);
    // ';' and tab leave ',' free to be a decimal comma (what European
    // spreadsheets and LabVIEW's spreadsheet VIs write): each field is read
    // with '.' first, then with ','.
    decimal_ = sep_ == ',' ? Decimal::kPoint : Decimal::kSniff;
    ParseHeader(names_, value_cols_, time_col_, columns_);
  }

  ReadStatus ReadNext(Frame& frame) override {
    while (ReadDataLine()) {
      if (restarted_) {
        restarted_ = false;
        if (!HeaderAgain()) continue;
        continue;
      }
      if (SkipCutRow() || SkipLongRow()) {
        ++row_;
        continue;
      }
      if (Trim(line_).empty()) continue;
      SplitRow(line_, sep_, fields_);
      if (ParseRow(row_++, frame)) return ReadStatus::kFrame;
    }
    return End();
  }

 private:
  void ParseHeader(std::vector<std::string>& names, std::vector<size_t>& cols, int& time_col, size_t& columns) {
    Split(line_, sep_, fields_);
    columns = fields_.size();
    time_col = -1;
    names.clear();
    cols.clear();
    for (size_t i = 0; i < fields_.size(); ++i) {
      const std::string name = common::ToUtf8(Trim(fields_[i]));
      if (name.empty()) Fail("header column " + std::to_string(i + 1) + " has no name");
      double ignored = 0;
      if (ParseValue(name, ignored)) Fail("no header row: column name " + Quote(name) + " is a number");
      if (name == "time") {
        time_col = static_cast<int>(i);
        continue;
      }
      for (const auto& n : names) {
        if (n == name) Fail("column " + Quote(name) + " appears twice in the header");
      }
      names.push_back(name);
      cols.push_back(i);
    }
  }

  // The input started over (a reconnection, a replaced file): line_ should
  // be the same header again (blank lines before it skipped). Another header
  // stops the read: the channels of a run do not change under it.
  bool HeaderAgain() {
    while (Trim(line_).empty()) {
      if (!ReadLine()) return false;
    }
    if (line_cut_) {
      // Broken off again: the next restart brings the header once more.
      ++stats_.warnings;
      Report("header line " + Quote(line_) + " after the restart broken off before its line end (skipped)");
      return false;
    }
    std::vector<std::string> names;
    std::vector<size_t> cols;
    int time_col = -1;
    size_t columns = 0;
    ParseHeader(names, cols, time_col, columns);
    if (names != names_ || time_col != time_col_) {
      Fail("the header after the restart names other columns than the first header");
    }
    value_cols_ = cols;
    columns_ = columns;
    rebase_pending_ = true;
    return true;
  }

  int64_t row_{0};
};

// LabVIEW Measurement file (NI's "LabVIEW Measurement File (.lvm) Format"):
// a file header, then segments, each with a header (Channels, Samples, X0,
// Delta_X, ... one value per channel) ended by ***End_of_Header***, a column
// row and data rows. X_Columns: One (one X_Value column), No (the X_Value
// column is empty or absent: time is X0 + k Delta_X), Multi (an X_Value
// column before every channel: the first is used, the others checked).
class LvmSource final : public TextSource {
 public:
  LvmSource(std::unique_ptr<detail::LineInput> input, const std::string& path, const SourceOptions& options)
      : TextSource(std::move(input), path, options) {
    if (!ReadLine()) Fail(live() ? "no header arrived (stopped, or idle timeout)" : "empty file: expected 'LabVIEW Measurement'");
    FailIfHeaderCut();
    ReadFileHeader();
    // The first segment defines the channels.
    if (!ReadSegmentHeader()) Fail("no segment: the file ends after its header");
  }

  ReadStatus ReadNext(Frame& frame) override {
    while (ReadDataLine()) {
      if (restarted_) {
        // A replaced file: its own file header, then segments whose
        // channels must be the first file's.
        restarted_ = false;
        EndSegment();
        try {
          ReadFileHeader();
        } catch (const std::exception& e) {
          Fail(std::string("after the file was replaced: ") + e.what());
        }
        if (!ReadSegmentHeaderNoThrow()) return End();
        rebase_pending_ = true;
        continue;
      }
      if (SkipCutRow() || SkipLongRow()) {
        if (!skip_segment_) ++segment_rows_;
        continue;
      }
      const std::string_view trimmed = Trim(line_);
      if (trimmed.empty()) continue;
      SplitRow(line_, sep_, fields_);
      const std::string_view first = Trim(fields_[0]);
      if (first == "Channels" || first == "***End_of_Header***") {
        // A new segment starts: its header was the next thing in the file.
        --line_no_;
        pending_header_line_ = true;
        EndSegment();
        if (!ReadSegmentHeaderNoThrow()) return End();
        continue;
      }
      if (skip_segment_) {
        ++stats_.rows;
        ++stats_.bad_rows;
        continue;
      }
      if (ParseRow(segment_rows_++, frame)) return ReadStatus::kFrame;
    }
    EndSegment();
    return End();
  }

 private:
  // line_ is the file's first line. File header: key<TAB>value lines up to
  // ***End_of_Header***.
  void ReadFileHeader() {
    if (Trim(line_).rfind("LabVIEW Measurement", 0) != 0) Fail("not a LabVIEW Measurement file");
    bool ended = false;
    bool decimal_given = false;
    Decimal decimal = Decimal::kPoint;
    char sep = '\t';
    XColumns x_columns = XColumns::kOne;
    while (ReadLine()) {
      FailIfHeaderCut();
      Split(line_, '\t', fields_);
      const std::string_view key = Trim(fields_[0]);
      if (key == "***End_of_Header***") {
        ended = true;
        break;
      }
      const std::string_view value = fields_.size() > 1 ? Trim(fields_[1]) : std::string_view();
      if (key == "Separator") {
        if (value == "Tab") sep = '\t';
        else if (value == "Comma") sep = ',';
        else Fail("Separator " + Quote(value) + " is not Tab or Comma");
      } else if (key == "Decimal_Separator") {
        decimal_given = true;
        decimal = (value == ",") ? Decimal::kComma : Decimal::kPoint;
      } else if (key == "X_Columns") {
        if (value == "No") x_columns = XColumns::kNo;
        else if (value == "Multi") x_columns = XColumns::kMulti;
        else if (value == "One") x_columns = XColumns::kOne;
        else Fail("X_Columns " + Quote(value) + " is not No, One or Multi");
      }
    }
    if (!ended) Fail("truncated file header: no ***End_of_Header***");
    if (sep == ',' && decimal_given && decimal == Decimal::kComma) {
      Fail("Separator Comma with Decimal_Separator ',' is ambiguous");
    }
    // Without a Decimal_Separator line (older writers) each number is read
    // with '.' first, then with ',' (only possible with Tab separators).
    if (!decimal_given) decimal = sep == '\t' ? Decimal::kSniff : Decimal::kPoint;
    if (!names_.empty() && (sep != sep_)) Fail("the replaced file has another Separator");
    sep_ = sep;
    decimal_ = decimal;
    x_columns_ = x_columns;
  }

  void EndSegment() {
    if (segment_done_) return;
    segment_done_ = true;
    if (samples_ && *samples_ != segment_rows_) {
      ++stats_.warnings;
      std::ostringstream msg;
      msg << "segment " << segment_ << " header says Samples " << *samples_ << " but it has "
          << segment_rows_ << " rows (the rows are used)";
      Report(msg.str());
    }
  }

  bool ReadSegmentHeaderNoThrow() {
    try {
      return ReadSegmentHeader();
    } catch (const Idle&) {
      throw;
    } catch (const std::exception& e) {
      ++stats_.warnings;
      Report(std::string(e.what()) + " (rest of the file skipped)");
      return false;
    }
  }

  // Reads one segment header and its column row. Returns false at end of file.
  bool ReadSegmentHeader() {
    std::optional<double> x0;
    std::optional<double> dx;
    std::vector<std::string> units;  // Y_Unit_Label, one per channel
    samples_.reset();
    bool ended = false;
    bool any = false;
    const bool first_segment = names_.empty();
    while (pending_header_line_ || ReadLine()) {
      if (pending_header_line_) {
        pending_header_line_ = false;
        ++line_no_;
      } else {
        FailIfHeaderCut();
      }
      Split(line_, '\t', fields_);
      const std::string_view key = Trim(fields_[0]);
      if (key.empty() && fields_.size() <= 2) continue;
      any = true;
      if (key == "***End_of_Header***") {
        ended = true;
        break;
      }
      if (key == "Y_Unit_Label") {
        // One label per channel in channel order (X_Value columns have
        // none: X_Unit_Label is theirs), Windows-1252 or UTF-8 text.
        units.clear();
        for (size_t i = 1; i < fields_.size(); ++i) units.push_back(common::ToUtf8(Trim(fields_[i])));
        continue;
      }
      if (key == "X0" || key == "Delta_X" || key == "Samples") {
        // One value per channel; the first is used (the channels share one
        // clock here: a segment whose channels have other time bases is
        // not one frame per row).
        double v = 0;
        if (fields_.size() < 2 || !ParseValue(fields_[1], v)) {
          Fail(std::string(key) + " is not a number");
        }
        if (key == "X0") {
          if (!(std::abs(v) <= kMaxAbsTimeS)) Fail("X0 must be within [-1e12, 1e12] s");
          x0 = v;
        }
        if (key == "Delta_X") dx = v;
        if (key == "Samples") {
          // Checked before the conversion: 1e300 has no int64 value. Samples
          // only cross-checks the rows, so a bad one is a warning.
          if (v >= 0 && v <= 1e15 && v == std::floor(v)) {
            samples_ = static_cast<int64_t>(v);
          } else {
            ++stats_.warnings;
            Report("Samples " + Quote(Trim(fields_[1])) + " is not a row count in [0, 1e15] (ignored)");
          }
        }
      }
    }
    if (!any) return false;
    if (!ended) Fail("truncated segment header: no ***End_of_Header***");
    ++segment_;
    stats_.segments = segment_;
    segment_done_ = false;
    segment_rows_ = 0;
    x_disagreement_reported_ = false;
    if (!dx || !(*dx >= 1.0 / kMaxRateHz && *dx <= 1.0 / kMinRateHz)) {
      Fail("segment header has no Delta_X in [1e-6, 1e6] s");
    }
    x0_s_ = x0.value_or(0.0);
    // Column header row.
    if (!ReadLine()) Fail("segment has no column header row");
    FailIfHeaderCut();
    if (line_too_long_) Fail("column header row longer than " + std::to_string(kMaxLineBytes) + " bytes");
    Split(line_, sep_, fields_);
    size_t n = fields_.size();
    while (n > 0 && Trim(fields_[n - 1]).empty()) --n;
    const bool comment = n > 0 && Trim(fields_[n - 1]) == "Comment";
    if (comment) --n;
    std::vector<size_t> x_cols;
    std::vector<std::string> names;
    std::vector<size_t> cols;
    for (size_t i = 0; i < n; ++i) {
      const std::string name = common::ToUtf8(Trim(fields_[i]));
      if (name == "X_Value") {
        x_cols.push_back(i);
        continue;
      }
      if (name.empty()) Fail("column " + std::to_string(i + 1) + " has no name");
      names.push_back(name);
      cols.push_back(i);
    }
    if (x_cols.size() > 1 && x_columns_ == XColumns::kOne) {
      Fail("more than one X_Value column with X_Columns One");
    }
    // X_Columns No: the X_Value column (when written) is empty: the time base is X0 and Delta_X.
    const int time_col = (x_columns_ == XColumns::kNo || x_cols.empty()) ? -1 : static_cast<int>(x_cols[0]);
    // Labels past the channels (trailing tabs) are dropped; missing ones are "".
    units.resize(names.size());
    if (first_segment) {
      names_ = std::move(names);
      units_ = std::move(units);
      comments_column_ = comment;
      rate_hz_ = 1.0 / *dx;
      skip_segment_ = false;
    } else {
      // Another unit in a later segment: its rows are kept (the channels
      // are the same) but the first segment's units are what the file is
      // said to hold, so the disagreement is reported and counted.
      for (size_t i = 0; i < units.size() && i < units_.size(); ++i) {
        if (!units[i].empty() && units[i] != units_[i] && names == names_) {
          ++stats_.warnings;
          Report("segment " + std::to_string(segment_) + " gives channel " + Quote(names_[i]) + " the unit " +
                 Quote(units[i]) + " where segment 1 says " + Quote(units_[i]) + " (segment 1's is reported)");
        }
      }
      skip_segment_ = names != names_ || std::abs(1.0 / *dx - rate_hz_) > 1e-9 * rate_hz_;
      if (skip_segment_) {
        ++stats_.warnings;
        Report("segment " + std::to_string(segment_) +
               " has other channels or another Delta_X than segment 1 (its rows are skipped)");
        return true;
      }
    }
    value_cols_ = std::move(cols);
    columns_ = n;
    has_comment_ = comment;
    time_col_ = time_col;
    other_x_cols_.clear();
    if (time_col >= 0) other_x_cols_.assign(x_cols.begin() + 1, x_cols.end());
    return true;
  }

  enum class XColumns { kNo, kOne, kMulti };
  XColumns x_columns_{XColumns::kOne};
  bool pending_header_line_{false};
  bool skip_segment_{false};
  bool segment_done_{true};
  int segment_{0};
  int64_t segment_rows_{0};
  std::optional<int64_t> samples_;
};

std::unique_ptr<detail::LineInput> StreamOrFail(std::unique_ptr<std::istream> in, const std::string& name) {
  if (!in || !*in) throw std::runtime_error(name + ": cannot open the input file");
  return detail::StreamLines(std::move(in));
}

detail::LiveOptions Live(const SourceOptions& options) {
  detail::LiveOptions live;
  live.stop = options.stop;
  live.idle_timeout_s = options.idle_timeout_s;
  return live;
}

}  // namespace

std::unique_ptr<Source> OpenCsvSource(const std::string& path, const SourceOptions& options) {
  auto lines = options.follow ? detail::FollowFile(path, Live(options)) : detail::FileLines(path);
  return std::make_unique<CsvSource>(std::move(lines), path, options);
}

std::unique_ptr<Source> OpenLvmSource(const std::string& path, const SourceOptions& options) {
  auto lines = options.follow ? detail::FollowFile(path, Live(options)) : detail::FileLines(path);
  return std::make_unique<LvmSource>(std::move(lines), path, options);
}

std::unique_ptr<Source> OpenCsvStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options) {
  return std::make_unique<CsvSource>(StreamOrFail(std::move(in), name), name, options);
}

std::unique_ptr<Source> OpenLvmStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options) {
  return std::make_unique<LvmSource>(StreamOrFail(std::move(in), name), name, options);
}

std::unique_ptr<Source> OpenTcpSource(const std::string& host_port, const SourceOptions& options, bool listen) {
  return std::make_unique<CsvSource>(detail::TcpLines(host_port, Live(options), listen),
                                     (listen ? "tcp-listen://" : "tcp://") + host_port, options);
}

}  // namespace rocklab::daq
