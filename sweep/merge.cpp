// sweep --merge (MergeShards, runner.h): shards in either format, the
// result in the format --out's extension names.
//
// Every shard's rows are read into the plan's case slots in the form the
// output takes: the CSV line (a CSV shard's as written; an HDF5 shard's
// formatted as FormatRow formats it) for a CSV --out, the typed cells (an
// HDF5 shard's as its datasets hold them; a CSV shard's parsed) for an
// HDF5 --out, which goes through H5Results, the table `sweep --out x.h5`
// writes. Round trips (docs/sweep.md, "Shards"):
// - HDF5 -> CSV is exact: a double is printed with the CSV writer's own
//   %.12g, NaN (no value) as an empty field, integers in decimal, so an
//   HDF5 shard gives the bytes its CSV twin holds.
// - CSV -> HDF5 holds the double nearest each 12-digit field (strtod), an
//   empty field as NaN; printed again with %.12g it is the same text (12 <
//   DBL_DIG = 15 digits survive the trip), so CSV -> HDF5 -> CSV is exact,
//   while HDF5 -> CSV -> HDF5 keeps 12 significant digits of each double.
// - Same format in and out: CSV lines copied as written, HDF5 values copied.
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/atomic_file.h"
#include "common/text.h"
#include "pipeline/option_error.h"
#include "sweep/plot.h"
#include "sweep/results_h5.h"
#include "sweep/row_writer.h"
#include "sweep/runner.h"

