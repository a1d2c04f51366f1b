#include "sweep/row_writer.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <vector>
#include <stdexcept>

#include "common/atomic_file.h"
#include "common/text.h"
#include "export/h5_writer.h"
#include "pipeline/option_error.h"

namespace rocklab::sweep {
namespace {

using pipeline::OptionError;

// Rows go to OUT.partial beside --out, flushed one by one (a stopped sweep
// keeps every row written there and --resume continues it); Close() renames
// the complete file to --out, so --out is never a torn or half sweep.
class CsvRowWriter final : public RowWriter {
 public:
  CsvRowWriter(const std::string& path, const Plan& plan, const Slice& slice, bool resume,
               const ProvenanceLines& provenance)
      : path_(path), partial_(PartialPath(path)), plan_(plan) {
    namespace fs = std::filesystem;
    std::uintmax_t keep = 0;  // bytes of the resumed file to keep
    if (resume) {
      // An interrupted run's rows are in the .partial; a finished run's (or
      // an older rocklab's, written in place) in --out itself.
      if (fs::exists(partial_)) {
        keep = CheckExisting(partial_, slice);
      } else if (fs::exists(path)) {
        keep = CheckExisting(path, slice);
        if (keep > 0) {
          std::error_code ec;
          fs::copy_file(path, partial_, fs::copy_options::overwrite_existing, ec);
          if (ec) throw OptionError("--out: cannot copy '" + path + "' to '" + partial_ + "': " + ec.message());
        }
      }
    }
    if (keep > 0) {
      std::error_code ec;
      fs::resize_file(partial_, keep, ec);
      if (ec) throw OptionError("--out: cannot cut '" + partial_ + "' to its complete rows: " + ec.message());
      file_ = std::fopen(partial_.c_str(), "a");
    } else {
      rows_done_ = 0;
      file_ = std::fopen(partial_.c_str(), "w");
    }
    if (!file_) throw OptionError("--out: cannot write '" + partial_ + "': " + std::strerror(errno));
    if (keep == 0) Put(DefinitionText(DefinitionOf(plan_)) + ProvenanceText(provenance) + HeaderOf(plan_) + "\n");
  }
  ~CsvRowWriter() override {
    if (file_) std::fclose(file_);  // the rows stay in the .partial for --resume
  }

  std::size_t rows_done() const override { return rows_done_; }

  void Write(std::size_t index, const Outcome& outcome) override { Put(FormatRow(plan_, index, outcome)); }

  void Close() override {
    if (!file_) return;
    const bool bad = std::ferror(file_) != 0;
    const bool close_failed = std::fclose(file_) != 0;
    file_ = nullptr;
    if (bad || close_failed) throw std::runtime_error("error writing '" + partial_ + "'");
    common::CommitRename(partial_, path_);
  }

 private:
  // Each row goes to the file at once, so a stopped sweep loses at most the
  // row being written (which --resume detects as a torn line).
  void Put(const std::string& text) {
    if (std::fputs(text.c_str(), file_) < 0 || std::fflush(file_) != 0) {
      throw std::runtime_error("error writing '" + partial_ + "': " + std::strerror(errno));
    }
  }

