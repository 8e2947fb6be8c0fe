# SPDX-License-Identifier: MIT
# Cortex-M4F (single-precision FPU), simulated by qemu-system-arm -M mps2-an386.
set(IMUCAL_CPU_FLAGS "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard")
set(IMUCAL_QEMU_MACHINE mps2-an386)
set(IMUCAL_FLASH 0x00000000)
set(IMUCAL_FLASH_SIZE 0x400000)
set(IMUCAL_RAM 0x20000000)
set(IMUCAL_RAM_SIZE 0x400000)
set(IMUCAL_STACK_SIZE 0x10000)
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-picolibc.cmake)
