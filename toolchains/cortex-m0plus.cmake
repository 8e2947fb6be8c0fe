# SPDX-License-Identifier: MIT
# Cortex-M0+ (ARMv6-M, no FPU: soft float). QEMU has no Cortex-M0+ board with enough RAM; the
# ARMv6-M binaries run on mps2-an385's Cortex-M3 (ARMv6-M is a subset of ARMv7-M).
set(IMUCAL_CPU_FLAGS "-mcpu=cortex-m0plus -mthumb -mfloat-abi=soft")
set(IMUCAL_QEMU_MACHINE mps2-an385)
set(IMUCAL_FLASH 0x00000000)
set(IMUCAL_FLASH_SIZE 0x400000)
set(IMUCAL_RAM 0x20000000)
set(IMUCAL_RAM_SIZE 0x400000)
set(IMUCAL_STACK_SIZE 0x10000)
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-picolibc.cmake)
