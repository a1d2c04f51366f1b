// The LabVIEW .lvm source; the reader it shares with CSV is text_source.h.
#include "daq/text_source.h"

namespace rocklab::daq {
namespace {

using namespace text_detail;  // NOLINT(google-build-using-namespace): this file's private helpers

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
      CheckGivenRate(rate_hz_, "the file's Delta_X");
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

}  // namespace

std::unique_ptr<Source> OpenLvmSource(const std::string& path, const SourceOptions& options) {
  auto lines = options.follow ? detail::FollowFile(path, Live(options)) : detail::FileLines(path);
  return std::make_unique<LvmSource>(std::move(lines), path, options);
}

std::unique_ptr<Source> OpenLvmStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options) {
  return std::make_unique<LvmSource>(StreamOrFail(std::move(in), name), name, options);
}

}  // namespace rocklab::daq