namespace rocklab::sweep {
namespace {

using exporter::ColumnType;
using pipeline::OptionError;

// ResultColumns(): 17 columns, 12 of them doubles, 2 integers, 3 text (checked in MakeLayout);
// an assembly's sweep adds a text and a double per body (ResultColumnsOf).
constexpr std::size_t kColumns = 17, kReals = 12, kIntegers = 2, kTexts = 3;
constexpr std::size_t kKeyColumns = 7;  // record..model: KeyPrefix

// An assembly's sweep adds at most these: first_overturned_body, a peak per body.
constexpr std::size_t kAssemblyTexts = 1, kAssemblyReals = model::stack::kMaxBodies;

// One row's cells as the HDF5 table holds them (about 300 bytes a case);
// a cell of column c is in the array of its type, at slot[c].
struct Cells {
  std::array<double, kReals + kAssemblyReals> real{};
  std::array<std::int64_t, kIntegers> integer{};
  std::array<std::string, kTexts + kAssemblyTexts> text;
};

struct Layout {
  std::vector<std::string> names;  // HeaderOf(plan)'s
  std::vector<ColumnType> type;
  std::vector<std::size_t> slot;  // index into Cells' array of type[c]
  std::array<std::size_t, 3> count{};  // columns by ColumnType
  std::string header;
  std::size_t columns() const { return names.size(); }
};

std::string Join(const std::vector<std::string>& parts) {
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : ",") + p;
  return out;
}

Layout MakeLayout(const Plan& plan) {
  if (ResultColumns().size() != kColumns) throw std::logic_error("sweep::ResultColumns() is not 17 columns");
  const std::vector<exporter::Column> columns = ResultColumnsOf(plan);
  Layout l;
  std::array<std::size_t, 3>& count = l.count;
  for (std::size_t c = 0; c < columns.size(); ++c) {
    l.names.push_back(columns[c].name);
    l.type.push_back(columns[c].type);
    l.slot.push_back(count[static_cast<std::size_t>(columns[c].type)]++);
    if (c + 1 == kColumns &&
        (count[static_cast<std::size_t>(ColumnType::kDouble)] != kReals ||
         count[static_cast<std::size_t>(ColumnType::kInt)] != kIntegers ||
         count[static_cast<std::size_t>(ColumnType::kString)] != kTexts)) {
      throw std::logic_error("sweep::ResultColumns() is not 12 doubles, 2 integers and 3 texts");
    }
  }
  if (count[static_cast<std::size_t>(ColumnType::kDouble)] > kReals + kAssemblyReals ||
      count[static_cast<std::size_t>(ColumnType::kInt)] > kIntegers ||
      count[static_cast<std::size_t>(ColumnType::kString)] > kTexts + kAssemblyTexts) {
    throw std::logic_error("sweep::ResultColumnsOf() has more columns than a merge's cells hold");
  }
  l.header = HeaderOf(plan);
  if (Join(l.names) != l.header) throw std::logic_error("sweep::ResultColumnsOf() does not match sweep::HeaderOf()");
  return l;
}

// Appends cell c as the CSV writer prints it (FormatRow): %.12g, NaN empty.
void AppendCell(const Layout& l, const Cells& cells, std::size_t c, std::string& out) {
  switch (l.type[c]) {
    case ColumnType::kDouble: {
      const double v = cells.real[l.slot[c]];
      if (std::isnan(v)) return;
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.12g", v);
      out += buf;
      return;
    }
    case ColumnType::kInt:
      out += std::to_string(cells.integer[l.slot[c]]);
      return;
    case ColumnType::kString:
      out += cells.text[l.slot[c]];
      return;
  }
}

// The first `count` cells as a CSV row (count = kKeyColumns: the case's key, with its comma).
std::string FormatCells(const Layout& l, const Cells& cells, std::size_t count) {
  std::string out;
  out.reserve(200);
  for (std::size_t c = 0; c < count; ++c) {
    AppendCell(l, cells, c, out);
    if (c + 1 < l.columns()) out += ',';
  }
  return out;
}

// Parses a CSV row's fields into `cells`; returns "" or what is wrong.
std::string ParseFields(const Layout& l, const std::string& line, Cells& cells) {
  std::size_t from = 0;
  const std::size_t columns = l.columns();
  for (std::size_t c = 0; c < columns; ++c) {
    std::size_t end = line.find(',', from);
    if (end == std::string::npos) end = line.size();
    if (c + 1 < columns && end == line.size()) {
      return "has " + std::to_string(c + 1) + " columns, the header " + std::to_string(columns);
    }
    const std::string field = line.substr(from, end - from);
    from = end + 1;
    if (l.type[c] == ColumnType::kString) {
      cells.text[l.slot[c]] = field;
      continue;
    }
    errno = 0;
    char* stop = nullptr;
    if (l.type[c] == ColumnType::kDouble) {
      // An empty field is a value that is not there: NaN, as the HDF5 writer stores it.
      cells.real[l.slot[c]] = field.empty() ? std::numeric_limits<double>::quiet_NaN()
                                            : std::strtod(field.c_str(), &stop);
    } else {
      cells.integer[l.slot[c]] = std::strtoll(field.c_str(), &stop, 10);
    }
    if (field.empty() ? l.type[c] == ColumnType::kInt : (stop != field.c_str() + field.size() || errno == ERANGE)) {
      return "column " + l.names[c] + ": " + common::Quote(field) + " is not " +
             (l.type[c] == ColumnType::kInt ? "an integer" : "a number");
    }
  }
  if (from <= line.size()) return "has more columns than the header's " + std::to_string(columns);
  return "";
}

// Where rows go until they are written, in the form --out takes.
struct Slots {
  Slots(std::size_t n, bool h5_out) : h5(h5_out), have(n, false) {
    if (h5_out) {
      cells.resize(n);
    } else {
      lines.resize(n);
    }
  }
  bool h5;
  std::vector<bool> have;
  std::vector<std::string> lines;  // CSV --out
  std::vector<Cells> cells;        // HDF5 --out
};

// Puts a row of case `key` into its slot. `where` names the file and row.
void Place(const std::unordered_map<std::string, std::size_t>& index_of, const std::string& key,
           const std::string& where, const std::string& row_text, Slots& slots, std::string line, Cells& cells) {
  const auto it = index_of.find(key);
  if (it == index_of.end()) {
    throw OptionError(where + "row " + common::Quote(row_text) + " is not a case of this sweep (other options?)");
  }
  if (slots.have[it->second]) throw OptionError(where + "case " + common::Quote(it->first) + " is there twice");
  slots.have[it->second] = true;
  if (slots.h5) {
    std::swap(slots.cells[it->second], cells);
  } else {
    slots.lines[it->second] = std::move(line);
  }
}

// The shards' definitions, checked one against another and against the
// merge's own plan as each shard is read.
struct Definitions {
  Definition plan;
  std::string first_part;  // the first shard that had one
  Definition first;
  bool any_missing{};
  std::vector<std::string> warnings;
};

// Refuses a shard whose definition differs from the first shard's (naming
// both files) or from the merge's options; a shard without one (an older
// rocklab's) is taken with a warning: its rows are still checked against
// the plan's cases, what the definition adds cannot be.
void CheckDefinition(const std::string& part, const Definition& d, Definitions& state) {
  if (d.empty()) {
    state.any_missing = true;
    state.warnings.push_back(part + ": no sweep definition (written by an older rocklab): its rows are checked "
                             "against this sweep's cases, but not its rtol, rate, duration, l or records' samples; "
                             "the merged file carries no definition");
    return;
  }
  std::string a, b;
  if (!state.first_part.empty()) {
    const std::string key = FirstDifference(d, state.first, a, b);
    if (!key.empty()) {
      throw OptionError("--merge: " + part + " and " + state.first_part + " are shards of different sweeps: " + key +
                        " " + common::Quote(a) + " in " + part + ", " + common::Quote(b) + " in " +
                        state.first_part);
    }
  }
  const std::string key = FirstDifference(d, state.plan, a, b);
  if (!key.empty()) {
    throw OptionError("--merge: " + part + ": its sweep ran with " + key + " " + common::Quote(a) +
                      ", this merge's options give " + common::Quote(b) + " (merge with the shards' own options)");
  }
  if (state.first_part.empty()) {
    state.first_part = part;
    state.first = d;
  }
}

// sweep-plot's check of a row (RowProblem), on the cells of either format.
void CheckRow(const Layout& l, const Cells& cells, const std::string& where, const std::string& text) {
  const auto real = [&](std::size_t c) { return cells.real[l.slot[c]]; };
  const std::string problem = RowProblem({real(1), real(2), real(3), real(4), real(5), real(7),
                                          static_cast<double>(cells.integer[l.slot[8]])});
  if (!problem.empty()) {
    throw OptionError(where + "row " + common::Quote(text) + ": " + problem + " (sweep-plot would refuse it)");
  }
}

void ReadCsvShard(const Layout& l, const std::unordered_map<std::string, std::size_t>& index_of,
                  const std::string& part, Slots& slots, Definitions& definitions) {
  std::ifstream in(part, std::ios::binary);
  if (!in) throw OptionError("--merge: cannot read '" + part + "'");
  std::string line;
  std::size_t line_no = 0;
  bool header_seen = false;
  Definition definition;
  Cells cells;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = "--merge: " + part + ":" + std::to_string(line_no) + ": ";
    if (in.eof()) throw OptionError(where + "a torn last line (the shard was interrupted: --resume it first)");
    if (!header_seen) {
      if (ParseDefinitionLine(line, definition)) continue;
      if (line != l.header) {
        throw OptionError(where + "header " + common::Quote(line) + " is not a sweep's" +
                          (l.columns() > kColumns ? " of this assembly (" + l.header + ")" : ""));
      }
      CheckDefinition(part, definition, definitions);
      header_seen = true;
      continue;
    }
    std::size_t cut = std::string::npos, from = 0;  // the 7th comma ends the case's key
    for (std::size_t commas = 0; commas < kKeyColumns; ++commas) {
      cut = line.find(',', from);
      if (cut == std::string::npos) break;
      from = cut + 1;
    }
    const std::string key = cut == std::string::npos ? std::string() : line.substr(0, cut + 1);
    if (!key.empty() && index_of.count(key) != 0) {
      const std::string wrong = ParseFields(l, line, cells);
      if (!wrong.empty()) throw OptionError(where + "row " + common::Quote(line) + " " + wrong);
      CheckRow(l, cells, where, line);
    }
    const std::string text = line;
    Place(index_of, key, where, text, slots, std::move(line), cells);
  }
  if (!header_seen) throw OptionError("--merge: " + part + ": no sweep header (an empty file?)");
}

