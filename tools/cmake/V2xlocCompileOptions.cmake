# Flags shared by every target. -ffp-contract=off keeps x86-64 and aarch64 bit-identical
# (GCC fuses multiply-add on aarch64 by default).
add_compile_options(-ffp-contract=off -Wall -Wextra -Wpedantic -Wshadow -Wconversion-null)
# Scalar Eigen in every target, not only algo/: inline Eigen functions are instantiated in many
# translation units and the linker keeps one copy, so mixing vectorized and scalar builds would
# make the core's arithmetic depend on link order.
add_compile_definitions(EIGEN_DONT_VECTORIZE EIGEN_MPL2_ONLY)
# V2XLOC_FUZZ (preset "fuzz", clang only): every target gets libFuzzer's coverage instrumentation
# and ASan+UBSan, so the fuzz targets see coverage inside the libraries they drive; only the
# fuzz targets are built (see v2xloc_fuzz_target in V2xlocTesting.cmake).
option(V2XLOC_FUZZ "Build the libFuzzer targets (clang), instrumented, and register timed fuzz runs" OFF)
if(V2XLOC_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "V2XLOC_FUZZ needs clang (libFuzzer); use the fuzz preset")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
endif()
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
