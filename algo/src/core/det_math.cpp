// det_math is header-only; this translation unit makes sure the header compiles on its own
// under the core's flags (-fno-exceptions -fno-rtti, bare-metal).
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"
