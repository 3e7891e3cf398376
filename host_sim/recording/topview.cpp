#include "host_sim/recording/topview.hpp"

#include "host_sim/common/raster.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

namespace v2xloc::sim {
namespace {

const Rgb kGround{235, 235, 228}, kSidewalk{200, 200, 200}, kRoad{120, 120, 125}, kMarking{250, 250, 250},
    kTree{60, 140, 60}, kPole{40, 40, 40}, kParked{90, 90, 160}, kGnss{240, 140, 0}, kEgo{220, 30, 30},
    kInfraRing{20, 20, 20}, kInfra{255, 220, 0}, kInk{20, 20, 20}, kPaper{255, 255, 255};
const Rgb kAgentColours[2] = {Rgb{30, 80, 230}, Rgb{0, 170, 200}};

Rgb building_shade(double height) {
  const auto s = static_cast<std::uint8_t>(std::clamp(190.0 - height * 3.0, 60.0, 190.0));
  return Rgb{s, static_cast<std::uint8_t>(s - 20), static_cast<std::uint8_t>(s - 40)};
}

// One legend row: a symbol drawn into a 24 x 14 px cell at (x, y), then the label.
struct LegendRow {
  std::string label;
  std::function<void(Canvas&, int, int)> symbol;
};

void draw_legend(Canvas& c, const std::vector<LegendRow>& rows) {
  const int pad = 8, row_h = 20, sym_w = 28;
  int text_w = 0;
  for (const auto& r : rows) text_w = std::max(text_w, Canvas::text_width_px(r.label));
  const int x0 = 10, y0 = 44;
  const int w = pad * 2 + sym_w + text_w, h = pad * 2 + row_h * static_cast<int>(rows.size()) - 6;
  c.fill_rect_px(x0, y0, x0 + w, y0 + h, kPaper);
  c.frame_rect_px(x0, y0, x0 + w, y0 + h, kInk);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const int y = y0 + pad + row_h * static_cast<int>(i);
    rows[i].symbol(c, x0 + pad, y);
    c.text_px(x0 + pad + sym_w, y, rows[i].label, kInk);
  }
}

// Scale bar of `metres` in the bottom-left corner, with end ticks and its length written above.
void draw_scale_bar(Canvas& c, double metres) {
  const int len = static_cast<int>(std::lround(metres * c.pixels_per_metre()));
  const int x0 = 20, y = c.image().height - 24;
  const std::string label = std::to_string(static_cast<int>(metres)) + " m";
  c.fill_rect_px(x0 - 8, y - 30, x0 + len + 8, y + 12, kPaper);
  c.fill_rect_px(x0, y - 2, x0 + len, y + 2, kInk);
  c.fill_rect_px(x0, y - 8, x0 + 2, y + 8, kInk);
  c.fill_rect_px(x0 + len - 2, y - 8, x0 + len, y + 8, kInk);
  c.text_px(x0 + (len - Canvas::text_width_px(label)) / 2, y - 24, label, kInk);
}

// North arrow in the bottom-right corner (ENU: +y is north, up in the picture).
void draw_north_arrow(Canvas& c) {
  const int x = c.image().width - 30, y = c.image().height - 20;
  c.fill_rect_px(x - 16, y - 64, x + 16, y + 8, kPaper);
  c.line_px(x, y, x, y - 36, kInk, 3.0);
  c.line_px(x, y - 40, x - 8, y - 28, kInk, 3.0);
  c.line_px(x, y - 40, x + 8, y - 28, kInk, 3.0);
  c.text_px(x - 4, y - 60, "N", kInk);
}

}  // namespace

