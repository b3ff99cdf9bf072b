// The one small SVG helper of the studies' plots: a document with a white background, and the
// few elements the trade scatter and the stability heatmaps draw, text escaped (markup.h).
#pragma once

#include <ostream>
#include <string>
#include <string_view>

namespace rayproof::studies::svg {

// <svg …> with a white background; close with end().
void begin(std::ostream& out, double width, double height, int font_size);
void end(std::ostream& out);

std::string text(double x, double y, std::string_view content, std::string_view attributes = "");
std::string line(double x1, double y1, double x2, double y2, std::string_view attributes);
// A filled rectangle with an optional tooltip.
std::string rect(double x, double y, double width, double height, std::string_view fill, std::string_view tooltip = "");

}  // namespace rayproof::studies::svg