const char* KindName(char kind) {
  return kind == 'd' ? "floats" : kind == 'i' ? "integers" : kind == 's' ? "strings" : "of another type";
}

void ReadH5Shard(const Layout& l, const std::unordered_map<std::string, std::size_t>& index_of,
                 const std::string& part, Slots& slots, Definitions& definitions) {
  H5ResultsTable read;
  try {
    read = ReadResultsTableH5(part, l.names);
  } catch (const std::runtime_error& e) {
    throw OptionError("--merge: " + std::string(e.what()));
  }
  // The datasets must be HeaderOf(plan)'s columns and no others, each of the type the HDF5 writer gives it.
  const std::size_t columns = l.columns();
  std::vector<const H5ResultsColumn*> column(columns);
  std::string missing;
  for (std::size_t c = 0; c < columns; ++c) {
    column[c] = &read.columns[c];
    if (read.columns[c].kind == 0) missing += (missing.empty() ? "" : ",") + l.names[c];
  }
  if (!missing.empty() || read.links != columns) {
    throw OptionError("--merge: " + part + ": /results columns (" + std::to_string(read.links) + " links" +
                      (missing.empty() ? "" : ", lacking " + missing) + ") are not a sweep's (" + l.header + ")");
  }
  CheckDefinition(part, read.definition, definitions);
  const std::size_t n = column[0]->size();
  for (std::size_t c = 0; c < columns; ++c) {
    const char want = l.type[c] == ColumnType::kDouble ? 'd' : l.type[c] == ColumnType::kInt ? 'i' : 's';
    if (column[c]->kind != want) {
      throw OptionError("--merge: " + part + ": /results/" + l.names[c] + " holds " + KindName(column[c]->kind) +
                        ", a sweep's " + KindName(want));
    }
    if (column[c]->size() != n) {
      throw OptionError("--merge: " + part + ": /results/" + l.names[c] + " has " +
                        std::to_string(column[c]->size()) + " rows, /results/" + l.names[0] + " " +
                        std::to_string(n));
    }
  }
  Cells cells;
  for (std::size_t r = 0; r < n; ++r) {
    const std::string where = "--merge: " + part + ": /results row " + std::to_string(r + 1) + ": ";
    for (std::size_t c = 0; c < columns; ++c) {
      switch (l.type[c]) {
        case ColumnType::kDouble: cells.real[l.slot[c]] = column[c]->real[r]; break;
        case ColumnType::kInt: cells.integer[l.slot[c]] = column[c]->integer[r]; break;
        case ColumnType::kString: cells.text[l.slot[c]] = column[c]->text[r]; break;
      }
    }
    std::string line = FormatCells(l, cells, columns);
    if (!slots.h5) {
      // A CSV field cannot hold , " or a control character (the CSV writer never writes one).
      for (std::size_t k = 0; k < l.count[static_cast<std::size_t>(ColumnType::kString)]; ++k) {
        const std::string& t = cells.text[k];
        if (t.find_first_of(",\"") != std::string::npos ||
            std::any_of(t.begin(), t.end(), [](char ch) { return static_cast<unsigned char>(ch) < 0x20; })) {
          throw OptionError(where + "text " + common::Quote(t) + " cannot be a CSV field (, \" or a control character)");
        }
      }
    }
    const std::string key = FormatCells(l, cells, kKeyColumns);
    if (index_of.count(key) != 0) CheckRow(l, cells, where, line);
    const std::string text = line;
    Place(index_of, key, where, text, slots, std::move(line), cells);
  }
}

