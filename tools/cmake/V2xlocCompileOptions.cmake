# Flags shared by every target. -ffp-contract=off keeps x86-64 and aarch64 bit-identical
# (GCC fuses multiply-add on aarch64 by default).
add_compile_options(-ffp-contract=off -Wall -Wextra -Wpedantic -Wshadow -Wconversion-null)
# Scalar Eigen in every target, not only algo/: inline Eigen functions are instantiated in many
# translation units and the linker keeps one copy, so mixing vectorized and scalar builds would
# make the core's arithmetic depend on link order.
add_compile_definitions(EIGEN_DONT_VECTORIZE EIGEN_MPL2_ONLY)
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
