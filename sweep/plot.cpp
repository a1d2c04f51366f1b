#include "sweep/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <map>
#include <stdexcept>

#include "common/atomic_file.h"
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
      path);
  report.files.push_back(path);
}

const char* const kColours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
std::string RecordStyle(std::size_t k) {
  return std::string("with linespoints lw 1 pt 7 ps 0.5 lc rgb '") + kColours[k % 10] + "'";
}
const std::string kMedianStyle = "with linespoints lw 2.5 pt 5 ps 0.7 lc rgb '#000000'";

}  // namespace

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
  std::vector<ResultRow> rows;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (common::Trim(line).empty()) continue;
    common::Split(line, ',', fields);
    if (at.empty()) {
      for (std::size_t i = 0; i < fields.size(); ++i) column[std::string(common::Trim(fields[i]))] = i;
      for (const char* name : needed) {
        const auto it = column.find(name);
        if (it == column.end()) throw std::runtime_error(where + "no column '" + name + "' in the header (a sweep's results?)");
        at.push_back(it->second);
      }
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
    if (!(r.pga_g > 0) || !(r.alpha > 0)) throw std::runtime_error(where + "pga_g and alpha must be > 0");
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
      out.push_back({r.model, r.alpha_text, r.p_text, r.mu_text, 0, 0, {}});
      points.emplace_back();
    }
    BlockFragility& b = out[it->second];
    ++b.rows;
    if (r.overturned) ++b.overturned;
    FragilityPoint& pt = points[it->second][r.pga_g];
    pt.x = r.pga_g;
    pt.trials += 1;
    pt.overturned += r.overturned ? 1 : 0;
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    std::vector<FragilityPoint> v;
    for (const auto& [x, pt] : points[i]) v.push_back(pt);
    out[i].fit = FitLognormalFragility(v);
  }
  return out;
}

