// Binds each message of the codec's table (firmware/protocol/can_message_table.hpp) to physical
// values by DBC signal name, so tests can drive any message generically: values in by name -> pack;
// unpack -> values by name. Derived from the table: one binding per table entry, no per-message code.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "firmware/protocol/can_messages.hpp"

namespace v2xloc::test {

using Values = std::map<std::string, double>;

struct MessageBinding {
  std::uint32_t id;
  std::function<hal::CanFrame(const Values&, protocol::PackStats*)> pack;
  std::function<protocol::DecodeStatus(const hal::CanFrame&, Values&)> unpack;
};

// Writes the named values into m: the multiplexer first, then every signal the frame carries at that
// multiplexer value (a name left out is 0).
template <class Layout, class M>
void set_values(const Layout& layout, const Values& v, M& m) {
  const auto get = [&v](const char* name) {
    const auto it = v.find(name);
    return it == v.end() ? 0.0 : it->second;
  };
  layout.for_each_field([&](const auto& f) {
    if (f.signal.kind == protocol::SignalKind::kMultiplexer) protocol::assign_physical(f.of(m), get(f.signal.name));
  });
  const int mux = protocol::detail::mux_of(m);
  layout.for_each_field([&](const auto& f) {
    if (f.signal.carried(mux)) protocol::assign_physical(f.of(m), get(f.signal.name));
  });
}

// The values of every signal m carries, by name.
template <class Layout, class M>
Values values_of(const Layout& layout, const M& m) {
  Values v;
  const int mux = protocol::detail::mux_of(m);
  layout.for_each_field([&](const auto& f) {
    if (f.signal.carried(mux)) v[f.signal.name] = protocol::to_physical(f.of(m));
  });
  return v;
}

template <class Layout>
MessageBinding bind(const Layout& layout) {
  using M = typename Layout::Message;
  return {layout.id,
          [&layout](const Values& v, protocol::PackStats* stats) {
            M m;
            set_values(layout, v, m);
            return protocol::pack(m, stats);
          },
          [&layout](const hal::CanFrame& f, Values& v) {
            M m;
            const protocol::DecodeStatus status = protocol::unpack(f, m);
            v = values_of(layout, m);
            return status;
          }};
}

inline std::vector<MessageBinding> message_bindings() {
  std::vector<MessageBinding> out;
  protocol::for_each_can_message([&out](const auto& layout) { out.push_back(bind(layout)); });
  return out;
}

}  // namespace v2xloc::test
