// Text into HTML and SVG, in one place: printf into a string (every plot and report places its
// numbers with it) and the escaping of text inside elements and attributes. The SVG helper
// (svg.h), the trade and stability plots and the audit's report.html all use these two.
#pragma once

#include <string>
#include <string_view>

namespace rayproof::studies::markup {

// printf into a string.
std::string format(const char* pattern, ...) __attribute__((format(printf, 1, 2)));
// Text safe inside HTML or SVG elements and attributes (&, <, >, ', ").
std::string escape(std::string_view text);
// Bytes as base64 (RFC 4648), for images inlined in pages (data: URLs).
std::string base64(const std::string& bytes);

}  // namespace rayproof::studies::markup
