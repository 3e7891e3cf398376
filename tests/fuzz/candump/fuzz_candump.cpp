// candump -L logs (host_sim/canlog): every line parses or is reported with a reason; a parsed
// record formats to a line that parses back to the same record. The parsed log, read as CAN layout
// 1 and converted, keeps every other frame as it was and turns each 8-byte 0x130 / 0x132 frame into
// two CRC-sealed frames of the same stamp.
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "firmware/protocol/can_messages.hpp"
#include "host_sim/canlog/can_layout.hpp"
#include "host_sim/canlog/candump_log.hpp"

namespace {

using namespace v2xloc;

// The converted log against the parsed one, record by record.
void check_conversion(const std::vector<sim::CandumpRecord>& in) {
  std::vector<sim::CandumpRecord> out = in;
  const sim::CanLayoutConversion done = sim::convert_can_layout_1_to_2(out);
  if (out.size() != in.size() + done.positions + done.times) std::abort();
  std::size_t j = 0;
  for (const sim::CandumpRecord& r : in) {
    const bool split = (r.frame.id == protocol::kGnssPositionId || r.frame.id == protocol::kGnssTimeId) && r.frame.dlc == 8;
    for (std::size_t k = 0; k < (split ? 2u : 1u); ++k, ++j) {
      const hal::CanFrame& f = out[j].frame;
      if (out[j].timestamp_us != r.timestamp_us) std::abort();
      if (split && (f.dlc != 8 || f.data[7] != protocol::frame_crc(f.id, f.data))) std::abort();
      if (!split && (f.id != r.frame.id || f.dlc != r.frame.dlc || std::memcmp(f.data, r.frame.data, 8) != 0)) std::abort();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace v2xloc::sim;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  const CandumpLog log = read_candump(in);
  for (const auto& e : log.errors)
    if (e.message.empty()) std::abort();
  for (const CandumpRecord& r : log.records) {
    CandumpRecord back;
    std::string error;
    if (!parse_candump_line(format_candump_line(r), back, error) || back.timestamp_us != r.timestamp_us ||
        back.interface != r.interface || back.frame.id != r.frame.id || back.frame.dlc != r.frame.dlc ||
        std::memcmp(back.frame.data, r.frame.data, r.frame.dlc) != 0)
      std::abort();
  }
  check_conversion(log.records);
  return 0;
}
