// candump -L logs (host_sim/canlog): every line parses or is reported with a reason; a parsed
// record formats to a line that parses back to the same record.
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>

#include "host_sim/canlog/candump_log.hpp"

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
  return 0;
}
