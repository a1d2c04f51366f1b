#include "monitor/assets.h"

namespace rocklab::monitor {

const Asset* FindAsset(std::string_view url_path) {
  if (url_path == "/") url_path = "/index.html";
  for (const Asset& a : AllAssets()) {
    if (a.path == url_path) return &a;
  }
  return nullptr;
}

}  // namespace rocklab::monitor
