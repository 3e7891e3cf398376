# Flags shared by every target. -ffp-contract=off keeps x86-64 and aarch64 bit-identical
# (GCC fuses multiply-add on aarch64 by default).
add_compile_options(-ffp-contract=off -Wall -Wextra -Wpedantic -Wshadow -Wconversion-null)
if(V2XLOC_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
endif()

# algo/ and anything that must build bare-metal: no exceptions, no RTTI, Eigen may not allocate.
function(v2xloc_core_target target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-fno-exceptions -fno-rtti> -Werror=vla)
  target_compile_definitions(${target} PRIVATE EIGEN_NO_MALLOC)
endfunction()
