# SPDX-License-Identifier: MIT
# GoogleTest built from Debian's source (/usr/src/googletest) for bare-metal Arm or RISC-V with
# picolibc: no exceptions, RTTI, threads, POSIX regex or stream redirection. Provides
# GTest::gtest_main.
set(IMUCAL_GTEST_SOURCE_DIR /usr/src/googletest/googletest CACHE PATH "GoogleTest source")
add_library(imucal_gtest STATIC
  ${IMUCAL_GTEST_SOURCE_DIR}/src/gtest-all.cc
  ${IMUCAL_GTEST_SOURCE_DIR}/src/gtest_main.cc
  ${PROJECT_SOURCE_DIR}/ports/qemu-mps2/posix_stubs.c)
target_include_directories(imucal_gtest SYSTEM PUBLIC ${IMUCAL_GTEST_SOURCE_DIR}/include)
target_include_directories(imucal_gtest PRIVATE ${IMUCAL_GTEST_SOURCE_DIR})
target_compile_definitions(imucal_gtest PUBLIC GTEST_HAS_EXCEPTIONS=0 GTEST_HAS_RTTI=0
  GTEST_HAS_PTHREAD=0 GTEST_HAS_POSIX_RE=0 GTEST_HAS_STREAM_REDIRECTION=0
  _POSIX_C_SOURCE=200809L)
add_library(GTest::gtest_main ALIAS imucal_gtest)