void WriteCsv(const Layout& l, const Slots& slots, const Definition& definition, const ProvenanceLines& provenance,
              const std::string& out_path) {
  std::unique_ptr<common::AtomicFile> out;
  try {
    out = std::make_unique<common::AtomicFile>(out_path);
  } catch (const std::runtime_error& e) {
    throw OptionError(std::string("--out: ") + e.what());
  }
  std::FILE* f = out->stream();
  const std::string head =
      (definition.empty() ? "" : DefinitionText(definition)) + ProvenanceText(provenance) + l.header + "\n";
  bool ok = std::fputs(head.c_str(), f) >= 0;
  for (const std::string& row : slots.lines) ok = ok && std::fputs(row.c_str(), f) >= 0 && std::fputc('\n', f) != EOF;
  if (!ok) throw std::runtime_error("error writing '" + out_path + "'");
  out->Commit();
}

void WriteH5(const Plan& plan, const Layout& l, const Slots& slots, const Definition& definition,
             const ProvenanceLines& provenance, const std::string& out_path) {
  // Destroyed without Close() (an error), out_path keeps what it held.
  H5Results out(out_path, plan, definition, provenance);
  exporter::Row row;
  row.Resize(l.columns());
  for (const Cells& cells : slots.cells) {
    for (std::size_t c = 0; c < l.columns(); ++c) {
      switch (l.type[c]) {
        case ColumnType::kDouble: row.real[c] = cells.real[l.slot[c]]; break;
        case ColumnType::kInt: row.integer[c] = cells.integer[l.slot[c]]; break;
        case ColumnType::kString: row.text[c] = cells.text[l.slot[c]]; break;
      }
    }
    out.Append(row);
  }
  out.Close();
}

}  // namespace

