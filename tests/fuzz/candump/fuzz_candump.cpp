// candump -L logs (host_sim/canlog): every line parses or is reported with a reason; a parsed
// record formats to a line that parses back to the same record. Every parsed frame of a known id
// goes through the CAN codec's unpack of that message: any bytes give a status, never a crash, and
// only a frame of DLC 8 with its CRC right is decoded.
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "firmware/protocol/can_messages.hpp"
#include "host_sim/canlog/candump_log.hpp"

namespace {

using namespace v2xloc;

void check_decoding(const hal::CanFrame& frame) {
  protocol::for_each_can_message([&](const auto& layout) {
    if (layout.id != frame.id) return;
    typename std::remove_cvref_t<decltype(layout)>::Message m;
    const protocol::DecodeStatus s = protocol::unpack(frame, m);
    const bool decoded = s == protocol::DecodeStatus::kOk || s == protocol::DecodeStatus::kOutOfRange;
    if (decoded && (frame.dlc != 8 || frame.data[7] != protocol::frame_crc(frame.id, frame.data))) std::abort();
    if (!decoded && s != protocol::DecodeStatus::kWrongDlc && s != protocol::DecodeStatus::kBadChecksum) std::abort();
  });
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
  for (const CandumpRecord& r : log.records) check_decoding(r.frame);
  return 0;
}
