#include "web/page_assets.h"

namespace occmap::web {

const PageAsset* findPageAsset(std::string_view path) {
  if (path == "/") path = "/index.html";
  for (const PageAsset& asset : pageAssets()) {
    if (asset.path == path) return &asset;
  }
  return nullptr;
}

}  // namespace occmap::web
