// The report's page: the monitor's index.html with every file it refers to
// (styles, uPlot, the page script) and the snapshot written into it, so it
// opens from disk with no server and no network.
#include <cctype>
#include <filesystem>
#include <regex>
#include <stdexcept>
#include <string>
#include <string_view>

#include "common/text.h"
#include "monitor/assets.h"
#include "report/report.h"

namespace rocklab::report {
namespace {

const monitor::Asset& Asset(const std::string& reference) {
  // The page refers to its files relative to itself ("app.js"); the server
  // has them at the root ("/app.js").
  const std::string url = reference.empty() || reference[0] != '/' ? "/" + reference : reference;
  const monitor::Asset* asset = monitor::FindAsset(url);
  if (!asset) {
    throw std::runtime_error("the monitor page refers to '" + reference +
                             "', which is not embedded in this build");
  }
  return *asset;
}

// Text that goes inside <script> or <style> cannot hold that element's end
// tag (in any case); "<\/" is the same text to JavaScript and never occurs
// in CSS.
std::string Inline(std::string_view body, std::string_view end_tag) {
  std::string out(body);
  for (std::size_t at = 0; at + end_tag.size() <= out.size(); ++at) {
    bool match = true;
    for (std::size_t i = 0; i < end_tag.size() && match; ++i) {
      match = std::tolower(static_cast<unsigned char>(out[at + i])) == end_tag[i];
    }
    if (match) out.replace(at, 2, "<\\/");
  }
  return out;
}

// Replaces each match of `re` (group 1: the referenced file) with what
// `make` returns for it.
template <class Make>
std::string ReplaceReferences(const std::string& html, const std::regex& re, Make make) {
  std::string out;
  auto last = html.cbegin();
  for (std::sregex_iterator it(html.begin(), html.end(), re), end; it != end; ++it) {
    out.append(last, (*it)[0].first);
    out += make((*it)[1].str());
    last = (*it)[0].second;
  }
  out.append(last, html.cend());
  return out;
}

}  // namespace

std::string ReportPage(const RecordReport& record) {
  std::string html(Asset("/index.html").body);

  static const std::regex kStylesheet(R"re(<link\s+rel="stylesheet"\s+href="([^"]+)"\s*/?>)re");
  static const std::regex kScript(R"re(<script\s+src="([^"]+)"\s*>\s*</script>)re");
  html = ReplaceReferences(html, kStylesheet, [](const std::string& file) {
    return "<style>\n" + Inline(Asset(file).body, "</style") + "\n</style>";
  });
  // The snapshot goes before the first script, so the page script finds it
  // and draws it statically instead of connecting to a server.
  bool snapshot_written = false;
  html = ReplaceReferences(html, kScript, [&](const std::string& file) {
    std::string out;
    if (!snapshot_written) {
      // '<' only occurs inside JSON strings, where \u003c is the same text:
      // nothing in the data can end the script element.
      const std::string json =
          record.snapshot.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      out += "<script>window.ROCKLAB_SNAPSHOT = ";
      for (char c : json) {
        if (c == '<') {
          out += "\\u003c";
        } else {
          out += c;
        }
      }
      out += ";</script>\n";
      snapshot_written = true;
    }
    return out + "<script>\n" + Inline(Asset(file).body, "</script") + "\n</script>";
  });
  // The browser tab names the log.
  const std::size_t title = html.find("<title>");
  const std::size_t title_end = html.find("</title>", title);
  if (title != std::string::npos && title_end != std::string::npos) {
    const std::string name = common::XmlText(std::filesystem::path(record.log_path).filename().string());
    html.replace(title + 7, title_end - title - 7, "rocklab report: " + name);
  }
  if (!snapshot_written) {
    throw std::runtime_error("the monitor page (index.html) has no <script src=...> to inline");
  }
  // Its provenance, at the foot of the page: which rocklab, command, time
  // and files (with their SHA-256) made it.
  const std::size_t body_end = html.rfind("</body>");
  if (!record.provenance.empty() && body_end != std::string::npos) {
    std::string foot = "<footer class=\"provenance\" style=\"font-size:small;color:#555;margin:1em\">\n<dl>\n";
    for (const auto& [key, value] : record.provenance) {
      foot += "<dt>" + common::XmlText(key) + "</dt><dd><code>" + common::XmlText(value) + "</code></dd>\n";
    }
    foot += "</dl>\n</footer>\n";
    html.insert(body_end, foot);
  }
  return html;
}

}  // namespace rocklab::report
