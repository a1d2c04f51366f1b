#include "tests/tools/figure_probe.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include <expat.h>

namespace rocklab::test {
namespace {

struct State {
  SvgProbe* probe{};
  int depth{};
  int plot_depth{-1};   // depth of the open gnuplot_plot group, -1 outside
  bool in_title{};      // inside that group's <title>
  int text_depth{-1};   // depth of the open <text>, -1 outside
};

const char* Attribute(const XML_Char** attrs, const char* name) {
  for (int i = 0; attrs[i]; i += 2) {
    if (std::strcmp(attrs[i], name) == 0) return attrs[i + 1];
  }
  return nullptr;
}

void XMLCALL Start(void* data, const XML_Char* name, const XML_Char** attrs) {
  auto* s = static_cast<State*>(data);
  ++s->depth;
  if (std::strcmp(name, "svg") == 0 && s->depth == 1) {
    if (const char* w = Attribute(attrs, "width")) s->probe->width = std::atoi(w);
    if (const char* h = Attribute(attrs, "height")) s->probe->height = std::atoi(h);
  }
  if (std::strcmp(name, "g") == 0 && s->plot_depth < 0) {
    const char* id = Attribute(attrs, "id");
    if (id && std::strncmp(id, "gnuplot_plot_", 13) == 0) {
      s->plot_depth = s->depth;
      s->probe->curves.emplace_back();
    }
  }
  if (s->plot_depth >= 0 && std::strcmp(name, "title") == 0 && s->depth == s->plot_depth + 1) {
    s->in_title = true;
  }
  if (s->plot_depth >= 0 && std::strcmp(name, "path") == 0) {
    if (const char* d = Attribute(attrs, "d")) {
      for (const char* c = d; *c; ++c) s->probe->curves.back().vertices += (*c == 'M' || *c == 'L');
    }
  }
  if (std::strcmp(name, "text") == 0 && s->text_depth < 0) {
    s->text_depth = s->depth;
    s->probe->texts.emplace_back();
  }
}

void XMLCALL End(void* data, const XML_Char*) {
  auto* s = static_cast<State*>(data);
  if (s->depth == s->plot_depth) s->plot_depth = -1;
  if (s->depth == s->text_depth) s->text_depth = -1;
  s->in_title = false;
  --s->depth;
}

void XMLCALL Text(void* data, const XML_Char* text, int len) {
  auto* s = static_cast<State*>(data);
  if (s->in_title) s->probe->curves.back().title.append(text, static_cast<std::size_t>(len));
  if (s->text_depth >= 0) s->probe->texts.back().append(text, static_cast<std::size_t>(len));
}

}  // namespace

SvgProbe ProbeSvg(const std::string& svg) {
  SvgProbe probe;
  State state;
  state.probe = &probe;
  XML_Parser parser = XML_ParserCreate("UTF-8");
  XML_SetUserData(parser, &state);
  XML_SetElementHandler(parser, Start, End);
  XML_SetCharacterDataHandler(parser, Text);
  probe.well_formed =
      XML_Parse(parser, svg.data(), static_cast<int>(svg.size()), XML_TRUE) == XML_STATUS_OK;
  if (!probe.well_formed) {
    probe.error = std::string(XML_ErrorString(XML_GetErrorCode(parser))) + " at line " +
                  std::to_string(XML_GetCurrentLineNumber(parser));
  }
  XML_ParserFree(parser);
  return probe;
}

PngProbe ProbePng(const std::string& bytes) {
  PngProbe probe;
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 24 || std::memcmp(bytes.data(), kSignature, 8) != 0 ||
      bytes.compare(12, 4, "IHDR") != 0) {
    return probe;
  }
  probe.signature = true;
  auto be32 = [&bytes](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
    return static_cast<int>(v);
  };
  probe.width = be32(16);
  probe.height = be32(20);
  return probe;
}

}  // namespace rocklab::test
