#pragma once
/// @file
/// The monitor page's files, embedded in the binary at build time
/// (monitor/web and uPlot's dist, by monitor/embed_assets.cmake). The server
/// serves these and nothing else: there is no file system behind it.

#include <cstddef>
#include <string_view>

namespace rocklab::monitor {

struct Asset {
  std::string_view path;          ///< URL path, e.g. "/app.js"
  std::string_view content_type;  ///< e.g. "text/javascript; charset=utf-8"
  std::string_view body;          ///< the file's bytes
};

/// Every embedded asset, in a fixed order.
struct AssetList {
  const Asset* first;
  const Asset* last;  ///< one past the end
  const Asset* begin() const { return first; }
  const Asset* end() const { return last; }
  std::size_t size() const { return static_cast<std::size_t>(last - first); }
};
AssetList AllAssets();

/// The asset at exactly `url_path` ("/" is "/index.html"); null when there
/// is none. No normalisation: "/./app.js" or "/a/../app.js" find nothing.
const Asset* FindAsset(std::string_view url_path);

}  // namespace rocklab::monitor
