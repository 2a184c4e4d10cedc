// The files the report page is made of, inlined at build time by embed.cmake (nothing is
// fetched at build or view time): uPlot's script, stylesheet and licence
// (third_party/uplot), and the page's own template and script (page.html, page.js).
#pragma once

#include <string_view>

namespace rtuscope::report::assets {

std::string_view uplot_js();
std::string_view uplot_css();
std::string_view uplot_license();
std::string_view page_html();
std::string_view page_js();

}  // namespace rtuscope::report::assets
