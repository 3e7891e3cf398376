// The one way the firmware and the offline replay path configure the localizer.
#pragma once

#include "v2xloc/algo/core/geodesy.hpp"
#include "v2xloc/algo/localization/localizer.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc::firmware {

inline void configure_localizer(Localizer& localizer, const GeodeticOrigin& origin) {
  localizer.configure(LocalizerParams{}, origin);
}

}  // namespace v2xloc::firmware
