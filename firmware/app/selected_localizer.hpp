// Which localizer the firmware and the offline replay path run. V2XLOC_HAVE_LOCALIZER is set by
// firmware/app/CMakeLists.txt once algo/ provides v2xloc::Localizer; until then both run the
// StandInLocalizer (and say so), so the plumbing and its bit-identity test work meanwhile.
#pragma once

#include "v2xloc/algo/geodesy.hpp"

#if V2XLOC_HAVE_LOCALIZER
#include "v2xloc/algo/localizer.hpp"
#include "v2xloc/algo/localizer_params.hpp"
#else
#include "firmware/app/stand_in_localizer.hpp"
#endif

namespace v2xloc::firmware {

#if V2XLOC_HAVE_LOCALIZER
using SelectedLocalizer = Localizer;
inline constexpr const char* kSelectedLocalizerName = "v2xloc::Localizer";
inline void configure_localizer(SelectedLocalizer& localizer, const GeodeticOrigin& origin) {
  localizer.configure(LocalizerParams{}, origin);
}
#else
using SelectedLocalizer = StandInLocalizer;
inline constexpr const char* kSelectedLocalizerName = "StandInLocalizer (dead reckoning + GNSS; algo Localizer not built)";
inline void configure_localizer(SelectedLocalizer& localizer, const GeodeticOrigin& origin) {
  localizer.configure(origin);
}
#endif

}  // namespace v2xloc::firmware