MergeReport MergeShards(const Plan& plan, const std::vector<std::string>& parts, const std::string& out_path,
                        const ProvenanceLines& provenance) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const std::string& part : parts) {
    if (fs::is_directory(part, ec)) {
      throw OptionError("--merge: " + common::Quote(part) + " is a directory; give the shard files (e.g. part*.csv)");
    }
    if (fs::exists(out_path, ec) && fs::equivalent(part, out_path, ec)) {
      throw OptionError("--merge: " + common::Quote(part) + " is also --out " + common::Quote(out_path) +
                        ": the merge would replace a shard it reads; write the merge to another file");
    }
  }
  const Layout layout = MakeLayout(plan);
  const bool h5_out = common::HasExtension(out_path, ".h5") || common::HasExtension(out_path, ".hdf5");
  const std::size_t n = plan.size();
  std::unordered_map<std::string, std::size_t> index_of;
  index_of.reserve(n);
  for (std::size_t i = 0; i < n; ++i) index_of.emplace(KeyPrefix(plan, i), i);
  Slots slots(n, h5_out);
  Definitions definitions;
  definitions.plan = DefinitionOf(plan);
  for (const std::string& part : parts) {
    if (IsHdf5File(part)) {
      ReadH5Shard(layout, index_of, part, slots, definitions);
    } else {
      ReadCsvShard(layout, index_of, part, slots, definitions);
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!slots.have[i]) {
      throw OptionError("--merge: no file holds case " + std::to_string(i) + " (" + common::Quote(KeyPrefix(plan, i)) +
                        "): a shard is missing or unfinished");
    }
  }
  // The output claims the definition only when every shard carried it.
  const Definition written = definitions.any_missing ? Definition{} : definitions.plan;
  if (h5_out) {
    WriteH5(plan, layout, slots, written, provenance, out_path);
  } else {
    WriteCsv(layout, slots, written, provenance, out_path);
  }
  return MergeReport{std::move(definitions.warnings)};
}

}  // namespace rocklab::sweep
