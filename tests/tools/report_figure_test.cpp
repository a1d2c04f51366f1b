// ThetaFigure: the static report figure drawn by gnuplot.
// Oracles: the curves and captions handed in (read back from the SVG with an
// XML parser), the PNG format's signature and IHDR size, and the documented
// failure messages.
#include "report/report_figure.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "tests/tools/figure_probe.h"
#include "tests/tools/run_cli.h"

namespace rocklab::report {
namespace {

// A damped rocking-like curve with n samples at 100 Hz.
ThetaCurve Curve(const std::string& title, int n, double scale, bool reference) {
  ThetaCurve c;
  c.title = title;
  c.reference = reference;
  for (int k = 0; k < n; ++k) {
    const double t = 0.01 * k;
    c.time_s.push_back(t);
    c.theta_deg.push_back(scale * std::exp(-0.3 * t) * std::sin(6.0 * t));
  }
  return c;
}

ThetaFigure ThreeCurves() {
  ThetaFigure f;
  f.set_title("test record");
  f.AddCurve(Curve("experiment", 300, 4.0, true));
  f.AddCurve(Curve("fitted (complex)", 250, 3.9, false));
  // Quotes, XML and gnuplot markup characters pass through as plain text.
  f.AddCurve(Curve("it's <a&b> x_1^2 {y} @z", 200, 3.5, false));
  f.AddCaptionLine("fitted: complex formulation, alpha 0.235 rad, p 3.884 rad/s, mu 0.937");
  f.AddCaptionLine("rig lab-table-A 'block1' <&>, record 3 s");
  return f;
}

// Every curve is one plotted group whose path has one vertex per sample plus
// the two of its legend sample, titled with the curve's title; every caption
// line is a text element of its own; the file is well-formed XML of the size
// asked.
TEST(ReportFigure, SvgHasOneCurvePerSeriesAndTheCaption) {
  const std::string path = test::ScratchDir("figure_svg") + "/fig.svg";
  const ThetaFigure f = ThreeCurves();
  f.Write(path, FigureFormat::kSvg, 900, 600);
  const test::SvgProbe svg = test::ProbeSvg(test::ReadFile(path));
  ASSERT_TRUE(svg.well_formed) << svg.error;
  EXPECT_EQ(svg.width, 900);
  EXPECT_EQ(svg.height, 600);
  ASSERT_EQ(svg.curves.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(svg.curves[i].title, f.curves()[i].title);
    EXPECT_EQ(svg.curves[i].vertices, static_cast<int>(f.curves()[i].time_s.size()) + 2)
        << f.curves()[i].title;
  }
  for (const std::string& line : f.caption()) {
    EXPECT_NE(std::find(svg.texts.begin(), svg.texts.end(), line), svg.texts.end()) << line;
  }
  EXPECT_NE(std::find(svg.texts.begin(), svg.texts.end(), "theta (degrees)"), svg.texts.end());
  EXPECT_NE(std::find(svg.texts.begin(), svg.texts.end(), "time (s)"), svg.texts.end());
}

// NaN leaves a gap (the curve is cut into two sub-paths, the sample is not
// drawn) and an empty curve still has its legend entry.
TEST(ReportFigure, NaNIsAGapAndAnEmptyCurveKeepsItsLegend) {
  const std::string path = test::ScratchDir("figure_gap") + "/fig.svg";
  ThetaFigure f;
  ThetaCurve c = Curve("experiment", 100, 4.0, true);
  c.theta_deg[50] = std::nan("");
  f.AddCurve(c);
  f.AddCurve(ThetaCurve{"silent variant", {}, {}, false});
  f.Write(path, FigureFormat::kSvg, 600, 400);
  const test::SvgProbe svg = test::ProbeSvg(test::ReadFile(path));
  ASSERT_TRUE(svg.well_formed) << svg.error;
  ASSERT_EQ(svg.curves.size(), 2u);
  EXPECT_EQ(svg.curves[0].vertices, 99 + 2);
  EXPECT_EQ(svg.curves[1].title, "silent variant");
}

TEST(ReportFigure, PngHasTheSignatureAndTheSizeAsked) {
  const std::string path = test::ScratchDir("figure_png") + "/fig.png";
  ThreeCurves().Write(path, FigureFormat::kPng, 640, 480);
  const test::PngProbe png = test::ProbePng(test::ReadFile(path));
  EXPECT_TRUE(png.signature);
  EXPECT_EQ(png.width, 640);
  EXPECT_EQ(png.height, 480);
}

// The script carries the data inline: one data block per curve, no file.
TEST(ReportFigure, ScriptHasOneInlineDataBlockPerCurve) {
  const std::string script = ThreeCurves().Script("out.svg", FigureFormat::kSvg, 800, 600);
  for (const char* block : {"$c0 << EOD\n", "$c1 << EOD\n", "$c2 << EOD\n"}) {
    EXPECT_NE(script.find(block), std::string::npos) << block;
  }
  EXPECT_EQ(script.find("$c3"), std::string::npos);
  EXPECT_NE(script.find("title 'it''s <a&b> x_1^2 {y} @z' noenhanced"), std::string::npos);
}

TEST(ReportFigure, MissingGnuplotIsAClearError) {
  ThetaFigure f = ThreeCurves();
  f.set_gnuplot("/nonexistent/gnuplot");
  try {
    f.Write(test::ScratchDir("figure_missing") + "/fig.svg", FigureFormat::kSvg, 800, 600);
    FAIL() << "no error";
  } catch (const FigureError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("fig.svg"), std::string::npos) << what;
    EXPECT_NE(what.find("gnuplot not found ('/nonexistent/gnuplot')"), std::string::npos) << what;
    EXPECT_NE(what.find("gnuplot-nox"), std::string::npos) << what;
  }
}

TEST(ReportFigure, GnuplotFailureIsAClearError) {
  ThetaFigure f = ThreeCurves();
  f.set_gnuplot("false");  // exits 1 without reading
  EXPECT_THROW(f.Write(test::ScratchDir("figure_false") + "/fig.svg", FigureFormat::kSvg, 800, 600),
               FigureError);
  // An output folder that does not exist: the figure's temporary cannot be
  // made beside it, said in one line naming the file, before gnuplot runs.
  f.set_gnuplot("gnuplot");
  try {
    f.Write("/nonexistent-folder/fig.svg", FigureFormat::kSvg, 800, 600);
    FAIL() << "no error";
  } catch (const FigureError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'/nonexistent-folder/fig.svg'"), std::string::npos) << what;
    EXPECT_NE(what.find("No such file or directory"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  // gnuplot failing leaves a previous figure as it was, and no temporary.
  const std::string dir = test::ScratchDir("figure_kept");
  { std::ofstream(dir + "/fig.svg") << "<svg>previous</svg>"; }
  f.set_gnuplot("false");
  EXPECT_THROW(f.Write(dir + "/fig.svg", FigureFormat::kSvg, 800, 600), FigureError);
  std::ifstream in(dir + "/fig.svg");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "<svg>previous</svg>");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 1);
}

TEST(ReportFigure, BadCurvesAndSizesAreRefused) {
  ThetaFigure f;
  EXPECT_THROW(f.AddCurve(ThetaCurve{"x", {0.0, 1.0}, {0.0}, false}), std::invalid_argument);
  EXPECT_THROW(f.Write("x.svg", FigureFormat::kSvg, 800, 600), std::invalid_argument);  // no curve
  f.AddCurve(Curve("experiment", 10, 1.0, true));
  EXPECT_THROW(f.Write("x.svg", FigureFormat::kSvg, 199, 600), std::invalid_argument);
  // Twelve caption lines (one per variant of a large comparison) leave no
  // room for the plot in 300 px.
  for (int i = 0; i < 12; ++i) f.AddCaptionLine("variant " + std::to_string(i));
  EXPECT_THROW(f.Write("x.svg", FigureFormat::kSvg, 800, 300), std::invalid_argument);
}

}  // namespace
}  // namespace rocklab::report
