// The localizer the firmware and the offline replay path run, configured the one way both use.
#pragma once

#include "v2xloc/algo/core/geodesy.hpp"
#include "v2xloc/algo/localization/localizer.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc::firmware {

using SelectedLocalizer = Localizer;
inline constexpr const char* kSelectedLocalizerName = "v2xloc::Localizer";
inline void configure_localizer(SelectedLocalizer& localizer, const GeodeticOrigin& origin) {
  localizer.configure(LocalizerParams{}, origin);
}

}  // namespace v2xloc::firmware