PlotReport MakeFigures(const std::vector<ResultRow>& rows, const std::vector<BlockFragility>& fragilities,
                       const PlotOptions& o) {
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) throw std::runtime_error("cannot make '" + o.out_dir + "': " + ec.message());
  PlotReport report;

  // Rows by block, then by record in first-appearance order, each in file order.
  std::vector<std::string> block_order;
  std::map<std::string, std::vector<const ResultRow*>> by_block;
  for (const ResultRow& r : rows) {
    auto& v = by_block[BlockKey(r)];
    if (v.empty()) block_order.push_back(BlockKey(r));
    v.push_back(&r);
  }
  auto records_of = [](const std::vector<const ResultRow*>& v) {
    std::vector<std::string> names;
    std::map<std::string, std::vector<const ResultRow*>> by;
    for (const ResultRow* r : v) {
      if (by[r->record].empty()) names.push_back(r->record);
      by[r->record].push_back(r);
    }
    return std::make_pair(names, by);
  };

  // Spectra against PGA / (g tan alpha), one figure per block with 2+ scales.
  std::size_t drawn = 0;
  for (std::size_t b = 0; b < block_order.size(); ++b) {
    const auto& v = by_block[block_order[b]];
    const auto [names, by] = records_of(v);
    const std::size_t scales = by.at(names.front()).size();
    if (scales < 2) continue;
    if (drawn++ >= o.max_figures_per_kind) {
      ++report.skipped;
      continue;
    }
    std::vector<Series> series;
    std::vector<std::vector<double>> xs(scales), ys(scales);
    for (std::size_t k = 0; k < names.size(); ++k) {
      Series s{names[k], {}, RecordStyle(k)};
      const auto& rr = by.at(names[k]);
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
    Series median{"median of " + std::to_string(names.size()) + " records", {}, kMedianStyle};
    for (std::size_t j = 0; j < scales; ++j) median.xy.emplace_back(Median(xs[j]), Median(ys[j]));
    std::sort(median.xy.begin(), median.xy.end());
    series.push_back(std::move(median));
    const ResultRow& r0 = *v.front();
    Draw(o, "spectrum_pga_" + std::to_string(b + 1),
         "set title " + GnuplotQuoted("rocking spectrum, " + r0.model + ", alpha " + r0.alpha_text + " rad, p " +
                                      r0.p_text + " rad/s, mu " + r0.mu_text + " (overturned at 1)") +
             " noenhanced\nset xlabel 'PGA / (g tan alpha)'\nset ylabel 'peak theta / alpha'\nset yrange [0:1.05]\n"
             "set key outside right top\n",
         series, report);
  }

  // Spectra against p: per (model, alpha, mu) and scale position, with 2+ p.
  drawn = 0;
  std::map<std::string, std::vector<const ResultRow*>> by_family;  // model, alpha, mu
  std::vector<std::string> family_order;
  for (const ResultRow& r : rows) {
    const std::string key = r.model + "," + r.alpha_text + "," + r.mu_text;
    auto& f = by_family[key];
    if (f.empty()) family_order.push_back(key);
    f.push_back(&r);
  }
  std::size_t figure = 0;
  for (const std::string& key : family_order) {
    const auto& v = by_family[key];
    std::map<std::string, int> ps;
    for (const ResultRow* r : v) ps[r->p_text] = 1;
    if (ps.size() < 2) continue;
    // Scale position j of each row within its (record, p).
    std::map<std::string, std::size_t> seen;
    std::map<std::size_t, std::vector<const ResultRow*>> by_position;
    for (const ResultRow* r : v) by_position[seen[r->record + "," + r->p_text]++].push_back(r);
    for (const auto& [j, at_scale] : by_position) {
      ++figure;
      if (drawn++ >= o.max_figures_per_kind) {
        ++report.skipped;
        continue;
      }
      const auto [names, by] = records_of(at_scale);
      std::vector<Series> series;
      std::map<double, std::vector<double>> at_p;
      for (std::size_t k = 0; k < names.size(); ++k) {
        Series s{names[k], {}, RecordStyle(k)};
        for (const ResultRow* r : by.at(names[k])) {
          s.xy.emplace_back(r->p, Ordinate(*r));
          at_p[r->p].push_back(Ordinate(*r));
        }
        std::sort(s.xy.begin(), s.xy.end());
        series.push_back(std::move(s));
      }
      Series median{"median", {}, kMedianStyle};
      for (const auto& [p, ys] : at_p) median.xy.emplace_back(p, Median(ys));
      series.push_back(std::move(median));
      const ResultRow& r0 = *at_scale.front();
      char scale[64];
      std::snprintf(scale, sizeof scale, "scale %.6g (PGA %.4g g for %s)", r0.scale, r0.pga_g, r0.record.c_str());
      Draw(o, "spectrum_p_" + std::to_string(figure),
           "set title " + GnuplotQuoted("rocking spectrum, " + r0.model + ", alpha " + r0.alpha_text + " rad, mu " +
                                        r0.mu_text + ", " + scale) +
               " noenhanced\nset xlabel 'p (rad/s)'\nset ylabel 'peak theta / alpha'\nset yrange [0:1.05]\n"
               "set key outside right top\n",
           series, report);
    }
  }

  // Overturning map per model: p against PGA / (g tan alpha), coloured by
  // the share of records that overturned.
  std::map<std::string, std::map<std::pair<double, double>, std::pair<double, double>>> maps;
  for (const ResultRow& r : rows) {
    auto& cell = maps[r.model][{r.p, r.pga_g / std::tan(r.alpha)}];
    cell.first += 1;
    cell.second += r.overturned ? 1 : 0;
  }
  for (const auto& [model, cells] : maps) {
    const std::string path = (std::filesystem::path(o.out_dir) / ("overturn_map_" + model + Extension(o))).string();
    std::string s = "set grid\nset title " + GnuplotQuoted("overturning map, " + model) +
                    " noenhanced\nset xlabel 'p (rad/s)'\nset ylabel 'PGA / (g tan alpha)'\n"
                    "set cblabel 'share of records overturned'\nset cbrange [0:1]\n"
                    "set palette defined (0 '#2c7bb6', 0.5 '#ffffbf', 1 '#d7191c')\n$m << EOD\n";
    for (const auto& [xy, counts] : cells) s += Num(xy.first) + " " + Num(xy.second) + " " + Num(counts.second / counts.first) + "\n";
    s += "EOD\nplot $m using 1:2:3 with points pt 5 ps 1.5 lc palette notitle\nset output\n";
    report::RunGnuplot(
        o.gnuplot,
        [&](const std::string& output) {
          return Terminal(o) + "set encoding utf8\nset output " + GnuplotQuoted(output) + "\n" + s;
        },
        path);
    report.files.push_back(path);
  }

  // Fragility curves per block.
  drawn = 0;
  for (std::size_t b = 0; b < fragilities.size(); ++b) {
    const BlockFragility& f = fragilities[b];
    if (drawn++ >= o.max_figures_per_kind) {
      ++report.skipped;
      continue;
    }
    std::map<double, std::pair<double, double>> at_pga;
    for (const ResultRow& r : rows) {
      if (r.model != f.model || r.alpha_text != f.alpha || r.p_text != f.p || r.mu_text != f.mu) continue;
      at_pga[r.pga_g].first += 1;
      at_pga[r.pga_g].second += r.overturned ? 1 : 0;
    }
    Series points{"fraction overturned", {}, "with points pt 7 ps 0.8 lc rgb '#1f77b4'"};
    double x_max = 0;
    for (const auto& [x, c] : at_pga) {
      points.xy.emplace_back(x, c.second / c.first);
      x_max = std::max(x_max, x);
    }
    std::string curve;
    std::string title = "fragility, " + f.model + ", alpha " + f.alpha + " rad, p " + f.p + " rad/s, mu " + f.mu;
    if (f.fit.status == FragilityFit::Status::kFitted) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "norm(log(x/%.9g)/%.9g) with lines lw 2 lc rgb '#d62728' title 'lognormal: median %.4g g, beta %.3g'",
                    f.fit.median, f.fit.beta, f.fit.median, f.fit.beta);
      curve = buf;
    } else {
      title += " (no fit: " + std::string(ToString(f.fit.status)) + ")";
    }
    Draw(o, "fragility_" + std::to_string(b + 1),
         "set title " + GnuplotQuoted(title) + " noenhanced\nset xlabel 'PGA (g)'\nset ylabel 'P(overturn)'\n"
         "set yrange [-0.02:1.02]\nset xrange [0:" + Num(1.1 * x_max) + "]\nset samples 400\nset key left top\n",
         {points}, report, curve);
  }

  // The fits as a table.
  const std::string table = (std::filesystem::path(o.out_dir) / "fragility.csv").string();
  std::ostringstream out;
  out << "model,alpha,p,mu,rows,overturned,status,median_pga_g,beta,safe_below_g,overturned_above_g\n";
  for (const BlockFragility& f : fragilities) {
    const bool fitted = f.fit.status == FragilityFit::Status::kFitted;
    const bool separated = f.fit.status == FragilityFit::Status::kSeparated;
    out << f.model << ',' << f.alpha << ',' << f.p << ',' << f.mu << ',' << f.rows << ',' << f.overturned << ','
        << ToString(f.fit.status) << ',' << (fitted ? Num(f.fit.median) : "") << ',' << (fitted ? Num(f.fit.beta) : "")
        << ',' << (separated ? Num(f.fit.safe_below) : "") << ',' << (separated ? Num(f.fit.overturned_above) : "")
        << '\n';
  }
  common::WriteFileAtomically(table, out.str());
  report.files.push_back(table);
  return report;
}

}  // namespace rocklab::sweep
