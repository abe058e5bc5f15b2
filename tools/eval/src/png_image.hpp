// An 8-bit palette image written as a PNG through libpng: the top view's raster (topview_png.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace pl::eval {

using Rgb = std::array<std::uint8_t, 3>;

struct PaletteImage {
  int width = 0, height = 0;
  std::vector<Rgb> palette;          // at most 256 colours
  std::vector<std::uint8_t> pixels;  // width * height palette indices, row by row from the top

  PaletteImage(int w, int h, std::vector<Rgb> colours, std::uint8_t background);
  bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  void set(int x, int y, std::uint8_t index) {
    if (inside(x, y)) pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)] = index;
  }
  std::uint8_t at(int x, int y) const {
    return pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)];
  }
  void fill_rect(int x0, int y0, int x1, int y1, std::uint8_t index);  // [x0, x1) x [y0, y1), clipped
  // A line `thickness` pixels wide (a square brush) from (ax, ay) to (bx, by), in pixel coordinates
  // that may lie outside the image: the segment is clipped first.
  void line(double ax, double ay, double bx, double by, int thickness, std::uint8_t index);
  void disc(double cx, double cy, double radius, std::uint8_t index);
};

// Writes `image` to `path` (best zlib compression, no row filters: a palette raster compresses best
// unfiltered), with text chunks (keyword, text) such as Title and Description: tEXt, or iTXt for
// text that is not ASCII (UTF-8). Throws pl::Error naming the path when the file cannot be written.
void write_png(const std::string& path, const PaletteImage& image, const std::vector<std::pair<std::string, std::string>>& text);

}  // namespace pl::eval
