#include "host_sim/common/raster.hpp"

#include "host_sim/common/bitmap_font.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc::sim {

Canvas::Canvas(double x0, double y0, double x1, double y1, double ppm, Rgb bg) : x0_(x0), y1_(y1), ppm_(ppm) {
  img_.width = static_cast<int>(std::ceil((x1 - x0) * ppm));
  img_.height = static_cast<int>(std::ceil((y1 - y0) * ppm));
  img_.pixels.resize(static_cast<std::size_t>(img_.width) * static_cast<std::size_t>(img_.height) * 3);
  for (std::size_t i = 0; i < img_.pixels.size(); i += 3) {
    img_.pixels[i] = bg.r;
    img_.pixels[i + 1] = bg.g;
    img_.pixels[i + 2] = bg.b;
  }
}

Eigen::Vector2d Canvas::to_px(const Eigen::Vector2d& w) const {
  return {(w.x() - x0_) * ppm_, (y1_ - w.y()) * ppm_};
}

void Canvas::put(int x, int y, Rgb c) {
  if (x < 0 || y < 0 || x >= img_.width || y >= img_.height) return;
  const std::size_t i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(img_.width) + static_cast<std::size_t>(x)) * 3;
  img_.pixels[i] = c.r;
  img_.pixels[i + 1] = c.g;
  img_.pixels[i + 2] = c.b;
}

void Canvas::fill_rect(double xa, double ya, double xb, double yb, Rgb c) {
  const Eigen::Vector2d p0 = to_px({std::min(xa, xb), std::max(ya, yb)});
  const Eigen::Vector2d p1 = to_px({std::max(xa, xb), std::min(ya, yb)});
  for (int y = static_cast<int>(std::floor(p0.y())); y < static_cast<int>(std::ceil(p1.y())); ++y)
    for (int x = static_cast<int>(std::floor(p0.x())); x < static_cast<int>(std::ceil(p1.x())); ++x) put(x, y, c);
}

void Canvas::fill_polygon(const std::vector<Eigen::Vector2d>& poly, Rgb c) {
  if (poly.size() < 3) return;
  std::vector<Eigen::Vector2d> p;
  for (const auto& w : poly) p.push_back(to_px(w));
  double ymin = p[0].y(), ymax = p[0].y();
  for (const auto& q : p) { ymin = std::min(ymin, q.y()); ymax = std::max(ymax, q.y()); }
  for (int y = std::max(0, static_cast<int>(std::floor(ymin))); y <= std::min(img_.height - 1, static_cast<int>(std::ceil(ymax))); ++y) {
    const double sy = y + 0.5;
    std::vector<double> xs;  // even-odd scanline fill
    for (std::size_t i = 0; i < p.size(); ++i) {
      const auto& a = p[i];
      const auto& b = p[(i + 1) % p.size()];
      if ((a.y() <= sy) != (b.y() <= sy)) xs.push_back(a.x() + (sy - a.y()) / (b.y() - a.y()) * (b.x() - a.x()));
    }
    std::sort(xs.begin(), xs.end());
    for (std::size_t k = 0; k + 1 < xs.size(); k += 2)
      for (int x = static_cast<int>(std::ceil(xs[k] - 0.5)); x <= static_cast<int>(std::floor(xs[k + 1] - 0.5)); ++x) put(x, y, c);
  }
}

void Canvas::disc_px(double cx, double cy, double r, Rgb c) {
  const int x0 = static_cast<int>(std::floor(cx - r)), x1 = static_cast<int>(std::ceil(cx + r));
  const int y0 = static_cast<int>(std::floor(cy - r)), y1 = static_cast<int>(std::ceil(cy + r));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
      if (dx * dx + dy * dy <= r * r) put(x, y, c);
    }
}

void Canvas::line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, Rgb c, double width_px) {
  const Eigen::Vector2d pa = to_px(a), pb = to_px(b);
  const double len = (pb - pa).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(len * 2.0)));
  const double r = std::max(0.5, width_px * 0.5);
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector2d q = pa + (pb - pa) * (static_cast<double>(i) / steps);
    disc_px(q.x(), q.y(), r, c);
  }
}

void Canvas::polyline(const std::vector<Eigen::Vector2d>& pts, Rgb c, double width_px) {
  for (std::size_t i = 1; i < pts.size(); ++i) line(pts[i - 1], pts[i], c, width_px);
}

void Canvas::circle(const Eigen::Vector2d& centre, double radius_px, Rgb c, bool filled) {
  const Eigen::Vector2d p = to_px(centre);
  if (filled) {
    disc_px(p.x(), p.y(), radius_px, c);
    return;
  }
  const int n = std::max(16, static_cast<int>(radius_px * 8));
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    disc_px(p.x() + radius_px * std::cos(a), p.y() + radius_px * std::sin(a), 0.8, c);
  }
}

void Canvas::cross(const Eigen::Vector2d& centre, double half_px, Rgb c) {
  const double h = half_px / ppm_;
  line(centre + Eigen::Vector2d(-h, -h), centre + Eigen::Vector2d(h, h), c);
  line(centre + Eigen::Vector2d(-h, h), centre + Eigen::Vector2d(h, -h), c);
}

void Canvas::fill_rect_px(int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, y0); y < std::min(img_.height, y1); ++y)
    for (int x = std::max(0, x0); x < std::min(img_.width, x1); ++x) put(x, y, c);
}

void Canvas::frame_rect_px(int x0, int y0, int x1, int y1, Rgb c) {
  fill_rect_px(x0, y0, x1, y0 + 1, c);
  fill_rect_px(x0, y1 - 1, x1, y1, c);
  fill_rect_px(x0, y0, x0 + 1, y1, c);
  fill_rect_px(x1 - 1, y0, x1, y1, c);
}

void Canvas::line_px(double xa, double ya, double xb, double yb, Rgb c, double width_px) {
  const double len = std::hypot(xb - xa, yb - ya);
  const int steps = std::max(1, static_cast<int>(std::ceil(len * 2.0)));
  const double r = std::max(0.5, width_px * 0.5);
  for (int i = 0; i <= steps; ++i) {
    const double f = static_cast<double>(i) / steps;
    disc_px(xa + (xb - xa) * f, ya + (yb - ya) * f, r, c);
  }
}

// One glyph cell is the 5-pixel glyph plus one pixel of spacing.
int Canvas::text_width_px(const std::string& text, int scale) {
  return text.empty() ? 0 : static_cast<int>(text.size()) * (kGlyphWidth + 1) * scale - scale;
}

int Canvas::text_height_px(int scale) { return kGlyphHeight * scale; }

void Canvas::text_px(int x, int y, const std::string& text, Rgb c, int scale) {
  for (char ch : text) {
    const GlyphRows& g = glyph(ch);
    for (int r = 0; r < kGlyphHeight; ++r)
      for (int col = 0; col < kGlyphWidth; ++col)
        if (g[static_cast<std::size_t>(r)] & (1u << (kGlyphWidth - 1 - col)))
          fill_rect_px(x + col * scale, y + r * scale, x + (col + 1) * scale, y + (r + 1) * scale, c);
    x += (kGlyphWidth + 1) * scale;
  }
}

}  // namespace v2xloc::sim
