#include "sweep/plot.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "common/atomic_file.h"
#include "common/provenance.h"
#include "common/text.h"
#include "sweep/results_h5.h"

namespace rocklab::sweep {
namespace {

using report::GnuplotQuoted;

std::string Num(double v) {
  if (!std::isfinite(v)) return "NaN";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

constexpr std::size_t kBandPoints = 200;

std::string Num4(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

std::string Num3(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Spectrum ordinate: overturned cases sit at the ceiling 1.
double Ordinate(const ResultRow& r) { return r.overturned ? 1.0 : r.peak_theta_over_alpha; }

std::string BlockKey(const ResultRow& r) { return r.model + "," + r.alpha_text + "," + r.p_text + "," + r.mu_text; }

std::string Terminal(const PlotOptions& o) {
  return o.format == report::FigureFormat::kSvg
             ? "set terminal svg size 900,600 font 'sans-serif,11' background '#ffffff'\n"
             : "set terminal pngcairo size 900,600 font 'sans,10' background '#ffffff'\n";
}
std::string Extension(const PlotOptions& o) { return o.format == report::FigureFormat::kSvg ? ".svg" : ".png"; }

// A name's part from a value as written: letters, digits, '.', '-' and '+'
// kept, anything else '_'.
std::string Slug(const std::string& text) {
  std::string out;
  for (char c : text) out += std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '+' ? c : '_';
  return out;
}

// Curves on one spectrum against p, at most.
constexpr std::size_t kMaxCurves = 10;

// A title in lines that fit the figure whole. gnuplot centres the title
// on the plot area, which a key outside on the right pushes left, so a
// line may be at most (width - 2 x key) wide: 900 px - 2 x 180 px at 11 px
// sans-serif, whose glyphs average under 0.62 em (DejaVu Sans, the
// fontconfig default: 0.55 em over lowercase text and digits), 79 characters.
// Lines break after ", " or ": " or "; ".
constexpr std::size_t kTitleChars = 79;
std::string WrapTitle(const std::string& title) {
  std::string out, line;
  std::size_t from = 0;
  while (from < title.size()) {
    std::size_t cut = title.size();
    for (const char* sep : {", ", ": ", "; ", ". "}) {
      const std::size_t at = title.find(sep, from);
      if (at != std::string::npos) cut = std::min(cut, at + 2);
    }
    const std::string piece = title.substr(from, cut - from);
    if (!line.empty() && line.size() + piece.size() > kTitleChars) {
      out += (out.empty() ? "" : "\n") + line.substr(0, line.find_last_not_of(' ') + 1);
      line.clear();
    }
    line += piece;
    from = cut;
  }
  if (!line.empty()) out += (out.empty() ? "" : "\n") + line;
  return out;
}

// `text` as a gnuplot double-quoted string, its newlines as \n (a
// single-quoted string would print them as they are); other control
// characters become spaces.
std::string DoubleQuoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += static_cast<unsigned char>(c) < 0x20 ? ' ' : c;
    }
  }
  return out + "\"";
}

// A title wrapped to kTitleChars a line, as a gnuplot string.
std::string TitleLiteral(const std::string& title) { return DoubleQuoted(WrapTitle(title)); }

// A curve as a gnuplot data block $name, then its plot clause.
struct Series {
  std::string title;
  std::vector<std::pair<double, double>> xy;
  std::string style;  // gnuplot "with ..." clause
};

void Draw(const PlotOptions& o, const std::string& file, const std::string& setup, const std::vector<Series>& series,
          PlotReport& report, const std::string& extra_plot = "") {
  const std::string path = (std::filesystem::path(o.out_dir) / (file + Extension(o))).string();
  std::string s = "set grid\n" + setup;
  std::string plot = "plot ";
  for (std::size_t i = 0; i < series.size(); ++i) {
    const std::string name = "$s" + std::to_string(i);
    s += name + " << EOD\n";
    for (const auto& [x, y] : series[i].xy) s += Num(x) + " " + Num(y) + "\n";
    if (series[i].xy.empty()) s += "NaN NaN\n";
    s += "EOD\n";
    plot += (i ? ", " : "") + name + " using 1:2 " + series[i].style + " title " + GnuplotQuoted(series[i].title) +
            " noenhanced";
  }
  if (!extra_plot.empty()) plot += (series.empty() ? "" : ", ") + extra_plot;
  s += plot + "\nset output\n";
  report::RunGnuplot(
      o.gnuplot,
      [&](const std::string& output) {
        return Terminal(o) + "set encoding utf8\nset output " + GnuplotQuoted(output) + "\n" + s;
      },
      path, o.provenance);
  report.files.push_back(path);
}

// A figure from a whole gnuplot script body (after terminal and output).
void DrawRaw(const PlotOptions& o, const std::string& file, const std::string& body, PlotReport& report) {
  const std::string path = (std::filesystem::path(o.out_dir) / (file + Extension(o))).string();
  report::RunGnuplot(
      o.gnuplot,
      [&](const std::string& output) {
        return Terminal(o) + "set encoding utf8\nset output " + GnuplotQuoted(output) + "\n" + body + "set output\n";
      },
      path, o.provenance);
  report.files.push_back(path);
}

const char* const kColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
std::string RecordStyle(std::size_t k) {
  return std::string("with linespoints lw 1 pt 7 ps 0.5 lc rgb '") + kColours[k % 10] + "'";
}
// An assembly's bodies in the fragility figure: the record colours less the
// fraction overturned's blue and the fitted curve's red, one per body.
const char* const kBodyColours[] = {"#ff7f0e", "#2ca02c", "#9467bd", "#8c564b",
                                    "#e377c2", "#bcbd22", "#17becf", "#7f7f7f"};
const std::string kMedianStyle = "with linespoints lw 2.5 pt 5 ps 0.7 lc rgb '#000000'";

}  // namespace

// Here, not in results_h5.cpp: the signature needs no HDF5, and the rocklab
// command, which opens HDF5 through a plugin (tools/hdf5_forward.cpp),
// calls it before it knows it needs the plugin.
bool IsHdf5File(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  return in.read(head, sizeof head) && std::memcmp(head, "\x89HDF\r\n\x1a\n", 8) == 0;
}

std::string RowProblem(const RowValues& v) {
  const std::pair<const char*, double> numbers[] = {{"scale", v.scale}, {"pga_g", v.pga_g},
                                                    {"alpha", v.alpha}, {"p", v.p},
                                                    {"mu", v.mu},       {"peak_theta_over_alpha", v.peak_theta_over_alpha}};
  for (const auto& [name, value] : numbers) {
    if (!std::isfinite(value)) return std::string(name) + " is not a finite number";
  }
  if (v.overturned != 0 && v.overturned != 1) return "overturned is not 0 or 1";
  if (!(v.pga_g > 0) || !(v.alpha > 0)) return "pga_g and alpha must be > 0";
  return "";
}

std::vector<ResultRow> ReadResults(const std::string& path) {
  if (IsHdf5File(path)) return ReadResultsH5(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open for reading");
  std::string line;
  std::vector<std::string_view> fields;
  std::size_t line_no = 0;
  std::map<std::string, std::size_t> column;
  const char* const needed[] = {"record", "scale", "pga_g", "alpha", "p", "mu", "model", "peak_theta_over_alpha",
                                "overturned"};
  std::vector<std::size_t> at;
  std::optional<std::size_t> block_at, first_body_at;
  std::vector<ResultRow> rows;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (common::Trim(line).empty() || (at.empty() && line[0] == '#')) continue;
    common::Split(line, ',', fields);
    if (at.empty()) {
      for (std::size_t i = 0; i < fields.size(); ++i) column[std::string(common::Trim(fields[i]))] = i;
      for (const char* name : needed) {
        const auto it = column.find(name);
        if (it == column.end()) throw std::runtime_error(where + "no column '" + name + "' in the header (a sweep's results?)");
        at.push_back(it->second);
      }
      if (column.count("block")) block_at = column["block"];
      if (column.count("first_overturned_body")) first_body_at = column["first_overturned_body"];
      continue;
    }
    const std::size_t last = *std::max_element(at.begin(), at.end());
    if (fields.size() <= last) throw std::runtime_error(where + "a short row " + common::Quote(line));
    ResultRow r;
    r.record = std::string(fields[at[0]]);
    r.model = std::string(fields[at[6]]);
    r.alpha_text = std::string(fields[at[3]]);
    r.p_text = std::string(fields[at[4]]);
    r.mu_text = std::string(fields[at[5]]);
    double* numbers[] = {&r.scale, &r.pga_g, &r.alpha, &r.p, &r.mu, &r.peak_theta_over_alpha};
    const std::size_t number_cols[] = {1, 2, 3, 4, 5, 7};
    for (int k = 0; k < 6; ++k) {
      const std::string_view f = fields[at[number_cols[k]]];
      if (!common::ParseDouble(f, *numbers[k]) || !std::isfinite(*numbers[k])) {
        throw std::runtime_error(where + needed[number_cols[k]] + " " + common::Quote(f) + " is not a number");
      }
    }
    const std::string_view over = common::Trim(fields[at[8]]);
    if (over != "0" && over != "1") throw std::runtime_error(where + "overturned " + common::Quote(over) + " is not 0 or 1");
    r.overturned = over == "1";
    const std::string problem =
        RowProblem({r.scale, r.pga_g, r.alpha, r.p, r.mu, r.peak_theta_over_alpha, r.overturned ? 1.0 : 0.0});
    if (!problem.empty()) throw std::runtime_error(where + problem);
    // The row's own block label (a row cut before it has none).
    if (block_at && *block_at < fields.size() && !common::Trim(fields[*block_at]).empty()) {
      r.block = std::string(common::Trim(fields[*block_at]));
    }
    if (first_body_at && *first_body_at < fields.size() && r.overturned) {
      r.first_overturned_body = std::string(common::Trim(fields[*first_body_at]));
    }
    rows.push_back(std::move(r));
  }
  if (at.empty()) throw std::runtime_error(path + ": empty file (expected a sweep's header)");
  return rows;
}

std::vector<BlockFragility> FitFragilities(const std::vector<ResultRow>& rows) {
  std::vector<BlockFragility> out;
  std::map<std::string, std::size_t> index;
  std::vector<std::map<double, FragilityPoint>> points;
  for (const ResultRow& r : rows) {
    const auto [it, fresh] = index.emplace(BlockKey(r), out.size());
    if (fresh) {
      BlockFragility fresh_block;
      fresh_block.model = r.model;
      fresh_block.alpha = r.alpha_text;
      fresh_block.p = r.p_text;
      fresh_block.mu = r.mu_text;
      out.push_back(std::move(fresh_block));
      points.emplace_back();
    }
    BlockFragility& b = out[it->second];
    ++b.rows;
    if (r.overturned) ++b.overturned;
    if (!r.first_overturned_body.empty()) {
      auto& by_body = b.first_overturned;
      auto at = std::find_if(by_body.begin(), by_body.end(),
                             [&r](const auto& entry) { return entry.first == r.first_overturned_body; });
      if (at == by_body.end()) at = by_body.insert(by_body.end(), {r.first_overturned_body, 0});
      ++at->second;
    }
    FragilityPoint& pt = points[it->second][r.pga_g];
    pt.x = r.pga_g;
    pt.trials += 1;
    pt.overturned += r.overturned ? 1 : 0;
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    std::vector<FragilityPoint> v;
    for (const auto& [x, pt] : points[i]) v.push_back(pt);
    BlockFragility& b = out[i];
    b.fit = FitLognormalFragility(v);
    b.pga_min_g = v.front().x;
    b.pga_max_g = v.back().x;
    if (b.fit.status != FragilityFit::Status::kFitted) continue;
    std::vector<double> xs(kBandPoints);
    for (std::size_t k = 0; k < kBandPoints; ++k) xs[k] = 1.1 * b.pga_max_g * static_cast<double>(k + 1) / kBandPoints;
    b.band = LikelihoodBand(v, b.fit, xs);
    std::vector<std::string> notes;
    if (b.fit.median > b.pga_max_g) notes.push_back("median above the highest PGA tried (" + Num(b.pga_max_g) + " g): extrapolated");
    if (b.fit.median < b.pga_min_g) notes.push_back("median below the lowest PGA tried (" + Num(b.pga_min_g) + " g): extrapolated");
    if (b.overturned < kFewOutcomes) notes.push_back("only " + std::to_string(b.overturned) + " overturned");
    if (b.rows - b.overturned < kFewOutcomes) notes.push_back("only " + std::to_string(b.rows - b.overturned) + " safe");
    if (b.band.median_low_open || b.band.median_high_open) {
      notes.push_back("the likelihood leaves the median's 95 % interval open");
    } else if (b.band.median_high > 10 * b.pga_max_g || b.band.median_low < 0.1 * b.pga_min_g) {
      notes.push_back("the median's 95 % interval (" + Num3(b.band.median_low) + " to " + Num3(b.band.median_high) +
                      " g) reaches past 10 times the PGAs tried");
    }
    for (const std::string& n : notes) b.caveat += (b.caveat.empty() ? "" : "; ") + n;
  }
  return out;
}

namespace {

// Figure names: a figure is named after what it shows (spectrum_vs_pga_
// housner_alpha0.2_p3_mu0.9.svg); the same name twice gets _2, _3, ...
class FigureNames {
 public:
  explicit FigureNames(const std::vector<ResultRow>& rows) {
    for (const ResultRow& r : rows) mus_of_[r.model + "," + r.alpha_text][r.mu_text] = 1;
  }
  std::string Unique(const std::string& name) {
    const int n = ++names_used_[name];
    return n == 1 ? name : name + "_" + std::to_string(n);
  }
  // mu is in a name only where one (model, alpha) has several.
  std::string MuPart(const ResultRow& r) {
    return mus_of_[r.model + "," + r.alpha_text].size() > 1 ? "_mu" + Slug(r.mu_text) : std::string();
  }
  // A block by its label when it has one (rectangle WxH, polygon file),
  // else by alpha, p (and mu).
  std::string BlockPart(const ResultRow& r) {
    return r.block != "-" && !r.block.empty() ? "_block" + Slug(r.block)
                                              : "_alpha" + Slug(r.alpha_text) + "_p" + Slug(r.p_text) + MuPart(r);
  }

