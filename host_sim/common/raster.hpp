// Simple RGB raster drawing for top-view plots (the paper's Fig. 2 style): a world-to-pixel
// mapping, lines, circles, filled rectangles and polygons, plus pixel-space boxes and 5x7 bitmap
// text for legends, scale bars and titles. PNG output goes through libpng (png.hpp).
#pragma once

#include "host_sim/common/png.hpp"

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace v2xloc::sim {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
};

class Canvas {
 public:
  // World rectangle [x0, x1] x [y0, y1] (metres, y up) drawn at `pixels_per_metre`.
  Canvas(double x0, double y0, double x1, double y1, double pixels_per_metre, Rgb background);

  void fill_rect(double xa, double ya, double xb, double yb, Rgb c);        // world, axis aligned
  void fill_polygon(const std::vector<Eigen::Vector2d>& poly, Rgb c);        // world, convex or not
  void line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, Rgb c, double width_px = 1.0);
  void polyline(const std::vector<Eigen::Vector2d>& pts, Rgb c, double width_px = 1.0);
  void circle(const Eigen::Vector2d& centre, double radius_px, Rgb c, bool filled = true);
  void cross(const Eigen::Vector2d& centre, double half_px, Rgb c);

  // Pixel space (x right, y down), for legends and labels placed on the picture, not the world.
  void fill_rect_px(int x0, int y0, int x1, int y1, Rgb c);             // [x0, x1) x [y0, y1)
  void frame_rect_px(int x0, int y0, int x1, int y1, Rgb c);            // 1-pixel outline
  void line_px(double xa, double ya, double xb, double yb, Rgb c, double width_px = 1.0);
  void disc_at_px(double cx, double cy, double r, Rgb c) { disc_px(cx, cy, r, c); }
  // Text with its top-left corner at (x, y); every font pixel becomes scale x scale pixels.
  void text_px(int x, int y, const std::string& text, Rgb c, int scale = 2);
  static int text_width_px(const std::string& text, int scale = 2);
  static int text_height_px(int scale = 2);

  double pixels_per_metre() const { return ppm_; }
  const ImageRgb& image() const { return img_; }

 private:
  Eigen::Vector2d to_px(const Eigen::Vector2d& w) const;
  void put(int x, int y, Rgb c);
  void disc_px(double cx, double cy, double r, Rgb c);
  double x0_, y1_, ppm_;
  ImageRgb img_;
};

}  // namespace v2xloc::sim
