# Cross build for 64-bit Arm Linux (the Jetson AGX Orin's architecture) on a Debian amd64 host:
# the cross compiler g++-aarch64-linux-gnu, the project's libraries as Debian multiarch arm64
# packages (libfoo-dev:arm64, under /usr/lib/aarch64-linux-gnu), the programs run under
# qemu-user (qemu-aarch64). tools/install-deps.sh installs all three with ROSGUARD_AARCH64=ON;
# `make test-aarch64` builds with this file in $(BUILD)-aarch64 and runs its tests.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
# Test programs (ctest, catch_discover_tests) run under qemu-user; the arm64 loader and
# libraries are where multiarch put them (/lib/ld-linux-aarch64.so.1).
find_program(ROSGUARD_QEMU_AARCH64 qemu-aarch64 REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR ${ROSGUARD_QEMU_AARCH64})
