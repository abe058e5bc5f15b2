#include "png_image.hpp"

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>

#include "pl/common/error.hpp"

namespace pl::eval {

namespace {

// libpng reports errors through a callback that must not return; it longjmps back to write_rows,
// whose frame holds only trivially destructible objects made before the setjmp.
struct PngErrorState {
  char message[256] = "";
};

void on_png_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof state->message, "%s", message);
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}

// Returns false (and the message in `state`) when libpng failed.
bool write_rows(std::FILE* file, const PaletteImage& image, png_color* palette, png_text* text, int text_count, png_bytep* rows,
                PngErrorState* state) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, state, on_png_error, on_png_warning);
  if (!png) {
    std::snprintf(state->message, sizeof state->message, "out of memory");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    if (!info) std::snprintf(state->message, sizeof state->message, "out of memory");
    png_destroy_write_struct(&png, info ? &info : nullptr);
    return false;
  }
  png_init_io(png, file);
  png_set_compression_level(png, 9);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8,
               PNG_COLOR_TYPE_PALETTE, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  png_set_PLTE(png, info, palette, static_cast<int>(image.palette.size()));
  if (text_count > 0) png_set_text(png, info, text, text_count);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

PaletteImage::PaletteImage(int w, int h, std::vector<Rgb> colours, std::uint8_t background)
    : width(w), height(h), palette(std::move(colours)) {
  if (w <= 0 || h <= 0) throw Error("an image needs a positive size");
  if (palette.empty() || palette.size() > 256 || background >= palette.size()) throw Error("an image needs 1 to 256 colours");
  pixels.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), background);
}

void PaletteImage::fill_rect(int x0, int y0, int x1, int y1, std::uint8_t index) {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, width);
  y1 = std::min(y1, height);
  for (int y = y0; y < y1; ++y)
    std::fill_n(pixels.begin() + static_cast<std::ptrdiff_t>(y) * width + x0, std::max(0, x1 - x0), index);
}

void PaletteImage::line(double ax, double ay, double bx, double by, int thickness, std::uint8_t index) {
  if (!std::isfinite(ax) || !std::isfinite(ay) || !std::isfinite(bx) || !std::isfinite(by)) return;
  // Liang-Barsky against the image grown by the brush.
  const double m = thickness, lo_x = -m, lo_y = -m, hi_x = width + m, hi_y = height + m;
  const double dx = bx - ax, dy = by - ay;
  double t0 = 0.0, t1 = 1.0;
  const double p[4] = {-dx, dx, -dy, dy}, q[4] = {ax - lo_x, hi_x - ax, ay - lo_y, hi_y - ay};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0.0) {
      if (q[k] < 0.0) return;
      continue;
    }
    const double t = q[k] / p[k];
    if (p[k] < 0.0)
      t0 = std::max(t0, t);
    else
      t1 = std::min(t1, t);
    if (t0 > t1) return;
  }
  const double sx = ax + t0 * dx, sy = ay + t0 * dy, ex = ax + t1 * dx, ey = ay + t1 * dy;
  const int steps = static_cast<int>(std::ceil(std::max(std::fabs(ex - sx), std::fabs(ey - sy)))) + 1;
  const int before = (thickness - 1) / 2, after = thickness - before;
  for (int i = 0; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    const int x = static_cast<int>(std::floor(sx + t * (ex - sx))), y = static_cast<int>(std::floor(sy + t * (ey - sy)));
    fill_rect(x - before, y - before, x + after, y + after, index);
  }
}

void PaletteImage::disc(double cx, double cy, double radius, std::uint8_t index) {
  if (!std::isfinite(cx) || !std::isfinite(cy)) return;
  const int r = static_cast<int>(std::ceil(radius));
  const int px = static_cast<int>(std::floor(cx)), py = static_cast<int>(std::floor(cy));
  for (int y = py - r; y <= py + r; ++y)
    for (int x = px - r; x <= px + r; ++x) {
      const double ddx = x + 0.5 - cx, ddy = y + 0.5 - cy;
      if (ddx * ddx + ddy * ddy <= radius * radius) set(x, y, index);
    }
}

void write_png(const std::string& path, const PaletteImage& image, const std::vector<std::pair<std::string, std::string>>& text) {
  std::vector<png_color> palette;
  for (const Rgb& c : image.palette) palette.push_back(png_color{c[0], c[1], c[2]});
  std::vector<std::string> keys, values;
  for (const auto& [k, v] : text) {
    keys.push_back(k.substr(0, 79));  // a PNG keyword has 1 to 79 Latin-1 characters
    values.push_back(v);
  }
  std::vector<png_text> chunks(text.size());
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    // tEXt holds Latin-1; text with other characters (UTF-8 bytes) goes into an iTXt chunk.
    const bool ascii =
        std::all_of(values[i].begin(), values[i].end(), [](char c) { return static_cast<unsigned char>(c) < 0x80; });
    chunks[i] = png_text{};
    chunks[i].compression = ascii ? PNG_TEXT_COMPRESSION_NONE : PNG_ITXT_COMPRESSION_NONE;
    chunks[i].key = keys[i].data();
    chunks[i].text = values[i].data();
    if (ascii)
      chunks[i].text_length = values[i].size();
    else
      chunks[i].itxt_length = values[i].size();
  }
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y)
    rows[static_cast<std::size_t>(y)] = const_cast<png_bytep>(image.pixels.data() + static_cast<std::size_t>(y) * image.width);

  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw Error(path + ": cannot write (" + std::strerror(errno) + "; check that the folder exists and is writable)");
  PngErrorState state;
  const bool written =
      write_rows(file, image, palette.data(), chunks.data(), static_cast<int>(chunks.size()), rows.data(), &state);
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed) std::remove(path.c_str());
  if (!written) throw Error(path + ": writing the PNG failed: " + state.message);
  if (!closed) throw Error(path + ": write failed (disk full?)");
}

}  // namespace pl::eval
