#include "rayproof/studies/svg.h"

#include <cstdarg>
#include <cstdio>
#include <vector>

namespace rayproof::studies::svg {

std::string format(const char* pattern, ...) {
  va_list args, copy;
  va_start(args, pattern);
  va_copy(copy, args);
  const int n = std::vsnprintf(nullptr, 0, pattern, copy);
  va_end(copy);
  std::vector<char> buffer(static_cast<size_t>(n > 0 ? n : 0) + 1);
  std::vsnprintf(buffer.data(), buffer.size(), pattern, args);
  va_end(args);
  return std::string(buffer.data(), buffer.size() - 1);
}

std::string escape(std::string_view text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '\'': out += "&apos;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

void begin(std::ostream& out, double width, double height, int font_size) {
  out << format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='%g' height='%g' font-family='sans-serif' "
      "font-size='%d'>\n<rect width='100%%' height='100%%' fill='white'/>\n",
      width, height, font_size);
}

void end(std::ostream& out) { out << "</svg>\n"; }

std::string text(double x, double y, std::string_view content, std::string_view attributes) {
  return format("<text x='%.1f' y='%.1f'%s%s>", x, y, attributes.empty() ? "" : " ", std::string(attributes).c_str()) +
         escape(content) + "</text>";
}

std::string line(double x1, double y1, double x2, double y2, std::string_view attributes) {
  return format("<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' %s/>", x1, y1, x2, y2, std::string(attributes).c_str());
}

std::string rect(double x, double y, double width, double height, std::string_view fill, std::string_view tooltip) {
  const std::string head = format("<rect x='%.1f' y='%.1f' width='%.1f' height='%.1f' fill='%s'", x, y, width, height,
                                  std::string(fill).c_str());
  if (tooltip.empty()) return head + "/>";
  return head + "><title>" + escape(tooltip) + "</title></rect>";
}

}  // namespace rayproof::studies::svg
