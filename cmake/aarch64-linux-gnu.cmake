# Cross-compiling for 64-bit Arm Linux on a Debian host (scripts/cross_aarch64.sh, docs/building.md): Debian's
# cross compiler, the arm64 libraries of Debian multiarch (/usr/lib/aarch64-linux-gnu), and the programs the
# build runs (Catch2's test discovery, ctest) started through user-mode QEMU with the cross C library.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# -L /: the dynamic loader of the arm64 C library installed through multiarch (/lib/ld-linux-aarch64.so.1),
# which must match the libc.so.6 it loads; the cross compiler's copy under /usr/aarch64-linux-gnu is a
# different build of glibc, and its loader with multiarch's libc hangs in the first pthread_create.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L /)

# Libraries and CMake packages: the arm64 ones only (the multiarch directory, chosen by
# CMAKE_LIBRARY_ARCHITECTURE), or the architecture-independent header-only ones (GLM, nlohmann-json, Catch2).
# Programs: the host's.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
# pkg-config (stb): the arm64 .pc files, not the host's.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
# GCC's note that std::pair<double, double> is passed differently than by GCC 9 and earlier concerns linking
# against objects those compilers built; there are none.
set(CMAKE_CXX_FLAGS_INIT -Wno-psabi)
