#include "host_sim/recording/topview.hpp"

#include "host_sim/common/raster.hpp"

#include <algorithm>

namespace v2xloc::sim {

bool write_top_view(const std::string& path, const IntersectionWorld& iw, const TopViewData& d, std::string& error) {
  using L = IntersectionLayout;
  const double e = 120.0;
  Canvas c(-e, -e, e, e, 4.0, Rgb{235, 235, 228});
  // Roads and sidewalks.
  const double side = L::kRoadHalfWidth + L::kSidewalkWidth;
  c.fill_rect(-e, -side, e, side, Rgb{200, 200, 200});
  c.fill_rect(-side, -e, side, e, Rgb{200, 200, 200});
  c.fill_rect(-e, -L::kRoadHalfWidth, e, L::kRoadHalfWidth, Rgb{120, 120, 125});
  c.fill_rect(-L::kRoadHalfWidth, -e, L::kRoadHalfWidth, e, Rgb{120, 120, 125});
  // Lane markings (centre lines).
  c.line({-e, 0}, {-L::kRoadHalfWidth, 0}, Rgb{250, 250, 250});
  c.line({L::kRoadHalfWidth, 0}, {e, 0}, Rgb{250, 250, 250});
  c.line({0, -e}, {0, -L::kRoadHalfWidth}, Rgb{250, 250, 250});
  c.line({0, L::kRoadHalfWidth}, {0, e}, Rgb{250, 250, 250});
  // Buildings, shaded by height.
  for (const auto& b : iw.buildings) {
    const auto shade = static_cast<std::uint8_t>(std::clamp(190.0 - b.height * 3.0, 60.0, 190.0));
    c.fill_rect(b.lo.x(), b.lo.y(), b.hi.x(), b.hi.y(), Rgb{shade, static_cast<std::uint8_t>(shade - 20), static_cast<std::uint8_t>(shade - 40)});
  }
  for (const auto& t : iw.trees) c.circle(t.head<2>(), 6.0, Rgb{60, 140, 60});
  for (const auto& p : iw.poles) c.circle(p, 1.5, Rgb{40, 40, 40});
  for (const auto& p : iw.parked_cars) c.fill_rect(p.x() - 1.0, p.y() - 1.0, p.x() + 1.0, p.y() + 1.0, Rgb{90, 90, 160});
  // Paths: ego red, agents blue/cyan (dashed look via thinner line when they have no LiDAR).
  const Rgb agent_colours[2] = {Rgb{30, 80, 230}, Rgb{0, 170, 200}};
  for (std::size_t a = 0; a < d.agent_paths.size(); ++a) {
    const auto& agent_path = d.agent_paths[a];
    c.polyline(agent_path, agent_colours[a % 2], d.agents_have_lidar ? 3.0 : 1.5);
    if (!agent_path.empty()) c.circle(agent_path.front(), 5.0, agent_colours[a % 2]);
  }
  for (const auto& f : d.gnss_fixes) c.cross(f, 3.0, Rgb{240, 140, 0});
  c.polyline(d.ego_path, Rgb{220, 30, 30}, 3.0);
  if (!d.ego_path.empty()) c.circle(d.ego_path.front(), 6.0, Rgb{220, 30, 30});
  for (const auto& p : d.infra) {
    c.circle(p, 7.0, Rgb{20, 20, 20});
    c.circle(p, 4.5, Rgb{255, 220, 0});
  }
  return write_png(path, c.image(), error);
}

}  // namespace v2xloc::sim
