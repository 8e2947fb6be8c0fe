# SPDX-License-Identifier: MIT
# Common part of the RISC-V toolchain files: riscv64-unknown-elf GCC with picolibc, semihosting
# start-up from picolibc (trap handler, .data/.bss set-up, exit code, argv), and
# qemu-system-riscv32 as the CMAKE_CROSSCOMPILING_EMULATOR so that ctest runs every test binary
# under simulation. The including file sets IMUCAL_RISCV_ARCH, IMUCAL_RISCV_ABI,
# IMUCAL_QEMU_MACHINE and the memory map.
# Packages (Debian 12): tools/setup_debian.sh gcc-riscv64-unknown-elf picolibc-riscv64-unknown-elf
# qemu-system-misc gcc-12-source.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR riscv32)
set(CMAKE_C_COMPILER riscv64-unknown-elf-gcc)
set(CMAKE_CXX_COMPILER riscv64-unknown-elf-g++)
set(CMAKE_ASM_COMPILER riscv64-unknown-elf-gcc)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

# Debian ships no C++ library for this compiler: libstdc++ is built once per multilib from
# Debian's source of the same GCC (toolchains/riscv-libstdcxx.sh, about three minutes), into a
# folder that every build folder of the source tree shares.
set(IMUCAL_RISCV_LIBSTDCXX
    "${CMAKE_CURRENT_LIST_DIR}/../build/libstdcxx/${IMUCAL_RISCV_ARCH}-${IMUCAL_RISCV_ABI}"
    CACHE PATH "Where libstdc++ for the RISC-V target is (built there if missing)")
# CMake's compiler checks read this file again in projects of their own: the same folder there.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES IMUCAL_RISCV_LIBSTDCXX)
if(NOT EXISTS "${IMUCAL_RISCV_LIBSTDCXX}/lib/libstdc++.a")
  message(STATUS "Building libstdc++ for ${IMUCAL_RISCV_ARCH}/${IMUCAL_RISCV_ABI} in "
                 "${IMUCAL_RISCV_LIBSTDCXX}")
  execute_process(COMMAND "${CMAKE_CURRENT_LIST_DIR}/riscv-libstdcxx.sh" ${IMUCAL_RISCV_ARCH}
                          ${IMUCAL_RISCV_ABI} "${IMUCAL_RISCV_LIBSTDCXX}"
                  RESULT_VARIABLE _rc)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "toolchains/riscv-libstdcxx.sh failed")
  endif()
endif()
execute_process(COMMAND ${CMAKE_C_COMPILER} -dumpversion OUTPUT_VARIABLE _gcc_version
                OUTPUT_STRIP_TRAILING_WHITESPACE)
set(_cxx_include "${IMUCAL_RISCV_LIBSTDCXX}/include/c++/${_gcc_version}")

set(_common "-march=${IMUCAL_RISCV_ARCH} -mabi=${IMUCAL_RISCV_ABI} -ffunction-sections \
-fdata-sections")
# C and C++ get their own specs file; never both.
set(CMAKE_C_FLAGS_INIT "${_common} --specs=picolibc.specs")
set(CMAKE_CXX_FLAGS_INIT "${_common} --specs=picolibcpp.specs -fno-exceptions -fno-rtti \
-nostdinc++ -isystem ${_cxx_include} -isystem ${_cxx_include}/riscv64-unknown-elf \
-isystem ${_cxx_include}/backward")
set(CMAKE_EXE_LINKER_FLAGS_INIT
    "--oslib=semihost --crt0=semihost -Wl,--gc-sections -L${IMUCAL_RISCV_LIBSTDCXX}/lib \
-Wl,--defsym=__flash=${IMUCAL_FLASH} -Wl,--defsym=__flash_size=${IMUCAL_FLASH_SIZE} \
-Wl,--defsym=__ram=${IMUCAL_RAM} -Wl,--defsym=__ram_size=${IMUCAL_RAM_SIZE} \
-Wl,--defsym=__stack_size=${IMUCAL_STACK_SIZE} -T picolibcpp.ld -Wl,--no-warn-rwx-segments")
# The -T after the --defsym: the specs file's own -T comes first, when __stack_size is not yet
# defined, and picolibcpp.ld then reserves its 2 KB default for the stack (__heap_end at
# __stack - 0x800). Read again here, it reserves IMUCAL_STACK_SIZE.
# --no-warn-rwx-segments: picolibc.ld puts the exception tables (.eh_frame, which RISC-V GCC
# emits writable: libstdc++ and libgcc have them) in the segment of the code.

set(CMAKE_CROSSCOMPILING_EMULATOR
    "${CMAKE_CURRENT_LIST_DIR}/qemu-run.sh;riscv32:${IMUCAL_QEMU_MACHINE}")
set(IMUCAL_TARGET_SIZE riscv64-unknown-elf-size)
set(IMUCAL_TARGET_NM riscv64-unknown-elf-nm)
