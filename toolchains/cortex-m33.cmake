# SPDX-License-Identifier: MIT
# Cortex-M33 (single-precision FPU, secure state), simulated by qemu-system-arm -M mps2-an505.
set(IMUCAL_CPU_FLAGS "-mcpu=cortex-m33 -mthumb -mfpu=fpv5-sp-d16 -mfloat-abi=hard")
set(IMUCAL_QEMU_MACHINE mps2-an505)
set(IMUCAL_FLASH 0x10000000)
set(IMUCAL_FLASH_SIZE 0x400000)
set(IMUCAL_RAM 0x38000000)
set(IMUCAL_RAM_SIZE 0x200000)
set(IMUCAL_STACK_SIZE 0x10000)
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-picolibc.cmake)
