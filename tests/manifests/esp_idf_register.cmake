# SPDX-License-Identifier: MIT
# Runs imucal's root CMakeLists.txt as ESP-IDF's first pass does (script mode, ESP_PLATFORM and
# CMAKE_BUILD_EARLY_EXPANSION set) with a stand-in idf_component_register that prints what it
# was given, for tools/check_manifests.py:
#   cmake -DIMUCAL_SOURCE_DIR=... -P tests/manifests/esp_idf_register.cmake
set(ESP_PLATFORM 1)
set(CMAKE_BUILD_EARLY_EXPANSION 1)
function(idf_component_register)
  cmake_parse_arguments(arg "" "" "SRCS;INCLUDE_DIRS;REQUIRES;PRIV_REQUIRES" ${ARGN})
  if(arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "idf_component_register: unknown arguments ${arg_UNPARSED_ARGUMENTS}")
  endif()
  message(STATUS "SRCS ${arg_SRCS}")
  message(STATUS "INCLUDE_DIRS ${arg_INCLUDE_DIRS}")
endfunction()
set(CMAKE_CURRENT_LIST_DIR ${IMUCAL_SOURCE_DIR})
# It must return() after registering: project() and the rest cannot run in script mode.
include(${IMUCAL_SOURCE_DIR}/CMakeLists.txt)
