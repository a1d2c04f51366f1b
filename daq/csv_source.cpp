// The CSV source (a header row naming the columns, then data rows) and the
// TCP stream of CSV rows; the reader they share is text_source.h.
#include <exception>
#include <utility>

#include "daq/text_source.h"

namespace rocklab::daq {
namespace {

using namespace text_detail;  // NOLINT(google-build-using-namespace): this file's private helpers

class CsvSource final : public TextSource {
 public:
  CsvSource(std::unique_ptr<detail::LineInput> input, const std::string& path, const SourceOptions& options)
      : TextSource(std::move(input), path, options) {
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
    SetRate();
  }

  ReadStatus ReadNext(Frame& frame) override {
    while (NextDataLine()) {
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
  // The rate: the time column's (read ahead over the first rows of a file)
  // checked against the one given, or the one given where the file has no
  // time column or is live (its rows are not there yet to read ahead).
  void SetRate() {
    rate_hz_ = given_rate_hz_;
    if (time_col_ < 0 || live()) {
      if (rate_hz_ == 0) {
        Fail(std::string(time_col_ < 0 ? "no time column" : "a live input") +
             ": the sample rate must be given (--rate, or the rig's sample_rate_hz)");
      }
      return;
    }
    std::vector<double> times;
    try {
      while (pending_.size() < kRateProbeRows && ReadLine()) {
        pending_.push_back({std::string(line_), line_no_, line_too_long_});
        double t = kNaN;
        SplitRow(line_, sep_, fields_);
        if (!line_too_long_ && static_cast<size_t>(time_col_) < fields_.size() &&
            ParseValue(fields_[time_col_], t)) {
          times.push_back(t);
        }
      }
    } catch (const std::exception&) {
      // A read error after some rows: those rows come first, then the
      // error, as without the read-ahead (NextDataLine rethrows it).
      probe_error_ = std::current_exception();
    }
    probe_end_line_ = line_no_;
    const std::optional<double> file_rate = RateOfTimes(times);
    if (!file_rate && probe_error_ && rate_hz_ == 0) std::rethrow_exception(probe_error_);
    if (!file_rate) {
      if (rate_hz_ == 0) {
        Fail(std::string(pending_.empty() ? "no data rows after the header"
                                          : "the time column's first rows hold fewer than two increasing times") +
             ": the sample rate cannot be taken from it; give it (--rate, or the rig's sample_rate_hz)");
      }
      return;  // no data rows: nothing to number
    }
    if (!(*file_rate >= kMinRateHz && *file_rate <= kMaxRateHz)) {
      std::ostringstream msg;
      msg << "the time column gives a sample rate of " << *file_rate << " Hz, outside [1e-6, 1e6] Hz";
      Fail(msg.str());
    }
    CheckGivenRate(*file_rate, "the time column");
    if (rate_hz_ == 0) rate_hz_ = *file_rate;
  }

  // The next data line: the rows read ahead by SetRate first, then the input's.
  bool NextDataLine() {
    if (pending_next_ < pending_.size()) {
      const PendingLine& p = pending_[pending_next_++];
      line_ = p.text;
      line_no_ = p.line_no;
      line_too_long_ = p.too_long;
      line_cut_ = false;
      return true;
    }
    if (!pending_.empty() || probe_error_) {
      line_no_ = probe_end_line_;
      pending_.clear();
      pending_.shrink_to_fit();
      pending_next_ = 0;
      if (probe_error_) std::rethrow_exception(std::exchange(probe_error_, nullptr));
    }
    return ReadDataLine();
  }

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
  // Data lines read ahead for the rate (a file only: never cut, never restarted).
  struct PendingLine {
    std::string text;
    int64_t line_no;
    bool too_long;
  };
  std::vector<PendingLine> pending_;
  std::size_t pending_next_{0};
  int64_t probe_end_line_{0};  // line_no_ after the read-ahead
  std::exception_ptr probe_error_;  // a read error during the read-ahead, thrown after its rows
};

}  // namespace

std::unique_ptr<Source> OpenCsvSource(const std::string& path, const SourceOptions& options) {
  auto lines = options.follow ? detail::FollowFile(path, Live(options)) : detail::FileLines(path);
  return std::make_unique<CsvSource>(std::move(lines), path, options);
}

std::unique_ptr<Source> OpenCsvStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options) {
  return std::make_unique<CsvSource>(StreamOrFail(std::move(in), name), name, options);
}

std::unique_ptr<Source> OpenTcpSource(const std::string& host_port, const SourceOptions& options, bool listen) {
  return std::make_unique<CsvSource>(detail::TcpLines(host_port, Live(options), listen),
                                     (listen ? "tcp-listen://" : "tcp://") + host_port, options);
}

}  // namespace rocklab::daq
