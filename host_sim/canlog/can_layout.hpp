// CAN layout versions of recorded logs. Layout 2 (tools/dbc/v2xloc.dbc now) gives every inbound
// frame a rolling counter and a CRC: 0x130 carries latitude and longitude in two multiplexed frames,
// 0x132 only the time, the DOPs moved to 0x134. Layout 1 (recordings made before; a manifest
// without can_log.layout_version) had 0x130 = latitude + longitude and 0x132 = time + DOP, with
// neither counter nor CRC. Converting copies every signal's raw bits, so a converted log hands the
// localizer bit-identical values.
#pragma once

#include <cstddef>
#include <vector>

#include "host_sim/canlog/candump_log.hpp"

namespace v2xloc::sim {

inline constexpr int kCanLayoutLegacy = 1;
inline constexpr int kCanLayoutVersion = 2;  // what the recorder writes and the firmware decodes
// The manifest's can_log.gnss note for layout 2: one fix's frames in the order they are sent.
inline constexpr const char* kCanLayoutGnssFrames =
    "0x130 latitude, 0x130 longitude, 0x131 status, 0x133 velocity, 0x134 DOP, 0x132 time at the GNSS rate";

struct CanLayoutConversion {
  std::size_t positions = 0;  // layout-1 0x130 frames, each now a latitude and a longitude frame
  std::size_t times = 0;      // layout-1 0x132 frames, each now a DOP (0x134) and a time frame
  std::size_t kept = 0;       // 0x130 / 0x132 frames with DLC != 8: left as they were (refused either way)
};

// Layout 1 -> 2 in place: order and time stamps kept, each 0x130 / 0x132 frame replaced by two
// frames of the same stamp with counters as a layout-2 sender steps them (0x130 +1 per frame;
// 0x134 and 0x132 +1 per fix, from 0). Other ids are unchanged in layout 2 and stay as they are.
CanLayoutConversion convert_can_layout_1_to_2(std::vector<CandumpRecord>& records);

}  // namespace v2xloc::sim
