# SPDX-License-Identifier: MIT
# Common part of the Cortex-M toolchain files: arm-none-eabi GCC with picolibc, semihosting
# start-up from picolibc (vector table, FPU enable, exit code), and qemu-system-arm as the
# CMAKE_CROSSCOMPILING_EMULATOR so that ctest runs every test binary under simulation.
# The including file sets IMUCAL_CPU_FLAGS, IMUCAL_QEMU_MACHINE and the memory map.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_CXX_COMPILER arm-none-eabi-g++)
set(CMAKE_ASM_COMPILER arm-none-eabi-gcc)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(_common "${IMUCAL_CPU_FLAGS} -ffunction-sections -fdata-sections")
# C and C++ get their own specs file; never both.
set(CMAKE_C_FLAGS_INIT "${_common} --specs=picolibc.specs")
set(CMAKE_CXX_FLAGS_INIT "${_common} --specs=picolibcpp.specs -fno-exceptions -fno-rtti")
set(CMAKE_EXE_LINKER_FLAGS_INIT
    "--oslib=semihost --crt0=semihost -Wl,--gc-sections \
-Wl,--defsym=__flash=${IMUCAL_FLASH} -Wl,--defsym=__flash_size=${IMUCAL_FLASH_SIZE} \
-Wl,--defsym=__ram=${IMUCAL_RAM} -Wl,--defsym=__ram_size=${IMUCAL_RAM_SIZE} \
-Wl,--defsym=__stack_size=${IMUCAL_STACK_SIZE} -T picolibcpp.ld")
# The -T after the --defsym: the specs file's own -T comes first, when __stack_size is not yet
# defined, and picolibcpp.ld then reserves its 2 KB default for the stack (__heap_end at
# __stack - 0x800). Read again here, it reserves IMUCAL_STACK_SIZE.

set(CMAKE_CROSSCOMPILING_EMULATOR "${CMAKE_CURRENT_LIST_DIR}/qemu-run.sh;${IMUCAL_QEMU_MACHINE}")
set(IMUCAL_TARGET_SIZE arm-none-eabi-size)
set(IMUCAL_TARGET_NM arm-none-eabi-nm)
