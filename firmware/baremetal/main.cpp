// Bare-metal link check: calls into every algo stage with static storage.
#include "v2xloc/algo/det_math.hpp"

volatile double g_sink;

int main() {
  double acc = 0.0;
  for (int i = 0; i < 16; ++i) acc += v2xloc::det::atan2(i, 3.0) + v2xloc::det::sin(i);
  g_sink = acc;
  for (;;) {
  }
}