 private:
  std::map<std::string, int> names_used_;
  std::map<std::string, std::map<std::string, int>> mus_of_;
};

// Rows of one block by record, records in first-appearance order, each in
// file order.
std::pair<std::vector<std::string>, std::map<std::string, std::vector<const ResultRow*>>> RecordsOf(
    const std::vector<const ResultRow*>& v) {
  std::vector<std::string> names;
  std::map<std::string, std::vector<const ResultRow*>> by;
  for (const ResultRow* r : v) {
    if (by[r->record].empty()) names.push_back(r->record);
    by[r->record].push_back(r);
  }
  return std::make_pair(names, by);
}

// Rows by (model, alpha, mu), keys in first-appearance order.
struct Families {
  std::vector<std::string> order;
  std::map<std::string, std::vector<const ResultRow*>> rows;
};

Families FamiliesOf(const std::vector<ResultRow>& rows) {
  Families out;
  for (const ResultRow& r : rows) {
    const std::string key = r.model + "," + r.alpha_text + "," + r.mu_text;
    auto& f = out.rows[key];
    if (f.empty()) out.order.push_back(key);
    f.push_back(&r);
  }
  return out;
}

void DrawSpectraVsPga(const std::vector<ResultRow>& rows, const PlotOptions& o, FigureNames& names,
                      PlotReport& report) {
  // Rows by block, then by record in first-appearance order, each in file order.
  std::vector<std::string> block_order;
  std::map<std::string, std::vector<const ResultRow*>> by_block;
  for (const ResultRow& r : rows) {
    auto& v = by_block[BlockKey(r)];
    if (v.empty()) block_order.push_back(BlockKey(r));
    v.push_back(&r);
  }
  // Spectra against PGA / (g tan alpha), one figure per block with 2+ scales.
  std::size_t drawn = 0;
  for (std::size_t b = 0; b < block_order.size(); ++b) {
    const auto& v = by_block[block_order[b]];
    const auto [records, by] = RecordsOf(v);
    const std::size_t scales = by.at(records.front()).size();
    if (scales < 2) continue;
    if (drawn++ >= o.max_figures_per_kind) {
      ++report.skipped;
      continue;
    }
    std::vector<Series> series;
    std::vector<std::vector<double>> xs(scales), ys(scales);
    for (std::size_t k = 0; k < records.size(); ++k) {
      Series s{records[k], {}, RecordStyle(k)};
      const auto& rr = by.at(records[k]);
      for (std::size_t j = 0; j < rr.size(); ++j) {
        const double x = rr[j]->pga_g / std::tan(rr[j]->alpha);
        s.xy.emplace_back(x, Ordinate(*rr[j]));
        if (j < scales) {
          xs[j].push_back(x);
          ys[j].push_back(Ordinate(*rr[j]));
        }
      }
      std::sort(s.xy.begin(), s.xy.end());
      series.push_back(std::move(s));
    }
    Series median{"median of " + std::to_string(records.size()) + " records", {}, kMedianStyle};
    for (std::size_t j = 0; j < scales; ++j) median.xy.emplace_back(Median(xs[j]), Median(ys[j]));
    std::sort(median.xy.begin(), median.xy.end());
    series.push_back(std::move(median));
    const ResultRow& r0 = *v.front();
    Draw(o, names.Unique("spectrum_vs_pga_" + Slug(r0.model) + names.BlockPart(r0)),
         "set title " + TitleLiteral(("rocking spectrum against PGA, " + r0.model + ", alpha " + r0.alpha_text +
                                               " rad, p " + r0.p_text + " rad/s, mu " + r0.mu_text +
                                               " (overturned at 1)")) +
             " noenhanced\nset xlabel 'PGA / (g tan alpha)'\nset ylabel 'peak theta / alpha'\nset yrange [0:1.05]\n"
             "set key outside right top\n",
         series, report);
  }
}

void DrawSpectraVsP(const Families& families, const PlotOptions& o, FigureNames& names, PlotReport& report) {
  // Spectra against p: one figure per (model, alpha, mu) with 3 or more p
  // (2 points make no spectrum), the median over the records against p,
  // one curve per scale step (at most kMaxCurves, evenly chosen).
  std::size_t drawn = 0;
  for (const std::string& key : families.order) {
    const auto& v = families.rows.at(key);
    std::map<std::string, int> ps;
    for (const ResultRow* r : v) ps[r->p_text] = 1;
    if (ps.size() < 3) continue;
    if (drawn++ >= o.max_figures_per_kind) {
      ++report.skipped;
      continue;
    }
    // Scale position j of each row within its (record, p).
    std::map<std::string, std::size_t> seen;
    std::map<std::size_t, std::vector<const ResultRow*>> by_position;
    for (const ResultRow* r : v) by_position[seen[r->record + "," + r->p_text]++].push_back(r);
    const std::size_t steps = by_position.size();
    std::vector<Series> series;
    std::set<std::string> records;
    std::size_t curve = 0;
    for (const auto& [j, at_scale] : by_position) {
      // Every step when they fit, else kMaxCurves evenly spread (first and last kept).
      if (steps > kMaxCurves) {
        bool keep = false;
        for (std::size_t c = 0; c < kMaxCurves && !keep; ++c) keep = j == c * (steps - 1) / (kMaxCurves - 1);
        if (!keep) continue;
      }
      std::map<double, std::vector<double>> at_p;
      std::set<double> pgas;
      for (const ResultRow* r : at_scale) {
        at_p[r->p].push_back(Ordinate(*r));
        pgas.insert(r->pga_g);
        records.insert(r->record);
      }
      const ResultRow& r0 = *at_scale.front();
      Series s{pgas.size() == 1 ? "PGA " + Num4(r0.pga_g) + " g" : "scale " + Num4(r0.scale), {}, RecordStyle(curve++)};
      for (const auto& [p, ys] : at_p) s.xy.emplace_back(p, Median(ys));
      series.push_back(std::move(s));
    }
    const ResultRow& r0 = *v.front();
    Draw(o, names.Unique("spectrum_vs_p_" + Slug(r0.model) + "_alpha" + Slug(r0.alpha_text) + names.MuPart(r0)),
         "set title " + TitleLiteral(("rocking spectrum against p, " + r0.model + ", alpha " + r0.alpha_text +
                                               " rad, mu " + r0.mu_text + ": median of " + std::to_string(records.size()) +
                                               " records" + (steps > kMaxCurves ? ", " + std::to_string(kMaxCurves) +
                                               " of " + std::to_string(steps) + " scale steps" : "") +
                                               " (overturned at 1)")) +
             " noenhanced\nset xlabel 'p (rad/s)'\nset ylabel 'peak theta / alpha'\nset yrange [0:1.05]\n"
             "set key outside right top\n",
         series, report);
  }
}

void DrawOverturnMaps(const std::vector<ResultRow>& rows, const std::vector<std::string>& family_order,
                      const PlotOptions& o, FigureNames& names, PlotReport& report) {
  // Overturning maps: p against PGA / (g tan alpha), coloured by the share
  // of records that overturned, one per (model, alpha, mu) with 2 or more
  // p. Blocks that are alone at their alpha (rectangles, polygons) share
  // one map per model, a column per block.
  struct Cell {
    double rows{}, overturned{};
  };
  std::map<std::string, std::map<std::pair<double, double>, Cell>> family_cells;
  std::map<std::string, const ResultRow*> family_first;
  for (const ResultRow& r : rows) {
    const std::string key = r.model + "," + r.alpha_text + "," + r.mu_text;
    Cell& c = family_cells[key][{r.p, r.pga_g / std::tan(r.alpha)}];
    c.rows += 1;
    c.overturned += r.overturned ? 1 : 0;
    if (!family_first.count(key)) family_first[key] = &r;
  }
  const std::string map_setup =
      "set cblabel 'share of records overturned'\nset cbrange [0:1]\n"
      "set palette defined (0 '#2c7bb6', 0.5 '#ffffbf', 1 '#d7191c')\n";
  std::map<std::string, std::vector<std::string>> lone_blocks;  // model -> family keys with one p
  std::size_t drawn = 0;
  for (const std::string& key : family_order) {
    const auto& cells = family_cells[key];
    std::set<double> ps;
    for (const auto& [xy, c] : cells) ps.insert(xy.first);
    const ResultRow& r0 = *family_first[key];
    if (ps.size() < 2) {
      lone_blocks[r0.model].push_back(key);
      continue;
    }
    if (drawn++ >= o.max_figures_per_kind) {
      ++report.skipped;
      continue;
    }
    std::string data = "$m << EOD\n";
    for (const auto& [xy, c] : cells) data += Num(xy.first) + " " + Num(xy.second) + " " + Num(c.overturned / c.rows) + "\n";
    DrawRaw(o, names.Unique("overturn_map_" + Slug(r0.model) + "_alpha" + Slug(r0.alpha_text) + names.MuPart(r0)),
            "set grid\nset title " +
                TitleLiteral(("overturning map, " + r0.model + ", alpha " + r0.alpha_text + " rad, mu " +
                                        r0.mu_text)) +
                " noenhanced\nset xlabel 'p (rad/s)'\nset ylabel 'PGA / (g tan alpha)'\n" + map_setup + data +
                "EOD\nplot $m using 1:2:3 with points pt 5 ps 1.5 lc palette notitle\n",
            report);
  }
  for (const auto& [model, keys] : lone_blocks) {
    if (drawn++ >= o.max_figures_per_kind) {
      ++report.skipped;
      continue;
    }
    std::string tics, data = "$m << EOD\n";
    for (std::size_t i = 0; i < keys.size(); ++i) {
      const ResultRow& r0 = *family_first[keys[i]];
      tics += (i ? ", " : "") + DoubleQuoted((r0.block != "-" ? r0.block + "\n" : "") + "alpha " + Num3(r0.alpha) + ", p " + Num3(r0.p)) + " " + std::to_string(i + 1);
      for (const auto& [xy, c] : family_cells[keys[i]]) {
        data += std::to_string(i + 1) + " " + Num(xy.second) + " " + Num(c.overturned / c.rows) + "\n";
      }
    }
    DrawRaw(o, names.Unique("overturn_map_" + Slug(model) + "_by_block"),
            "set grid\nset title " + TitleLiteral(("overturning map, " + model + ", a column per block")) +
                " noenhanced\nset bmargin 6\nset xlabel 'block (alpha rad, p rad/s)' offset 0,-1\nset ylabel 'PGA / (g tan alpha)'\n"
                "set xrange [0.5:" + std::to_string(keys.size()) + ".5]\nset xtics (" + tics + ") noenhanced\n" +
                map_setup + data + "EOD\nplot $m using 1:2:3 with points pt 5 ps 1.5 lc palette notitle\n",
            report);
  }
}

void DrawFragilityCurves(const std::vector<ResultRow>& rows, const std::vector<BlockFragility>& fragilities,
                         const PlotOptions& o, FigureNames& names, PlotReport& report) {
  // Fragility curves per block: the fraction overturned at each PGA, the
  // fitted lognormal and its 95 % profile-likelihood band; the caveats in
  // the title.
  std::size_t drawn = 0;
  for (std::size_t b = 0; b < fragilities.size(); ++b) {
    const BlockFragility& f = fragilities[b];
    if (drawn++ >= o.max_figures_per_kind) {
      ++report.skipped;
      continue;
    }
    std::map<double, std::pair<double, double>> at_pga;
    // An assembly's: per body, the cases at each PGA it overturned first in.
    std::vector<std::map<double, double>> body_at_pga(f.first_overturned.size());
    const ResultRow* first = nullptr;
    for (const ResultRow& r : rows) {
      if (r.model != f.model || r.alpha_text != f.alpha || r.p_text != f.p || r.mu_text != f.mu) continue;
      at_pga[r.pga_g].first += 1;
      at_pga[r.pga_g].second += r.overturned ? 1 : 0;
      for (std::size_t k = 0; k < f.first_overturned.size(); ++k) {
        body_at_pga[k][r.pga_g] += r.first_overturned_body == f.first_overturned[k].first ? 1 : 0;
      }
      if (first == nullptr) first = &r;
    }
    Series points{"fraction overturned", {}, "with points pt 7 ps 0.8 lc rgb '#1f77b4'"};
    for (const auto& [x, c] : at_pga) points.xy.emplace_back(x, c.second / c.first);
    std::vector<Series> series;
    std::string title = "fragility, " + f.model + ", alpha " + f.alpha + " rad, p " + f.p + " rad/s, mu " + f.mu + ": " +
                        std::to_string(f.overturned) + " of " + std::to_string(f.rows) + " cases overturned";
    if (!f.first_overturned.empty()) {
      title += ", first to overturn:";
      for (std::size_t k = 0; k < f.first_overturned.size(); ++k) {
        title += (k ? ", " : " ") + f.first_overturned[k].first + " " + std::to_string(f.first_overturned[k].second);
      }
    }
    std::string curve;
    if (f.fit.status == FragilityFit::Status::kFitted) {
      Series band{"95 % band (profile likelihood)", {}, "with filledcurves fs transparent solid 0.25 noborder lc rgb '#d62728'"};
      for (std::size_t k = 0; k < f.band.x.size(); ++k) band.xy.emplace_back(f.band.x[k], f.band.p_low[k]);
      Series high{"", {}, ""};
      for (std::size_t k = 0; k < f.band.x.size(); ++k) high.xy.emplace_back(f.band.x[k], f.band.p_high[k]);
      // The band as one closed polygon: low forwards, high backwards.
      for (auto it = high.xy.rbegin(); it != high.xy.rend(); ++it) band.xy.push_back(*it);
      series.push_back(std::move(band));
      char buf[320];
      std::snprintf(buf, sizeof buf,
                    "norm(log(x/%.9g)/%.9g) with lines lw 2 lc rgb '#d62728' title 'lognormal: median %.4g g "
                    "(95 %%: %s to %s), beta %.3g'",
                    f.fit.median, f.fit.beta, f.fit.median,
                    f.band.median_low_open ? "unbounded" : (Num3(f.band.median_low) + " g").c_str(),
                    f.band.median_high_open ? "unbounded" : (Num3(f.band.median_high) + " g").c_str(), f.fit.beta);
      curve = buf;
      if (!f.caveat.empty()) title += ". Caveat: " + f.caveat;
    } else {
      title += " (no fit: " + std::string(ToString(f.fit.status)) + ")";
    }
    series.push_back(std::move(points));
    // Which body overturns first: the fraction of cases at each PGA in which
    // each body fell first, a colour and a point shape per body (they add
    // up to the fraction overturned).
    for (std::size_t k = 0; k < f.first_overturned.size(); ++k) {
      Series body{f.first_overturned[k].first + " overturned first", {},
                  "with linespoints dt 2 lw 1 pt " + std::to_string(4 + 2 * (k % 6)) + " ps 0.9 lc rgb '" +
                      kBodyColours[k % 8] + "'"};
      for (const auto& [x, count] : body_at_pga[k]) body.xy.emplace_back(x, count / at_pga[x].first);
      series.push_back(std::move(body));
    }
    const double x_max = 1.1 * f.pga_max_g;
    Draw(o, names.Unique("fragility_" + Slug(f.model) + (first ? names.BlockPart(*first) : "")),
         "set title " + TitleLiteral((title)) + " noenhanced\nset xlabel 'PGA (g)'\nset ylabel 'P(overturn)'\n"
         "set yrange [-0.02:1.02]\nset xrange [0:" + Num(x_max) + "]\nset samples 400\nset key left top Left reverse\n",
         series, report, curve);
  }
}

void WriteFragilityTable(const std::vector<BlockFragility>& fragilities, const PlotOptions& o, PlotReport& report) {
  // The fits as a table.
  const std::string table = (std::filesystem::path(o.out_dir) / "fragility.csv").string();
  std::ostringstream out;
  out << "model,alpha,p,mu,rows,overturned,status,median_pga_g,beta,safe_below_g,overturned_above_g,"
         "pga_min_g,pga_max_g,median_low_g,median_high_g,caveat\n";
  for (const BlockFragility& f : fragilities) {
    const bool fitted = f.fit.status == FragilityFit::Status::kFitted;
    const bool separated = f.fit.status == FragilityFit::Status::kSeparated;
    out << f.model << ',' << f.alpha << ',' << f.p << ',' << f.mu << ',' << f.rows << ',' << f.overturned << ','
        << ToString(f.fit.status) << ',' << (fitted ? Num(f.fit.median) : "") << ',' << (fitted ? Num(f.fit.beta) : "")
        << ',' << (separated ? Num(f.fit.safe_below) : "") << ',' << (separated ? Num(f.fit.overturned_above) : "")
        << ',' << Num(f.pga_min_g) << ',' << Num(f.pga_max_g) << ','
        << (fitted && !f.band.median_low_open ? Num(f.band.median_low) : "") << ','
        << (fitted && !f.band.median_high_open ? Num(f.band.median_high) : "") << ',';
    std::string caveat = f.caveat;
    std::replace(caveat.begin(), caveat.end(), ',', ';');
    out << caveat << '\n';
  }
  common::WriteFileAtomically(table, out.str());
  report.files.push_back(table);
  if (!o.provenance.empty()) {
    common::WriteProvenanceSidecarFields(table, o.provenance);
    report.files.push_back(common::ProvenanceSidecarPath(table));  // fragility.provenance.csv
  }
}

}  // namespace

PlotReport MakeFigures(const std::vector<ResultRow>& rows, const std::vector<BlockFragility>& fragilities,
                       const PlotOptions& o) {
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) throw std::runtime_error("cannot make '" + o.out_dir + "': " + ec.message());
  PlotReport report;
  FigureNames names(rows);  // one set of names across the kinds: the order of the calls is the names' order
  const Families families = FamiliesOf(rows);
  DrawSpectraVsPga(rows, o, names, report);
  DrawSpectraVsP(families, o, names, report);
  DrawOverturnMaps(rows, families.order, o, names, report);
  DrawFragilityCurves(rows, fragilities, o, names, report);
  WriteFragilityTable(fragilities, o, report);
  return report;
}

}  // namespace rocklab::sweep
