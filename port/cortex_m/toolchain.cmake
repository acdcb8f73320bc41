# CMake toolchain for the Cortex-M4F firmware (arm-none-eabi-g++, hard float).
#
#   cmake -S . -B build-m4 -DCMAKE_TOOLCHAIN_FILE=port/cortex_m/toolchain.cmake -DCMAKE_BUILD_TYPE=Release
#   cmake --build build-m4          # -> build-m4/feedid_m4.elf
#
# Debian packages: gcc-arm-none-eabi libnewlib-arm-none-eabi
# libstdc++-arm-none-eabi-newlib (and qemu-system-arm to run it; .ci/firmware.sh
# installs them). The top-level CMakeLists.txt sees FEEDID_FIRMWARE and builds
# only port/cortex_m/ (no host tools, no tests).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_CXX_COMPILER arm-none-eabi-g++)
set(CMAKE_ASM_COMPILER arm-none-eabi-gcc)
find_program(FEEDID_ARM_SIZE arm-none-eabi-size)
find_program(FEEDID_ARM_NM arm-none-eabi-nm)
find_program(FEEDID_ARM_OBJDUMP arm-none-eabi-objdump)

# The compiler checks cannot link an executable without our startup code.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(FEEDID_FIRMWARE ON)

# Cortex-M4 with the single-precision FPU, float arguments in FPU registers.
set(FEEDID_CPU_FLAGS "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard")
# Freestanding, no exceptions / RTTI, nothing that registers destructors or
# guards statics through the C++ runtime; one section per function so the
# linker drops what is unused.
set(CMAKE_CXX_FLAGS_INIT
    "${FEEDID_CPU_FLAGS} -ffreestanding -fno-exceptions -fno-rtti -fno-threadsafe-statics -fno-use-cxa-atexit -ffunction-sections -fdata-sections")
set(CMAKE_C_FLAGS_INIT "${FEEDID_CPU_FLAGS} -ffreestanding -ffunction-sections -fdata-sections")
# Our own reset handler and linker script (port/cortex_m/); newlib-nano only
# for memcpy/memset, libgcc for the few integer/float conversion helpers.
set(CMAKE_EXE_LINKER_FLAGS_INIT "${FEEDID_CPU_FLAGS} -nostartfiles --specs=nano.specs -Wl,--gc-sections")
set(CMAKE_CXX_FLAGS_RELEASE_INIT "-O2")

# Search headers and libraries only in the target environment, programs on the host.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
