# Build-time generator: lists every `inline constexpr <type> k<Name>` of algo's config.hpp as a
# table v2xloc-info can print, so new capacities show up without editing the tool.
# Usage: cmake -DCONFIG_HEADER=... -DOUTPUT=... -P generate_config_table.cmake
file(STRINGS "${CONFIG_HEADER}" lines)
set(entries "")
set(section "")
foreach(line IN LISTS lines)
  if(line MATCHES "^// ---- ([^-]*[^ -]) -+")
    set(section "${CMAKE_MATCH_1}")
  elseif(line MATCHES "^inline constexpr [A-Za-z_:0-9]+ (k[A-Za-z0-9_]+) =")
    set(name "${CMAKE_MATCH_1}")
    set(comment "")
    if(line MATCHES "// *(.*)$")
      set(comment "${CMAKE_MATCH_1}")
      string(REPLACE "\\" "\\\\" comment "${comment}")
      string(REPLACE "\"" "\\\"" comment "${comment}")
    endif()
    string(APPEND entries
      "    {\"${section}\", \"${name}\", integral_value(config::${name}), \"${comment}\"},\n")
  endif()
endforeach()
file(WRITE "${OUTPUT}.tmp"
"// Generated from algo/include/v2xloc/algo/core/config.hpp by generate_config_table.cmake.\n"
"#include \"tools/info/config_table.hpp\"\n\n"
"#include \"v2xloc/algo/core/config.hpp\"\n\n"
"namespace v2xloc::tools {\n\n"
"std::span<const ConfigEntry> config_entries() {\n"
"  static const ConfigEntry kEntries[] = {\n${entries}  };\n"
"  return kEntries;\n}\n\n"
"}  // namespace v2xloc::tools\n")
# Only touch the output when it changed (no needless rebuilds).
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUTPUT}.tmp" "${OUTPUT}")
file(REMOVE "${OUTPUT}.tmp")