bool write_top_view(const std::string& path, const IntersectionWorld& iw, const TopViewData& d, std::string& error) {
  using L = IntersectionLayout;
  const double e = 120.0;
  Canvas c(-e, -e, e, e, 4.0, kGround);
  // Roads and sidewalks.
  const double side = L::kRoadHalfWidth + L::kSidewalkWidth;
  c.fill_rect(-e, -side, e, side, kSidewalk);
  c.fill_rect(-side, -e, side, e, kSidewalk);
  c.fill_rect(-e, -L::kRoadHalfWidth, e, L::kRoadHalfWidth, kRoad);
  c.fill_rect(-L::kRoadHalfWidth, -e, L::kRoadHalfWidth, e, kRoad);
  // Lane markings (centre lines).
  c.line({-e, 0}, {-L::kRoadHalfWidth, 0}, kMarking);
  c.line({L::kRoadHalfWidth, 0}, {e, 0}, kMarking);
  c.line({0, -e}, {0, -L::kRoadHalfWidth}, kMarking);
  c.line({0, L::kRoadHalfWidth}, {0, e}, kMarking);
  // Buildings, shaded by height.
  for (const auto& b : iw.buildings) c.fill_rect(b.lo.x(), b.lo.y(), b.hi.x(), b.hi.y(), building_shade(b.height));
  for (const auto& t : iw.trees) c.circle(t.head<2>(), 6.0, kTree);
  for (const auto& p : iw.poles) c.circle(p, 1.5, kPole);
  for (const auto& p : iw.parked_cars) c.fill_rect(p.x() - 1.0, p.y() - 1.0, p.x() + 1.0, p.y() + 1.0, kParked);
  // Paths: ego red, agents blue/cyan (thinner line when their LiDAR is not used).
  const double agent_width = d.agents_have_lidar ? 3.0 : 1.5;
  for (std::size_t a = 0; a < d.agent_paths.size(); ++a) {
    const auto& agent_path = d.agent_paths[a];
    c.polyline(agent_path, kAgentColours[a % 2], agent_width);
    if (!agent_path.empty()) c.circle(agent_path.front(), 5.0, kAgentColours[a % 2]);
  }
  for (const auto& f : d.gnss_fixes) c.cross(f, 3.0, kGnss);
  c.polyline(d.ego_path, kEgo, 3.0);
  if (!d.ego_path.empty()) c.circle(d.ego_path.front(), 6.0, kEgo);
  for (const auto& p : d.infra) {
    c.circle(p, 7.0, kInfraRing);
    c.circle(p, 4.5, kInfra);
  }

  // Title, legend, scale bar and north arrow: the picture explains itself.
  const std::string title = (d.title.empty() ? std::string("scenario") : d.title) + ": top view (ENU, x east, y north)";
  c.fill_rect_px(0, 0, c.image().width, 34, kPaper);
  c.text_px((c.image().width - Canvas::text_width_px(title)) / 2, 10, title, kInk);
  std::vector<LegendRow> rows;
  rows.push_back({"ego path (truth), disc = start", [](Canvas& k, int x, int y) {
                    k.line_px(x, y + 7, x + 22, y + 7, kEgo, 3.0);
                    k.disc_at_px(x + 3, y + 7, 5.0, kEgo);
                  }});
  for (std::size_t a = 0; a < d.agent_paths.size(); ++a) {
    const std::string label = "agent " + std::to_string(a) + " path" + (d.agents_have_lidar ? "" : " (lidar unused)");
    const Rgb col = kAgentColours[a % 2];
    rows.push_back({label, [col, agent_width](Canvas& k, int x, int y) {
                      k.line_px(x, y + 7, x + 22, y + 7, col, agent_width);
                      k.disc_at_px(x + 3, y + 7, 4.0, col);
                    }});
  }
  if (!d.infra.empty())
    rows.push_back({"infrastructure lidar", [](Canvas& k, int x, int y) {
                      k.disc_at_px(x + 11, y + 7, 7.0, kInfraRing);
                      k.disc_at_px(x + 11, y + 7, 4.5, kInfra);
                    }});
  if (!d.gnss_fixes.empty())
    rows.push_back({"gnss fix", [](Canvas& k, int x, int y) {
                      k.line_px(x + 8, y + 4, x + 14, y + 10, kGnss);
                      k.line_px(x + 8, y + 10, x + 14, y + 4, kGnss);
                    }});
  rows.push_back({"building (darker = taller)", [](Canvas& k, int x, int y) {
                    k.fill_rect_px(x, y, x + 11, y + 14, building_shade(8.0));
                    k.fill_rect_px(x + 11, y, x + 22, y + 14, building_shade(35.0));
                  }});
  rows.push_back({"road / sidewalk", [](Canvas& k, int x, int y) {
                    k.fill_rect_px(x, y, x + 11, y + 14, kRoad);
                    k.fill_rect_px(x + 11, y, x + 22, y + 14, kSidewalk);
                  }});
  rows.push_back({"tree / pole / parked car", [](Canvas& k, int x, int y) {
                    k.disc_at_px(x + 4, y + 7, 5.0, kTree);
                    k.disc_at_px(x + 13, y + 7, 1.5, kPole);
                    k.fill_rect_px(x + 17, y + 3, x + 25, y + 11, kParked);
                  }});
  draw_legend(c, rows);
  draw_scale_bar(c, 20.0);
  draw_north_arrow(c);
  return write_png(path, c.image(), error);
}

}  // namespace v2xloc::sim
