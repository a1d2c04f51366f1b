#include "sweep/row_writer.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "common/text.h"
#include "pipeline/option_error.h"

namespace rocklab::sweep {
namespace {

using pipeline::OptionError;

class CsvRowWriter final : public RowWriter {
 public:
  CsvRowWriter(const std::string& path, const Plan& plan, const Slice& slice, bool resume)
      : path_(path), plan_(plan) {
    std::uintmax_t keep = 0;  // bytes of the existing file to keep
    if (resume && std::filesystem::exists(path)) keep = CheckExisting(slice);
    if (keep > 0) {
      std::error_code ec;
      std::filesystem::resize_file(path, keep, ec);
      if (ec) throw OptionError("--out: cannot cut '" + path + "' to its complete rows: " + ec.message());
      file_ = std::fopen(path.c_str(), "a");
    } else {
      rows_done_ = 0;
      file_ = std::fopen(path.c_str(), "w");
    }
    if (!file_) throw OptionError("--out: cannot write '" + path + "': " + std::strerror(errno));
    if (keep == 0) Put(Header() + "\n");
  }
  ~CsvRowWriter() override {
    if (file_) std::fclose(file_);
  }

  std::size_t rows_done() const override { return rows_done_; }

  void Write(std::size_t index, const Outcome& outcome) override { Put(FormatRow(plan_, index, outcome)); }

  void Close() override {
    if (!file_) return;
    const bool bad = std::ferror(file_) != 0;
    const bool close_failed = std::fclose(file_) != 0;
    file_ = nullptr;
    if (bad || close_failed) throw std::runtime_error("error writing '" + path_ + "'");
  }

 private:
  // Each row goes to the file at once, so a stopped sweep loses at most the
  // row being written (which --resume detects as a torn line).
  void Put(const std::string& text) {
    if (std::fputs(text.c_str(), file_) < 0 || std::fflush(file_) != 0) {
      throw std::runtime_error("error writing '" + path_ + "': " + std::strerror(errno));
    }
  }

  // Returns the bytes to keep (0: start afresh) and sets rows_done_.
  std::uintmax_t CheckExisting(const Slice& slice) {
    std::ifstream in(path_, std::ios::binary);
    if (!in) throw OptionError("--out: cannot read '" + path_ + "' to resume: " + std::strerror(errno));
    std::string line;
    std::uintmax_t offset = 0, keep = 0;
    std::size_t line_no = 0;
    const std::size_t commas = static_cast<std::size_t>(std::count(Header().begin(), Header().end(), ','));
    rows_done_ = 0;
    while (std::getline(in, line)) {
      ++line_no;
      const bool complete = !in.eof();  // getline stopped at a newline
      if (!complete) break;             // a torn last line: written again
      offset += line.size() + 1;
      if (line_no == 1) {
        if (line != Header()) {
          throw OptionError("--out: " + path_ + ":1: header " + common::Quote(line) +
                            " is not a sweep's; --resume continues a file this command wrote");
        }
        keep = offset;
        continue;
      }
      if (rows_done_ >= slice.count()) {
        throw OptionError("--out: " + path_ + ":" + std::to_string(line_no) +
                          ": more rows than the sweep has; was it written with other options?");
      }
      const std::string expected = KeyPrefix(plan_, slice.index(rows_done_));
      if (line.compare(0, expected.size(), expected) != 0 ||
          static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) != commas) {
        throw OptionError("--out: " + path_ + ":" + std::to_string(line_no) + ": row " + common::Quote(line) +
                          " is not this sweep's next case (expected it to start " + common::Quote(expected) +
                          "); was it written with other options, or another --shard?");
      }
      ++rows_done_;
      keep = offset;
    }
    return keep;
  }

  std::string path_;
  const Plan& plan_;
  std::FILE* file_{};
  std::size_t rows_done_{0};
};

}  // namespace

std::unique_ptr<RowWriter> OpenRowWriter(const std::string& path, const Plan& plan, const Slice& slice,
                                         bool resume) {
  if (common::HasExtension(path, ".h5") || common::HasExtension(path, ".hdf5")) {
    // The HDF5 table writer of `rocklab export` (export/) implements RowWriter
    // here once it is merged; until then no .h5 file is written.
    throw OptionError("--out " + path +
                      ": HDF5 output is not built yet (it comes with `rocklab export`'s table writer); "
                      "write a .csv for now");
  }
  return std::make_unique<CsvRowWriter>(path, plan, slice, resume);
}

}  // namespace rocklab::sweep
