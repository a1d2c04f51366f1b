// The posterior's draws (CSV / HDF5) and corner plot (SVG) for `rocklab fit
// --posterior` (tools/posterior_output.h).
#include "tools/posterior_output.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/atomic_file.h"
#include "common/provenance.h"
#include "common/text.h"
#include "export/h5_writer.h"

namespace rocklab::tools {
namespace {

std::string UnitOf(const std::string& name) {
  static const std::map<std::string, std::string> units = {
      {"alpha", "rad"}, {"p", "rad/s"}, {"mu", "1"}, {"l", "1"}, {"sigma", "rad"}, {"t_offset", "s"}, {"sigma_mu", "1"},
      {"log_posterior", "1"}};
  const auto u = units.find(name);
  return u != units.end() ? u->second : "1";
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string F(double v, const char* fmt = "%.2f") {
  char buf[48];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

// The draws as CSV: the parameters' names, then log_posterior.
void WriteSamplesCsv(std::FILE* out, const model::PosteriorResult& r) {
  const auto cols = static_cast<std::size_t>(r.draws.cols());
  std::string header;
  for (const std::string& n : r.names) header += n + ",";
  header += "log_posterior\n";
  std::fputs(header.c_str(), out);
  for (Eigen::Index i = 0; i < r.draws.rows(); ++i) {
    for (std::size_t c = 0; c < cols; ++c) std::fprintf(out, "%.17g,", r.draws(i, static_cast<Eigen::Index>(c)));
    std::fprintf(out, "%.17g\n", r.log_posterior(i));
  }
}

}  // namespace

void WritePosteriorSamples(const std::string& path, const model::PosteriorResult& r,
                           const std::vector<std::pair<std::string, std::string>>& provenance) {
  const auto cols = static_cast<std::size_t>(r.draws.cols());
  if (EndsWith(path, ".h5") || EndsWith(path, ".hdf5")) {
    exporter::H5Writer h5(path);
    std::vector<exporter::Column> columns;
    for (const std::string& n : r.names) columns.emplace_back(n, exporter::ColumnType::kDouble, UnitOf(n));
    columns.emplace_back("log_posterior", exporter::ColumnType::kDouble, "1");
    columns.back().description = "log prior + log likelihood, up to a constant";
    const int table = h5.AddTable("posterior", columns);
    h5.Describe(table, "method", r.method);
    h5.Describe(table, "model", r.model);
    h5.Describe(table, "seed", std::to_string(r.seed));
    h5.Describe(table, "walkers", std::to_string(r.walkers));
    h5.Describe(table, "burn_in", std::to_string(r.diagnostics.burn_in));
    for (const auto& [key, value] : provenance) h5.DescribeFile(key, value);
    exporter::Row row;
    row.Resize(cols + 1);
    for (Eigen::Index i = 0; i < r.draws.rows(); ++i) {
      for (std::size_t c = 0; c < cols; ++c) row.real[c] = r.draws(i, static_cast<Eigen::Index>(c));
      row.real[cols] = r.log_posterior(i);
      h5.Append(table, row);
    }
    h5.Close();
    return;
  }
  if (path == "-") {  // CSV on standard output, no sidecar (docs/commands.md)
    WriteSamplesCsv(stdout, r);
    if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
      throw std::runtime_error("--samples -: cannot write to standard output");
    }
    return;
  }
  common::AtomicFile file(path);
  WriteSamplesCsv(file.stream(), r);
  file.Commit();
  common::WriteProvenanceSidecarFields(path, provenance);
}

void WriteCornerSvg(const std::string& path, const model::PosteriorResult& r, const std::string& title,
                    const std::vector<std::pair<std::string, std::string>>& provenance) {
  const int d = static_cast<int>(r.draws.cols());
  const double panel = 150.0, gap = 12.0, left = 70.0, top = 40.0, bins = 30;
  const double size_w = left + d * (panel + gap) + 140.0;  // room for the last title
  const double size_h = top + d * (panel + gap) + 50.0;
  // Each parameter's axis: its 0.5 to 99.5 percentiles, so that a stray walker
  // does not squash the rest.
  std::vector<double> lo(static_cast<std::size_t>(d)), hi(static_cast<std::size_t>(d));
  for (int i = 0; i < d; ++i) {
    std::vector<double> col(r.draws.col(i).data(), r.draws.col(i).data() + r.draws.rows());
    lo[static_cast<std::size_t>(i)] = model::Quantile(col, 0.005);
    hi[static_cast<std::size_t>(i)] = model::Quantile(col, 0.995);
    if (!(hi[static_cast<std::size_t>(i)] > lo[static_cast<std::size_t>(i)])) {
      hi[static_cast<std::size_t>(i)] = lo[static_cast<std::size_t>(i)] + 1e-12 * (1.0 + std::abs(lo[static_cast<std::size_t>(i)]));
    }
  }
  auto bin = [&](int i, double v) {
    const auto k = static_cast<std::size_t>(i);
    return static_cast<int>(std::floor((v - lo[k]) / (hi[k] - lo[k]) * bins));
  };
  std::string svg;
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + F(size_w, "%.0f") + "\" height=\"" +
         F(size_h, "%.0f") + "\" viewBox=\"0 0 " + F(size_w, "%.0f") + " " + F(size_h, "%.0f") +
         "\" font-family=\"sans-serif\" font-size=\"11\">\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg += "<text x=\"" + F(left) + "\" y=\"20\" font-size=\"13\">" + common::XmlText(title) + "</text>\n";
  const auto n = static_cast<double>(r.draws.rows());
  for (int row = 0; row < d; ++row) {
    for (int col = 0; col <= row; ++col) {
      const double x0 = left + col * (panel + gap), y0 = top + row * (panel + gap);
      svg += "<g transform=\"translate(" + F(x0) + "," + F(y0) + ")\">\n";
      svg += "<rect width=\"" + F(panel) + "\" height=\"" + F(panel) + "\" fill=\"none\" stroke=\"#888\"/>\n";
      if (row == col) {
        std::vector<double> h(static_cast<std::size_t>(bins), 0.0);
        for (Eigen::Index i = 0; i < r.draws.rows(); ++i) {
          const int b = bin(col, r.draws(i, col));
          if (b >= 0 && b < bins) h[static_cast<std::size_t>(b)] += 1.0;
        }
        const double peak = std::max(1.0, *std::max_element(h.begin(), h.end()));
        std::string pts = "0," + F(panel);
        for (int b = 0; b < bins; ++b) {
          const double y = panel - 0.95 * panel * h[static_cast<std::size_t>(b)] / peak;
          pts += " " + F(b * panel / bins) + "," + F(y) + " " + F((b + 1) * panel / bins) + "," + F(y);
        }
        pts += " " + F(panel) + "," + F(panel);
        svg += "<polyline points=\"" + pts + "\" fill=\"#c6dbef\" stroke=\"#08519c\"/>\n";
        const model::ParameterSummary& s = r.summary[static_cast<std::size_t>(col)];
        for (double v : {s.ci68_lo, s.median, s.ci68_hi}) {
          const double x = (v - lo[static_cast<std::size_t>(col)]) / (hi[static_cast<std::size_t>(col)] - lo[static_cast<std::size_t>(col)]) * panel;
          svg += "<line x1=\"" + F(x) + "\" x2=\"" + F(x) + "\" y1=\"0\" y2=\"" + F(panel) +
                 "\" stroke=\"#d62728\" stroke-dasharray=\"" + (v == s.median ? "none" : "4,3") + "\"/>\n";
        }
        svg += "<text x=\"2\" y=\"-3\">" + common::XmlText(s.name) + " = " + F(s.median, "%.6g") + " [" + F(s.ci68_lo, "%.6g") +
               ", " + F(s.ci68_hi, "%.6g") + "]</text>\n";
      } else {
        std::vector<double> h(static_cast<std::size_t>(bins * bins), 0.0);
        for (Eigen::Index i = 0; i < r.draws.rows(); ++i) {
          const int bx = bin(col, r.draws(i, col)), by = bin(row, r.draws(i, row));
          if (bx >= 0 && bx < bins && by >= 0 && by < bins) h[static_cast<std::size_t>(by * bins + bx)] += 1.0;
        }
        const double peak = std::max(1.0, *std::max_element(h.begin(), h.end()));
        const double c = panel / bins;
        for (int by = 0; by < bins; ++by) {
          for (int bx = 0; bx < bins; ++bx) {
            const double v = h[static_cast<std::size_t>(by * bins + bx)];
            if (v <= 0.0) continue;
            svg += "<rect x=\"" + F(bx * c) + "\" y=\"" + F(panel - (by + 1) * c) + "\" width=\"" + F(c + 0.3) +
                   "\" height=\"" + F(c + 0.3) + "\" fill=\"#08519c\" fill-opacity=\"" + F(v / peak, "%.3f") +
                   "\"/>\n";
          }
        }
      }
      svg += "</g>\n";
      // Axis ends under the bottom row and beside the first column.
      if (row == d - 1) {
        const auto k = static_cast<std::size_t>(col);
        svg += "<text x=\"" + F(x0) + "\" y=\"" + F(y0 + panel + 14) + "\">" + F(lo[k], "%.6g") + "</text>\n";
        svg += "<text x=\"" + F(x0 + panel) + "\" y=\"" + F(y0 + panel + 14) + "\" text-anchor=\"end\">" +
               F(hi[k], "%.6g") + "</text>\n";
        svg += "<text x=\"" + F(x0 + panel / 2) + "\" y=\"" + F(y0 + panel + 30) + "\" text-anchor=\"middle\">" +
               common::XmlText(r.names[k]) + " (" + common::XmlText(UnitOf(r.names[k])) + ")</text>\n";
      }
      if (col == 0 && row > 0) {
        const auto k = static_cast<std::size_t>(row);
        svg += "<text x=\"" + F(x0 - 4) + "\" y=\"" + F(y0 + panel) + "\" text-anchor=\"end\">" + F(lo[k], "%.6g") +
               "</text>\n";
        svg += "<text x=\"" + F(x0 - 4) + "\" y=\"" + F(y0 + 10) + "\" text-anchor=\"end\">" + F(hi[k], "%.6g") +
               "</text>\n";
      }
    }
  }
  svg += "<text x=\"" + F(left) + "\" y=\"" + F(size_h - 8) + "\">" +
         common::XmlText(std::to_string(r.walkers) + " walkers x " + std::to_string(r.steps) + " steps, burn-in " +
             std::to_string(r.diagnostics.burn_in) + ", " + std::to_string(static_cast<long>(n)) +
             " draws; red: median and 68 % interval; " + (r.converged() ? "converged" : "NOT converged")) +
         "</text>\n</svg>\n";
  common::AtomicFile file(path);
  if (std::fwrite(svg.data(), 1, svg.size(), file.stream()) != svg.size()) {
    throw std::runtime_error("cannot write '" + path + "'");
  }
  file.Finish();
  if (!provenance.empty()) common::AddProvenanceToFigure(file.path(), provenance);
  file.Commit();
}

}  // namespace rocklab::tools
