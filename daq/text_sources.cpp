// CSV and LabVIEW .lvm sources: one line-oriented reader, two header parsers.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

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
// Sample rates a file's time base may give, Hz.
constexpr double kMinRateHz = 1e-6;
constexpr double kMaxRateHz = 1e6;

// State shared by the text formats: the file, the current line, the column
// layout of the current block of rows and the time base.
class TextSource : public Source {
 public:
  TextSource(std::unique_ptr<std::istream> in, const std::string& path, const SourceOptions& options)
      : path_(path), in_(std::move(in)), on_problem_(options.on_problem) {
    if (!in_ || !*in_) throw std::runtime_error(path + ": cannot open the input file");
  }

  const std::vector<std::string>& channel_names() const override { return names_; }
  double sample_rate_hz() const override { return rate_hz_; }
  const SourceStats& stats() const override { return stats_; }
  const std::string& path() const override { return path_; }

  // The streaming path never throws (source.h): what would stop the read is
  // kError, reported and kept in error_.
  ReadStatus Next(Frame& frame) final {
    if (!error_.empty()) return ReadStatus::kError;
    try {
      return ReadNext(frame);
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

  // Reads the next line into line_ (without its '\n'); false at the end of
  // the file. A line longer than kMaxLineBytes is cut there (line_too_long_
  // says so) and the rest of it skipped. A read error is never the end of the
  // file: it throws, naming the file and the last line read.
  bool ReadLine() {
    line_.clear();
    line_too_long_ = false;
    std::streambuf* buf = in_->rdbuf();
    bool any = false;
    try {
      for (int c = buf->sbumpc(); c != std::char_traits<char>::eof(); c = buf->sbumpc()) {
        any = true;
        if (c == '\n') break;
        if (line_.size() < kMaxLineBytes) {
          line_.push_back(static_cast<char>(c));
        } else {
          line_too_long_ = true;
        }
      }
    } catch (const std::exception& e) {
      std::ostringstream msg;
      msg << path_ << ": read error after line " << line_no_ << " (" << e.what()
          << "): the rest of the file is not read";
      throw std::runtime_error(msg.str());
    }
    if (!any) return false;
    ++line_no_;
    if (line_no_ == 1) common::StripByteOrderMark(line_);  // a BOM must not hide the first column
    return true;
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
    // A trailing empty field (LVM's empty Comment column, a trailing separator).
    size_t n = fields_.size();
    if (n == columns_ + 1 && Trim(fields_.back()).empty()) --n;
    if (n != columns_) {
      ++stats_.bad_rows;
      std::ostringstream msg;
      msg << "row has " << n << " fields, the header has " << columns_ << " (row skipped)";
      Report(msg.str());
      return false;
    }
    double t = 0;
    if (time_col_ >= 0) {
      if (!ParseNumber(fields_[time_col_], decimal_comma_, t) || !std::isfinite(t)) {
        ++stats_.bad_rows;
        Report("time " + Quote(Trim(fields_[time_col_])) + " is not a finite number (row skipped)");
        return false;
      }
    } else {
      t = x0_s_ + static_cast<double>(k) / rate_hz_;
    }
    if (!(std::abs(t) <= kMaxAbsTimeS)) {
      ++stats_.bad_rows;
      std::ostringstream msg;
      msg << "time " << t << " s is outside [-1e12, 1e12] s (row skipped)";
      Report(msg.str());
      return false;
    }
    if (!first_time_) first_time_ = t;
    frame.time_s = t;
    frame.seq = std::llround((t - *first_time_) * rate_hz_);
    frame.line = line_no_;
    frame.values.resize(names_.size());
    for (size_t i = 0; i < value_cols_.size(); ++i) {
      double v = kNaN;
      if (!ParseNumber(fields_[value_cols_[i]], decimal_comma_, v)) {
        v = kNaN;
        ++stats_.bad_values;
        Report("column " + Quote(names_[i]) + ": " + Quote(Trim(fields_[value_cols_[i]])) +
               " is not a number (sample set to NaN)");
      }
      frame.values[i] = v;
    }
    ++frames_;
    return true;
  }

  std::string path_;
  std::unique_ptr<std::istream> in_;
  ProblemCallback on_problem_;
  std::string line_;
  bool line_too_long_{false};
  int64_t frames_{0};  // rows delivered
  std::vector<std::string_view> fields_;
  int64_t line_no_{0};
  SourceStats stats_;

  std::vector<std::string> names_;  // channel names, frame order
  std::vector<size_t> value_cols_;  // column of each channel
  size_t columns_{};                // fields per row
  int time_col_{-1};
  char sep_{','};
  bool decimal_comma_{false};
  double rate_hz_{};
  double x0_s_{};                   // time of row 0 of the block without a time column
  std::optional<double> first_time_;
};

class CsvSource final : public TextSource {
 public:
  CsvSource(std::unique_ptr<std::istream> in, const std::string& path, const SourceOptions& options)
      : TextSource(std::move(in), path, options) {
    rate_hz_ = options.sample_rate_hz;
    if (!(rate_hz_ >= kMinRateHz && rate_hz_ <= kMaxRateHz)) {
      throw std::invalid_argument("CSV source: sample_rate_hz must be in [1e-6, 1e6] Hz");
    }
    // Header: the first non-blank line.
    while (ReadLine()) {
      if (!Trim(line_).empty()) break;
    }
    if (line_too_long_) Fail("header row longer than " + std::to_string(kMaxLineBytes) + " bytes");
    if (Trim(line_).empty()) Fail("empty file: expected a header row");
    Split(line_, sep_, fields_);
    columns_ = fields_.size();
    for (size_t i = 0; i < fields_.size(); ++i) {
      const std::string name(Trim(fields_[i]));
      if (name.empty()) Fail("header column " + std::to_string(i + 1) + " has no name");
      double ignored = 0;
      if (ParseNumber(name, false, ignored)) Fail("no header row: column name " + Quote(name) + " is a number");
      if (name == "time") {
        time_col_ = static_cast<int>(i);
        continue;
      }
      for (const auto& n : names_) {
        if (n == name) Fail("column " + Quote(name) + " appears twice in the header");
      }
      names_.push_back(name);
      value_cols_.push_back(i);
    }
  }

  ReadStatus ReadNext(Frame& frame) override {
    while (ReadLine()) {
      if (SkipLongRow()) {
        ++row_;
        continue;
      }
      if (Trim(line_).empty()) continue;
      Split(line_, sep_, fields_);
      if (ParseRow(row_++, frame)) return ReadStatus::kFrame;
    }
    return End();
  }

 private:
  int64_t row_{0};
};

// LabVIEW Measurement file: a file header, then segments, each with a header
// (Channels, Samples, X0, Delta_X, ...) ended by ***End_of_Header***, a column
// header row and data rows.
class LvmSource final : public TextSource {
 public:
  LvmSource(std::unique_ptr<std::istream> in, const std::string& path, const SourceOptions& options)
      : TextSource(std::move(in), path, options) {
    if (!ReadLine()) Fail("empty file: expected 'LabVIEW Measurement'");
    if (Trim(line_).rfind("LabVIEW Measurement", 0) != 0) Fail("not a LabVIEW Measurement file");
    // File header: key<TAB>value lines up to ***End_of_Header***.
    bool ended = false;
    while (ReadLine()) {
      Split(line_, '\t', fields_);
      const std::string_view key = Trim(fields_[0]);
      if (key == "***End_of_Header***") {
        ended = true;
        break;
      }
      const std::string_view value = fields_.size() > 1 ? Trim(fields_[1]) : std::string_view();
      if (key == "Separator") {
        if (value == "Tab") sep_ = '\t';
        else if (value == "Comma") sep_ = ',';
        else Fail("Separator " + Quote(value) + " is not Tab or Comma");
      } else if (key == "Decimal_Separator") {
        decimal_comma_ = (value == ",");
      } else if (key == "X_Columns") {
        if (value == "Multi") Fail("X_Columns Multi is not supported (one time base for all channels)");
      }
    }
    if (!ended) Fail("truncated file header: no ***End_of_Header***");
    if (sep_ == ',' && decimal_comma_) Fail("Separator Comma with Decimal_Separator ',' is ambiguous");
    // The first segment defines the channels.
    if (!ReadSegmentHeader()) Fail("no segment: the file ends after its header");
  }

  ReadStatus ReadNext(Frame& frame) override {
    while (ReadLine()) {
      if (SkipLongRow()) {
        if (!skip_segment_) ++segment_rows_;
        continue;
      }
      const std::string_view trimmed = Trim(line_);
      if (trimmed.empty()) continue;
      Split(line_, sep_, fields_);
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
    samples_.reset();
    bool ended = false;
    bool any = false;
    const bool first_segment = names_.empty();
    while (pending_header_line_ || ReadLine()) {
      if (pending_header_line_) {
        pending_header_line_ = false;
        ++line_no_;
      }
      Split(line_, '\t', fields_);
      const std::string_view key = Trim(fields_[0]);
      if (key.empty() && fields_.size() <= 2) continue;
      any = true;
      if (key == "***End_of_Header***") {
        ended = true;
        break;
      }
      if (key == "X0" || key == "Delta_X" || key == "Samples") {
        double v = 0;
        if (fields_.size() < 2 || !ParseNumber(fields_[1], decimal_comma_, v)) {
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
    if (!dx || !(*dx >= 1.0 / kMaxRateHz && *dx <= 1.0 / kMinRateHz)) {
      Fail("segment header has no Delta_X in [1e-6, 1e6] s");
    }
    x0_s_ = x0.value_or(0.0);
    // Column header row.
    if (!ReadLine()) Fail("segment has no column header row");
    if (line_too_long_) Fail("column header row longer than " + std::to_string(kMaxLineBytes) + " bytes");
    Split(line_, sep_, fields_);
    size_t n = fields_.size();
    while (n > 0 && (Trim(fields_[n - 1]).empty() || Trim(fields_[n - 1]) == "Comment")) --n;
    int time_col = -1;
    std::vector<std::string> names;
    std::vector<size_t> cols;
    for (size_t i = 0; i < n; ++i) {
      const std::string name(Trim(fields_[i]));
      if (name == "X_Value") {
        if (time_col >= 0) Fail("more than one X_Value column");
        time_col = static_cast<int>(i);
        continue;
      }
      if (name.empty()) Fail("column " + std::to_string(i + 1) + " has no name");
      names.push_back(name);
      cols.push_back(i);
    }
    if (first_segment) {
      names_ = std::move(names);
      value_cols_ = std::move(cols);
      columns_ = n;
      time_col_ = time_col;
      rate_hz_ = 1.0 / *dx;
      skip_segment_ = false;
    } else {
      skip_segment_ = names != names_ || time_col != time_col_ ||
                      std::abs(1.0 / *dx - rate_hz_) > 1e-9 * rate_hz_;
      if (skip_segment_) {
        ++stats_.warnings;
        Report("segment " + std::to_string(segment_) +
               " has other channels or another Delta_X than segment 1 (its rows are skipped)");
      }
    }
    return true;
  }

  bool pending_header_line_{false};
  bool skip_segment_{false};
  bool segment_done_{true};
  int segment_{0};
  int64_t segment_rows_{0};
  std::optional<int64_t> samples_;
};

}  // namespace

std::unique_ptr<Source> OpenCsvSource(const std::string& path, const SourceOptions& options) {
  return std::make_unique<CsvSource>(std::make_unique<std::ifstream>(path, std::ios::binary), path, options);
}

std::unique_ptr<Source> OpenLvmSource(const std::string& path, const SourceOptions& options) {
  return std::make_unique<LvmSource>(std::make_unique<std::ifstream>(path, std::ios::binary), path, options);
}

std::unique_ptr<Source> OpenCsvStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options) {
  return std::make_unique<CsvSource>(std::move(in), name, options);
}

std::unique_ptr<Source> OpenLvmStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options) {
  return std::make_unique<LvmSource>(std::move(in), name, options);
}

}  // namespace rocklab::daq
