#include "rayproof/studies/svg.h"

#include "rayproof/studies/markup.h"

#include <cstdio>

namespace rayproof::studies::svg {

void begin(std::ostream& out, double width, double height, int font_size) {
  out << markup::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='%g' height='%g' font-family='sans-serif' "
      "font-size='%d'>\n<rect width='100%%' height='100%%' fill='white'/>\n",
      width, height, font_size);
}

void end(std::ostream& out) { out << "</svg>\n"; }

std::string text(double x, double y, std::string_view content, std::string_view attributes) {
  return markup::format("<text x='%.1f' y='%.1f'%s%s>", x, y, attributes.empty() ? "" : " ",
                        std::string(attributes).c_str()) +
         markup::escape(content) + "</text>";
}

std::string line(double x1, double y1, double x2, double y2, std::string_view attributes) {
  return markup::format("<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' %s/>", x1, y1, x2, y2,
                        std::string(attributes).c_str());
}

std::string rect(double x, double y, double width, double height, std::string_view fill, std::string_view tooltip) {
  const std::string head = markup::format("<rect x='%.1f' y='%.1f' width='%.1f' height='%.1f' fill='%s'", x, y, width,
                                          height, std::string(fill).c_str());
  if (tooltip.empty()) return head + "/>";
  return head + "><title>" + markup::escape(tooltip) + "</title></rect>";
}

}  // namespace rayproof::studies::svg