  // Returns the bytes to keep (0: start afresh) and sets rows_done_.
  std::uintmax_t CheckExisting(const std::string& path, const Slice& slice) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw OptionError("--out: cannot read '" + path + "' to resume: " + std::strerror(errno));
    std::string line;
    std::uintmax_t offset = 0, keep = 0;
    std::size_t line_no = 0;
    const std::string header = HeaderOf(plan_);
    const std::size_t commas = static_cast<std::size_t>(std::count(header.begin(), header.end(), ','));
    rows_done_ = 0;
    bool header_seen = false;
    Definition definition;
    while (std::getline(in, line)) {
      ++line_no;
      const bool complete = !in.eof();  // getline stopped at a newline
      if (!complete) break;             // a torn last line: written again
      offset += line.size() + 1;
      if (!header_seen) {
        // The definition's lines, then the header (an older rocklab's file
        // has the header alone, and is continued as it is).
        if (ParseDefinitionLine(line, definition)) continue;
        // The definition first: another assembly's header differs too, and
        // its field says why.
        if (!definition.empty()) {
          std::string theirs, ours;
          const std::string key = FirstDifference(definition, DefinitionOf(plan_), theirs, ours);
          if (!key.empty()) {
            throw OptionError("--out: " + path + ": its sweep ran with " + key + " " + common::Quote(theirs) +
                              ", this one's options give " + common::Quote(ours) +
                              "; --resume continues the same sweep only");
          }
        }
        if (line != header) {
          throw OptionError("--out: " + path + ":" + std::to_string(line_no) + ": header " + common::Quote(line) +
                            " is not a sweep's; --resume continues a file this command wrote");
        }
        header_seen = true;
        keep = offset;
        continue;
      }
      if (rows_done_ >= slice.count()) {
        throw OptionError("--out: " + path + ":" + std::to_string(line_no) +
                          ": more rows than the sweep has; was it written with other options?");
      }
      const std::string expected = KeyPrefix(plan_, slice.index(rows_done_));
      if (line.compare(0, expected.size(), expected) != 0 ||
          static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) != commas) {
        throw OptionError("--out: " + path + ":" + std::to_string(line_no) + ": row " + common::Quote(line) +
                          " is not this sweep's next case (expected it to start " + common::Quote(expected) +
                          "); was it written with other options, or another --shard?");
      }
      ++rows_done_;
      keep = offset;
    }
    return keep;
  }

  std::string path_;     // --out
  std::string partial_;  // PartialPath(path_): where the rows go
  const Plan& plan_;
  std::FILE* file_{};
  std::size_t rows_done_{0};
};

// The same rows as the CSV, one table "results" in an HDF5 file
// (H5Results): an empty CSV field (no overturn, no uplift, a symmetric
// block) is NaN.
class H5RowWriter final : public RowWriter {
 public:
  H5RowWriter(const std::string& path, const Plan& plan, const ProvenanceLines& provenance)
      : file_(path, plan, DefinitionOf(plan), provenance), plan_(plan) {
    row_.Resize(ResultColumnsOf(plan).size());
  }

  std::size_t rows_done() const override { return 0; }

  void Write(std::size_t index, const Outcome& o) override {
    constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
    const CaseIndex c = Locate(plan_, index);
    const Scaling s = ScalingOf(plan_, index);
    const Block& block = plan_.blocks[c.block];
    const model::BlockParams& b = block.params;
    row_.text[0] = plan_.records[c.record].name;
    row_.real[1] = s.factor;
    row_.real[2] = s.pga_g;
    row_.real[3] = b.alpha;
    row_.real[4] = b.p;
    row_.real[5] = b.mu;
    row_.text[6] = model::ToString(plan_.model);
    row_.real[7] = o.peak_theta_over_alpha;
    row_.integer[8] = o.overturned ? 1 : 0;
    row_.real[9] = o.overturned ? o.overturn_time_s : kNone;
    row_.integer[10] = o.impacts;
    row_.real[11] = o.uplift_time_s.value_or(kNone);
    row_.real[12] = o.peak_time_s;
    row_.text[13] = block.label;
    row_.real[14] = b.minus ? b.minus->alpha : kNone;
    row_.real[15] = b.minus ? b.minus->p : kNone;
    row_.real[16] = b.minus ? b.minus->mu : kNone;
    if (plan_.assembly) {
      const std::size_t at = ResultColumns().size();
      row_.text[at] = o.first_overturned >= 0 ? plan_.assembly->body_name(o.first_overturned) : std::string();
      for (int k = 0; k < plan_.bodies(); ++k) {
        row_.real[at + 1 + static_cast<std::size_t>(k)] = o.peak_abs_theta_rad[static_cast<std::size_t>(k)];
      }
    }
    file_.Append(row_);
  }

  void Close() override { file_.Close(); }

