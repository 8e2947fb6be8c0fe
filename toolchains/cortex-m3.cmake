# SPDX-License-Identifier: MIT
# Cortex-M3 (ARMv7-M, no FPU: soft float), simulated by qemu-system-arm -M mps2-an385.
set(IMUCAL_CPU_FLAGS "-mcpu=cortex-m3 -mthumb -mfloat-abi=soft")
set(IMUCAL_QEMU_MACHINE mps2-an385)
set(IMUCAL_FLASH 0x00000000)
set(IMUCAL_FLASH_SIZE 0x400000)
set(IMUCAL_RAM 0x20000000)
set(IMUCAL_RAM_SIZE 0x400000)
set(IMUCAL_STACK_SIZE 0x10000)
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-picolibc.cmake)
