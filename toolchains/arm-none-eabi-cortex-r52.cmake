# Bare-metal Cortex-R52 (hard-float, double-precision FPU). NEON is left off on purpose:
# Eigen 3.4's 32-bit NEON packet math does not compile with this GCC (see shared toolchain notes),
# and the core is scalar anyway for cross-ISA bit-identical results.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_CXX_COMPILER arm-none-eabi-g++)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(V2XLOC_CPU_FLAGS "-mcpu=cortex-r52 -mfpu=fp-armv8 -mfloat-abi=hard -marm")
set(CMAKE_C_FLAGS_INIT "${V2XLOC_CPU_FLAGS} -ffunction-sections -fdata-sections")
# -Wno-psabi: GCC notes that std::span/Eigen argument passing changed in GCC 7.1; everything in
# the image is built by this one compiler, so the note is noise that hides real warnings.
set(CMAKE_CXX_FLAGS_INIT "${V2XLOC_CPU_FLAGS} -ffunction-sections -fdata-sections -fno-exceptions -fno-rtti -fno-threadsafe-statics -Wno-psabi")
set(CMAKE_EXE_LINKER_FLAGS_INIT "--specs=nosys.specs -Wl,--gc-sections")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
# Eigen is header-only and architecture-neutral: use Debian's copy.
set(Eigen3_DIR /usr/share/eigen3/cmake)
