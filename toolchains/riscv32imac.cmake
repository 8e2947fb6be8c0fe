# SPDX-License-Identifier: MIT
# RV32IMAC (no FPU: soft float), simulated by qemu-system-riscv32 -M virt. virt has its RAM at
# 0x80000000 and no flash: the program is loaded into the first 4 MB of RAM, its data and stack
# use the next 4 MB (the same sizes as the Arm boards).
set(IMUCAL_RISCV_ARCH rv32imac)
set(IMUCAL_RISCV_ABI ilp32)
set(IMUCAL_QEMU_MACHINE virt)
set(IMUCAL_FLASH 0x80000000)
set(IMUCAL_FLASH_SIZE 0x400000)
set(IMUCAL_RAM 0x80400000)
set(IMUCAL_RAM_SIZE 0x400000)
set(IMUCAL_STACK_SIZE 0x10000)
include(${CMAKE_CURRENT_LIST_DIR}/riscv-picolibc.cmake)