 private:
  H5Results file_;
  const Plan& plan_;
  exporter::Row row_;
};

}  // namespace

const std::vector<exporter::Column>& ResultColumns() {
  using exporter::Column;
  using exporter::ColumnType;
  static const std::vector<Column> columns = {
      {"record", ColumnType::kString, ""},          {"scale", ColumnType::kDouble, "1"},
      {"pga_g", ColumnType::kDouble, "g"},          {"alpha", ColumnType::kDouble, "rad"},
      {"p", ColumnType::kDouble, "rad/s"},          {"mu", ColumnType::kDouble, "1"},
      {"model", ColumnType::kString, ""},           {"peak_theta_over_alpha", ColumnType::kDouble, "1"},
      {"overturned", ColumnType::kInt, ""},         {"overturn_time", ColumnType::kDouble, "s"},
      {"impacts", ColumnType::kInt, ""},            {"uplift_time", ColumnType::kDouble, "s"},
      {"peak_time", ColumnType::kDouble, "s"},      {"block", ColumnType::kString, ""},
      {"alpha_minus", ColumnType::kDouble, "rad"},  {"p_minus", ColumnType::kDouble, "rad/s"},
      {"mu_minus", ColumnType::kDouble, "1"},
  };
  return columns;
}

std::vector<exporter::Column> ResultColumnsOf(const Plan& plan) {
  std::vector<exporter::Column> columns = ResultColumns();
  if (!plan.assembly) return columns;
  columns.push_back({"first_overturned_body", exporter::ColumnType::kString, ""});
  for (int k = 1; k <= plan.bodies(); ++k) {
    columns.push_back({"peak_abs_theta_" + std::to_string(k), exporter::ColumnType::kDouble, "rad"});
  }
  return columns;
}

H5Results::H5Results(const std::string& path, const Definition& definition, const ProvenanceLines& provenance) {
  Open(path, ResultColumns(), Header(), definition, provenance);
}

H5Results::H5Results(const std::string& path, const Plan& plan, const Definition& definition,
                     const ProvenanceLines& provenance) {
  Open(path, ResultColumnsOf(plan), HeaderOf(plan), definition, provenance);
}

void H5Results::Open(const std::string& path, const std::vector<exporter::Column>& columns, const std::string& header,
                     const Definition& definition, const ProvenanceLines& provenance) {
  try {
    writer_ = std::make_unique<exporter::H5Writer>(path);
    table_ = writer_->AddTable("results", columns);
    writer_->DescribeFile("columns_as_csv", header);
    if (!definition.empty()) {
      std::string keys;
      for (const DefinitionField& f : definition) {
        writer_->DescribeFile(kH5DefinitionPrefix + f.key, f.value);
        keys += (keys.empty() ? "" : " ") + f.key;
      }
      writer_->DescribeFile(kH5DefinitionKeys, keys);
    }
    for (const auto& [key, value] : provenance) writer_->DescribeFile(key, value);
  } catch (const std::exception& e) {
    throw OptionError("--out: " + std::string(e.what()));
  }
}

H5Results::~H5Results() = default;

void H5Results::Append(const exporter::Row& row) { writer_->Append(table_, row); }

void H5Results::Close() {
  if (writer_) writer_->Close();
}

std::string PartialPath(const std::string& out) { return out + ".partial"; }

std::unique_ptr<RowWriter> OpenRowWriter(const std::string& path, const Plan& plan, const Slice& slice,
                                         bool resume, const ProvenanceLines& provenance) {
  if (common::HasExtension(path, ".h5") || common::HasExtension(path, ".hdf5")) {
    if (resume && std::filesystem::exists(path)) {
      throw OptionError("--out " + path + ": --resume continues a .csv only (an HDF5 file is written whole); "
                        "resume into a .csv, or start the .h5 afresh without --resume");
    }
    return std::make_unique<H5RowWriter>(path, plan, provenance);
  }
  return std::make_unique<CsvRowWriter>(path, plan, slice, resume, provenance);
}

}  // namespace rocklab::sweep
