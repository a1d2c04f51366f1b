#pragma once
// What a figure file shows, for the tests' oracles: a gnuplot SVG read with
// expat (well-formed or not, its plotted curves, i.e. the `gnuplot_plot_N`
// groups with their legend title and path vertices, and every text element),
// and a PNG's signature and size.

#include <string>
#include <vector>

namespace rocklab::test {

struct SvgCurve {
  std::string title;  ///< the group's <title>, XML entities resolved
  int vertices{};     ///< M and L commands in the group's paths (legend sample included)
};

struct SvgProbe {
  bool well_formed{};
  std::string error;                ///< expat's message and line when not well-formed
  int width{}, height{};            ///< the root's width and height attributes
  std::vector<SvgCurve> curves;     ///< in document order
  std::vector<std::string> texts;   ///< text content of each <text> element
};

SvgProbe ProbeSvg(const std::string& svg);

struct PngProbe {
  bool signature{};   ///< starts with the 8-byte PNG signature and an IHDR chunk
  int width{}, height{};  ///< from IHDR, px
};

PngProbe ProbePng(const std::string& bytes);

}  // namespace rocklab::test
